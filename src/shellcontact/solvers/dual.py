"""The dual QP (MODEL.md §8, seed (7.9)): minimise ½ΛᵀSΛ − hᵀΛ over Λ ≥ 0, S = B A⁻¹ Bᵀ,
h = −(G + B A⁻¹F); then U = A⁻¹(F + BᵀΛ). The gradient SΛ − h is the gap vector g.

Algorithm: MPRGP (Dostál, *Optimal Quadratic Programming Algorithms*, 2009) with its
conjugate-gradient steps replaced by EXACT minimisation on the current face. m (contact
vertices) is moderate, so the face block S_FF is formed from columns of S obtained by blocked
solves with the single factorisation of A (``schur.Workspace``) and factorised densely.
Each iteration, with F = {Λ_i > 0}, free gradient φ = g on F, chopped gradient β = min(g, 0)
off F:

* if ‖β‖² > Γ²‖φ‖² (Γ = 1) — **proportioning**: Λ ← Λ − αβ̂ with the exact step
  α = β̂ᵀg / β̂ᵀSβ̂, β̂ = β restricted to β_i ≤ θ·min β (θ = ``growth`` = 0.9: release the most
  negative gaps first, so that columns of S are computed only near the final contact set;
  θ = 0 is MPRGP's proportioning);
* else — **face** step: the face minimiser y (S_FF y_F = h_F, Λ_A = 0); while y has negative
  entries, (a) drop them all and re-solve on the smaller face; if the positive face minimiser
  so found does not lower the energy, (b) redo the step Lawson–Hanson style: move to P(y) if
  that lowers the energy, else to the first bound hit on the segment towards y, drop the
  bounds at zero, re-solve, until y > 0 on its face (monotone).

(MPRGP's fixed-step expansion, ᾱ ≤ 2/‖S‖, was tried first: with S conditioned like h⁻⁴ it
crawls — hundreds of iterations on a 64-element beam under force control — and is not used.)

Convergence: every step decreases the dual energy strictly unless Λ is optimal; each face
step ends at the minimiser of the energy on a face, and as those values strictly decrease no
face can recur: finite termination, as in Lawson–Hanson's NNLS, but with all bounds with
negative gap released at once. No h⁻² iteration growth from unpreconditioned CG. Stops when
max|φ| and max|β| ≤ tol·(length scale: ``Workspace.length_scale``), then the common KKT check on a freshly solved U.

Force control (DᵀΛ = −P): SMALBE-type augmented Lagrangian (Dostál): the inner bound QP uses
S + ρDDᵀ and linear term −h + D(δ + ρP), whose gradient is the gap at δ + ρ(DᵀΛ + P); after each
inner solve δ ← δ + ρ(DᵀΛ + P), and a polish step solves the face KKT system with δ exactly
(finite termination once the face is right).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from ..errors import SolverError
from ..linalg import Factorization
from .qp import ContactQP, ContactSolution, History, as_mask, check_arguments, check_growth
from .schur import Workspace, default_growth

_NEG = 1e-13  # relative size below which a negative face-minimiser component counts as zero


def _face_descend(ws: Workspace, cols: Callable, c: np.ndarray, idx: np.ndarray, x: np.ndarray,
                  drop_all: bool, fval: Callable | None = None, grad: Callable | None = None):
    """Face minimisation from x on the face idx (module docstring); returns the final point and
    the number of dense face solves."""
    xs = x.copy()
    inner = 0
    while idx.size:
        inner += 1
        H = cols(idx)[idx]
        y, _, _ = ws.face_solve(idx, -c[idx], H=H, use_D=False)
        ymax = float(np.abs(y).max(initial=0.0))
        neg = y < -_NEG * ymax
        if not neg.any():
            xs = np.zeros_like(x)
            xs[idx] = np.maximum(y, 0.0)
            break
        if drop_all:
            step = np.maximum(y, 0.0)
        else:
            xp = np.zeros_like(x)
            xp[idx] = np.maximum(y, 0.0)
            if fval(xp, grad(xp)) < fval(xs, grad(xs)):
                step = xp[idx]
            else:
                d = y - xs[idx]
                alpha_f = float(min(1.0, np.min(xs[idx][neg] / -d[neg])))
                step = xs[idx] + alpha_f * d
        xs = np.zeros_like(x)
        keep = step > _NEG * max(float(step.max(initial=0.0)), 1e-300)
        xs[idx[keep]] = step[keep]
        idx = idx[keep]
    return xs, inner


def bound_qp(
    ws: Workspace,
    x0: np.ndarray,
    c: np.ndarray,
    cols: Callable[[np.ndarray], np.ndarray],
    tol: float,
    max_iterations: int,
    history: list,
    gamma: float = 1.0,
    it0: int = 0,
    growth: float = 0.9,
) -> tuple[np.ndarray, int, bool]:
    """Minimise ½xᵀHx + cᵀx over x ≥ 0 (rows not ``ws.live`` stay 0), H[:, J] = cols(J), by
    MPRGP with exact face solves (module docstring). Stops when the free and chopped gradients
    (gaps) are ≤ tol times the length scale at the current gaps (``Workspace.length_scale``).
    Returns x, iterations, converged."""
    live = ws.live
    x = np.where(live, np.maximum(x0, 0.0), 0.0)

    def grad(x: np.ndarray) -> np.ndarray:
        supp = np.flatnonzero(x)
        return c + (cols(supp) @ x[supp] if supp.size else 0.0)

    def fval(x: np.ndarray, g: np.ndarray) -> float:
        return 0.5 * float(x @ (g - c)) + float(c @ x)

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
            if growth > 0:  # release only the most negative gaps: fewer columns of S
                beta = np.where(beta <= growth * beta.min(), beta, 0.0)
            supp = np.flatnonzero(beta)
            Hb = cols(supp) @ beta[supp]
            curvature = float(beta @ Hb)
            if not curvature > 0.0:  # S = B A⁻¹ Bᵀ is singular on these rows: B cannot move them
                raise SolverError(
                    "dual: the dual Hessian has no curvature along the constraint rows "
                    f"{supp[:5].tolist()}{' ...' if supp.size > 5 else ''} (points the supports hold fixed, e.g. on "
                    "a clamped edge, carry the load); use method = \"active-set\"", iterations=it0 + it)
            alpha = float(beta @ beta) / curvature
            x = x - alpha * beta
            g = g - alpha * Hb
            rec["step"] = "proportioning"
        else:
            # exact minimisation on the face, Lawson–Hanson style: step to the first bound the
            # segment towards the face minimiser hits, drop the bounds hit, re-solve on the
            # smaller face, until the face minimiser is positive
            idx = np.flatnonzero(F)
            f0 = fval(x, g)
            # (a) drop every negative component of the face minimiser and re-solve, until the
            #     minimiser is positive on its face; accept if the energy went down
            xs, inner = _face_descend(ws, cols, c, idx, x, drop_all=True)
            if fval(xs, grad(xs)) >= f0:
                # (b) monotone Lawson–Hanson: stop at the first bound hit on the way to y
                xs, more = _face_descend(ws, cols, c, idx, x, drop_all=False, fval=fval, grad=grad)
                inner += more
                rec["lawson_hanson"] = True
            rec["face_solves"] = inner
            x = xs
            rec["step"] = "face"
            g = grad(x)  # recompute from the columns: no drift
        rec["energy"] = fval(x, g)
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
        lam, its, ok = bound_qp(ws, lam0, ws.c0, ws.columns, tol, max_iterations, history, gamma, it0, growth)
        if not ok:
            raise SolverError(
                f"dual: MPRGP did not reach the tolerance {tol:g}",
                residuals=_dual_residuals(ws, lam, None),
                iterations=its,
            )
        return lam, None, its
    D, P = qp.D, qp.P
    lam = np.where(ws.live, np.maximum(lam0, 0.0), 0.0)
    if not np.any(lam > 0):
        seed = ws.first_contact(np.zeros(qp.m, dtype=bool), ws.c0)
        ws.ensure(np.flatnonzero(seed))
    else:
        ws.ensure(np.flatnonzero(lam > 0))
    if rho is None:
        diag = ws.known_diagonal()
        rho = 10.0 * float(diag.max()) if diag.size else 1.0
    delta = np.zeros(qp.k)
    total = 0

    def cols(J: np.ndarray) -> np.ndarray:
        return ws.columns(J) + rho * (D @ D[J].T)

    for outer in range(1, 51):
        c = ws.c0 + D @ (delta + rho * P)
        lam, its, ok = bound_qp(ws, lam, c, cols, tol, max_iterations - total, history, gamma, it0 + total,
                                growth)
        total += its
        if not ok:
            break
        delta = delta + rho * (D.T @ lam + P)
        # polish: the face KKT system with δ, exactly
        idx = np.flatnonzero(lam > 0)
        if idx.size:
            x, d, _ = ws.face_solve(idx, -ws.c0[idx], -P)
            if np.all(x >= 0):
                trial = np.zeros(qp.m)
                trial[idx] = x
                gtr = ws.gap(trial, d)
                if gtr[ws.live].min(initial=0.0) >= -tol * ws.length_scale(gtr):
                    history.append({"iteration": it0 + total, "outer": outer, "step": "polish", "free": int(idx.size)})
                    return trial, d, total
        fb = np.linalg.norm(D.T @ lam + P) / max(np.linalg.norm(P), np.linalg.norm(abs(D).T @ lam), 1e-300)
        history.append({"iteration": it0 + total, "outer": outer, "force_balance": float(fb)})
        if fb <= tol:
            return lam, delta, total
        if total >= max_iterations:
            break
    raise SolverError(
        f"dual: augmented-Lagrangian iteration did not reach the tolerance {tol:g}",
        residuals=_dual_residuals(ws, lam, delta),
        iterations=total,
    )


def _dual_residuals(ws: Workspace, lam: np.ndarray, delta: np.ndarray | None) -> dict[str, float]:
    g = ws.gap(lam, delta)
    out = {
        "penetration": float(max(0.0, -g[ws.live].min(initial=0.0))),
        "complementarity_gap": float(np.abs(lam * g).max(initial=0.0)),
        "dual_feasibility": float(max(0.0, -lam.min(initial=0.0))),
    }
    if delta is not None:
        out["force_balance"] = float(np.linalg.norm(ws.qp.D.T @ lam + ws.qp.P))
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
) -> ContactSolution:
    """Dual method (module docstring). Warm start from Λ (``initial_lambda``) or from an
    active set (``initial_active``: the face solve on it, clipped at 0). ``growth`` θ = 0 gives
    MPRGP's full proportioning (default ``schur.default_growth``: 0.9, or 0 with the dense Schur
    complement). ``extended``: the final solves with mixed-precision refinement (``schur.Workspace``)."""

    check_arguments(tol, max_iterations)
    ws = Workspace(qp, factorization, extended=extended)
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
