"""Penalty method (MODEL.md §6 (6.7)–(6.8), §8): minimise
    J(U, δ) = ½UᵀAU − FᵀU − Pᵀδ + (1/(2ε)) Σ_i ω_i [G_i + B_iU + D_iδ]₋²
by semismooth Newton with an Armijo line search, for one ε or a continuation sequence (each
solve warm-started from the previous). Λ_ε = (ω/ε)[g]₋ approximates the nodal forces, and
p_ε = Λ_ε/ω = (1/ε)[g]₋ the pressure.

Newton step for the penetrating set I = {g_i < 0}: the Hessian A + (1/ε)B_IᵀW_IB_I changes with
I. ``hessian="schur"`` (default) never refactorises: by Woodbury the step is U = A⁻¹(F + B_IᵀΛ_I)
with (S_II + εW_I⁻¹)Λ_I (+ D_Iδ) = −c0_I (+ D_IᵀΛ_I = −P), S = B A⁻¹ Bᵀ from the cached columns
(``schur.Workspace``); the iterate is carried as coordinates μ (U = A⁻¹(F + Bᵀμ)) and J(μ, δ) =
const + ½μᵀSμ − Pᵀδ + (1/(2ε))Σω[c0 + Sμ + Dδ]₋², so the line search costs no solves.
``hessian="refactorize"`` factorises A + (1/ε)B_IᵀW_IB_I at every Newton step (no force
control) — kept to measure against.

Globalisation: every Newton matrix is SPD, so the direction is a descent direction of the
convex C¹ function J; Armijo backtracking gives global convergence, and near the solution the
full step is taken and the piecewise-quadratic J is minimised exactly once I stops changing
(finite termination). Stop: penalised stationarity ‖AU − F − BᵀΛ_ε(U)‖/‖F + BᵀΛ_ε‖ ≤ tol (and
‖DᵀΛ_ε + P‖/‖P‖ ≤ tol), checked on a freshly solved U. The reported KKT residuals of the exact
problem then show penetration and complementarity of order ε, as they must.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence

import numpy as np
import scipy.sparse as sp

from ..errors import InputError, SolverError
from ..linalg import Factorization, factorize
from .kkt import TINY, evaluate, largest_row_norm
from .qp import ContactQP, ContactSolution, History, check_arguments
from .schur import Workspace

#: a penetration below this multiple of ε_mach times the size of the terms its gap sums is their round-off: the
#: row touches and carries no force (ω/ε amplifies it: 7 ε_mach gave 5.7e-7 N where a shell pushed rigidly by its
#: only punch carries none); its force would be ~1e-9 of the rows that carry one, far below the O(ε) error
GAP_ROUNDOFF = 1e3 * np.finfo(float).eps


def _check_eps(epsilon: float) -> float:
    try:
        e = float(epsilon)
    except (TypeError, ValueError):
        raise InputError("epsilon", f"must be a positive number, got {epsilon!r}") from None
    if not (np.isfinite(e) and e > 0):
        raise InputError("epsilon", f"the penalty parameter ε must be > 0, got {epsilon!r}")
    return e


def solve_penalty(
    qp: ContactQP,
    epsilon: float = 1e-6,
    continuation: Sequence[float] | None = None,
    tol: float = 1e-10,
    max_iterations: int = 50,
    factorization: Factorization | None = None,
    hessian: str = "schur",
    initial_U: np.ndarray | None = None,
    callback: Callable[[dict], None] | None = None,
) -> ContactSolution:
    """Penalty solution for ``epsilon``; ``continuation`` = ε values solved first (in the given
    order, each warm-starting the next). ``max_iterations`` bounds Newton steps per ε."""
    eps_final = _check_eps(epsilon)
    seq = [_check_eps(e) for e in (continuation or [])] + [eps_final]
    check_arguments(tol, max_iterations)
    if hessian not in ("schur", "refactorize"):
        raise InputError("hessian", f"must be 'schur' or 'refactorize', got {hessian!r}")
    if hessian == "refactorize":
        if qp.k:
            raise InputError("hessian", "'refactorize' does not support force control; use 'schur'")
        return _penalty_refactorize(qp, seq, tol, max_iterations, factorization, initial_U, callback)
    ws = Workspace(qp, factorization)
    k = qp.k
    mu = np.zeros(qp.m)
    delta = np.zeros(k) if k else None
    if initial_U is not None:
        g0 = qp.gap(np.asarray(initial_U, dtype=float))
        mu = qp.weights / seq[0] * np.maximum(-g0, 0.0) * ws.live
    history: list = History(callback)
    stages = []
    total = 0
    for eps in seq:
        mu, delta, its = _newton(ws, eps, mu, delta, tol, max_iterations, history, total)
        total += its
        U, lam, rep, pstat, mu, delta, berr = _final(ws, eps, mu, delta, tol)
        stages.append({"epsilon": eps, "iterations": its, "penetration": rep.residuals["penetration"],
                       "active": int((lam > 0).sum()), "penalty_stationarity": pstat, "backward_error": berr})
    if berr > tol:
        raise SolverError(f"penalty: backward error {berr:.3e} of the penalised equation above tolerance {tol:g}",
                          residuals=rep.residuals, iterations=total)
    return ws.result(U, lam, delta, lam > 0, rep, "penalty", total, history,
                     info={"epsilon": eps_final, "continuation": stages, "hessian": "schur"})


def _final(ws: Workspace, eps: float, mu: np.ndarray, delta: np.ndarray | None, tol: float, refine: int = 3):
    """Fresh U = A⁻¹(F + Bᵀμ), Λ_ε(U) and residuals; then iterative refinement of the Newton
    system with the true gaps. Convergence: the normwise backward error of the penalised equation,
    ‖AU − F − BᵀΛ_ε‖ / ‖|A||U| + |F| + |Bᵀ|(Λ_ε + (ω/ε)1_I(|G| + |B||U| + |D||δ|))‖ ≤ tol (the
    forward residual cannot go below ε_mach·cond because Λ_ε amplifies gap round-off by ω/ε).
    The best refinement step is kept."""
    qp = ws.qp
    w = qp.weights
    best = None
    for step in range(refine + 1):
        U = ws.solve(qp.F + qp.B.T @ mu)
        g = qp.gap(U, delta)
        # |G| + |B||U| + |D||δ|: the size of the terms each gap sums, whose round-off ω/ε turns into a force
        dd_mag = np.abs(qp.D) @ np.abs(delta) if qp.k else 0.0
        gap_mag = np.abs(qp.G) + abs(qp.B) @ np.abs(U) + dd_mag
        pen = np.maximum(-g, 0.0) * ws.live
        pen[pen <= GAP_ROUNDOFF * gap_mag] = 0.0  # touching, not penetrating
        lam = w / eps * pen
        rep = evaluate(qp, U, lam, delta, ws.fact, max_flexibility=ws.max_flexibility())
        ws.n_solves += 1
        pstat = rep.residuals["stationarity"]
        if qp.k:
            pstat = max(pstat, rep.residuals["force_balance"])
        # normwise backward error of the penalised equation AU − F − Bᵀ(ω/ε)[g]₋ = 0
        pen_mag = w / eps * (lam > 0) * gap_mag
        mag = qp.abs_A @ np.abs(U) + np.abs(qp.F) + abs(qp.B).T @ (lam + pen_mag)
        # floored like ``_newton``'s stationarity: a zero answer's residual is round-off, not its own scale
        floor = ws.force_scale(g) * largest_row_norm(qp.B)
        berr = float(np.linalg.norm(qp.A @ U - qp.F - qp.B.T @ lam) / max(np.linalg.norm(mag), floor, TINY))
        if qp.k:
            fb = np.linalg.norm(qp.D.T @ lam + qp.P)
            berr = max(berr, float(fb / max(np.linalg.norm(np.abs(qp.D).T @ (lam + pen_mag)) + np.linalg.norm(qp.P),
                                               ws.force_scale(g), TINY)))
        if best is None or berr < best[6]:
            best = (U, lam, rep, pstat, mu, delta, berr)
        if berr <= tol or step == refine:
            break
        # Newton step of the penalised problem based at the true gap: g(μ') = g + S(μ' − μ)
        I = pen > 0
        if qp.k:
            I = ws.first_contact(I, g)
        idx = np.flatnonzero(I)
        rhs = -g[idx] + ws.Sx(mu)[idx] + (qp.D[idx] @ delta if qp.k else 0.0)
        x, dN, _ = ws.face_solve(idx, rhs, -qp.P if qp.k else None, shift=eps / w[idx])
        mu = np.zeros(qp.m)
        mu[idx] = x
        if qp.k:
            delta = dN
    return best


def _newton(ws: Workspace, eps: float, mu: np.ndarray, delta: np.ndarray | None, tol: float,
            max_iterations: int, history: list, it0: int):
    qp = ws.qp
    k = qp.k
    w = qp.weights
    live = ws.live
    D, P = qp.D, qp.P

    def parts(mu, delta):
        Smu = ws.Sx(mu)
        g = ws.c0 + Smu + (D @ delta if k else 0.0)
        lam = w / eps * np.maximum(-g, 0.0) * live
        J = 0.5 * float(mu @ Smu) + 0.5 / eps * float(np.sum(w * np.maximum(-g, 0.0) ** 2 * live))
        if k:
            J -= float(P @ delta)
        return Smu, g, lam, J

    Smu, g, lam, J = parts(mu, delta)
    b_row = largest_row_norm(qp.B)  # Λ_ref b_row: the floor of the stationarity's scale (below)
    prev_I = None
    full_step = False
    for it in range(1, max_iterations + 1):
        # scales floored by the problem's force scale Λ_ref (``kkt``): a zero answer's forces are round-off
        # (a shell pushed rigidly by its only punch: 2e-9 N of gap round-off times ω/ε), not its own scale
        lam_ref = ws.force_scale(g)
        rhs_norm = max(float(np.linalg.norm(qp.F + qp.B.T @ lam)), lam_ref * b_row)
        stat = float(np.linalg.norm(qp.B.T @ (mu - lam)) / max(rhs_norm, TINY))
        fscale = max(np.linalg.norm(P), np.linalg.norm(abs(D).T @ lam), lam_ref, TINY) if k else TINY
        fb = float(np.linalg.norm(D.T @ lam + P) / fscale) if k else 0.0
        I = live & (g < 0)
        if k:
            I = ws.first_contact(I, g)
        # converged: residual at its tolerance , or finite termination:
        # a full Newton step that reproduces its own penetrating set minimised J exactly
        if it > 1 and ((stat <= tol and fb <= tol)
                       or (full_step and np.array_equal(I, prev_I))):
            return mu, delta, it - 1
        idx = np.flatnonzero(I)
        x, dN, singular = ws.face_solve(idx, -ws.c0[idx], -P if k else None, shift=eps / w[idx])
        dmu = -mu.copy()
        dmu[idx] += x
        ddel = (dN - delta) if k else None
        Sd = ws.Sx(dmu)
        dg = Sd + (D @ ddel if k else 0.0)
        slope = float((mu - lam) @ Sd) + (float((-P - D.T @ lam) @ ddel) if k else 0.0)
        a, b = float(dmu @ Sd), float(mu @ Sd)
        t = 1.0
        while True:
            gt = g + t * dg
            Jt = 0.5 * float(mu @ Smu) + t * b + 0.5 * t * t * a + 0.5 / eps * float(
                np.sum(w * np.maximum(-gt, 0.0) ** 2 * live))
            if k:
                Jt -= float(P @ (delta + t * ddel))
            if Jt <= J + 1e-4 * t * slope + 1e-14 * abs(J) or t < 1e-12:
                break
            t *= 0.5
        mu = mu + t * dmu
        if k:
            delta = delta + t * ddel
        Smu, g, lam, J = parts(mu, delta)
        prev_I, full_step = I, t == 1.0
        history.append({"iteration": it0 + it, "epsilon": eps, "active": int(idx.size), "step": t,
                        "stationarity": stat, "energy": J, "singular": singular})
    raise SolverError(f"penalty: semismooth Newton did not converge for ε = {eps:g}",
                      residuals={"stationarity": stat, "force_balance": fb}, iterations=max_iterations)


def _penalty_refactorize(qp: ContactQP, seq: list[float], tol: float, max_iterations: int,
                         factorization: Factorization | None, initial_U: np.ndarray | None,
                         callback: Callable[[dict], None] | None = None) -> ContactSolution:
    """The same Newton iteration in U-space, factorising A + (1/ε)B_IᵀW_IB_I at every step."""
    t0 = time.perf_counter()
    timings = {"factorization": 0.0, "solve": 0.0, "feasibility": 0.0}
    from .qp import check_feasibility

    t = time.perf_counter()
    live = check_feasibility(qp)
    timings["feasibility"] = time.perf_counter() - t
    w = qp.weights
    A, B, F, G = qp.A, qp.B, qp.F, qp.G
    U = np.zeros(qp.n) if initial_U is None else np.asarray(initial_U, dtype=float).copy()
    history: list = History(callback)
    total = 0
    nfact = 0
    fact_A = factorization
    stages = []
    for eps in seq:
        def J(U: np.ndarray, eps: float = eps) -> float:
            g = G + B @ U
            pen = float(np.sum(w * np.maximum(-g, 0) ** 2 * live))
            return 0.5 * float(U @ (A @ U)) - float(F @ U) + 0.5 / eps * pen

        ok = False
        prev_I, s = None, 0.0
        for it in range(1, max_iterations + 1):
            g = G + B @ U
            lam = w / eps * np.maximum(-g, 0.0) * live
            r = A @ U - F - B.T @ lam
            I = live & (g < 0)
            pen_mag = w / eps * I * (np.abs(G) + abs(B) @ np.abs(U))
            mag = abs(A) @ np.abs(U) + np.abs(F) + abs(B).T @ (lam + pen_mag)
            stat = float(np.linalg.norm(r) / max(np.linalg.norm(mag), TINY))  # backward error
            if it > 1 and (stat <= tol or (s == 1.0 and np.array_equal(I, prev_I))):
                ok = True
                break
            prev_I = I
            Wd = sp.diags(np.where(I, w / eps, 0.0))
            H = (A + B.T @ Wd @ B).tocsr()
            t = time.perf_counter()
            fh = factorize(H)
            timings["factorization"] += time.perf_counter() - t
            nfact += 1
            t = time.perf_counter()
            Un = fh.solve(F - B.T @ (Wd @ G))
            timings["solve"] += time.perf_counter() - t
            d = Un - U
            J0 = J(U)
            slope = float(-(r @ d))
            s = 1.0
            while J(U + s * d) > J0 + 1e-4 * s * slope + 1e-14 * abs(J0) and s > 1e-12:
                s *= 0.5
            U = U + s * d
            history.append({"iteration": total + it, "epsilon": eps, "active": int(I.sum()), "step": s,
                            "stationarity": stat})
        total += it - 1 if ok else max_iterations
        if not ok:
            raise SolverError(f"penalty: semismooth Newton did not converge for ε = {eps:g}",
                              residuals={"stationarity": stat}, iterations=total)
        stages.append({"epsilon": eps, "iterations": it - 1})
    lam = w / seq[-1] * np.maximum(-(G + B @ U), 0.0) * live
    if fact_A is None:
        t = time.perf_counter()
        fact_A = factorize(A)
        timings["factorization"] += time.perf_counter() - t
    rep = evaluate(qp, U, lam, None, fact_A)
    timings["total"] = time.perf_counter() - t0
    timings["n_factorizations"] = float(nfact)
    return ContactSolution(U=U, Lambda=lam, pressure=lam / w, active=lam > 0, delta=None, iterations=total,
                           residuals=rep.residuals, method="penalty", history=history, timings=timings,
                           energy=rep.energy, dual_value=rep.dual_value,
                           info={"gap": rep.gap, "scaled_residuals": rep.scaled, "epsilon": seq[-1],
                                 "continuation": stages, "hessian": "refactorize"})
