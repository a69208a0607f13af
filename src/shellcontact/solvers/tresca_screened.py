"""Tresca friction on the screened rows: the frictionless pipeline's bordered factorisation reused
(``screening.factorize_screened``: A with the dense Schur complement of the rows predicted to touch).

A row outside the contact zone has Λ_i = 0 and, since its bound is 0 there (the case's Tresca bound and
Coulomb's μΛ act on the rows in contact only), T_i = 0: it leaves the problem as long as it does not
penetrate. So the Tresca problem is solved on the rows ``order`` (the screened rows first, so that the
``schur.Workspace`` of the restricted QP takes its normal block from the dense Schur complement, then the
rows of the frictionless contact set and those with a bound), and a row outside that penetrates joins the
next round, as in ``screening.solve_screened``. Every Tresca solve of Coulomb's fixed point reuses one
``Workspace`` per row set (its Schur columns and the pair solves A⁻¹C_jᵀ in ``cache``); the Newton's fallback,
the dual, then forms its dense Ŝ over these rows only, not over every candidate row.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import scipy.sparse as sp

from ..errors import SolverError
from ..linalg import Factorization
from .qp import ContactQP, ContactSolution
from .schur import Workspace
from .tresca import _pair_rows, friction_residuals, slips


def screened_order(screen: np.ndarray, extra: np.ndarray) -> np.ndarray:
    """The screened rows (in their order: the dense Schur complement's prefix) and then the rows of the mask
    ``extra`` not among them."""
    screen = np.asarray(screen, dtype=np.int64)
    inside = np.zeros(extra.size, dtype=bool)
    inside[screen] = True
    return np.concatenate([screen, np.flatnonzero(extra & ~inside)])


def solve_tresca_screened(qp: ContactQP, C: sp.csr_matrix, c: np.ndarray, g: np.ndarray, solver: Callable,
                          screen: np.ndarray, factorization: Factorization, cache: dict,
                          initial: np.ndarray | None = None, max_rounds: int = 20, **options) -> ContactSolution:
    """``solver`` (``solve_tresca_newton``) on the rows ``screen`` plus those with Λ > 0 in ``initial`` or a bound
    g > 0 (module docstring), growing by the rows outside that penetrate. ``cache`` keeps the row set and, per
    row set, the solver's cache (its Workspace on the restricted QP) between calls. ``g`` may be a law (m, 2)
    whose solver computes the bounds (``coulomb_newton``, bounds 0 off contact): then only Λ > 0 adds rows."""
    m = qp.m
    E = options.pop("E", None)  # the slips' δ columns (force control, rigid motions): restricted with the rows
    lam0 = np.zeros(m) if initial is None else np.asarray(initial[:m], float)
    need = (lam0 > 0) | (g > 0) if g.ndim == 1 else lam0 > 0
    order = cache.get("order")
    if order is None or np.any(need & ~_mask(order, m)):
        order = screened_order(screen, need | (_mask(order, m) if order is not None else np.zeros(m, bool)))
    rounds: list[int] = []
    for _ in range(max_rounds):
        rounds.append(int(order.size))
        key = order.tobytes()
        if cache.get("key") != key:  # a new row set: a new Workspace (the dense Schur complement's prefix reused)
            sub = qp.restrict(order)
            cache.update(key=key, order=order, sub=sub, inner={"ws": Workspace(sub, factorization), "rows": order,
                                                               "tail": cache.setdefault("tail", {})})
        sub, inner = cache["sub"], cache["inner"]
        pr = _pair_rows(order)
        start = None if initial is None else np.concatenate([lam0[order], np.asarray(initial[m:3 * m]).reshape(-1, 2)
                                                             [order].ravel(), np.asarray(initial[3 * m:])])
        if E is not None:  # only the Tresca solvers take E (``coulomb_newton`` has no δ columns)
            options["E"] = E[pr]
        sol = solver(sub, C[pr], c[pr], g[order], factorization=factorization, initial=start, cache=inner, **options)
        gap = qp.gap(sol.U, sol.delta)
        if g.ndim == 2 and sol.info.get("fallback") is not None:  # a whole-law Newton that did not converge: its
            return _whole(qp, C, c, g, sol, order, gap, rounds, E)  # iterate's penetrations call no rows in
        outside = ~_mask(order, m) & (gap < 0)
        if not outside.any() or -gap[outside].min() <= options.get("tol", 1e-10) * max(float(np.abs(gap).max()),
                                                                                       1e-300):
            return _whole(qp, C, c, g, sol, order, gap, rounds, E)
        new = np.flatnonzero(outside)
        order = np.concatenate([order, new[np.argsort(gap[new], kind="stable")]])
        Lam, T = np.zeros(m), np.zeros(2 * m)
        Lam[order[:sol.Lambda.size]] = sol.Lambda
        T.reshape(-1, 2)[order[:sol.Lambda.size]] = sol.info["T"].reshape(-1, 2)
        initial, lam0 = np.concatenate([Lam, T] + ([sol.delta] if sol.delta is not None else [])), Lam
    raise SolverError(f"tresca (screened rows): rows outside kept penetrating after {max_rounds} rounds",
                      iterations=sum(rounds))


def _mask(order: np.ndarray | None, m: int) -> np.ndarray:
    out = np.zeros(m, dtype=bool)
    if order is not None:
        out[order] = True
    return out


def _whole(qp: ContactQP, C: sp.csr_matrix, c: np.ndarray, g: np.ndarray, sol: ContactSolution, order: np.ndarray,
           gap: np.ndarray, rounds: list[int], E: np.ndarray | None = None) -> ContactSolution:
    """The restricted solution as one of the whole problem (Λ = 0, T = 0 outside)."""
    m = qp.m
    Lam, T = np.zeros(m), np.zeros(2 * m)
    Lam[order] = sol.Lambda
    T.reshape(-1, 2)[order] = sol.info["T"].reshape(-1, 2)
    if g.ndim == 2:  # a law: the bounds its solver found on the rows, 0 outside (no contact)
        g = np.zeros(m)
        g[order] = sol.info["bounds"]
    info = {**sol.info, "T": T, "slip": slips(qp, C, c, sol.U, sol.delta, E), "bounds": g, "gap": gap,
            "screening": {"rows": rounds, "rounds": len(rounds), "candidates": m}}
    return ContactSolution(U=sol.U, Lambda=Lam, pressure=Lam / qp.weights, active=Lam > 0, delta=sol.delta,
                           iterations=sol.iterations,
                           residuals=friction_residuals(qp, C, c, g, sol.U, Lam, T, sol.delta, E),
                           method=sol.method, history=sol.history, energy=sol.energy, timings=sol.timings, info=info)
