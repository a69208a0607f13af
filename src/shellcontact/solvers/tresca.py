"""Contact with Tresca friction (MODEL.md §11): the dual with disc constraints and the penalty (regularised)
primal. Both take the frictionless QP (``qp.ContactQP``) and the friction data of the reduced problem:

    C (2m × n): the tangential rows, pairs 2i, 2i+1 of constraint row i (``friction.tangential_operator``, reduced)
    c (2m,): the punches' slides on the pairs; g (m,): the bounds g_i ≥ 0 (N)

and return a ``ContactSolution`` whose ``info`` holds ``T`` (2m,: the tangential nodal forces on the shell,
N), ``slip`` (σ = C U − c, m) and ``bounds`` (g).

* ``solve_tresca_dual``: y = (Λ, T), Ŝ = B̂ A⁻¹ B̂ᵀ with B̂ = [B; C], linear term Ĝ + B̂ A⁻¹F with Ĝ = (G; −c)
  (its gradient is (gap; slip)), minimised over Λ ≥ 0, |T_i| ≤ g_i by ``disc_qp`` (MPGP); U = A⁻¹(F + B̂ᵀy).
  Ŝ is formed densely from blocked solves with one factorisation of A (m + 2·#{g_j > 0} columns, 256 at a
  time), so this is for contact zones of moderate size (m up to a few thousand).
* ``solve_tresca_penalty``: minimise 𝓔(U) + Σ ω_i/(2ε) [gap_i]₋² + Σ ψ_i(σ_i), ψ_i the Huber function
  of tangential stiffness k_i = ω_i/ε capped at the force g_i: a spring per point that slides past g_i
  (regularised friction, as Abaqus' penalty friction with an elastic slip g_i/k_i). Newton's method on the
  (piecewise twice differentiable, convex) energy with a backtracking line search; U_ε → U as ε → 0, the
  slip in stick is O(ε).
"""

from __future__ import annotations

import copy
import time

import numpy as np
import scipy.sparse as sp

from ..errors import InputError, SolverError
from ..linalg import Factorization, factorize
from .augmented import RhoGrowth, augmented_lagrangian
from .disc_qp import disc_qp
from .penalty import solve_penalty
from .qp import ContactQP, ContactSolution, check_arguments

_BLOCK = 256  # right-hand sides per blocked solve when forming Ŝ
#: the penalised equation's relative residual accepted once Newton's energy stops decreasing (round-off: the
#: penalty springs raise cond(K); measured 2.5e-9 on the paper panel at ε/10, 1.9e-6 with stick springs ω/ε on
#: the points in contact at the default ε, Tresca 1e7 Pa): below the penalty's O(ε) error
_FLOOR = 1e-5
#: a sliding point whose slip shrank below this fraction of the last iteration's is tried on its stick branch: Newton's
#: model of a sliding point has no stiffness along its slip, so a point that sticks in the solution is approached
#: from outside geometrically (the vessel on saddles under self-weight, 20 × 24: k|σ|/g 20 → 3 in 85 steps, 6 % a
#: step, the residual stuck at 0.064 after 100 steps; with the trial below 1e-8 in 15 steps)
SHRINK = 0.97


def _check(qp: ContactQP, C: sp.spmatrix, c: np.ndarray, g: np.ndarray, E: np.ndarray | None = None
           ) -> tuple[sp.csr_matrix, np.ndarray, np.ndarray, np.ndarray | None]:
    """The friction data checked; E (2m × k): the slips' change per unit δ (None: 0; only with qp.k > 0)."""
    C = sp.csr_matrix(C, dtype=float)
    if C.shape != (2 * qp.m, qp.n):
        raise InputError("friction.C", f"must have shape (2m, n) = {(2 * qp.m, qp.n)}, got {C.shape}")
    c = np.asarray(c, float).reshape(-1)
    g = np.asarray(g, float).reshape(-1)
    if c.shape != (2 * qp.m,) or g.shape != (qp.m,):
        raise InputError("friction", f"slides c need {2 * qp.m} entries and bounds g {qp.m}")
    if not (np.all(np.isfinite(g)) and np.all(g >= 0)):
        raise InputError("friction.bound", "the friction bounds must be finite and ≥ 0 (N)")
    if qp.k:
        E = np.zeros((2 * qp.m, qp.k)) if E is None else np.asarray(E, float).reshape(2 * qp.m, qp.k)
        if not np.all(np.isfinite(E)):
            raise InputError("friction.E", "has non-finite entries")
    elif E is not None and np.size(E):
        raise InputError("friction.E", "slip columns need the QP's δ unknowns (qp.D, qp.P)")
    else:
        E = None
    return C, c, g, E


def slips(qp: ContactQP, C: sp.csr_matrix, c: np.ndarray, U: np.ndarray, delta: np.ndarray | None,
          E: np.ndarray | None) -> np.ndarray:
    """σ = C U + E δ − c (2m): the shell's slip relative to the punches."""
    s = C @ U - c
    return s if E is None or delta is None else s + E @ delta


def friction_residuals(qp: ContactQP, C: sp.csr_matrix, c: np.ndarray, g: np.ndarray, U: np.ndarray,
                       Lam: np.ndarray, T: np.ndarray, delta: np.ndarray | None = None,
                       E: np.ndarray | None = None) -> dict[str, float]:
    """Stationarity ‖AU − F − BᵀΛ − CᵀT‖/‖F + BᵀΛ + CᵀT‖, penetration, max(−Λ) (dual feasibility, N),
    complementarity (scaled by the largest gap and force), the bound max(|T_i| − g_i)/max g and the law: slip
    where |T_i| < g_i (stick), and the slip's component along T_i where |T_i| = g_i (must be ≤ 0), relative to
    the largest gap. With δ unknowns (qp.k > 0) also the force balance ‖DᵀΛ + EᵀT + P‖ / its gross size."""
    f = qp.F + qp.B.T @ Lam + C.T @ T
    r = qp.A @ U - f
    gap = qp.gap(U, delta)
    slip = slips(qp, C, c, U, delta, E).reshape(-1, 2)
    Tm = np.asarray(T).reshape(-1, 2)
    t = np.linalg.norm(Tm, axis=1)
    length = max(float(np.abs(gap).max(initial=0.0)), float(np.abs(slip).max(initial=0.0)), 1e-300)
    gscale = max(float(g.max(initial=0.0)), 1e-300)
    stick = t < (1.0 - 1e-6) * g
    along = np.sum(slip * Tm, axis=1) / np.maximum(t, 1e-300)
    out = {
        "stationarity": float(np.linalg.norm(r) / max(np.linalg.norm(f), 1e-300)),
        "penetration": float(max(0.0, -gap.min(initial=0.0)) / length),
        "dual_feasibility": float(max(0.0, -float(Lam.min(initial=0.0)))),
        "complementarity": float(np.abs(Lam * gap).max(initial=0.0) / length / max(Lam.max(initial=0.0), 1e-300)),
        "friction_bound": float(max(0.0, float(np.max(t - g, initial=0.0))) / gscale),
        "stick_slip": float(np.linalg.norm(slip[stick], axis=1).max(initial=0.0) / length),
        "slip_direction": float(max(0.0, float(along[~stick].max(initial=0.0))) / length),
    }
    if qp.k:
        out["force_balance"] = float(np.linalg.norm(balance(qp, E, Lam, T)) / force_scale(qp, E, Lam, T))
    return out


def balance(qp: ContactQP, E: np.ndarray, Lam: np.ndarray, T: np.ndarray) -> np.ndarray:
    """DᵀΛ + EᵀT + P (k): the equilibrium of each δ unknown (a punch's travel, a rigid motion of the shell)."""
    return qp.D.T @ Lam + E.T @ T + qp.P


def force_scale(qp: ContactQP, E: np.ndarray, Lam: np.ndarray, T: np.ndarray) -> float:
    """The gross size of the force balance: max(‖P‖, ‖|D|ᵀ|Λ| + |E|ᵀ|T|‖)."""
    return max(float(np.linalg.norm(qp.P)), float(np.linalg.norm(np.abs(qp.D).T @ np.abs(Lam)
                                                                  + np.abs(E).T @ np.abs(T))), 1e-300)


def _solves(rows: sp.csr_matrix, fac: Factorization) -> np.ndarray:
    """A⁻¹ rowsᵀ (n × k), from blocked solves (``_BLOCK`` right-hand sides at a time)."""
    RT = rows.T.tocsc()
    out = np.empty((rows.shape[1], rows.shape[0]))
    for j in range(0, rows.shape[0], _BLOCK):
        cols = slice(j, min(rows.shape[0], j + _BLOCK))
        out[:, cols] = fac.solve_many(RT[:, cols].toarray())
    return out


def _pair_rows(pairs: np.ndarray) -> np.ndarray:
    """The rows 2j, 2j+1 of C of the pairs j."""
    return np.stack([2 * pairs, 2 * pairs + 1], axis=1).ravel().astype(int)


def dual_hessian(qp: ContactQP, C: sp.csr_matrix, pairs: np.ndarray, fac: Factorization, cache: dict) -> np.ndarray:
    """Ŝ = B̂ A⁻¹ B̂ᵀ, dense, for B̂ = [B; the pairs ``pairs`` of C]. The normal block and the solves A⁻¹C_jᵀ of
    every pair met so far stay in ``cache``: a pair whose bound is 0 has T_j = 0 and costs nothing (Coulomb
    and the case's Tresca bound only the rows in contact). ``cache["given"]`` = (pairs, Ŝ): Ŝ from the caller's
    products for those pairs (``tresca_newton``'s fallback on the joint border of ``pair_block``: no solves)."""
    given = cache.get("given")
    if given is not None and np.array_equal(given[0], pairs):
        return given[1]
    if "SBB" not in cache:
        SBB = qp.B @ _solves(qp.B, fac)
        cache.update(SBB=0.5 * (SBB + SBB.T), X={})
    X: dict = cache["X"]
    new = np.array([j for j in pairs if j not in X], dtype=int)
    if new.size:
        Xn = _solves(C[_pair_rows(new)], fac)
        for i, j in enumerate(new):
            X[j] = Xn[:, 2 * i:2 * i + 2]
    Xp = np.hstack([X[j] for j in pairs]) if len(pairs) else np.zeros((qp.n, 0))
    SBC = qp.B @ Xp
    SCC = C[_pair_rows(pairs)] @ Xp
    return np.block([[cache["SBB"], SBC], [SBC.T, 0.5 * (SCC + SCC.T)]])


def solve_tresca_dual(qp: ContactQP, C: sp.spmatrix, c: np.ndarray, g: np.ndarray, tol: float = 1e-10,
                      max_iterations: int = 2000, factorization: Factorization | None = None,
                      initial: np.ndarray | None = None, cache: dict | None = None,
                      E: np.ndarray | None = None) -> ContactSolution:
    """Tresca friction by the dual with disc constraints (module docstring). ``initial``: a start y = (Λ, T)
    (and δ after them, with qp.k > 0). ``cache``: a dict that keeps the blocks of Ŝ between calls on the same QP,
    C and c (Coulomb's fixed point changes only g). Pairs with g_j = 0 are left out of the QP (T_j = 0).
    With δ unknowns (force-controlled punches, a shell's rigid motions: qp.D, qp.P, and E their slip columns)
    the equality D̂ᵀy = −P, D̂ = (D; E), by the augmented Lagrangian (``_augmented``). ``max_iterations``: MPGP's
    steps (per inner solve of the augmented Lagrangian; the vessel on saddles, 80 × 96, 482 pairs sliding, took
    789 from the Newton's fallback: 2000, not the 500 of before, which only a run that would fail reaches)."""
    check_arguments(tol, max_iterations)
    C, c, g, E = _check(qp, C, c, g, E)
    t0 = time.perf_counter()
    fac = factorization if factorization is not None else factorize(qp.A)
    t1 = time.perf_counter()
    cache = {} if cache is None else cache
    if "u0" not in cache:
        cache["u0"] = fac.solve(qp.F)
    pairs = np.flatnonzero(g > 0)  # T_j = 0 where g_j = 0: those pairs leave the QP
    rows = _pair_rows(pairs)
    S = dual_hessian(qp, C, pairs, fac, cache)
    Bh = sp.vstack([qp.B, C[rows]], format="csr")
    lin = np.concatenate([qp.G, -c[rows]]) + Bh @ cache["u0"]
    t2 = time.perf_counter()
    history: list = []
    y0 = delta = None
    if initial is not None:
        y0 = np.concatenate([initial[:qp.m], np.asarray(initial[qp.m:3 * qp.m]).reshape(-1, 2)[pairs].ravel()])
        if qp.k and len(initial) == 3 * qp.m + qp.k:
            delta = np.asarray(initial[3 * qp.m:], float)
    if qp.k:
        Dh = np.vstack([qp.D, E[rows]])
        y, delta, its, ok = _augmented(S, lin, Dh, qp.P, qp.m, g[pairs], y0, delta, tol, max_iterations, history)
    else:
        y, its, ok = disc_qp(S, lin, qp.m, g[pairs], y0=y0, tol=tol, max_iterations=max_iterations,
                             history=history)
    U = fac.solve(qp.F + Bh.T @ y)
    Lam, T = y[:qp.m], np.zeros(2 * qp.m)
    T.reshape(-1, 2)[pairs] = y[qp.m:].reshape(-1, 2)
    res = friction_residuals(qp, C, c, g, U, Lam, T, delta, E)
    if not ok:
        raise SolverError(f"tresca dual: MPGP did not reach the tolerance {tol:g} in {its} iterations"
                          + (" (the force balance of the punches' travels and the shell's rigid motions not met: "
                             "the friction may not hold the shell)" if qp.k else ""), residuals=res, iterations=its)
    t3 = time.perf_counter()
    return ContactSolution(
        U=U, Lambda=Lam, pressure=Lam / qp.weights, active=Lam > 0, delta=delta, iterations=its, residuals=res,
        method="tresca-dual", history=history, energy=qp.energy(U, delta),
        timings={"factorization": t1 - t0, "schur": t2 - t1, "solve": t3 - t2, "total": t3 - t0},
        info={"T": T, "slip": slips(qp, C, c, U, delta, E), "bounds": g, "gap": qp.gap(U, delta)})


#: the augmented Lagrangian's first penalty ρ, relative to max diag Ŝ / max ‖D̂_j‖²
RHO = 100.0
#: ρ grows by this factor whenever an outer step divides the force balance's error by less than ``RHO_GAIN``
#: (a motion that friction alone holds: the slipping discs' face sees it weakly, and ρ = 100 divided the error
#: by only 1.5 per step on the vessel on saddles, 20 × 24), up to ``RHO_MAX`` times its first value
RHO_GROWTH, RHO_GAIN, RHO_MAX = 10.0, 10.0, 1e6
#: outer steps of the augmented Lagrangian
OUTER = 60


def _augmented(S: np.ndarray, lin: np.ndarray, Dh: np.ndarray, P: np.ndarray, m: int, g: np.ndarray,
               y0: np.ndarray | None, delta: np.ndarray | None, tol: float, max_iterations: int,
               history: list) -> tuple[np.ndarray, np.ndarray, int, bool]:
    """min ½yᵀŜy + linᵀy over Λ ≥ 0, |T_j| ≤ g_j with D̂ᵀy = −P: ``augmented.augmented_lagrangian`` around
    ``disc_qp`` on Ŝ + ρD̂D̂ᵀ, ρ growing where the balance's error falls slowly (``RHO_GROWTH``). Stops when the
    inner QP converged with the gaps of the true δ to ``tol`` and ‖D̂ᵀy + P‖ ≤ tol × its gross size.
    ``max_iterations`` bounds each inner solve (at most ``OUTER`` of them). Returns y, δ, iterations, converged."""
    colnorm = float(np.max(np.sum(Dh**2, axis=0)))
    rho0 = RHO * max(float(np.max(np.diag(S), initial=0.0)), 1e-300) / max(colnorm, 1e-300)
    DD = Dh @ Dh.T
    H = {}  # Ŝ + ρD̂D̂ᵀ of the current ρ

    def inner(delta: np.ndarray, rho: float, y: np.ndarray | None) -> tuple[np.ndarray, int, bool]:
        if rho not in H:
            H.clear()
            H[rho] = S + rho * DD
        shifted = lin + Dh @ (delta + rho * P)
        # the inner tolerance relative to the true gaps' scale, not to ρD̂P's (which the linear term carries)
        scale = max(float(np.abs(lin + Dh @ delta).max(initial=0.0)), 1e-300)
        inner_tol = tol * scale / max(float(np.abs(shifted).max(initial=0.0)), 1e-300)
        # from the last iterate: MPGP once crawled from warm starts with many discs on their circles and was
        # restarted from 0 after 150 steps; the cause was its face step (``disc_qp._face_step``: no shorter step
        # along the circles' arc when the free variables allowed the whole step). Vessel on saddles, 20 × 24, dual:
        # without the restart 2 warm solves failed at 2000 steps before the fix; after it none, ≤ 76 steps each
        return disc_qp(H[rho], shifted, m, g, y0=y, tol=inner_tol, max_iterations=max_iterations, history=history)

    def size(y: np.ndarray, _delta: np.ndarray) -> float:
        return max(float(np.linalg.norm(P)), float(np.linalg.norm(np.abs(Dh).T @ np.abs(y))), 1e-300)

    y, delta, total, ok = augmented_lagrangian(
        inner, Dh, P, y0, np.zeros(Dh.shape[1]) if delta is None else delta.copy(), rho0, tol, OUTER, size,
        budget=2 * OUTER * max_iterations, growth=RhoGrowth(RHO_GROWTH, RHO_GAIN, RHO_MAX))
    return y, delta, total, ok


def _tangential(sig: np.ndarray, k: np.ndarray, g: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
    """The Huber spring at slips σ (m, 2): the force on the shell T = −ψ'(σ) (m, 2), the blocks of ψ'' (m, 2, 2),
    the blocks of its majorant (g/|σ|)·I in slip (the curvature of the quadratic that touches g|σ| from above at
    σ, so that a step on it decreases ψ), and Σ ψ(σ)."""
    r = np.linalg.norm(sig, axis=1)
    slide = k * r > g
    rs = np.maximum(r, 1e-300)
    T = np.where(slide[:, None], -(g / rs)[:, None] * sig, -k[:, None] * sig)
    n = sig / rs[:, None]
    eye = np.eye(2)[None]
    soft = np.where(slide, g / rs, k)[:, None, None]
    Hs = np.where(slide[:, None, None], soft * (eye - n[:, :, None] * n[:, None, :]), soft * eye)
    psi = np.where(slide, g * r - 0.5 * g**2 / np.maximum(k, 1e-300), 0.5 * k * r**2)
    return T, Hs, soft * eye, float(psi.sum())


def solve_tresca_penalty(qp: ContactQP, C: sp.spmatrix, c: np.ndarray, g: np.ndarray, epsilon: float,
                         tol: float = 1e-10, max_iterations: int = 100, initial_U: np.ndarray | None = None,
                         backend: str = "auto", E: np.ndarray | None = None) -> ContactSolution:
    """Tresca friction by penalty: normal springs ω_i/ε, tangential springs ω_i/ε capped at g_i (module
    docstring). Newton with backtracking (a step on the slip's majorant (g/|σ|)·I where Newton needs
    a step below ¼: its tangent has no stiffness along the slip; sliding points whose slip keeps shrinking are
    tried on their stick branch first, ``SHRINK``); stops when the penalised equation's residual is below
    tol × ‖F + BᵀΛ + CᵀT‖ or below ``_FLOOR`` once the energy stops decreasing (round-off). With δ unknowns
    (qp.k > 0) the unknowns are x = (U, δ): A, F, B, C bordered by (0, P, D, E), and Newton starts from the
    frictionless penalty solution's penetrating rows (a punch that starts apart has none at G)."""
    check_arguments(tol, max_iterations)
    if not (np.isfinite(epsilon) and epsilon > 0):
        raise InputError("solver.penalty", f"must be a positive number, got {epsilon!r}")
    C, c, g, E = _check(qp, C, c, g, E)
    t0 = time.perf_counter()
    kn = qp.weights / epsilon
    n, k = qp.n, qp.k
    A, F, B, Ct = qp.A, qp.F, qp.B, C
    if k:  # bordered by the δ unknowns
        A = sp.block_diag([qp.A, sp.csr_matrix((k, k))], format="csr")
        F = np.concatenate([qp.F, qp.P])
        B = sp.hstack([qp.B, sp.csr_matrix(qp.D)], format="csr")
        Ct = sp.hstack([C, sp.csr_matrix(E)], format="csr")
    U = None if initial_U is None else np.asarray(initial_U, float).copy()
    if U is not None and k and U.size == n:
        U = None

    def energy(x: np.ndarray) -> float:
        return 0.5 * float(x @ (A @ x)) - float(F @ x)

    def state(x: np.ndarray):
        gap = qp.G + B @ x
        Lam = kn * np.maximum(-gap, 0.0)
        T, Hs, Hm, psi = _tangential((Ct @ x - c).reshape(-1, 2), kn, g)
        En = energy(x) + 0.5 * float(np.sum(kn * np.maximum(-gap, 0.0) ** 2)) + psi
        return En, Lam, T.ravel(), (Hs, Hm), gap

    if U is None:  # from the stuck state: every spring linear (the slips then grow from small values,
        # where Newton's model of the slip holds; from U = 0 every point starts sliding by the whole slide and
        # Newton crawls: 40 steps without converging on the paper panel)
        closed = qp.G < 0
        if k:  # the frictionless penalty solution's penetrating rows (without the δ no gap sees: 0 there)
            qp0, keep = normal_part(qp)
            free = solve_penalty(qp0, epsilon, tol=tol)
            closed = qp0.gap(free.U, free.delta) < 0
        Bn = B[closed]
        K = A + Bn.T @ sp.diags(kn[closed]) @ Bn + Ct.T @ sp.diags(np.repeat(kn, 2)) @ Ct
        U = factorize(K, backend).solve(F - Bn.T @ (kn[closed] * qp.G[closed]) + Ct.T @ (np.repeat(kn, 2) * c))
    history: list = []
    En, Lam, T, Hs, gap = state(U)
    previous = np.zeros(qp.m)
    last = np.inf  # the last iteration's residual: the round-off floor is where it stops falling
    for it in range(1, max_iterations + 1):
        grad = A @ U - F - B.T @ Lam - Ct.T @ T
        Bn = B[gap < 0]
        Kn = A + Bn.T @ sp.diags(kn[gap < 0]) @ Bn
        slope = 0.0
        sig = (Ct @ U - c).reshape(-1, 2)
        r = np.linalg.norm(sig, axis=1)
        creeping = (g > 0) & (kn * r > g) & (r < SHRINK * previous)
        previous = r
        trial = None
        if creeping.any():  # the step with those points on their stick branch (force −kσ, stiffness k), kept
            # where it lowers the energy (else Newton's step below)
            blocks = np.where(creeping[:, None, None], kn[:, None, None] * np.eye(2)[None], Hs[0])
            Tm = T.reshape(-1, 2).copy()
            Tm[creeping] = -kn[creeping, None] * sig[creeping]
            K = Kn + Ct.T @ sp.block_diag(list(blocks), format="csr") @ Ct
            dU = -factorize(K, backend).solve(grad - Ct.T @ (Tm.ravel() - T))
            t, trial = 1.0, state(U + dU)
            if not trial[0] < En:
                trial = None
        for blocks, shortest in zip(Hs if trial is None else (), (0.25, 1e-10)):  # Newton; if it needs a short
            # step, the majorant
            K = Kn + Ct.T @ sp.block_diag(list(blocks), format="csr") @ Ct
            dU = -factorize(K, backend).solve(grad)
            slope = float(grad @ dU)
            t = 1.0
            while True:
                trial = state(U + t * dU)
                if trial[0] <= En + 1e-4 * t * slope or t < shortest:
                    break
                t *= 0.5
            if trial[0] <= En + 1e-4 * t * slope:
                break
        decrease = En - trial[0]
        U = U + t * dU
        En, Lam, T, Hs, gap = trial
        f = np.linalg.norm(F + B.T @ Lam + Ct.T @ T)
        resid = np.linalg.norm(A @ U - F - B.T @ Lam - Ct.T @ T) / max(f, 1e-300)
        history.append({"iteration": it, "step": t, "energy": En, "residual": float(resid)})
        if resid <= tol and decrease <= tol * max(abs(En), 1e-300):
            break
        if resid <= _FLOOR and decrease <= 16 * np.finfo(float).eps * abs(En) and resid > 0.5 * last:
            break  # the round-off floor of r: the energy and the residual stopped falling (from a warm start the
            # energy falls by round-off alone while r still halves: stopping there left 1e-6 of the bounds
            # in Λ and the Coulomb fixed point on the vessel on saddles stalled, 13 iterations instead of 8)
        last = resid
    else:
        raise SolverError(f"tresca penalty: Newton's method did not converge in {max_iterations} iterations",
                          iterations=max_iterations)
    x, delta = (U[:n], U[n:]) if k else (U, None)
    res = friction_residuals(qp, C, c, g, x, Lam, T, delta, E)
    return ContactSolution(
        U=x, Lambda=Lam, pressure=Lam / qp.weights, active=gap < 0, delta=delta, iterations=it, residuals=res,
        method="tresca-penalty", history=history, energy=qp.energy(x, delta),
        timings={"total": time.perf_counter() - t0},
        info={"T": T, "slip": slips(qp, C, c, x, delta, E), "bounds": g, "gap": gap})


def normal_part(qp: ContactQP) -> tuple[ContactQP, np.ndarray]:
    """The QP without the δ columns no gap sees (D_j = 0: a rigid motion only friction holds), and the mask of the
    columns kept: the frictionless start of a friction solve, where those amounts are undetermined (set to 0)."""
    keep = np.any(qp.D != 0.0, axis=0) if qp.k else np.zeros(0, dtype=bool)
    if keep.all():
        return qp, keep
    sub = copy.copy(qp)
    sub.D, sub.P = (np.ascontiguousarray(qp.D[:, keep]), qp.P[keep]) if keep.any() else (None, None)
    if qp.friction_held is not None:
        sub.friction_held = np.asarray(qp.friction_held)[keep] if keep.any() else None
    if qp.force_labels is not None:
        sub.force_labels = [label for label, k in zip(qp.force_labels, keep) if k] if keep.any() else None
    return sub, keep
