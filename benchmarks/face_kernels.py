"""Issue 23 item 2(b): what the active set's dense work and the bordered factorisation cost at the 1.12M-dof sizes
(CPU seconds; benchmarks/RESULTS.md, "Issue 23, item 2(b)").

    python benchmarks/face_kernels.py kernels             # dense kernels at m = 7 749 border rows, |I| = 5 193
    python benchmarks/face_kernels.py force 2 active-set  # the demo's force, iterations, CPU s (one solve)
    python benchmarks/face_kernels.py border 2 1000 2000  # the bordered factorisation's CPU s against its rows

``kernels``: random SPD matrices of the sizes of the demo at 1.12M dofs (the border of 7 749 predicted rows, a
face of 5 193 active rows): T's Cholesky, 1 000 unit columns of T⁻¹ (×6 for the ~6 000 columns read), LAPACK
potri (the whole inverse), a face's Cholesky, and a bordered face solve with 100 rows moved.
``border R K…``: the bordered factorisation of the demo at ``mesh.refine = R`` by the deepest K rows of its overlap.
Run with one thread (OPENBLAS_NUM_THREADS=1 MKL_NUM_THREADS=1) on a quiet machine for comparable CPU seconds.
"""

from __future__ import annotations

import hashlib
import sys
import time
from pathlib import Path

import numpy as np
import scipy.linalg as sla

CASE = Path(__file__).resolve().parent.parent / "src" / "shellcontact" / "cases" / "paper_panel.toml"


def _cpu(f, *args, **kw):
    c = time.process_time()
    out = f(*args, **kw)
    return time.process_time() - c, out


def kernels(m: int = 7749, n: int = 5193, q: int = 100) -> None:
    rng = np.random.default_rng(0)
    X = rng.standard_normal((m, m)) / np.sqrt(m)
    T = X @ X.T + np.eye(m)
    del X
    t, ch = _cpu(sla.cho_factor, T, lower=True, check_finite=False)
    print(f"Cholesky of T, m = {m}: {t:.1f} s")
    E = np.zeros((m, 1000))
    E[np.arange(1000), np.arange(1000)] = 1.0
    t, _ = _cpu(sla.cho_solve, ch, E, check_finite=False)
    print(f"1 000 unit columns of T⁻¹: {t:.1f} s (6 000 columns: {6 * t:.1f} s)")
    del E
    t, _ = _cpu(sla.lapack.dpotri, ch[0], lower=1, overwrite_c=1)
    print(f"potri, the whole T⁻¹: {t:.1f} s")
    H = T[:n, :n].copy()
    del T, ch
    t, L = _cpu(sla.cholesky, H, lower=True, check_finite=False)
    print(f"face Cholesky, |I| = {n}: {t:.1f} s")
    C = rng.standard_normal((n, q))
    t1, W = _cpu(sla.solve_triangular, L, C, lower=True, check_finite=False)
    r = rng.standard_normal(n)

    def bordered() -> np.ndarray:
        z = sla.solve_triangular(L, r, lower=True, check_finite=False)
        v = sla.solve(-(W.T @ W), -(W.T @ z), assume_a="sym", check_finite=False)
        return sla.solve_triangular(L, z - W @ v, lower=True, trans="T", check_finite=False)

    t2, _ = _cpu(bordered)
    print(f"bordered face solve, {q} rows moved: {t1:.2f} s (their triangular solves) + {t2:.2f} s")


def force(refine: int, method: str) -> None:
    from shellcontact.analysis.pipeline import solve as solve_case
    from shellcontact.problem.case import load_case

    t, res = _cpu(solve_case, load_case(CASE, [f"mesh.refine={refine}"]), method=method)
    cs = res.contact.solution
    act = np.flatnonzero(res.contact.active)
    tim = cs.timings
    print(f"refine {refine}, {method}: force {res.summary()['contact'][0]['force_magnitude']:.15g} N, "
          f"{cs.iterations} iterations, {act.size} active (sha1 {hashlib.sha1(act.tobytes()).hexdigest()[:10]}), "
          f"{t:.1f} CPU s; contact solve {tim['total']:.2f} s wall: dense {tim['dense']:.2f} s, "
          f"schur {tim['schur']:.2f} s")


def border(refine: int, counts: list[int]) -> None:
    """CPU seconds of ``substructure.factorize_contact`` bordered by the deepest k rows of the overlap G."""
    from shellcontact.analysis.discretization import discretize
    from shellcontact.problem.case import load_case
    from shellcontact.solvers.substructure import factorize_contact

    qp = discretize(load_case(CASE, [f"mesh.refine={refine}"])).qp()
    order = np.argsort(qp.G, kind="stable")
    for k in counts:
        rows = np.sort(order[:k])
        t, fac = _cpu(factorize_contact, qp.A, qp.B[rows], min_unknowns=0, flexibility=qp.flexibility[rows])
        print(f"border of {k} rows: {t:.2f} CPU s (Schur complement: {fac.schur is not None})", flush=True)
        del fac


if __name__ == "__main__":
    what, *rest = sys.argv[1:] or ["kernels"]
    if what == "kernels":
        kernels()
    elif what == "border":
        border(int(rest[0]), [int(k) for k in rest[1:]])
    else:
        force(int(rest[0]), rest[1] if len(rest) > 1 else "active-set")
