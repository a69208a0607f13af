"""Friction whose bound depends on the normal force, by one semismooth Newton on the whole law: the
primal–dual active set of Hüeber, Stadler & Wohlmuth (SIAM J. Sci. Comput. 30 (2008) 572–596, their Coulomb
algorithm) with the bound updated inside the Newton, no outer fixed point (docs/theory.md §9a).

The law per row (``law`` = (m, 2): a = μ_i|∇Z_i| for Coulomb, t = ω_i g for the case's Tresca), with
ξ_i = Λ_i − c_n gap_i:

    Λ_i = max(0, ξ_i),   T_j = P_{|·| ≤ g_j}(T_j − c_t,j σ_j),   g_j = a_j max(0, ξ_j) + t_j [ξ_j > 0].

At the solution ξ_j = Λ_j on closed rows, so g_j = a_j Λ_j + t_j there and 0 on open rows: Coulomb's μ × the
normal force and the Tresca bound on the rows in contact. Each iteration takes the closed set 𝒜 as
``tresca_newton`` (the rows still pulling and the deepest penetrated), the bounds g from ξ of the iterate, the
pairs of 𝒜 with a law (the others have T_j = 0), their stick and slip sets, and solves the Newton system of
``tresca_newton`` with, on a slip pair j ∈ 𝒜, the bound's derivative: g_j = a_j Λ_j + t_j on 𝒜, so the linearised
slip law |z|T − g z = 0 gets the column −a_j z_j at Λ_j (normal and tangential sets together, HSW).

The case's Tresca (a = 0) has a bound that jumps with the closed set; where its law has no solution the sets
cycle (docs/theory.md §9a). The Newton stops at the first revisit of a set without a smaller residual, after
``tresca_newton.PATIENCE`` iterations without progress, or at ``max_iterations``, and says so in
``info["fallback"]``, returning its iterate of the smallest residual (no dual finish here: the caller runs the
fixed point of Tresca problems from that iterate instead).
"""

from __future__ import annotations

import time

import numpy as np
import scipy.sparse as sp

from ..linalg import Factorization
from .qp import ContactQP, ContactSolution, check_arguments
from .schur import Workspace, deepest_violations, default_growth
from .tresca import friction_residuals
from .tresca_newton import SetWatch, _pair_products, _solve_equilibrated, _system, _tangential_ncp

#: the most penetrated rows that join the closed set per iteration. Each joins with its friction at the bound
#: (slip), and the friction's moment through the Kirchhoff offset lifts its neighbours: on the 32 × 32 panel
#: (1 mm slide) the frictionless set's rule (at least 64 rows) closed 98 rows where 54 touch and wandered
#: (μ = 0.3, 1: no convergence); at most 4 rows: converged in 10–12 iterations for μ = 0.1, 0.3, 1
#: (μ = 3 with no limit, 1, 4 or 16: not in 25)
JOIN_LIMIT = 4
#: while the residual falls, up to this share of the closed set joins per iteration (at least ``JOIN_LIMIT``);
#: after a step that raised it, ``JOIN_LIMIT`` again: 4 rows per iteration crept from 254 to 290 closed rows in
#: 21 iterations at 211k unknowns where the solution closes ≈ 560 (a fixed 16 or 64 overshot at 68k)
JOIN_SHARE = 0.25


def law_bounds(law: np.ndarray, xi: np.ndarray) -> np.ndarray:
    """g_j = a_j max(0, ξ_j) + t_j [ξ_j > 0] (N) of the law (m, 2) = (a, t) at ξ (module docstring)."""
    return law[:, 0] * np.maximum(xi, 0.0) + np.where(xi > 0, law[:, 1], 0.0)


def solve_friction_newton(qp: ContactQP, C: sp.spmatrix, c: np.ndarray, law: np.ndarray, tol: float = 1e-10,
                          max_iterations: int = 50, factorization: Factorization | None = None,
                          initial: np.ndarray | None = None, cache: dict | None = None) -> ContactSolution:
    """The friction law ``law`` (m, 2) = (μ|∇Z|, Tresca ω g) per row by semismooth Newton (module docstring).
    ``initial`` a start y = (Λ, T) (m + 2m), by default Λ = 0; ``cache`` a dict kept between calls on the same QP,
    C and c (the Workspace and the pair solves). ``info["fallback"]`` is None where it converged, else why not."""
    check_arguments(tol, max_iterations)
    m = qp.m
    law = np.asarray(law, float).reshape(m, 2)
    C = sp.csr_matrix(C)
    c = np.asarray(c, float)
    t0 = time.perf_counter()
    cache = {} if cache is None else cache
    if "ws" not in cache:
        cache["ws"] = Workspace(qp, factorization)
    ws: Workspace = cache["ws"]
    has_law = (law > 0).any(axis=1)
    Lam = np.zeros(m) if initial is None else np.maximum(np.asarray(initial[:m], float), 0.0)
    T = np.zeros(2 * m) if initial is None else np.asarray(initial[m:], float).copy()
    T.reshape(-1, 2)[~has_law] = 0.0
    growth = default_growth(ws)
    tscale = float(law[:, 1].max(initial=0.0))
    history: list = []
    watch = SetWatch(tol)
    fallback = None
    g = np.zeros(m)
    it = 0
    ct = cache.setdefault("ct", {})
    lawful = np.flatnonzero(has_law)

    def pair_constants(pairs: np.ndarray) -> None:
        """c_t of the pairs: 1 / the pair's flexibility (its solves A⁻¹C_jᵀ kept in ``cache``)."""
        new = np.array([j for j in pairs if j not in ct], dtype=int)
        if new.size:
            _pair_products(qp, C, new, ws, cache)
            for j in new:
                ct[j] = 2.0 / max(float(np.trace(cache["CX"][j][2 * j:2 * j + 2])), 1e-300)

    def measure(Lam: np.ndarray, T: np.ndarray) -> dict:
        """U, gaps, slips, ξ and the bounds at y = (Λ, T), and the law's residual (NCP functions scaled by the
        largest force), with the law's bound where Λ_j > 0 and 0 elsewhere (the normal residual measures any
        penetration), so there its residual is |T_j| (g from ξ would put the Tresca bound on rows
        penetrating at round-off, ξ = −c_n gap > 0)."""
        U = ws.solve(qp.F + qp.B.T @ Lam + C.T @ T)
        gap, sigma = qp.gap(U), (C @ U - c).reshape(-1, 2)
        lam_scale = max(float(Lam.max(initial=0.0)), tscale, 1e-300)
        xi = Lam - lam_scale / ws.length_scale(gap) * gap
        g = law_bounds(law, xi)
        on = Lam[lawful] > 0
        # c_t of a pair not yet solved: the mean of the others (it only scales that pair's NCP function; a
        # solve for it here, one call of the factorisation per iteration, took 22 of 66 s at 68k unknowns)
        if not ct:  # the first: the pairs in contact, solved once (they are the first Newton system's pairs)
            pair_constants(lawful[on])
        known = float(np.mean(list(ct.values()))) if ct else 0.0
        cl = np.array([ct.get(j, known) for j in lawful])
        _, rt = _tangential_ncp(T.reshape(-1, 2)[lawful], sigma[lawful], np.where(on, g[lawful], 0.0), cl)
        normal = float(np.abs(Lam - np.maximum(0.0, xi)).max(initial=0.0)) / lam_scale
        tangential = float(np.linalg.norm(rt, axis=1).max(initial=0.0)) / lam_scale
        return {"gap": gap, "sigma": sigma, "g": g, "normal": normal, "tangential": tangential,
                "residual": max(normal, tangential)}

    def newton_step(closed: np.ndarray, Lam: np.ndarray, T: np.ndarray, state: dict
                    ) -> tuple[np.ndarray, np.ndarray] | None:
        """The Newton step (Λ, T) on the closed set ``closed`` from the iterate (None: singular)."""
        gap, sigma, g = state["gap"], state["sigma"], state["g"]
        A = np.flatnonzero(closed)
        pairs = np.flatnonzero(closed & has_law)
        pair_constants(pairs)
        BXp, SPP = _pair_products(qp, C, pairs, ws, cache)
        cp = np.array([ct[j] for j in pairs])
        b = g[pairs]
        Tp, sig = T.reshape(-1, 2)[pairs], sigma[pairs]
        # pairs that left the system (their row opened) carry T_j ≠ 0 in the iterate and 0 after the step: their
        # part of the gaps and slips leaves the offsets too (``_system`` removes only the system's own pairs'),
        # else every closed row's gap after the step is off by B A⁻¹C_jᵀT_j (68k: 1e-6–3e-4 of the length
        # scale, the residual's plateaus of ≈ 2e-6 at any closed set, benchmarks/RESULTS.md "Branch coul15")
        # (the slip law stays linearised at the iterate's true slips)
        gap0, sig0 = gap, sig
        left = np.setdiff1d(np.flatnonzero(np.any(T.reshape(-1, 2) != 0.0, axis=1)), pairs)
        if left.size:
            missing = np.array([j for j in left if j not in cache["BX"]], dtype=int)
            if missing.size:  # a start's T off its closed rows (else kept from when they were pairs)
                _pair_products(qp, C, missing, ws, cache)
            Tl = T.reshape(-1, 2)[left].ravel()
            gap0 = gap - np.hstack([cache["BX"][j] for j in left]) @ Tl
            sig0 = sig - (np.hstack([cache["CX"][j] for j in left]) @ Tl).reshape(-1, 2)[pairs]
        z, _ = _tangential_ncp(Tp, sig, b, cp)
        nz = np.linalg.norm(z, axis=1)
        slip = (nz >= b) & (nz > 0)
        J, rhs = _system(ws, A, BXp, SPP, Lam, Tp, gap0, sig0)
        k = A.size
        at = np.searchsorted(A, pairs)  # the column of Λ_j for pair j
        for j in np.flatnonzero(slip):  # slip rows: the linearised slip law with the bound's derivative
            r = slice(k + 2 * j, k + 2 * j + 2)
            n = z[j] / nz[j]
            Tt = b[j] * Tp[j] / max(b[j], float(np.linalg.norm(Tp[j]))) if b[j] > 0 else np.zeros(2)
            M = np.outer(Tt, n) + (nz[j] - b[j]) * np.eye(2)
            N = cp[j] * (np.outer(Tt, n) - b[j] * np.eye(2))
            Fj = nz[j] * Tp[j] - b[j] * z[j]
            a = law[pairs[j], 0]
            rows = -N @ J[r]
            rows[:, k + 2 * j:k + 2 * j + 2] += M
            rows[:, at[j]] -= a * z[j]  # g_j = a_j Λ_j + t_j on the closed set
            rhs[r] = M @ Tp[j] - N @ sig[j] - a * z[j] * Lam[pairs[j]] - Fj - N @ rhs[r]
            J[r] = rows
        y = _solve_equilibrated(J, rhs)
        if y is None:
            return None
        Lam_new = np.zeros(m)
        Lam_new[A] = y[:k]
        T_new = np.zeros(2 * m)
        T_new.reshape(-1, 2)[pairs] = y[k:].reshape(-1, 2)
        return Lam_new, T_new

    state = measure(Lam, T)
    best = (np.inf, Lam, T)  # the smallest residual's iterate
    falling = False  # the last step lowered the residual: the join limit grows with the closed set
    for it in range(1, max_iterations + 1):
        gap, sigma, g = state["gap"], state["sigma"], state["g"]
        keep = Lam > 0
        limit = max(JOIN_LIMIT, int(JOIN_SHARE * keep.sum())) if falling else JOIN_LIMIT
        closed = keep | deepest_violations(gap + tol * ws.length_scale(gap), ~keep, growth, int(keep.sum()),
                                           limit=limit)
        pairs = np.flatnonzero(closed & has_law)
        pair_constants(pairs)
        resid = state["residual"]
        b = g[pairs]
        z, _ = _tangential_ncp(T.reshape(-1, 2)[pairs], sigma[pairs], b, np.array([ct[j] for j in pairs]))
        nz = np.linalg.norm(z, axis=1)
        slip = (nz >= b) & (nz > 0)
        key = (closed.tobytes(), pairs[slip].tobytes())
        history.append({"iteration": it, "closed": int(closed.sum()), "stick": int((~slip).sum()),
                        "slip": int(slip.sum()), "residual": resid, "normal": state["normal"],
                        "tangential": state["tangential"]})
        if resid < best[0]:
            best = (resid, Lam, T)
        if resid <= tol:
            break
        stop, fallback = watch.stop(key, resid)  # the same rule as the Tresca Newton
        if stop:
            break
        step = newton_step(closed, Lam, T, state)
        joined = closed & ~keep
        # rows that joined and pull in the step leave again before it is taken (the frictionless active set's rule
        # in ``schur.finish_exact``): at 16.8k unknowns, μ = 0.3, two edge rows joined at a residual of 1.5e-4, the
        # full step with them made it 0.62 and the sets cycled (7 iterations); without them: converged in 6
        while True:  # ends: each pass removes a joined row, or stops
            pulling = joined & (step[0] < 0) if step is not None else np.zeros(m, bool)
            if not pulling.any():
                break
            closed, joined = closed & ~pulling, joined & ~pulling
            step = newton_step(closed, Lam, T, state)
        if step is None:
            fallback = "singular"
            break
        # full steps: a backtracking on the residual's max norm found no shorter step that lowers it once rows
        # with small Λ change sets (32 × 32 panel, μ = 0.1–1: stalled at 1e-5–2e-2, where full steps converge)
        Lam, T = step
        state = measure(Lam, T)
        falling = state["residual"] < resid
    else:
        fallback = "iterations"
        if state["residual"] < best[0]:  # the last step's iterate, measured but not yet compared
            best = (state["residual"], Lam, T)
    if fallback is not None:  # the best iterate, the start of what follows (the fixed point, ``analysis.friction``)
        resid, Lam, T = best
    U = ws.solve(qp.F + qp.B.T @ Lam + C.T @ T)
    gap = qp.gap(U)
    bounds = law_bounds(law, np.maximum(Lam, 0.0))  # at the solution ξ = Λ on the closed rows
    res = friction_residuals(qp, C, c, bounds, U, Lam, T)
    return ContactSolution(
        U=U, Lambda=Lam, pressure=Lam / qp.weights, active=Lam > 0, delta=None, iterations=it, residuals=res,
        method="coulomb-active-set", history=history, energy=qp.energy(U),
        timings={"newton": time.perf_counter() - t0, "total": time.perf_counter() - t0},
        info={"T": T, "slip": C @ U - c, "bounds": bounds, "gap": gap, "fallback": fallback,
              "residual": resid if history else 0.0})

