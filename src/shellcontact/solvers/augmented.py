"""Exact contact solve with ONE factorisation of an augmented stiffness, for a known active set.

When an active set I0 is predicted before the stiffness is factorised (nested iteration: the
coarse-mesh solution prolongated; a sweep: the previous step), factorise instead of A

    K = A + B_I0ᵀ R B_I0,      R = diag(r_i),  r_i = κ / Ŝ_ii,

(the same sparsity as A when each row of B couples dofs of one vertex; Ŝ_ii a solve-free
estimate of S_ii = B_i A⁻¹ B_iᵀ, below) and solve the equality-constrained QP of MODEL.md §8 on a
working set I ⊆ I0 by the augmented Lagrangian: with U(μ) = K⁻¹(F + B_Iᵀμ), the gaps on I vanish
iff S^K μ = −c^K, S^K = B_I K⁻¹ B_Iᵀ, c^K = G_I + B_I K⁻¹F, and then A U = F + B_IᵀΛ with
Λ_I = μ − R B_I U exactly (identity K − B_IᵀRB_I = A). The eigenvalues of R S^K are
r s/(1 + r s) for the eigenvalues s of S_II: with r·s_min ≫ 1 they cluster at 1, so conjugate
gradients preconditioned by R converge in a few iterations, one solve with K each (measured: 4 CG
iterations, 7 solves with K, for 84 active constraints at 211k unknowns, κ ≈ 1e6; S_II itself has
a condition number of 3e6 there). No column of S is ever formed.

The working set is then checked exactly (Λ_I ≥ 0, gaps off I ≥ 0, every scaled KKT residual of
``kkt`` ≤ tol on the freshly solved U). If the prediction was wrong, the exact active-set method
(``solve_active_set``) takes over, warm-started from the primal–dual update of the working set,
with A⁻¹ applied through the SAME factorisation by the Woodbury identity (``AugmentedInverse``:
A⁻¹ = K⁻¹ + K⁻¹B_0ᵀ C⁻¹ B_0K⁻¹, C = R⁻¹ − B_0K⁻¹B_0ᵀ, |I0| blocked columns of K⁻¹B_0ᵀ, solves
refined against A itself; the columns S[:, I0] come from the same products without a solve) — no
second factorisation; the answer is always the exact KKT point,
only the cost differs. Optionally (``max_refactor`` > 0) up to that many primal–dual rounds with a
numeric refactorisation of K for the updated set come first (``Factorization.refactor``).

Round-off: Λ = μ − R B_I U amplifies errors of B_I U by r; κ trades CG iterations
(fewer for larger κ) against this (measured at 211k unknowns: κ = 1e2 / 1e4 / 1e6 → 37 / 11 / 4
CG iterations, every scaled KKT residual ≤ 1e-15 in all three).

The solve-free estimate: by Cauchy–Schwarz S_ii ≥ |b_i|⁴ / (b_iᵀ A b_i); on the sphere panel the
true S_ii is 3e3–4e5 times this bound, hence the default r_i = 30 · (b_iᵀ A b_i) / |b_i|⁴,
i.e. κ_i = r_i S_ii ≈ 1e5–1e7.
"""

from __future__ import annotations

import time
from collections.abc import Callable

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp

from ..errors import InputError, SolverError
from ..linalg import Factorization
from .active_set import _as_mask, _check_common, solve_active_set
from .kkt import TINY, evaluate
from .qp import ContactQP, ContactSolution, History, check_feasibility

DEFAULT_STRENGTH = 30.0


def augmentation(qp: ContactQP, active: np.ndarray,
                 strength: float = DEFAULT_STRENGTH) -> tuple[sp.csr_matrix, np.ndarray]:
    """K = A + B_Iᵀ R B_I for the predicted active set ``active`` (mask or indices) and the
    penalty vector r (length m, zero off the set): r_i = strength · (b_iᵀ A b_i) / |b_i|⁴."""
    if qp.k:
        raise InputError("solver.method", "the augmented solve does not support force control")
    if not (np.isfinite(strength) and strength > 0):
        raise InputError("solver.strength", f"must be a positive number, got {strength!r}")
    mask = _as_mask(active, qp.m)
    idx = np.flatnonzero(mask)
    r = np.zeros(qp.m)
    if idx.size == 0:
        return sp.csr_matrix(qp.A), r
    BI = qp.B[idx].tocsr()
    bAb = np.asarray(BI.multiply(BI @ qp.A).sum(axis=1)).ravel()
    bb = np.asarray(BI.multiply(BI).sum(axis=1)).ravel()
    ok = (bb > 0) & (bAb > 0)
    r[idx[ok]] = strength * bAb[ok] / bb[ok] ** 2
    K = (qp.A + BI.T @ sp.diags(r[idx]) @ BI).tocsr()
    return K, r


def _al_solve(fac: Factorization, qp: ContactQP, idx: np.ndarray, r: np.ndarray, UF: np.ndarray,
              mu0: np.ndarray, gtol: float, maxit: int) -> tuple[np.ndarray, np.ndarray, int, int]:
    """PCG on S^K μ = −c^K (module docstring) for the set idx ⊆ supp(r); returns U, Λ_I, CG its, solves."""
    BI = qp.B[idx]
    BIT = BI.T.tocsc()
    rI = r[idx]
    mu = mu0.copy()
    U = fac.solve(qp.F + BIT @ mu) if np.any(mu) else UF.copy()
    solves = 1 if np.any(mu) else 0
    h = qp.G[idx] + BI @ U
    res = -h
    z = rI * res
    p = z.copy()
    rz = float(res @ z)
    its = 0
    while float(np.abs(h).max(initial=0.0)) > gtol and its < maxit:
        W = fac.solve(BIT @ p)
        solves += 1
        q = BI @ W
        pq = float(p @ q)
        if not pq > 0:
            break
        a = rz / pq
        mu += a * p
        U += a * W
        h += a * q
        res -= a * q
        z = rI * res
        rz_new = float(res @ z)
        p = z + (rz_new / rz) * p
        rz = rz_new
        its += 1
    U = fac.solve(qp.F + BIT @ mu)  # fresh U: no drift from the recurrences
    solves += 1
    lam = mu - rI * (BI @ U)
    return U, lam, its, solves


def solve_augmented(
    qp: ContactQP,
    active: np.ndarray,
    r: np.ndarray,
    factorization: Factorization,
    tol: float = 1e-10,
    max_iterations: int = 100,
    max_refactor: int = 0,
    cg_iterations: int = 200,
    growth: float = 0.9,
    callback: Callable[[dict], None] | None = None,
) -> ContactSolution:
    """Exact contact solve with ``factorization`` = factorize(K), (K, r) = augmentation(qp, active)
    (module docstring). ``factorization`` is refactorised in place when the predicted set is wrong."""
    _check_common(tol, max_iterations)
    if qp.k:
        raise InputError("solver.method", "the augmented solve does not support force control")
    t0 = time.perf_counter()
    timings = {"feasibility": 0.0, "factorization": 0.0, "solve": 0.0, "schur": 0.0, "dense": 0.0}
    t = time.perf_counter()
    live = check_feasibility(qp)
    timings["feasibility"] = time.perf_counter() - t
    fac = factorization
    r = np.asarray(r, dtype=float).copy()
    I = _as_mask(active, qp.m) & live & (r > 0)
    history: list = History(callback)
    n_solves = 0
    n_refactor = 0
    lam = np.zeros(qp.m)
    t = time.perf_counter()
    UF = fac.solve(qp.F)
    n_solves += 1
    lscale = max(float(np.abs(qp.G).max(initial=0.0)), float(np.abs(qp.B @ UF).max(initial=0.0)), TINY)
    gtol = 1e-3 * tol * lscale
    it = 0
    while True:
        it += 1
        idx = np.flatnonzero(I)
        mu0 = lam[idx] + r[idx] * qp.G[idx]  # μ = Λ − R B U with B_I U = −G_I
        U, lamI, its, solves = _al_solve(fac, qp, idx, r, UF, mu0, gtol, cg_iterations)
        n_solves += solves
        lam = np.zeros(qp.m)
        lam[idx] = lamI
        g = qp.gap(U)
        lam_scale = max(float(np.abs(lam).max(initial=0.0)), TINY)
        v_lam = max(0.0, -float(lamI.min(initial=0.0))) / lam_scale
        v_gap = max(0.0, -float(g[live & ~I].min(initial=0.0))) / lscale
        history.append({"iteration": it, "active": int(idx.size), "cg_iterations": its, "solves": solves,
                        "negative_force": v_lam, "penetration": v_gap})
        if v_lam <= tol and v_gap <= tol:
            lam = np.maximum(lam, 0.0)
            rep = evaluate(qp, U, lam, None, fac)  # fac (of K) only enters the O(‖r‖²) gap term
            if rep.converged(tol):
                timings["solve"] = time.perf_counter() - t
                timings["total"] = time.perf_counter() - t0
                timings["n_solves"] = float(n_solves + 1)
                timings["schur_columns"] = 0.0
                timings["n_refactorizations"] = float(n_refactor)
                return ContactSolution(
                    U=U, Lambda=lam, pressure=lam / qp.weights, active=lam > 0, delta=None, iterations=it,
                    residuals=rep.residuals, method="active-set", history=history, timings=timings,
                    energy=rep.energy, dual_value=rep.dual_value,
                    info={"gap": rep.gap, "scaled_residuals": rep.scaled, "fallback": None, "augmented": True,
                          "refactorizations": n_refactor})
            history[-1]["kkt_worst"] = rep.worst()
        if v_lam > tol:  # release the rows with negative force first (no additions in the same round)
            I_new = I & (lam > 0)
        else:  # then add the deepest penetrations (growth-limited, as in solve_active_set)
            v = live & ~I & (g < 0)
            if v.any():
                v &= g <= growth * g[v].min()
            I_new = I | v
        if n_refactor >= max_refactor or it >= max_iterations or np.array_equal(I_new, I):
            break
        # the prediction was wrong: primal-dual active-set update, numeric refactorisation of K
        K, r = augmentation(qp, I_new, _strength(qp, r, I))
        tf = time.perf_counter()
        fac.refactor(K)
        timings["factorization"] += time.perf_counter() - tf
        n_refactor += 1
        UF = fac.solve(qp.F)
        n_solves += 1
        I = I_new & (r > 0)
    # the exact active-set method, A⁻¹ by Woodbury through the same factorisation of K
    tf = time.perf_counter()
    rows0 = np.flatnonzero(r > 0)
    inv = AugmentedInverse(qp.A, fac, qp.B[rows0], r[rows0], rows=rows0)
    timings["schur"] += time.perf_counter() - tf
    v = live & ~I & (g < 0)
    if v.any():
        v &= g <= growth * g[v].min()
    start = (I & (lam > 0)) | v
    cs = solve_active_set(qp, tol=tol, max_iterations=max_iterations, initial_active=start, factorization=inv,
                          growth=growth)
    cs.info["fallback_from"] = "augmented"
    cs.info["augmented_history"] = history
    cs.info["woodbury_columns"] = inv.rank
    for key, val in timings.items():
        cs.timings[key] = cs.timings.get(key, 0.0) + val
    cs.timings["n_solves"] += n_solves + inv.rank
    cs.timings["total"] = time.perf_counter() - t0
    return cs


class AugmentedInverse:
    """A⁻¹ through a factorisation of K = A + B_0ᵀ diag(r) B_0 (Woodbury), behaving like a
    ``Factorization`` of A for the solvers: ``raw_solve`` (no refinement: Schur columns) and
    ``solve`` (iterative refinement against A, LAPACK's stopping rule as in ``linalg``)."""

    def __init__(self, A, fac: Factorization, B0: sp.spmatrix, r0: np.ndarray, refine_steps: int = 5,
                 rows: np.ndarray | None = None) -> None:
        self.rows = np.asarray(rows, dtype=np.int64) if rows is not None else None
        self.r0 = np.asarray(r0, dtype=float)
        self.A = sp.csr_matrix(A)
        self.fac = fac
        self.backend = fac.backend
        self.B0 = sp.csr_matrix(B0)
        self.rank = self.B0.shape[0]
        self.refine_steps = refine_steps
        n = self.A.shape[0]
        self.W = np.empty((n, self.rank))
        chunk = int(max(1, min(64, 3e7 // max(n, 1))))
        BT = self.B0.T.tocsc()
        for s0 in range(0, self.rank, chunk):
            self.W[:, s0 : s0 + chunk] = self._k_raw(BT[:, s0 : s0 + chunk].toarray())
        C = np.diag(1.0 / r0) - self.B0 @ self.W
        self.cf = sla.cho_factor(0.5 * (C + C.T), lower=True, check_finite=False) if self.rank else None
        self._norm = float(np.max(np.add.reduceat(np.abs(self.A.data), self.A.indptr[:-1]))) if self.A.nnz else 0.0

    def schur_columns(self, B: sp.spmatrix) -> tuple[np.ndarray, np.ndarray]:
        """S[:, rows] = B A⁻¹ B_0ᵀ for the rows of B_0 (``rows``, their indices in B) without a solve:
        A⁻¹B_0ᵀ = W C⁻¹ diag(1/r) (Woodbury with B_0 W = diag(1/r) − C)."""
        if self.rows is None or not self.rank:
            return np.zeros(0, dtype=np.int64), np.zeros((B.shape[0], 0))
        X = sla.cho_solve(self.cf, np.diag(1.0 / self.r0), check_finite=False)
        return self.rows, (B @ self.W) @ X

    def _k_raw(self, b: np.ndarray) -> np.ndarray:
        f = self.fac
        sc = f.scale if b.ndim == 1 else f.scale[:, None]
        return sc * f.impl.solve(sc * b)

    def raw_solve(self, b: np.ndarray) -> np.ndarray:
        x = self._k_raw(b)
        if self.rank:
            x = x + self.W @ sla.cho_solve(self.cf, self.B0 @ x, check_finite=False)
        return x

    def solve(self, b: np.ndarray) -> np.ndarray:
        b = np.asarray(b, dtype=float)
        bnorm = np.max(np.abs(b), axis=0)

        def berr(x, res):
            return float(np.max(np.max(np.abs(res), axis=0) / np.maximum(
                self._norm * np.max(np.abs(x), axis=0) + bnorm, 1e-300)))

        x = self.raw_solve(b)
        res = b - self.A @ x
        e = berr(x, res)
        for _ in range(self.refine_steps):
            if not (e > 8.0 * np.finfo(float).eps):
                break
            x_new = x + self.raw_solve(res)
            res_new = b - self.A @ x_new
            e_new = berr(x_new, res_new)
            if not e_new < e:
                break
            x, res, e = x_new, res_new, e_new
        if not np.isfinite(e) or e > 1e-8:
            raise SolverError("augmented: Woodbury solve with A does not converge (numerically singular?)",
                              residuals={"backward_error": e})
        return x


def _strength(qp: ContactQP, r: np.ndarray, I: np.ndarray) -> float:
    """The strength used for r on I (r_i = strength · bAb/|b|⁴), recovered for a refactorisation."""
    idx = np.flatnonzero(I & (r > 0))
    if idx.size == 0:
        return DEFAULT_STRENGTH
    i = idx[:1]
    _, r1 = augmentation(qp, i, 1.0)
    return float(r[i[0]] / r1[i[0]]) if r1[i[0]] > 0 else DEFAULT_STRENGTH


__all__ = ["DEFAULT_STRENGTH", "AugmentedInverse", "augmentation", "solve_augmented"]
