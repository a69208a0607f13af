"""A case's friction (``punch.<i>.friction``, ``punch.<i>.slide``; MODEL.md §11) in ``analysis.solve``.

``has_friction(case)`` says whether any punch has friction or a slide; then ``solve_friction`` replaces the
frictionless contact solve: Tresca (a bound g in Pa, acting on the rows in contact: the bound of row i is
ω_i g where Λ_i > 0) or Coulomb (μ, the fixed point g = μ|∇Z|Λ), each Tresca problem of the fixed point
solved by the semismooth Newton of ``solvers.tresca_newton`` (method "active-set"), the dual with disc
constraints (method "dual") or the penalty (method "penalty", its ε). The fixed point is needed for the
case's Tresca too: its bound on the contact set is not a convex problem (docs/theory.md §9a).
``attach_friction`` adds the friction force to the shell's balance and the per-punch ``friction`` entry of
summary.json. Frictionless cases never come here: their results are today's, bit for bit.
"""

from __future__ import annotations

import sys
from typing import Any

import numpy as np

from ..contact.friction import COULOMB_CONTRACTION, COULOMB_TOL, TangentialOperator, solve_coulomb, tangential_operator
from ..linalg import factorize
from ..problem.case import Case
from ..solvers.qp import ContactSolution
from ..solvers.tresca import solve_tresca_dual, solve_tresca_penalty
from ..solvers.tresca_newton import solve_tresca_newton
from .validity import ResultWarning

#: the penalty's normal forces carry Newton's round-off (changes of ~3e-9 of the largest bound between
#: iterations on the paper panel at its default ε), so its fixed point stops at this relative change
PENALTY_FIXED_POINT_TOL = 1e-7


def has_friction(case: Case) -> bool:
    """Whether any punch of ``case`` has friction or a slide (else the frictionless path, unchanged)."""
    return any(p.friction.active or p.slide is not None for p in case.punches)


def solve_friction(case: Case, d: Any, setup: Any, method: str, tolerance: float) -> tuple[ContactSolution, dict]:
    """The contact solve with friction on the discretisation ``d`` (``analysis.Discretization``) from the
    ``analysis.ContactSetup`` ``setup``. Returns the solution of the reduced QP (``info`` holds T, slip, bounds)
    and the friction record for ``attach_friction``."""
    op, qp = d.operator, setup.qp
    top = tangential_operator(d.space, op)
    C = (top.C @ d.reduction.P).tocsr()
    c = top.offsets([p.slide for p in case.punches])
    specs = [case.punches[k].friction for k in op.punch]
    mu = np.array([s.coefficient if s.model == "coulomb" else 0.0 for s in specs])
    tresca_g = top.tresca_bounds(op.weights, np.array([s.bound if s.model == "tresca" else 0.0 for s in specs]))
    scale = np.linalg.norm(op.grad, axis=0)

    def bounds(Lam: np.ndarray) -> np.ndarray:
        return mu * scale * np.maximum(Lam, 0.0) + np.where(Lam > 0, tresca_g, 0.0)

    if method == "active-set":
        options = {"factorization": setup.factorization if setup.screen is None else None, "tol": tolerance,
                   "cache": {}}
        tresca, fixed_tol = solve_tresca_newton, COULOMB_TOL

        def warm(sol: ContactSolution) -> dict:
            return {"initial": np.concatenate([sol.Lambda, sol.info["T"]])}
    elif method == "penalty":
        options: dict[str, Any] = {"epsilon": setup.eps, "tol": tolerance}
        tresca, fixed_tol = solve_tresca_penalty, PENALTY_FIXED_POINT_TOL

        def warm(sol: ContactSolution) -> dict:  # from the stuck state each time: from the last U, whose slips
            return {}  # are far from the new ones, Newton crawled (100 steps on the paper panel)
    else:
        fac = setup.factorization if setup.screen is None else factorize(qp.A)
        options = {"factorization": fac, "tol": tolerance, "cache": {}}
        tresca, fixed_tol = solve_tresca_dual, COULOMB_TOL

        def warm(sol: ContactSolution) -> dict:
            return {"initial": np.concatenate([sol.Lambda, sol.info["T"]])}
    sol, record = solve_coulomb(qp, C, c, bounds, tresca, fixed_point_tol=fixed_tol, warm=warm, **options)
    return sol, {"operator": top, "record": record, "method": sol.method, "fallback": sol.info.get("fallback")}


def attach_friction(result: Any, friction: dict) -> None:
    """Put the friction force Cᵀ T into the shell's balance, the per-punch friction entries into the contact
    summary (``ContactResult.friction``) and a coded warning where the fixed point did not contract."""
    top: TangentialOperator = friction["operator"]
    sol = result.contact.solution
    T, slip, g = sol.info["T"], sol.info["slip"], sol.info["bounds"]
    result.solution.extra_forces = result.solution.extra_forces + top.C.T @ T
    record = friction["record"]
    entries = top.summary(result.contact.operator.weights, T, slip, g, result.contact.Lambda)
    for entry in entries:
        entry["units"] = {"force": "N", "stick_area": "m²", "slip_area": "m²", "max_slip": "m"}
        entry["fixed_point"] = record.summary()
        entry["method"] = friction["method"]
    result.contact.friction = entries
    if record.cycle:
        text = ("friction: the contact set alternates between sets that each, with the Tresca bound on its rows, "
                "close different rows: the Tresca law on the contact set has no solution among them (the bound "
                "exceeds what the contact pressure can hold without lifting the shell; docs/theory.md §9a) and "
                "this result is not one; lower the Tresca bound or the slide, or use Coulomb friction")
        result.info.setdefault("warnings", []).append(ResultWarning("friction_no_solution", text))
        print(f"warning: {text}", file=sys.stderr)
    elif not record.converged or record.contraction > COULOMB_CONTRACTION:
        state = (f"did not converge in {record.iterations} iterations" if not record.converged
                 else f"contracts only by {record.contraction:.3g} per iteration (> {COULOMB_CONTRACTION})")
        text = (f"friction: the fixed point of the friction bounds on the normal forces {state}: the static friction "
                "problem may have several solutions, and this result is not one of them unless it converged; lower "
                "the friction coefficient or the Tresca bound, or the slide")
        result.info.setdefault("warnings", []).append(ResultWarning("friction_contraction", text))
        print(f"warning: {text}", file=sys.stderr)
