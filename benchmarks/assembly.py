"""Target 1: basis + stiffness assembly, shellcontact vs scikit-fem, on the same mesh and operator.

    python benchmarks/assembly.py            # 32 768 triangles (128 × 128 panel)
    python benchmarks/assembly.py --quick    # 8 192 triangles
    python benchmarks/assembly.py --triangles 2048

Both sides assemble a(U, V) of MODEL.md §3 with quadrature order 10 on one structured mesh
of a cylindrical panel (constant thickness):

* shellcontact: a fresh ShellSpace, its Argyris basis (space.argyris, which the rest of the
  pipeline uses for loads and evaluation), the CSR pattern and model.stiffness: all 3 fields.
* scikit-fem (the peer): CellBasis(mesh, ElementTriP2() * ElementTriP2() * ElementTriArgyris(),
  intorder=10) plus BilinearForm.assemble of the same operator on all 3 fields — the
  like-for-like comparison, and the headline ratio. Also, as a conservative bound, scikit-fem
  on the Argyris w-block alone (CellBasis(mesh, ElementTriArgyris()) and the w–w part of the
  form), compared with shellcontact's full 3-field assembly.

Each side runs in its own subprocess; times are wall-clock (shellcontact: best of 3; scikit-fem:
one run, it takes minutes); memory is the peak of traced NumPy/Python allocations during the
run (tracemalloc) and the process's maximum RSS.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import common  # noqa: E402

GOAL = 30.0
PANEL = dict(radius=1.0, length=2.0, thickness=0.01, alpha=0.0, beta=1.0)
MATERIAL = dict(young=1.0, poisson=0.3)


def _mesh(n: int):
    from shellcontact.shell.geometry import Shell
    from shellcontact.shell.material import Isotropic
    from shellcontact.shell.mesh import structured

    return structured(Shell(**PANEL, material=Isotropic(**MATERIAL)), n, n)


def _assemble(mesh, st: common.Stages):
    """shellcontact's stages, timed by ``st``: space, Argyris basis, CSR pattern, matrix."""
    from shellcontact.shell import model
    from shellcontact.shell.spaces import ShellSpace

    with st.stage("space"):
        space = ShellSpace(mesh)
    with st.stage("argyris basis"):
        _ = space.argyris
    with st.stage("pattern"):
        model.stiffness_pattern(space)
    with st.stage("element matrices + scatter"):
        A = model.stiffness(space)
    return space, A


def worker_ours(n: int, reps: int) -> dict:
    m = _mesh(n)
    best: dict[str, float] = {}
    best_cpu: dict[str, float] = {}
    for _ in range(reps):
        st = common.Stages(trace_memory=False)
        space, A = _assemble(m, st)
        for k, v in st.times.items():
            best[k] = min(best.get(k, float("inf")), v)
            best_cpu[k] = min(best_cpu.get(k, float("inf")), st.cpu[k])
        del space, A
    # one traced run for memory
    import tracemalloc

    tracemalloc.start()
    base = tracemalloc.get_traced_memory()[0]
    st = common.Stages(trace_memory=True)
    space, A = _assemble(m, st)
    peak = tracemalloc.get_traced_memory()[1] - base
    matrix_bytes = A.data.nbytes + A.indices.nbytes + A.indptr.nbytes
    return {"triangles": m.nelements, "dofs": space.ndofs, "nnz": int(A.nnz), "times": best,
            "total": sum(best.values()), "cpu": sum(best_cpu.values()), "peaks": st.peaks, "peak_bytes": peak,
            "matrix_bytes": matrix_bytes}


def _forms():
    from skfem import BilinearForm

    a, mu, t, E = PANEL["radius"], MATERIAL["poisson"], PANEL["thickness"], MATERIAL["young"]
    B, D = E * t / (1 - mu**2), E * t**3 / (12 * (1 - mu**2))

    def energy(e, f):
        return B * (e[0] * f[0] + mu * (e[0] * f[1] + e[1] * f[0]) + e[1] * f[1] + 0.5 * (1 - mu) * e[2] * f[2]) + D * (
            e[3] * f[3] + mu * (e[3] * f[4] + e[4] * f[3]) + e[4] * f[4] + 2 * (1 - mu) * e[5] * f[5]
        )

    def strains(u, v, w):
        ux, us, vx, vs, H = u.grad[0], u.grad[1], v.grad[0], v.grad[1], w.hess
        return (ux, vs + w.value / a, us + vx, -H[0][0], -(H[1][1] + w.value / a**2), -H[0][1] + (vx - us) / (2 * a))

    def w_strains(w):
        z = 0.0 * w.value
        H = w.hess
        return (z, w.value / a, z, -H[0][0], -(H[1][1] + w.value / a**2), -H[0][1])

    @BilinearForm
    def full(u1, v1, w1, u2, v2, w2, _):
        return energy(strains(u1, v1, w1), strains(u2, v2, w2))

    @BilinearForm
    def w_only(w1, w2, _):
        return energy(w_strains(w1), w_strains(w2))

    return full, w_only


def worker_skfem(n: int, which: str) -> dict:
    import tracemalloc
    import warnings

    from skfem import CellBasis, ElementTriArgyris, ElementTriP2

    warnings.simplefilter("ignore")
    m = _mesh(n)
    full, w_only = _forms()
    tracemalloc.start()
    base = tracemalloc.get_traced_memory()[0]
    st = common.Stages(trace_memory=True)
    with st.stage("basis"):
        if which == "full":
            basis = CellBasis(m.mesh, ElementTriP2() * ElementTriP2() * ElementTriArgyris(), intorder=10)
        else:
            basis = CellBasis(m.mesh, ElementTriArgyris(), intorder=10)
    with st.stage("assemble"):
        A = (full if which == "full" else w_only).assemble(basis)
    peak = tracemalloc.get_traced_memory()[1] - base
    return {"triangles": m.nelements, "dofs": int(basis.N), "nnz": int(A.nnz), "times": st.times,
            "total": sum(st.times.values()), "cpu": sum(st.cpu.values()), "peaks": st.peaks, "peak_bytes": peak}


def main(argv=None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--quick", action="store_true", help="8192 triangles instead of 32768")
    ap.add_argument("--triangles", type=int, help="about this many triangles (2 n² for an n × n grid)")
    ap.add_argument("--reps", type=int, default=3)
    ap.add_argument("--no-w-block", action="store_true", help="skip the scikit-fem w-block-only run")
    ap.add_argument("--worker", nargs="*")
    args = ap.parse_args(argv)
    if args.worker:
        kind, n = args.worker[0], int(args.worker[1])
        res = worker_ours(n, args.reps) if kind == "ours" else worker_skfem(n, kind)
        common.emit(res)
        return res
    tri = args.triangles or (8192 if args.quick else 32768)
    n = max(2, round((tri / 2) ** 0.5))
    info = common.machine()
    me = Path(__file__)
    t0 = time.perf_counter()
    ours = common.run_worker(me, ["ours", str(n), "--reps", str(args.reps)])
    sk_full = common.run_worker(me, ["full", str(n)])
    sk_w = None if args.no_w_block else common.run_worker(me, ["w", str(n)])
    nel = ours["triangles"]
    ratio = sk_full["total"] / ours["total"]
    cpu_ratio = sk_full["cpu"] / ours["cpu"]

    def row(name, r):
        return [name, nel, r["dofs"], r["total"], r["cpu"], 1e3 * r["total"] / nel, r["peak_bytes"] / nel / 1e3,
                r["max_rss_bytes"] / 1e9, r["total"] / ours["total"], r["cpu"] / ours["cpu"]]

    rows = [row("shellcontact (3 fields)", ours), row("scikit-fem P2×P2×Argyris (3 fields)", sk_full)]
    if sk_w:
        rows.append(row("scikit-fem Argyris w-block only", sk_w))
    print(f"# Assembly of the shell stiffness, quadrature order 10, {nel} triangles")
    print(common.machine_line(info))
    print(common.table(["implementation", "triangles", "dofs", "wall s", "CPU s", "wall ms/triangle",
                        "peak KB/triangle", "max RSS GB", "wall ratio", "CPU ratio"], rows))
    print("\nstages (seconds; peak traced MB):")
    stage_rows = [["shellcontact", k, v, ours["peaks"].get(k, 0) / 1e6] for k, v in ours["times"].items()]
    stage_rows += [["scikit-fem 3 fields", k, v, sk_full["peaks"].get(k, 0) / 1e6] for k, v in sk_full["times"].items()]
    if sk_w:
        stage_rows += [["scikit-fem w-block", k, v, sk_w["peaks"].get(k, 0) / 1e6] for k, v in sk_w["times"].items()]
    print(common.table(["implementation", "stage", "seconds", "peak MB"], stage_rows))
    print(f"\nshellcontact's CSR matrix: {ours['nnz']} nonzeros, {ours['matrix_bytes'] / nel / 1e3:.2f} KB/triangle; "
          f"speedup {ratio:.1f}x wall, {cpu_ratio:.1f}x CPU (goal {GOAL:g}x) over scikit-fem on the same 3-field "
          "operator"
          + (f", {sk_w['total'] / ours['total']:.1f}x over scikit-fem's w-block alone" if sk_w else "")
          + f"; benchmark wall time {time.perf_counter() - t0:.0f} s")
    out = {"targets": {"assembly_speedup": common.target(
        round(ratio, 2), GOAL, "x (scikit-fem seconds / shellcontact seconds, basis + assembly)",
        "scikit-fem CellBasis(P2*P2*Argyris, intorder=10) + BilinearForm.assemble",
        triangles=nel, seconds=ours["total"], peer_seconds=sk_full["total"], cpu_ratio=round(cpu_ratio, 2),
        w_block_ratio=round(sk_w["total"] / ours["total"], 2) if sk_w else None,
        kb_per_triangle=round(ours["peak_bytes"] / nel / 1e3, 2),
        peer_kb_per_triangle=round(sk_full["peak_bytes"] / nel / 1e3, 2), machine=info)}}
    print(json.dumps(out))
    return out


if __name__ == "__main__":
    main()
