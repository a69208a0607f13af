"""Tresca friction by the exact primal method: a primal–dual active set / semismooth Newton on the normal
open/closed and the tangential stick/slip sets together (Hüeber, Stadler & Wohlmuth, SIAM J. Sci. Comput.
30 (2008) 572–596, their Tresca algorithm, in the multipliers; MODEL.md §11, docs/theory.md §9a).

The law, written as equations with c_n, c_t > 0 (``solvers.tresca`` for C, c, g; gap = B U + G, σ = C U − c):

    Λ_i = max(0, Λ_i − c_n gap_i)                      (normal: Λ ≥ 0, gap ≥ 0, Λ gap = 0)
    max(g_j, |z_j|) T_j = g_j z_j,  z_j = T_j − c_t,j σ_j   (tangential: T_j = P_{|·| ≤ g_j}(z_j))

It starts from the frictionless active set (``active_set``; or from ``initial``). Each iteration takes the
sets from the current iterate — closed 𝒜 = the rows still pulling (Λ_i > 0) and the deepest penetrated rows
(``schur.deepest_violations``, as the frictionless active set), stick 𝒮 = {|z_j| < g_j}, slip ℒ = the other
pairs with g_j > 0 — and solves the Newton system in y = (Λ, T):
Λ_i = 0 off 𝒜, gap_i = 0 on 𝒜, σ_j = 0 on 𝒮, and on ℒ the linearised slip law
[T̃ nᵀ + (|z| − g) I] T_j − c_t [T̃ nᵀ − g I] σ_j = (the same at the iterate) − F_j, n = z/|z|,
T̃ = g T/max(g, |T|) (HSW's damping of T in the derivative, which keeps the matrix regular away from the
solution). With U = A⁻¹(F + BᵀΛ + CᵀT), gap and σ are affine in y through Ŝ = B̂A⁻¹B̂ᵀ, so the system is
dense of order |𝒜| + 2·#{g_j > 0}: its normal block comes from ``schur.Workspace`` (columns of S only for
rows that were ever closed, cached), the pair products B A⁻¹C_jᵀ, C A⁻¹C_jᵀ from the Schur complement of a
factorisation bordered by the pairs' rows too (``pair_block``, where ``factorization`` is one) or else from
blocked solves A⁻¹C_jᵀ with the same factorisation (without refinement: the steps use the true gaps and
slips, so round-off in Ŝ is corrected like iterative refinement), kept in ``cache`` between calls (Coulomb's
fixed point changes only g). The iterate's gaps and slips come from one solve for U per iteration,
so open rows cost nothing.

Stops when the equations' residual (NCP functions scaled by the largest force and bound) is ≤ tol, or
≤ 1000·tol once the sets hold and it stops falling (round-off). Where a set returns with no smaller
residual, the residual has not fallen for ``PATIENCE`` iterations, or the iterations run out (the HSW
iteration has no global convergence proof), it hands over to the dual (``solve_tresca_dual``, MPGP, which
converges from any start) warm-started from its iterate; ``info["fallback"]`` says so.
"""

from __future__ import annotations

import time

import numpy as np
import scipy.linalg as la
import scipy.sparse as sp

from ..linalg import Factorization
from .active_set import solve_active_set
from .pair_block import PairBlock
from .qp import ContactQP, ContactSolution, check_arguments
from .schur import Workspace, deepest_violations, default_growth
from .tresca import _BLOCK, _check, _pair_rows, balance, force_scale, friction_residuals, slips, solve_tresca_dual

#: iterations without a new smallest residual after which the dual takes over (the sets wander: 50 iterations
#: without converging on the 8 × 8 panel at 1e8 Pa)
PATIENCE = 8
#: where the sets repeat but the residual no longer falls (its round-off), the residual accepted, relative to tol
_FLOOR = 1e3
#: rises of the residual in a row, with the sets held, after which the Newton stops (``stalled``)
RISES = 3


class SetWatch:
    """When a primal–dual active-set Newton stops short of ``tol`` (``stop`` gives why, or None while it goes on):
    the sets held and the residual rose ``RISES`` times in a row (``"stalled"``, or converged where it sits at its
    round-off, ``_FLOOR`` × tol: with the sets held it is Newton on the slip directions, quadratic until
    round-off, but its residual may rise a step or two before — the vessel on saddles, 454 sliding pairs: 1.2e-3,
    5.7e-3, 4.0e-5, 3.4e-4, 1.4e-8, 6.9e-12; stopping at the first rise, the dual took 789 steps); the sets
    returned to earlier ones without a smaller residual (``"cycle"``: a revisit with a smaller residual is not
    one, the slip directions differ); or ``PATIENCE`` iterations without a new smallest residual."""

    def __init__(self, tol: float) -> None:
        self.tol, self.seen, self.last = tol, {}, None
        self.best, self.since_best, self.rises, self.previous = np.inf, 0, 0, np.inf

    def stop(self, key: tuple, resid: float) -> tuple[bool, str | None]:
        """(stop, why: None where it stops converged)."""
        previous, self.previous = self.previous, resid
        if key == self.last:
            self.rises = self.rises + 1 if previous <= resid else 0
            if self.rises and (resid <= _FLOOR * self.tol or self.rises > RISES):
                return True, None if resid <= _FLOOR * self.tol else "stalled"
        elif key in self.seen and self.seen[key] <= resid:
            return True, "cycle"
        self.seen[key], self.last = resid, key
        if resid < self.best:
            self.best, self.since_best = resid, 0
        else:
            self.since_best += 1
            if self.since_best >= PATIENCE:
                return True, "stalled"
        return False, None


def _pair_products(qp: ContactQP, C: sp.csr_matrix, pairs: np.ndarray, ws: Workspace,
                   cache: dict) -> tuple[np.ndarray, np.ndarray]:
    """B A⁻¹C_Pᵀ (m × 2p) and C_P A⁻¹C_Pᵀ (2p × 2p) for the pairs P = ``pairs``. A⁻¹C_jᵀ is solved once per pair
    (kept in ``cache["X"]``, for the dual's fallback) and its products B X_j, C X_j kept in ``cache["BX"]``,
    ``cache["CX"]``: the Newton's steps need only these (stacking the n × 2p solves anew every step, 120 MB
    at 68k unknowns and 110 pairs, took 1.1 s of each step: 245 of 367 s of a Tresca run; at 276k the stacks
    of a changing pair set reached 7 GB)."""
    key = pairs.tobytes()
    if cache.get("products_key") == key:
        return cache["products"]
    X: dict = cache.setdefault("X", {})
    BX: dict = cache.setdefault("BX", {})
    CX: dict = cache.setdefault("CX", {})
    new = np.array([j for j in pairs if j not in BX], dtype=int)
    block = cache.get("block")
    if block is None and PairBlock.applies(qp, ws.fact):  # rows: those of a restricted QP (``tresca_screened``)
        block = cache["block"] = PairBlock(qp, C, ws.fact, cache.get("rows", np.arange(qp.m)), cache.get("tail"))
    if block is not None and new.size:  # from the joint Schur complement (``pair_block``): no solve per pair
        inside = new[new < block.k]
        if inside.size:
            BXn, CXn = block.products(inside)
            for i, j in enumerate(inside):
                BX[j], CX[j] = BXn[:, 2 * i:2 * i + 2], CXn[:, 2 * i:2 * i + 2]
        new = new[new >= block.k]
    if new.size:
        RT = C[_pair_rows(new)].T.tocsc()
        Xn = np.empty((qp.n, RT.shape[1]))
        for j0 in range(0, RT.shape[1], _BLOCK):  # blocked: a dense n × 2p right-hand side would not fit at 216k
            cols = slice(j0, min(RT.shape[1], j0 + _BLOCK))
            Xn[:, cols] = ws.fact.solve_many(RT[:, cols].toarray(), refine=False)
        BXn, CXn = qp.B @ Xn, C @ Xn
        for i, j in enumerate(new):
            X[j], BX[j], CX[j] = Xn[:, 2 * i:2 * i + 2], BXn[:, 2 * i:2 * i + 2], CXn[:, 2 * i:2 * i + 2]
    if not len(pairs):
        products = (np.zeros((qp.m, 0)), np.zeros((0, 0)))
    else:
        products = (np.hstack([BX[j] for j in pairs]), np.hstack([CX[j] for j in pairs])[_pair_rows(pairs)])
    cache.update(products_key=key, products=products)
    return products


def _tangential_ncp(T: np.ndarray, sig: np.ndarray, g: np.ndarray, ct: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """z = T − c_t σ and the residual T − P_g(z) of the pairs (p, 2)."""
    z = T - ct[:, None] * sig
    r = np.linalg.norm(z, axis=1)
    proj = z * np.divide(g, np.maximum(r, g), out=np.zeros_like(g), where=g > 0)[:, None]
    return z, T - proj


def _system(ws: Workspace, A: np.ndarray, BXp: np.ndarray, SPP: np.ndarray, Lam: np.ndarray, Tp: np.ndarray,
            gap: np.ndarray, sig: np.ndarray, EP: np.ndarray | None = None,
            delta: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """The Newton matrix with gap rows on 𝒜 and σ rows on the pairs (stick as they are; the caller rewrites the
    slip rows), and its right-hand side: the affine offsets of gap_𝒜 and σ_P in (Λ_𝒜, T_P) from the TRUE gaps
    and slips of the iterate (not from c0 + Ŝy: the columns of Ŝ carry round-off, and the true residual makes
    each step a refinement too). With δ unknowns (qp.k > 0; EP their slip columns on the pairs) the gap rows
    gain D_𝒜 δ, the slip rows E_P δ, and k rows the force balance D_𝒜ᵀΛ_𝒜 + E_PᵀT_P = −P."""
    SAP = BXp[A]
    k, p2 = A.size, SPP.shape[0]
    kd = 0 if EP is None else EP.shape[1]
    J = np.zeros((k + p2 + kd, k + p2 + kd))
    J[:k, :k], J[:k, k:k + p2] = ws.block(A), SAP
    J[k:k + p2, :k], J[k:k + p2, k:k + p2] = SAP.T, 0.5 * (SPP + SPP.T)
    rhs = np.empty(k + p2 + kd)
    rhs[:k] = -(gap[A] - ws.Sx(Lam)[A] - SAP @ Tp.ravel())
    rhs[k:k + p2] = -(sig.ravel() - BXp.T @ Lam - SPP @ Tp.ravel())
    if kd:
        DA = ws.qp.D[A]
        J[:k, k + p2:], J[k:k + p2, k + p2:] = DA, EP
        J[k + p2:, :k], J[k + p2:, k:k + p2] = DA.T, EP.T
        rhs[:k] += DA @ delta
        rhs[k:k + p2] += EP @ delta
        rhs[k + p2:] = -ws.qp.P
    return J, rhs


def _solve_equilibrated(J: np.ndarray, rhs: np.ndarray) -> np.ndarray | None:
    """J y = rhs, equilibrated: the gap rows (m/N) and the slip rows (N) differ by ~1e12, which LU's pivoting
    mixes (unequilibrated, the steps stalled at 3e-5 relative on the 8 × 8 panel). None where J is singular."""
    rs = 1.0 / np.maximum(np.abs(J).max(axis=1, initial=0.0), 1e-300)
    cs = 1.0 / np.maximum(np.abs(J * rs[:, None]).max(axis=0, initial=0.0), 1e-300)
    try:
        y = cs * la.lu_solve(la.lu_factor(J * rs[:, None] * cs), rhs * rs)
    except (la.LinAlgError, ValueError):
        return None
    return y if np.all(np.isfinite(y)) else None


def solve_tresca_newton(qp: ContactQP, C: sp.spmatrix, c: np.ndarray, g: np.ndarray, tol: float = 1e-10,
                        max_iterations: int = 50, factorization: Factorization | None = None,
                        initial: np.ndarray | None = None, cache: dict | None = None,
                        E: np.ndarray | None = None) -> ContactSolution:
    """Tresca friction by semismooth Newton on the open/closed and stick/slip sets (module docstring).
    Arguments as ``solve_tresca_dual``: ``initial`` a start y = (Λ, T) (m + 2m, then δ with qp.k > 0), ``cache`` a
    dict kept between calls on the same QP, C and c, ``E`` the slip columns of δ. Pairs with g_j = 0 have T_j = 0
    and leave the system; δ joins it with the force balance (``_system``)."""
    check_arguments(tol, max_iterations)
    C, c, g, E = _check(qp, C, c, g, E)
    t0 = time.perf_counter()
    cache = {} if cache is None else cache
    if "ws" not in cache:
        cache["ws"] = Workspace(qp, factorization)
    ws: Workspace = cache["ws"]
    m = qp.m
    candidates = g > 0
    t1 = time.perf_counter()

    if initial is None:  # from the frictionless solution (``active_set``, with its globalisation)
        free = solve_active_set(qp, tol=tol, factorization=ws.fact)
        if not np.any(candidates):
            free.method = "tresca-active-set"
            free.info.update(T=np.zeros(2 * m), slip=slips(qp, C, c, free.U, free.delta, E), bounds=g,
                             gap=qp.gap(free.U, free.delta), fallback=None)
            return free
        Lam, delta = free.Lambda.copy(), free.delta
    else:
        Lam = np.maximum(np.asarray(initial[:m], float), 0.0)
        delta = (np.asarray(initial[3 * m:], float) if len(initial) == 3 * m + qp.k else np.zeros(qp.k)) \
            if qp.k else None
    growth = default_growth(ws)
    T = np.zeros(2 * m) if initial is None else np.asarray(initial[m:3 * m], float).copy()
    T.reshape(-1, 2)[~candidates] = 0.0
    history: list = []
    watch = SetWatch(tol)
    fallback = None
    it = 0
    for it in range(1, max_iterations + 1):
        U = ws.solve(qp.F + qp.B.T @ Lam + C.T @ T)
        gap, sigma = qp.gap(U, delta), slips(qp, C, c, U, delta, E).reshape(-1, 2)
        lam_scale = max(float(Lam.max(initial=0.0)), float(g.max(initial=0.0)), 1e-300)
        cn = lam_scale / ws.length_scale(gap)
        # the closed set as in ``active_set``: the rows still pulling, and of the penetrated rows the deepest
        # (``schur.deepest_violations``); all penetrated rows at once wandered (421 → 109 rows in 16 steps, 32 × 32)
        keep = Lam > 0
        closed = keep | deepest_violations(gap + tol * ws.length_scale(gap), ~keep, growth, int(keep.sum()))
        pairs = np.flatnonzero(candidates)  # the pairs in the system (the rest have T_j = 0)
        BXp, SPP = _pair_products(qp, C, pairs, ws, cache)
        ct = cache.setdefault("ct", {})
        for j in pairs:
            if j not in ct:  # c_t: 1 / the pair's flexibility
                ct[j] = 2.0 / max(float(np.trace(cache["CX"][j][2 * j:2 * j + 2])), 1e-300)
        cp = np.array([ct[j] for j in pairs])
        b = g[pairs]  # the bounds in force
        Tp, sig = T.reshape(-1, 2)[pairs], sigma[pairs]
        z, rt = _tangential_ncp(Tp, sig, b, cp)
        rn = Lam - np.maximum(0.0, Lam - cn * gap)
        resid = max(float(np.abs(rn).max(initial=0.0)), float(np.abs(rt).max(initial=0.0))) / lam_scale
        if qp.k:  # the travels' and rigid motions' equilibrium (exact after a step: it is a row of the system)
            resid = max(resid, float(np.linalg.norm(balance(qp, E, Lam, T)) / force_scale(qp, E, Lam, T)))
        slip = np.linalg.norm(z, axis=1) >= b
        key = (closed.tobytes(), slip.tobytes())
        history.append({"iteration": it, "closed": int(closed.sum()), "stick": int((~slip).sum()),
                        "slip": int(slip.sum()), "residual": resid})
        if resid <= tol:
            break
        stop, fallback = watch.stop(key, resid)
        if stop:
            break
        A = np.flatnonzero(closed)
        J, rhs = _system(ws, A, BXp, SPP, Lam, Tp, gap, sig, None if E is None else E[_pair_rows(pairs)], delta)
        k = A.size
        for j in np.flatnonzero(slip):  # slip rows: the linearised slip law (module docstring)
            r = slice(k + 2 * j, k + 2 * j + 2)
            nz = np.linalg.norm(z[j])
            n = z[j] / nz
            Tt = b[j] * Tp[j] / max(b[j], float(np.linalg.norm(Tp[j])))
            M = np.outer(Tt, n) + (nz - b[j]) * np.eye(2)
            N = cp[j] * (np.outer(Tt, n) - b[j] * np.eye(2))
            Fj = nz * Tp[j] - b[j] * z[j]
            rows = -N @ J[r]  # −c_t N (S_jA Λ_A + S_jP T_P)
            rows[:, k + 2 * j:k + 2 * j + 2] += M
            rhs[r] = M @ Tp[j] - N @ sig[j] - Fj - N @ rhs[r]
            J[r] = rows
        y = _solve_equilibrated(J, rhs)
        if y is None:
            fallback = "singular"
            break
        Lam = np.zeros(m)
        Lam[A] = y[:k]
        T = np.zeros(2 * m)
        T.reshape(-1, 2)[pairs] = y[k:k + 2 * pairs.size].reshape(-1, 2)
        if qp.k:
            delta = y[k + 2 * pairs.size:]
    else:
        fallback = "iterations"
    t3 = time.perf_counter()
    if fallback is not None:  # the dual from this iterate (module docstring)
        # its Ŝ from this Workspace's Schur columns and pair solves (no second solve per row or pair)
        dual_cache = {"SBB": ws.block(np.arange(m)), "X": cache.setdefault("X", {}), "u0": ws.U0}
        pairs = np.flatnonzero(candidates)
        BXp, SPP = _pair_products(qp, C, pairs, ws, cache)
        dual_cache["given"] = (pairs, np.block([[dual_cache["SBB"], BXp], [BXp.T, 0.5 * (SPP + SPP.T)]]))
        sol = solve_tresca_dual(qp, C, c, g, tol=tol, factorization=ws.fact, cache=dual_cache, E=E,
                                initial=np.concatenate([np.maximum(Lam, 0.0), T] + ([delta] if qp.k else [])))
        sol.method = "tresca-active-set"
        sol.iterations += it
        sol.history = history + sol.history
        sol.info["fallback"] = fallback
        sol.timings = {"factorization": t1 - t0, "newton": t3 - t1, "dual": sol.timings["total"],
                       "total": time.perf_counter() - t0}
        return sol
    U = ws.solve(qp.F + qp.B.T @ Lam + C.T @ T)
    res = friction_residuals(qp, C, c, g, U, Lam, T, delta, E)
    return ContactSolution(
        U=U, Lambda=Lam, pressure=Lam / qp.weights, active=Lam > 0, delta=delta, iterations=it, residuals=res,
        method="tresca-active-set", history=history, energy=qp.energy(U, delta),
        timings={"factorization": t1 - t0, "newton": time.perf_counter() - t1, "total": time.perf_counter() - t0},
        info={"T": T, "slip": slips(qp, C, c, U, delta, E), "bounds": g, "gap": qp.gap(U, delta), "fallback": None})
