"""Contact solvers for the discrete QP of MODEL.md §8 (independent of punches and meshes).

    minimise ½UᵀAU − FᵀU (− Pᵀδ)   subject to   G + BU (+ Dδ) ≥ 0

Public API::

    from shellcontact.solvers import (ContactQP, ContactSolution, solve_penalty, solve_active_set,
                                      solve_dual, kkt_residuals)

    qp = ContactQP(A, F, B, G, weights, D=None, P=None)        # validated on construction
    solve_penalty(qp, epsilon=1e-6, continuation=None | [eps...], tol=1e-10, max_iterations=50, factorization=None)
    solve_active_set(qp, tol=1e-10, max_iterations=100, initial_active=None, factorization=None)
    solve_dual(qp, tol=1e-10, max_iterations=500, factorization=None)
    kkt_residuals(qp, U, Lambda, delta=None, factorization=None) -> dict

All three return a ``ContactSolution`` (U, Lambda = nodal forces, pressure = Λ/ω, active,
delta, iterations, residuals, method, history, timings, energy, dual_value, info). Pass
``factorization=shellcontact.linalg.factorize(A)`` to share one factorisation between solves.
Every solver works on the Schur complement S = B A⁻¹ Bᵀ, whose columns it computes lazily by
blocked solves with that single factorisation (``schur.Workspace``): only constraints that
carry force ever cost a solve. Errors: ``InputError`` (bad arguments, ε ≤ 0),
``InfeasibleProblemError`` (a ``SolverError``: empty admissible set, lists the constraints),
``SolverError`` (no convergence; carries ``residuals`` and ``iterations``).

Stopping: every residual of ``kkt.kkt_residuals`` scaled as documented in ``kkt`` must be
≤ tol; stationarity is tested as a normwise backward error ‖r‖/‖|A||U| + |F| + |Bᵀ|Λ‖ because
the forward form ‖r‖/‖F + BᵀΛ‖ reported in ``residuals`` has a round-off floor ε_mach·cond
(~1e-9 on fourth-order shells at 10⁵ dofs). The penalty method reports the exact-problem
residuals (penetration and complementarity O(ε)) and stops on the backward error of the
penalised equation.

Options beyond the common API: ``initial_U`` (active set, penalty), ``initial_lambda`` /
``initial_active`` (dual), ``growth`` (active set, dual: restricted growth of the working set),
``fallback`` (active set), ``hessian="schur"|"refactorize"`` (penalty).

Large problems (what ``analysis.solve`` does for the exact methods from 40k unknowns)::

    from shellcontact.solvers.screening import factorize_screened, solve_screened
    fac, rows = factorize_screened(qp)            # A bordered by the rows predicted to touch
    sol = solve_screened(qp, rows, solve_active_set, fac)   # rows None: the whole QP directly

``extended=True`` (active set, dual) refines the final solves in extended precision.

Modules: qp (data, feasibility check), kkt (residuals, duality gap), schur (factorisation and
S columns), substructure (a factorisation that also yields the dense S: ``factorize_contact``),
screening (the Schur complement of the rows predicted to touch, the others verified), penalty,
active_set (PDAS + fallback), dual (MPRGP with exact face solves, SMALBE for force control).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from ..lazy import lazy_attributes

if TYPE_CHECKING:
    from .active_set import solve_active_set
    from .dual import solve_dual
    from .kkt import dual_value, kkt_residuals, lagrangian
    from .penalty import solve_penalty
    from .qp import ContactQP, ContactSolution, InfeasibleProblemError, check_feasibility

# the public names, imported on first use: reading the method registry (solvers.methods) imports no solver
_LAZY = {
    "solve_active_set": "active_set", "solve_dual": "dual", "dual_value": "kkt", "kkt_residuals": "kkt",
    "lagrangian": "kkt", "solve_penalty": "penalty", "ContactQP": "qp", "ContactSolution": "qp",
    "InfeasibleProblemError": "qp", "check_feasibility": "qp",
}
__all__ = [
    "ContactQP",
    "ContactSolution",
    "InfeasibleProblemError",
    "check_feasibility",
    "dual_value",
    "kkt_residuals",
    "lagrangian",
    "solve_active_set",
    "solve_dual",
    "solve_penalty",
]


__getattr__, __dir__ = lazy_attributes(__name__, _LAZY, globals(), __all__)
