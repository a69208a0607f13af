"""A QP with separable convex constraints, half-lines and discs: the dual of Tresca friction (MODEL.md §11).

    minimise f(y) = ½ yᵀHy + cᵀy   over   y = (Λ, T):  Λ_i ≥ 0 (i < m),  |T_j| ≤ g_j (T_j = y[m+2j : m+2j+2])

H symmetric positive semi-definite (dense, of moderate order: the dual Hessian B̂ A⁻¹ B̂ᵀ of the rows
that carry force). Algorithm: MPGP (Dostál & Pospíšil's modified proportioning with gradient projection,
the extension of MPRGP to separable convex sets), with the conjugate-gradient steps replaced by EXACT
face minimisation as in ``dual.py`` (S is conditioned like h⁻⁴; fixed-step expansion crawls there):

* free set F: Λ_i > 0, |T_j| < g_j (both components); the rest are on their boundaries (a disc with
  g_j = 0 is the point 0 and never free);
* free gradient φ = g on F; chopped gradient β off F: min(g_i, 0) for Λ_i = 0, and for T_j on its circle
  (outward normal n = T_j/|T_j|) β_j = g_j − min(n·g_j, 0) n: the tangential part (turn along the circle)
  plus an inward part (release into the disc). KKT ⇔ φ = 0 and β = 0 (the projected gradient);
* if ‖β‖² > Γ²‖φ‖² — **proportioning**: the projected search P(y − tαβ), α = βᵀg/βᵀHβ the exact step,
  t = 1, ½, … until f decreases (−β descends: βᵀg = ‖β‖²);
* else — **face** step: the minimiser z of f with the variables off F held (H_FF z_F = −c_F − H_FN y_N),
  taken if feasible, else the projected search P(y + t(z − y)), t = 1, ½, … down to the largest feasible
  t_b, where the step stays feasible and decreases f (convex along z − y). H_FF may be singular (rows that
  repeat, a circle's tangent H does not see): z is then the minimum-norm solution, and where the face's
  gradient has a part H_FF does not see (f linear along it) the step goes along that part to the first bound;
* where the face step does not lower f — **expansion**: P(y − ᾱ∇f) with the fixed step ᾱ = 1/‖H‖∞ ≤ 1/‖H‖₂,
  which lowers f by at least ‖H‖₂/2 |z − y|² unless y is a KKT point; where that too is below f's round-off,
  the iteration stops ("stalled") and reports convergence if the projected gradient is within _FLOOR × tol.

Every step decreases f unless y is a KKT point; the tests against a general-purpose constrained minimiser
(also on singular H) are ``tests/test_disc_qp.py``.
"""

from __future__ import annotations

import numpy as np
import scipy.linalg as la
import scipy.sparse as sp

from ..errors import InputError

_EDGE = 1e-12  # relative distance to a bound below which a variable counts as on it
#: where no step lowers f any more (its round-off), the projected gradient accepted, relative to tol: measured
#: 5e-9 of max|c| on the 32 × 32 panel at tol = 1e-10 (penetration 5e-9 of the largest gap)
_FLOOR = 1e3


def project(y: np.ndarray, m: int, g: np.ndarray) -> np.ndarray:
    """The Euclidean projection on {Λ ≥ 0} × Π_j {|T_j| ≤ g_j}: a clip and a radial scaling per disc."""
    out = y.copy()
    out[:m] = np.maximum(out[:m], 0.0)
    T = out[m:].reshape(-1, 2)
    r = np.linalg.norm(T, axis=1)
    over = r > g
    T[over] *= (g[over] / r[over])[:, None]
    return out


def _sets(y: np.ndarray, m: int, g: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(free mask over y, mask of the discs on their circle)."""
    free = np.zeros(y.size, dtype=bool)
    free[:m] = y[:m] > 0.0
    r = np.linalg.norm(y[m:].reshape(-1, 2), axis=1)
    inside = r < (1.0 - _EDGE) * g
    free[m:] = np.repeat(inside, 2)
    return free, ~inside & (g > 0)


def split_gradient(y: np.ndarray, grad: np.ndarray, m: int, g: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(φ, β): the free gradient (with the tangential part on a circle) and the chopped gradient (module
    docstring)."""
    free, circle = _sets(y, m, g)
    phi = np.where(free, grad, 0.0)
    beta = np.zeros_like(grad)
    beta[:m] = np.where(free[:m], 0.0, np.minimum(grad[:m], 0.0))
    n, gn = _normals(y, grad, m)
    G = grad[m:].reshape(-1, 2)
    phi[m:] = np.where(circle[:, None], G - gn[:, None] * n, phi[m:].reshape(-1, 2)).ravel()
    beta[m:] = np.where(circle[:, None], np.maximum(gn, 0.0)[:, None] * n, 0.0).ravel()
    return phi, beta


def _normals(y: np.ndarray, grad: np.ndarray, m: int) -> tuple[np.ndarray, np.ndarray]:
    """The discs' outward unit normals n_j = T_j/|T_j| (p, 2) and the normal gradients n_j·g_j (p,)."""
    T = y[m:].reshape(-1, 2)
    n = T / np.maximum(np.linalg.norm(T, axis=1), 1e-300)[:, None]
    return n, np.sum(n * grad[m:].reshape(-1, 2), axis=1)


def _face_basis(y: np.ndarray, grad: np.ndarray, m: int, g: np.ndarray) -> tuple[sp.csc_matrix, np.ndarray]:
    """The face's directions Z (n × k, sparse: the free variables, and the tangent of every disc on its circle)
    and the curvature the circle adds along its tangent, κ_j/g_j with κ_j = max(−n_j·g_j, 0) its multiplier."""
    free, circle = _sets(y, m, g)
    n, gn = _normals(y, grad, m)
    fi = np.flatnonzero(free)
    cj = np.flatnonzero(circle)
    k0 = fi.size
    rows = np.concatenate([fi, m + 2 * cj, m + 2 * cj + 1])
    cols = np.concatenate([np.arange(k0), k0 + np.arange(cj.size), k0 + np.arange(cj.size)])
    vals = np.concatenate([np.ones(k0), -n[cj, 1], n[cj, 0]])
    Z = sp.csc_matrix((vals, (rows, cols)), shape=(y.size, k0 + cj.size))
    curv = np.concatenate([np.zeros(k0), np.maximum(-gn[cj], 0.0) / np.maximum(g[cj], 1e-300)])
    return Z, curv


def _feasible_step(y: np.ndarray, d: np.ndarray, m: int, g: np.ndarray, cap: float = 1.0) -> float:
    """The largest t ∈ [0, cap] with y + t d feasible."""
    t = cap
    neg = d[:m] < 0
    if neg.any():
        t = min(t, float(np.min(y[:m][neg] / -d[:m][neg])))
    T, D = y[m:].reshape(-1, 2), d[m:].reshape(-1, 2)
    a = np.sum(D * D, axis=1)
    b = np.sum(T * D, axis=1)
    c = np.sum(T * T, axis=1) - g**2
    moving = a > 0
    if moving.any():  # |T + tD|² = g²: the positive root (c ≤ 0 inside)
        root = (-b[moving] + np.sqrt(np.maximum(b[moving] ** 2 - a[moving] * c[moving], 0.0))) / a[moving]
        t = min(t, float(np.min(np.maximum(root, 0.0))))
    return max(t, 0.0)


def _reduced_solve(Hr: np.ndarray, rhs: np.ndarray) -> np.ndarray:
    """Hr⁺ rhs for the face's Hessian Hr (symmetric, positive SEMI-definite: rows of the dual that depend on each
    other, a circle's tangent that H does not see). Cholesky where its pivots are clear of round-off; else the
    minimum-norm least-squares solution. A singular Hr can factor with pivots of round-off size (1e-18 of its
    largest: the sleeve test at nx = 40), whose step is 1e32 long and lands anywhere on the circles; whether it
    factors depended on the BLAS thread count."""
    k = rhs.size
    if k == 0:
        return rhs.copy()
    floor = 64 * k * np.finfo(float).eps * max(float(np.max(np.diag(Hr))), 1e-300)
    try:
        factor = la.cho_factor(Hr)
        if float(np.min(np.abs(np.diag(factor[0])))) ** 2 > floor:
            return la.cho_solve(factor, rhs)
    except la.LinAlgError:
        pass
    return la.lstsq(Hr, rhs, cond=floor / max(float(np.max(np.diag(Hr))), 1e-300))[0]


def _face_step(H: np.ndarray, c: np.ndarray, y: np.ndarray, grad: np.ndarray, m: int, g: np.ndarray, f,
               f0: float) -> np.ndarray:
    """The face step from y (module docstring): Newton on the free variables and along the circles."""
    Z, curv = _face_basis(y, grad, m, g)
    ZH = np.asarray(Z.T @ H)  # k × n: Z has at most two entries per column
    Hr = np.asarray(Z.T @ ZH.T).T + np.diag(curv)
    rhs = -(Z.T @ grad)
    x = _reduced_solve(Hr, rhs)
    free = _sets(y, m, g)[0]
    res = rhs - Hr @ x  # ≠ 0: f falls linearly along Z res, which Hr does not see: to the first bound along it
    if np.linalg.norm(res) > 1e-8 * np.linalg.norm(rhs):
        d = Z @ res
        reach = _feasible_step(y, np.where(free, d, 0.0), m, g, cap=np.inf)
        x = res * reach if np.isfinite(reach) else x
    d = Z @ x
    t_b, t = _feasible_step(y, np.where(free, d, 0.0), m, g), 1.0
    while t > t_b:
        zt = project(y + t * d, m, g)
        if f(zt) < f0:
            return zt
        t *= 0.5
    # to the first bound; the variables that reach it are put on it exactly (a Λ_i left at 1e-25 stays free and
    # blocks every later face step at t_b = 0: 500 steps without progress at μ = 3)
    z = project(y + t_b * d, m, g)
    lam = z[:m]
    lam[lam <= _EDGE * max(float(lam.max(initial=0.0)), 1e-300)] = 0.0
    if t_b > 0.0 and f(z) >= f0:
        # t_b bounds the free variables only: along a circle's tangent the projection back onto it bends the step,
        # and a step the free variables allow (t_b = 1) may raise f; shorter ones follow the arc. (The loop above
        # never ran at t_b = 1: on the vessel on saddles pushed by a tangential force, 20 × 24, all 84 discs on
        # their circles, every face step raised f and MPGP crawled by 2000 expansion steps.)
        t = 0.5 * t_b
        while t > 1e-12 * t_b:
            zt = project(y + t * d, m, g)
            if f(zt) < f0:
                return zt
            t *= 0.5
    return z


def _roundoff(f0: float) -> float:
    """The round-off of an energy near f0."""
    return 64 * np.finfo(float).eps * abs(f0)


def disc_qp(H: np.ndarray, c: np.ndarray, m: int, g: np.ndarray, y0: np.ndarray | None = None,
            tol: float = 1e-10, max_iterations: int = 1000, gamma: float = 1.0,
            history: list | None = None) -> tuple[np.ndarray, int, bool]:
    """Minimise ½yᵀHy + cᵀy over Λ ≥ 0 (the first m entries) and |T_j| ≤ g_j (the pairs after them) by MPGP
    with exact face steps (module docstring). Stops when the projected gradient max(|φ|, |β|) ≤ tol × max|c|.
    Returns y, iterations, converged."""
    H = np.asarray(H, float)
    c = np.asarray(c, float)
    g = np.asarray(g, float)
    n = c.size
    if H.shape != (n, n) or n != m + 2 * g.size:
        raise InputError("disc_qp", f"H {H.shape} and c ({n}) must fit m = {m} half-lines and {g.size} discs")
    if np.any(g < 0) or not np.all(np.isfinite(g)):
        raise InputError("disc_qp", "the disc radii g_j must be finite and ≥ 0")
    y = project(np.zeros(n) if y0 is None else np.asarray(y0, float), m, g)
    history = [] if history is None else history
    scale = max(float(np.abs(c).max(initial=0.0)), 1e-300)
    norm_h = max(float(np.abs(H).sum(axis=1).max(initial=0.0)), 1e-300)

    def f(z: np.ndarray) -> float:
        return 0.5 * float(z @ (H @ z)) + float(c @ z)

    for it in range(1, max_iterations + 1):
        grad = H @ y + c
        phi, beta = split_gradient(y, grad, m, g)
        nphi, nbeta = float(np.abs(phi).max(initial=0.0)), float(np.abs(beta).max(initial=0.0))
        if max(nphi, nbeta) <= tol * scale:
            return y, it - 1, True
        f0 = f(y)
        z, step = None, "face"
        if beta @ beta > gamma**2 * (phi @ phi):
            Hb = H @ beta
            # β in H's null space (βᵀHβ of round-off, even < 0): a long finite step the projection cuts, not inf
            alpha = float(beta @ grad) / max(float(beta @ Hb), np.finfo(float).eps * norm_h * float(beta @ beta))
            t = 1.0
            while t > 1e-12:
                trial = project(y - t * alpha * beta, m, g)
                if f(trial) < f0:
                    z, step = trial, "proportioning"
                    break
                t *= 0.5
        if z is None:  # a face step (also where −β no longer descends: round-off in the proportioning)
            z = _face_step(H, c, y, grad, m, g, f, f0)
            if f(z) > f0 + _roundoff(f0) or np.array_equal(z, y):  # (a bound reached exactly may keep f)
                # the expansion step P(y − ᾱ∇f), ᾱ = 1/‖H‖∞ ≤ 1/‖H‖₂: lowers f by ≥ ‖H‖₂/2 |z − y|² off KKT
                z, step = project(y - grad / norm_h, m, g), "expansion"
                if f(z) >= f0 - _roundoff(f0):  # the round-off floor
                    ok = max(nphi, nbeta) <= _FLOOR * tol * scale
                    history.append({"iteration": it, "step": "stalled", "phi": nphi, "beta": nbeta, "energy": f0})
                    return y, it, ok
        history.append({"iteration": it, "step": step, "phi": nphi, "beta": nbeta, "energy": f0})
        y = z
    grad = H @ y + c
    phi, beta = split_gradient(y, grad, m, g)
    return y, max_iterations, max(np.abs(phi).max(initial=0.0), np.abs(beta).max(initial=0.0)) <= tol * scale
