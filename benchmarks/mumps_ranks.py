"""Issue 27: the mumps backend on 1 and 2 MPI ranks against PARDISO, on the demo case's stiffness.

    python benchmarks/mumps_ranks.py --refine 2                      # PARDISO, one process
    mpiexec -n 1 python benchmarks/mumps_ranks.py --refine 2 --backend mumps
    mpiexec -n 2 python benchmarks/mumps_ranks.py --refine 2 --backend mumps

Rank 0 builds the reduced stiffness A and the contact rows B of src/shellcontact/cases/paper_panel.toml at
``mesh.refine`` (``analysis.discretize``), factorises A (CPU and wall seconds), solves one right-hand side
(refined) and one block of 64 columns of Bᵀ (unrefined, as ``solvers.schur`` does), and prints one JSON line:
those times, the relative difference of the solution from PARDISO's (``--compare``), MUMPS's memory for the
factors on each rank (INFO(16), MB) and the peak resident set of each rank (bytes). Under mpiexec the other
ranks serve the MUMPS calls (``linalg.mpi.run_on_host``). The whole contact solve end to end is
``shellcontact run`` (docs/scaling.md gives both).
"""

from __future__ import annotations

import argparse
import json
import resource
import time
from pathlib import Path

import numpy as np

CASE = Path(__file__).resolve().parent.parent / "src" / "shellcontact" / "cases" / "paper_panel.toml"


def _cpu() -> float:
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime


def measure(refine: int, backend: str, compare: bool) -> dict:
    import shellcontact
    from shellcontact.analysis.discretization import discretize
    from shellcontact.linalg import factorize
    from shellcontact.linalg.mpi import mpi_started, peak_memory_bytes

    d = discretize(shellcontact.load_case(CASE, [f"mesh.refine={refine}"]))
    A, B = d.Ar, d.Br
    b = np.random.default_rng(0).standard_normal(A.shape[0])
    BT = B[:: max(1, B.shape[0] // 64)][:64].T.toarray()
    out: dict = {"refine": refine, "unknowns": A.shape[0], "nnz": int(A.nnz), "backend": backend}
    t, c = time.perf_counter(), _cpu()
    f = factorize(A, backend)
    out["factor_wall_s"], out["factor_cpu_s_rank0"] = time.perf_counter() - t, _cpu() - c
    t = time.perf_counter()
    x = f.solve(b)
    out["solve_wall_s"] = time.perf_counter() - t
    t = time.perf_counter()
    f.solve_many(BT, refine=False)
    out["block64_wall_s"] = time.perf_counter() - t
    info = f.info()
    out["factor_nnz"] = info["factor_nnz"]
    out["factor_mb_per_rank"] = info.get("factor_megabytes_per_rank")
    out["backward_error"] = f.backward_error
    f.free()
    if compare and backend != "pardiso":
        ref = factorize(A, "pardiso")
        out["difference_from_pardiso"] = float(np.max(np.abs(x - ref.solve(b))) / np.max(np.abs(x)))
        ref.free()
    out["peak_memory_bytes"] = peak_memory_bytes() if mpi_started() else [
        resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024]
    return out


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--refine", type=int, default=1)
    p.add_argument("--backend", default="pardiso")
    p.add_argument("--compare", action="store_true", help="also solve with PARDISO on rank 0 (its memory counts)")
    args = p.parse_args()
    from shellcontact.linalg.mpi import run_on_host

    result = run_on_host(lambda: measure(args.refine, args.backend, args.compare))
    if result is not None:
        print(json.dumps(result))


if __name__ == "__main__":
    main()
