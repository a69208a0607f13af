"""Issue 26 item 2: does the case's Tresca law (the bound ω_i g only on the rows in contact) have a solution?

On the paper's panel (8 × 8, tests/test_contact_solve.sphere_dict) with a 0.1 mm axial slide and g = 1e8 Pa,
the fixed point on the contact set alternates between two sets 𝒜 and ℬ. This script checks every set S with
𝒜 ∩ ℬ ⊆ S ⊆ 𝒜 ∪ ℬ: the classical Tresca problem with the bounds on S (solved by the dual) must close
exactly S for S to be a solution. Measured: 1024 sets, none consistent (120 s).

    .venv/bin/python benchmarks/tresca_contact_sets.py [--bound 1e8] [--slide 1e-4]
"""

from __future__ import annotations

import argparse
import itertools
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from test_contact_solve import sphere_dict  # noqa: E402

from shellcontact.analysis.discretization import discretize  # noqa: E402
from shellcontact.contact.friction import tangential_operator  # noqa: E402
from shellcontact.linalg import factorize  # noqa: E402
from shellcontact.problem.case import case_from_dict  # noqa: E402
from shellcontact.solvers.tresca import solve_tresca_dual  # noqa: E402


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--bound", type=float, default=1e8, help="Tresca bound g (Pa)")
    ap.add_argument("--slide", type=float, default=1e-4, help="axial slide (m)")
    args = ap.parse_args()
    d = discretize(case_from_dict(sphere_dict(n=8)))
    qp, op = d.qp(), d.operator
    top = tangential_operator(d.space, op)
    C, c = (top.C @ d.reduction.P).tocsr(), top.offsets([np.array([args.slide, 0.0, 0.0])])
    fac, cache = factorize(qp.A), {}
    g = top.tresca_bounds(op.weights, args.bound)

    def closes(S: np.ndarray) -> np.ndarray:
        return solve_tresca_dual(qp, C, c, np.where(S, g, 0.0), factorization=fac, cache=cache).Lambda > 0

    sets = [closes(np.zeros(qp.m, bool))]
    while not any(np.array_equal(sets[-1], s) for s in sets[:-1]):
        sets.append(closes(sets[-1]))
    cycle = sets[[i for i, s in enumerate(sets[:-1]) if np.array_equal(s, sets[-1])][0]:-1]
    print(f"fixed point on the contact set: {len(sets) - 1} steps, cycle of {len(cycle)} sets:",
          [np.flatnonzero(s).tolist() for s in cycle])
    if len(cycle) == 1:
        print("it converged: the law has this solution")
        return
    lo, hi = np.logical_and.reduce(cycle), np.logical_or.reduce(cycle)
    free = np.flatnonzero(hi & ~lo)
    t, found = time.perf_counter(), []
    for r in range(free.size + 1):
        for sub in itertools.combinations(free, r):
            S = lo.copy()
            S[list(sub)] = True
            if np.array_equal(closes(S), S):
                found.append(np.flatnonzero(S).tolist())
    print(f"{2 ** free.size} sets between the cycle's intersection and union checked in "
          f"{time.perf_counter() - t:.0f} s; consistent: {found or 'none'}")


if __name__ == "__main__":
    main()
