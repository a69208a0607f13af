"""Issue 26 item 6: what a friction pair costs at a given mesh of examples/panel_pushed_sideways.toml — the
solves A⁻¹C_jᵀ (two per pair in contact) with the factorisation of A, and the number of rows in contact of
the frictionless solution (the pairs a Tresca or Coulomb solve needs).

    .venv/bin/python benchmarks/pair_solve_cost.py 112     # nx = nphi = 112: 211k unknowns
"""

from __future__ import annotations

import sys
import time
import tomllib

from friction_cost import CASE

from shellcontact import solve
from shellcontact.analysis.discretization import discretize
from shellcontact.contact.friction import tangential_operator
from shellcontact.linalg import factorize
from shellcontact.problem.case import case_from_dict


def main(n: int) -> None:
    data = tomllib.loads(CASE.read_text())
    data["mesh"].update(nx=n, nphi=n, refine=0)
    data["punch"][0].pop("slide", None)
    data["punch"][0]["friction"] = 0.0
    case = case_from_dict(data)
    rows = int((solve(case, method="active-set").contact.Lambda > 0).sum())
    d = discretize(case)
    qp = d.qp()
    C = (tangential_operator(d.space, d.operator).C @ d.reduction.P).tocsr()
    t = time.process_time()
    fac = factorize(qp.A)
    print(f"unknowns {qp.n}; rows in contact (frictionless) {rows}; factorise {time.process_time() - t:.2f} CPU s")
    R = C[:128].T.toarray()
    for k in (1, 128):
        t = time.process_time()
        fac.solve_many(R[:, :k], refine=False)
        print(f"{k} right-hand sides: {time.process_time() - t:.3f} CPU s")


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 112)
