"""The dual QP (MODEL.md §8, seed (7.9)): minimise ½ΛᵀSΛ − hᵀΛ over Λ ≥ 0, S = B A⁻¹ Bᵀ,
h = −(G + B A⁻¹F); then U = A⁻¹(F + BᵀΛ). The gradient SΛ − h is the gap vector g.

Algorithm: MPRGP (Dostál, *Optimal Quadratic Programming Algorithms*, 2009) with its
conjugate-gradient steps replaced by EXACT minimisation on the current face. m (contact
vertices) is moderate, so the face block S_FF is formed from columns of S obtained by blocked
solves with the single factorisation of A (``schur.Workspace``) and factorised densely.
Each iteration, with F = {Λ_i > 0}, free gradient φ = g on F, chopped gradient β = min(g, 0)
off F:

* if ‖β‖² > Γ²‖φ‖² (Γ = 1) — **proportioning**: Λ ← Λ − αβ̂ with the exact step
  α = β̂ᵀg / β̂ᵀSβ̂, β̂ = β restricted to the rows ``schur.deepest_violations`` picks: β_i ≤ θ·min β
  (θ = ``growth``: 0.9 releases the most negative gaps first, so that columns of S are computed only
  near the final contact set; θ = 0 is MPRGP's proportioning), and at most max(64, |F|) of them, the
  deepest (the face at most doubles per step);
* else — **face** step: the face minimiser y (S_FF y_F = h_F, Λ_A = 0). If y ≥ 0 it is the new
  iterate. Else (a) drop all its negative entries and re-solve on the smaller face, until the
  minimiser is ≥ 0 on its face, and take that point if it lowers the energy; else (b) a projected
  search along the face's Newton direction d = y − Λ: P(Λ + t d) for t = 1, ½, ¼, … down to the first
  bound hit t_b, where the step stays on the face and strictly lowers the energy (d descends on the
  face, and the energy is convex there). A projection drops many bounds at once: the one-bound-per-
  solve Lawson–Hanson loop used before took dozens of dense solves of order 10³ with steps of 1e-12
  on a floating pipe at 213k unknowns and did not finish in 30 minutes.

(MPRGP's fixed-step expansion, ᾱ ≤ 2/‖S‖, was tried first: with S conditioned like h⁻⁴ it
crawls — hundreds of iterations on a 64-element beam under force control — and is not used.)

Convergence: every step decreases the dual energy strictly unless Λ is optimal (as in MPRGP, whose
expansion step the face step replaces: a face step that reaches a face minimiser, as most do, ends
where no later step returns, as in Lawson–Hanson's NNLS). No h⁻² iteration growth from
unpreconditioned CG. Stops when max|φ| and max|β| ≤ tol·(length scale: ``Workspace.length_scale``),
then the common KKT check on a freshly solved U. The Hessian enters only through products Hx
(``Workspace.Sx``: the cached columns on x's support) and face blocks H_FF (``Workspace.block``).

Force control and restrained rigid motions (DᵀΛ = −P): SMALBE-type augmented Lagrangian (Dostál):
the inner bound QP uses S + ρDDᵀ and linear term −h + D(δ + ρP), whose gradient is the gap at
δ + ρ(DᵀΛ + P); after each inner solve δ ← δ + ρ(DᵀΛ + P), and a polish step solves the face KKT
system with δ exactly (finite termination once the face is right). Λ and δ start at the KKT point
of a face that determines δ (the first row each punch and rigid motion would touch,
``Workspace.first_contact``, or Λ0's support): there DᵀΛ + P = 0, so the first gradient is the true
gap and not c0 shifted by ρDP alike on every row of a plate.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from ..errors import SolverError
from ..linalg import Factorization
from .augmented import augmented_lagrangian
from .qp import ContactQP, ContactSolution, History, as_mask, check_arguments, check_growth
from .schur import Unfinished, Workspace, deepest_violations, default_growth

_NEG = 1e-13  # relative size below which a negative face-minimiser component counts as zero
OUTER = 50  # the augmented Lagrangian's outer steps at most


def _face_minimiser(ws: Workspace, block: Callable, c: np.ndarray, idx: np.ndarray) -> np.ndarray:
    """The minimiser y of ½yᵀH_FF y + c_Fᵀy on the face idx (zero off it): one dense Cholesky."""
    y = np.zeros(ws.qp.m)
    if idx.size:
        y[idx] = ws.face_solve(idx, -c[idx], H=block(idx), use_D=False)[0]
    return y


def _negative(y: np.ndarray, idx: np.ndarray) -> np.ndarray:
    """Rows of the face idx where y is negative beyond round-off (relative ``_NEG``)."""
    ymax = float(np.abs(y[idx]).max(initial=0.0))
    return idx[y[idx] < -_NEG * ymax]


def _positive_part(y: np.ndarray) -> np.ndarray:
    """max(y, 0) with round-off-sized entries set to exactly 0."""
    yp = np.maximum(y, 0.0)
    yp[yp <= _NEG * max(float(yp.max(initial=0.0)), 1e-300)] = 0.0
    return yp


def _face_step(ws: Workspace, block: Callable, c: np.ndarray, x: np.ndarray, energy: Callable,
               record: dict) -> np.ndarray:
    """One face step from x (module docstring): the face minimiser, (a) or (b) if it is not ≥ 0."""
    F = np.flatnonzero(x > 0)
    y = _face_minimiser(ws, block, c, F)
    record["face_solves"] = 1
    if _negative(y, F).size == 0:
        return _positive_part(y)
    f0 = energy(x)
    # (a) drop every negative component and re-solve on the smaller face, until ≥ 0
    xa = y
    idx = F
    while (neg := _negative(xa, idx)).size:
        idx = np.setdiff1d(idx, neg, assume_unique=True)
        xa = _face_minimiser(ws, block, c, idx)
        record["face_solves"] += 1
    xa = _positive_part(xa)
    if energy(xa) < f0:
        return xa
    # (b) projected search along the face's Newton direction d = y − x: P(x + t d) for t = 1, ½, ¼, …
    #     down to the first bound hit t_b, where the step stays on the face (a strict descent: d
    #     descends on the face, whose energy is convex); a projection drops many bounds at once
    record["projected_search"] = True
    d = y - x
    hit = d[F] < 0
    t_b = float(min(1.0, np.min(x[F][hit] / -d[F][hit]))) if hit.any() else 1.0
    t = 1.0
    while t > t_b:
        xt = _positive_part(x + t * d)
        if energy(xt) < f0:
            return xt
        t *= 0.5
    return _positive_part(x + t_b * d)


def bound_qp(
    ws: Workspace,
    x0: np.ndarray,
    c: np.ndarray,
    matvec: Callable[[np.ndarray], np.ndarray],
    block: Callable[[np.ndarray], np.ndarray],
    tol: float,
    max_iterations: int,
    history: list,
    gamma: float = 1.0,
    it0: int = 0,
    growth: float = 0.9,
) -> tuple[np.ndarray, int, bool]:
    """Minimise ½xᵀHx + cᵀx over x ≥ 0 (rows not ``ws.live`` stay 0), with Hx = matvec(x) and
    H[J][:, J] = block(J), by MPRGP with exact face solves (module docstring). Stops when the free
    and chopped gradients (gaps) are ≤ tol times the length scale at the current gaps
    (``Workspace.length_scale``). Returns x, iterations, converged."""
    live = ws.live
    x = np.where(live, np.maximum(x0, 0.0), 0.0)

    def grad(x: np.ndarray) -> np.ndarray:
        return c + matvec(x)

    def energy(x: np.ndarray) -> float:
        return 0.5 * float(x @ matvec(x)) + float(c @ x)

    g = grad(x)
    for it in range(1, max_iterations + 1):
        F = x > 0
        phi = np.where(F, g, 0.0)
        beta = np.where(~F & live, np.minimum(g, 0.0), 0.0)
        nphi, nbeta = float(np.abs(phi).max(initial=0.0)), float(np.abs(beta).max(initial=0.0))
        tol_g = tol * ws.length_scale(g)
        if nphi <= tol_g and nbeta <= tol_g:
            return x, it - 1, True
        rec = {"iteration": it0 + it, "free": int(F.sum()), "phi": nphi, "beta": nbeta}
        if beta @ beta > gamma**2 * (phi @ phi):
            beta = np.where(deepest_violations(g, ~F & live, growth, int(F.sum())), beta, 0.0)
            Hb = matvec(beta)
            curvature = float(beta @ Hb)
            if not curvature > 0.0:  # S = B A⁻¹ Bᵀ is singular on these rows: B cannot move them
                supp = np.flatnonzero(beta)
                raise SolverError(
                    "dual: the dual Hessian has no curvature along the constraint rows "
                    f"{supp[:5].tolist()}{' ...' if supp.size > 5 else ''} (points the supports hold fixed, e.g. on "
                    "a clamped edge, carry the load); use method = \"active-set\"", iterations=it0 + it)
            alpha = float(beta @ beta) / curvature
            x = x - alpha * beta
            g = g - alpha * Hb
            rec["step"] = "proportioning"
        else:
            x = _face_step(ws, block, c, x, energy, rec)
            rec["step"] = "face"
            g = grad(x)  # recompute from the columns: no drift
        rec["energy"] = 0.5 * float(x @ (g - c)) + float(c @ x)
        history.append(rec)
    F = x > 0
    ok = max(np.abs(np.where(F, g, 0.0)).max(initial=0.0), np.abs(np.where(~F & live, np.minimum(g, 0.0), 0.0)).max(
        initial=0.0)) <= tol * ws.length_scale(g)
    return x, max_iterations, ok


def dual_core(
    ws: Workspace,
    lam0: np.ndarray,
    tol: float,
    max_iterations: int,
    history: list,
    gamma: float = 1.0,
    rho: float | None = None,
    it0: int = 0,
    growth: float = 0.9,
) -> tuple[np.ndarray, np.ndarray | None, int]:
    """Solve the dual from Λ0 ≥ 0; returns Λ, δ, iterations (raises SolverError on failure)."""
    qp = ws.qp
    if qp.k == 0:
        lam, its, ok = bound_qp(ws, lam0, ws.c0, ws.Sx, ws.block, tol, max_iterations, history, gamma, it0,
                                growth)
        if not ok:
            raise SolverError(
                f"dual: MPRGP did not reach the tolerance {tol:g}",
                residuals=_dual_residuals(ws, lam, None),
                iterations=its,
            )
        return lam, None, its
    D, P = qp.D, qp.P
    lam = np.where(ws.live, np.maximum(lam0, 0.0), 0.0)
    # start on a face that determines δ (the first rows each punch and rigid motion would touch, or
    # Λ0's support) at its KKT point: Λ and δ with DᵀΛ = −P exactly, so that the augmented term
    # starts at zero and the first gradient is the true gap there, not c0 shifted by ρDP alike on
    # every row of a plate (which would release all of them at once)
    face = lam > 0 if np.any(lam > 0) else ws.first_contact(np.zeros(qp.m, dtype=bool), ws.c0)
    idx = np.flatnonzero(face)
    delta = np.zeros(qp.k)
    x, d, singular = ws.face_solve(idx, -ws.c0[idx], -P)
    if not singular:
        lam = np.zeros(qp.m)
        lam[idx] = np.maximum(x, 0.0)
        delta = d
    if rho is None:
        diag = ws.known_diagonal()
        rho = 10.0 * float(diag.max()) if diag.size else 1.0
    spent = [0]  # the inner iterations so far: each inner solve gets what is left of max_iterations

    def inner(delta: np.ndarray, rho: float, lam: np.ndarray) -> tuple[np.ndarray, int, bool]:
        def matvec(x: np.ndarray) -> np.ndarray:  # (S + ρDDᵀ)x
            return ws.Sx(x) + rho * (D @ (D.T @ x))

        def block(J: np.ndarray) -> np.ndarray:
            return ws.block(J) + rho * (D[J] @ D[J].T)

        out = bound_qp(ws, lam, ws.c0 + D @ (delta + rho * P), matvec, block, tol, max_iterations - spent[0],
                       history, gamma, it0 + spent[0], growth)
        spent[0] += out[1]
        return out

    def polish(lam: np.ndarray, delta: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
        """The face KKT system with δ, exactly (finite termination once the face is right); None where it does
        not give a feasible point (a singular face leaves part of δ undetermined)."""
        idx = np.flatnonzero(lam > 0)
        if not idx.size:
            return None
        x, d, singular = ws.face_solve(idx, -ws.c0[idx], -P)
        if singular or not np.all(x >= 0):
            return None
        trial = np.zeros(qp.m)
        trial[idx] = x
        gtr = ws.gap(trial, d)
        if gtr[ws.live].min(initial=0.0) < -tol * ws.length_scale(gtr):
            return None
        history.append({"iteration": it0 + spent[0], "step": "polish", "free": int(idx.size)})
        return trial, d

    def record(outer: int, total: int, error: float) -> None:
        history.append({"iteration": it0 + total, "outer": outer, "force_balance": error})

    lam, delta, total, ok = augmented_lagrangian(
        inner, D, P, lam, delta, rho, tol, OUTER, lambda y, d: _force_scale(ws, y, d), budget=max_iterations,
        polish=polish, record=record)
    if ok:
        return lam, delta, total
    raise SolverError(
        f"dual: augmented-Lagrangian iteration did not reach the tolerance {tol:g}",
        residuals=_dual_residuals(ws, lam, delta),
        iterations=total,
    )


def _force_scale(ws: Workspace, lam: np.ndarray, delta: np.ndarray) -> float:
    """The gross size of the balance DᵀΛ + P, as ``kkt``'s force_balance takes it: against the problem's force
    scale too, since with P = 0 and Λ = 0 the gross force is round-off."""
    return float(max(np.linalg.norm(ws.qp.P), np.linalg.norm(abs(ws.qp.D).T @ lam),
                     ws.force_scale(ws.gap(lam, delta))))


def _dual_residuals(ws: Workspace, lam: np.ndarray, delta: np.ndarray | None) -> dict[str, float]:
    g = ws.gap(lam, delta)
    out = {
        "penetration": float(max(0.0, -g[ws.live].min(initial=0.0))),
        "complementarity_gap": float(np.abs(lam * g).max(initial=0.0)),
        "dual_feasibility": float(max(0.0, -lam.min(initial=0.0))),
    }
    if delta is not None:
        out["force_balance"] = float(np.linalg.norm(ws.qp.D.T @ lam + ws.qp.P)) / _force_scale(ws, lam, delta)
    return out


def solve_dual(
    qp: ContactQP,
    tol: float = 1e-10,
    max_iterations: int = 500,
    factorization: Factorization | None = None,
    initial_lambda: np.ndarray | None = None,
    initial_active: np.ndarray | None = None,
    gamma: float = 1.0,
    rho: float | None = None,
    growth: float | None = None,
    callback: Callable[[dict], None] | None = None,
    extended: bool = False,
    finish: bool = True,
) -> ContactSolution | Unfinished:
    """Dual method (module docstring). Warm start from Λ (``initial_lambda``) or from an
    active set (``initial_active``: the face solve on it, clipped at 0). ``growth`` θ = 0 gives
    MPRGP's full proportioning (default ``schur.default_growth``: 0.9, or 0 with the dense Schur
    complement). ``extended``: the final solves with mixed-precision refinement (``schur.Workspace``).
    ``finish`` False: the converged multipliers before their final check (``schur.Unfinished``)."""

    check_arguments(tol, max_iterations)
    ws = Workspace(qp, factorization, extended=extended, finish=finish)
    history: list = History(callback)
    lam0 = np.zeros(qp.m)
    if initial_lambda is not None:
        lam0 = np.maximum(np.asarray(initial_lambda, dtype=float).reshape(qp.m), 0.0)
    elif initial_active is not None:
        idx = np.flatnonzero(as_mask(initial_active, qp.m) & ws.live)
        if idx.size:
            x, _, _ = ws.face_solve(idx, -ws.c0[idx], None if qp.k == 0 else -qp.P)
            lam0[idx] = np.maximum(x, 0.0)
    growth = default_growth(ws) if growth is None else growth
    check_growth(growth)
    lam, delta, its = dual_core(ws, lam0, tol, max_iterations, history, gamma, rho, growth=growth)
    faces = int(sum(r.get("face_solves", 0) for r in history))
    return ws.finish_exact(lam, delta, tol, "dual", its, history, info={"face_solves": faces})
