"""Target 5 (linear part): time and peak memory per stage from about 10k to about 1M unknowns.

    python benchmarks/scaling.py              # n × n panels, n = 24, 48, 96, 160, 240 (10k … 1M dofs)
    python benchmarks/scaling.py --quick      # n = 24, 48, 96
    python benchmarks/scaling.py --n 24 48 96 128

Each size runs in a fresh subprocess: mesh, space + Argyris basis, stiffness (pattern +
element matrices + scatter), reduction to the clamped unknowns, factorisation with the default
backend, one solve. Per stage: wall time, CPU time and the peak of traced allocations; per run
the process's maximum RSS (which also sees the factor memory of MKL/CHOLMOD). The exponent p of
time ∝ dofs^p is fitted by least squares on log–log data over the sizes with ≥ 100k dofs (smaller
ones are dominated by fixed costs), for the wall time and for the CPU time.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import common  # noqa: E402

PANEL = dict(radius=1.0, length=2.0, thickness=0.01, alpha=0.0, beta=1.0)
MATERIAL = dict(young=1.0, poisson=0.3)
STAGES = ("mesh", "space + basis", "assembly", "reduction", "factorization", "solve")


def worker(n: int, backend: str) -> dict:
    import scipy.sparse as sp

    from shellcontact import linalg
    from shellcontact.shell import model
    from shellcontact.shell.geometry import Shell
    from shellcontact.shell.material import Isotropic
    from shellcontact.shell.mesh import structured
    from shellcontact.shell.spaces import ShellSpace
    from shellcontact.shell.supports import Reduction, Supports

    linalg.factorize(sp.identity(4, format="csr")).solve(np.ones(4))  # load MKL/CHOLMOD outside the timings
    st = common.Stages(trace_memory=True)
    with st.stage("mesh"):
        m = structured(Shell(**PANEL, material=Isotropic(**MATERIAL)), n, n)
    with st.stage("space + basis"):
        space = ShellSpace(m)
        _ = space.argyris
    with st.stage("assembly"):
        A = model.stiffness(space)
    with st.stage("reduction"):
        red = Reduction.build(space, Supports())
        Ar = red.reduce_matrix(A)
    b = red.reduce_vector(np.ones(space.ndofs))
    with st.stage("factorization"):
        f = linalg.factorize(Ar, backend)
    with st.stage("solve"):
        f.solve(b)
    return {"n": n, "triangles": m.nelements, "dofs": space.ndofs, "unknowns": Ar.shape[0], "nnz": int(A.nnz),
            "backend": f.backend, "times": st.times, "cpu": st.cpu, "peaks": st.peaks, "info": f.info(),
            "backward_error": f.backward_error}


def fit_exponent(dofs: np.ndarray, t: np.ndarray) -> float | None:
    keep = (dofs >= 1e5) & (t > 0)
    if keep.sum() < 2:
        keep = t > 0
    if keep.sum() < 2:
        return None
    return float(np.polyfit(np.log(dofs[keep]), np.log(t[keep]), 1)[0])


def main(argv=None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--n", type=int, nargs="*", help="mesh sizes n (n × n cells, 2n² triangles)")
    ap.add_argument("--backend", default="auto")
    ap.add_argument("--worker", nargs="*")
    args = ap.parse_args(argv)
    if args.worker:
        res = worker(int(args.worker[0]), args.worker[1])
        common.emit(res)
        return res
    sizes = args.n or ([24, 48, 96] if args.quick else [24, 48, 96, 160, 240])
    info = common.machine()
    t0 = time.perf_counter()
    runs = [common.run_worker(Path(__file__), [str(n), args.backend]) for n in sizes]
    print(f"# Scaling of the linear pipeline (clamped panel, backend {runs[0]['backend']})")
    print(common.machine_line(info))
    rows = []
    for r in runs:
        rows.append([r["dofs"], r["triangles"], r["nnz"]] + [r["times"][s] for s in STAGES]
                    + [sum(r["times"].values()), max(r["peaks"].values()) / 1e9, r["max_rss_bytes"] / 1e9])
    dofs = np.array([r["dofs"] for r in runs], float)
    expo = {s: fit_exponent(dofs, np.array([r["times"][s] for r in runs])) for s in STAGES}
    expo["total"] = fit_exponent(dofs, np.array([sum(r["times"].values()) for r in runs]))
    expo["max RSS"] = fit_exponent(dofs, np.array([r["max_rss_bytes"] for r in runs], float))
    cpu_expo = {s: fit_exponent(dofs, np.array([r["cpu"][s] for r in runs])) for s in STAGES}
    cpu_expo["total"] = fit_exponent(dofs, np.array([sum(r["cpu"].values()) for r in runs]))
    rows.append(["exponent p (wall)", "", ""] + [expo[s] for s in STAGES] + [expo["total"], "", expo["max RSS"]])
    rows.append(["exponent p (CPU)", "", ""] + [cpu_expo[s] for s in STAGES] + [cpu_expo["total"], "", ""])
    print("wall seconds per stage; memory: largest traced peak of a stage (GB) and process max RSS (GB)")
    print(common.table(["dofs", "triangles", "nnz(A)", *STAGES, "total", "peak traced GB", "max RSS GB"], rows))
    cpu_rows = [[r["dofs"]] + [r["cpu"][s] for s in STAGES] + [sum(r["cpu"].values())] for r in runs]
    print("\nCPU seconds per stage")
    print(common.table(["dofs", *STAGES, "total"], cpu_rows))
    mem_rows = [[r["dofs"]] + [r["peaks"][s] / 1e6 for s in STAGES] + [r["info"].get("kb_factor", 0) / 2**20]
                for r in runs]
    print("\npeak traced MB per stage (NumPy/Python allocations) and PARDISO's factor memory (GB)")
    print(common.table(["dofs", *STAGES, "factor GB"], mem_rows))
    print(f"benchmark wall time {time.perf_counter() - t0:.0f} s")
    out = {"scaling": {"runs": runs, "exponents": expo, "cpu_exponents": cpu_expo}, "machine": info}
    print(json.dumps(out))
    return out


if __name__ == "__main__":
    main()
