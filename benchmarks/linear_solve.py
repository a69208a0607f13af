"""Target 2: the sparse factorisation backends on one shell stiffness (clamped panel).

    python benchmarks/linear_solve.py             # 160 × 160 mesh, about 430k unknowns
    python benchmarks/linear_solve.py --quick     # 48 × 48, about 40k unknowns
    python benchmarks/linear_solve.py --n 96 --backends pardiso,superlu

For every available backend (PARDISO, CHOLMOD, SuperLU; SuperLU is the peer that is always
there), in a fresh subprocess: assemble and reduce the stiffness, factorise (analysis +
numeric), solve one right-hand side, and refactorise the same pattern with new values
(symbolic analysis reused). The right-hand side is b = A x* for a random x*, so every backend's
solution is compared with the others'. Memory: the process's maximum RSS over the
factorisation (MKL's and CHOLMOD's own allocations are not seen by tracemalloc) and, for
PARDISO, the memory it reports for the factors.
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import common  # noqa: E402

PANEL = dict(radius=1.0, length=2.0, thickness=0.01, alpha=0.0, beta=1.0)
MATERIAL = dict(young=1.0, poisson=0.3)


def build_system(n: int):
    from shellcontact.shell import model
    from shellcontact.shell.geometry import Shell
    from shellcontact.shell.material import Isotropic
    from shellcontact.shell.mesh import structured
    from shellcontact.shell.spaces import ShellSpace
    from shellcontact.shell.supports import Reduction, Supports

    space = ShellSpace(structured(Shell(**PANEL, material=Isotropic(**MATERIAL)), n, n))
    A = model.stiffness(space)
    return space, Reduction.build(space, Supports()).reduce_matrix(A)


def worker(n: int, backend: str, out: str) -> dict:
    from shellcontact import linalg

    t0 = time.perf_counter()
    _, A = build_system(n)
    t_build = time.perf_counter() - t0
    rss_before = common.max_rss_bytes()
    x_true = np.random.default_rng(0).standard_normal(A.shape[0])
    b = A @ x_true
    t0, c0 = time.perf_counter(), time.process_time()
    f = linalg.factorize(A, backend)
    t_fact, c_fact = time.perf_counter() - t0, time.process_time() - c0
    t0 = time.perf_counter()
    x = f.solve(b)
    t_solve = time.perf_counter() - t0
    res, berr, nref = f.residual, f.backward_error, f.refinements
    A2 = A.copy()
    A2.data *= 1.5
    t0 = time.perf_counter()
    f.refactor(A2)
    t_refactor = time.perf_counter() - t0
    x2 = f.solve(b)
    np.save(out, x)
    info = f.info()
    return {"n": n, "unknowns": A.shape[0], "nnz": int(A.nnz), "backend": backend, "build": t_build,
            "factorize": t_fact, "factorize_cpu": c_fact, "solve": t_solve, "refactor": t_refactor, "residual": res,
            "backward_error": berr,
            "refinements": nref, "error_vs_x_true": float(np.linalg.norm(x - x_true) / np.linalg.norm(x_true)),
            "refactor_check": float(np.linalg.norm(1.5 * x2 - x) / np.linalg.norm(x)),
            "rss_before_gb": rss_before / 1e9, "factor_nnz": info.get("factor_nnz"),
            "pardiso_factor_gb": info["kb_factor"] / 2**20 if "kb_factor" in info else None}


def main(argv=None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--n", type=int, help="mesh n × n (default 160, quick 48)")
    ap.add_argument("--backends", help="comma-separated subset of the available backends")
    ap.add_argument("--worker", nargs="*")
    args = ap.parse_args(argv)
    if args.worker:
        res = worker(int(args.worker[0]), args.worker[1], args.worker[2])
        common.emit(res)
        return res
    from shellcontact.linalg import available_backends

    n = args.n or (48 if args.quick else 160)
    backends = args.backends.split(",") if args.backends else available_backends()
    info = common.machine()
    results = {}
    with tempfile.TemporaryDirectory() as tmp:
        for be in backends:
            out = str(Path(tmp) / f"{be}.npy")
            results[be] = common.run_worker(Path(__file__), [str(n), be, out])
            results[be]["x"] = np.load(out)
    ref = results.get("superlu") or next(iter(results.values()))
    base = results[backends[0]]
    rows = []
    for be, r in results.items():
        diff = float(np.linalg.norm(r["x"] - base["x"]) / np.linalg.norm(base["x"]))
        rows.append([be, r["unknowns"], r["nnz"], r["factorize"], r["factorize_cpu"], r["solve"], r["refactor"],
                     r["max_rss_bytes"] / 1e9, r["factor_nnz"], r["backward_error"], diff,
                     ref["factorize"] / r["factorize"], ref["factorize_cpu"] / r["factorize_cpu"]])
    unknowns = base["unknowns"]
    print(f"# Sparse factorisation of the shell stiffness (clamped panel, {unknowns} unknowns, mesh {n}×{n})")
    print(common.machine_line(info))
    peer = "SuperLU" if "superlu" in results else backends[0]
    print(common.table(["backend", "unknowns", "nnz(A)", "factorize wall s", "factorize CPU s", "solve s",
                        "refactor s", "max RSS GB", "nnz(factor)", "backward error", f"|x - x_{backends[0]}|/|x|",
                        f"wall speedup vs {peer}", f"CPU speedup vs {peer}"], rows))
    out = {"linear_solve": {be: {k: v for k, v in r.items() if k != "x"} for be, r in results.items()},
           "machine": info}
    print(json.dumps(out))
    return out


if __name__ == "__main__":
    main()
