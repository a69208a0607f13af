"""The dense algebra of one face of the contact QP: the exact methods' and the penalty's Newton system

    H x + D_I δ = r,   D_Iᵀ x = r2   (the second only under force control or with a floating shell's motions),

with H = S_II (+ a diagonal shift), S = B A⁻¹ Bᵀ, solved by Cholesky of H and of the k × k Schur complement
S_d = D_Iᵀ H⁻¹ D_I.

A face may be singular in two ways, and each is found by a rank check on its Cholesky pivots (pivoted
Cholesky, LAPACK ``dpstrf``, relative threshold ``PIVOT_RTOL``) and repaired as MPRGP implementations do, by
dropping what is dependent from the face (Dostál 2009, §5.8; the column that the pivoted factorisation finds
dependent on those before it):

* **dependent rows** (columns of H): two contact rows of the face that B ties together (the same point seen
  twice, rows a support holds fixed, a row that is a combination of others). The dropped rows carry no force
  (x = 0); their gaps follow from the rows kept when the face is consistent.
* **dependent columns of D on the face** (S_d singular): the face does not determine every δ, e.g. a floating
  shell's rotation seen by no row of the face, or a punch's travel and the rigid translation it pushes when
  only that punch's rows are on the face. The undetermined combinations keep δ = 0 along the dropped columns.
  Before, ``numpy.linalg.solve`` raised only on an exactly singular S_d: round-off let it return an arbitrary δ
  with no flag (a face of one row and two columns of D: δ = −0.40 mm where −1 mm was the answer).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla
from scipy.linalg import lapack

#: a pivot below this fraction of the largest diagonal entry is round-off: its row (column) depends on the others
#: (the test before was L_jj ≤ 1e-7 max L_jj, the same 1e-14 on the pivots L_jj²)
PIVOT_RTOL = 1e-14


@dataclass(frozen=True)
class FaceSolution:
    x: np.ndarray  # (|I|,) the face's forces, 0 on the dropped rows
    delta: np.ndarray | None  # (k,) or None without D, 0 along the dropped columns of D
    dropped_rows: np.ndarray  # positions in the face (not row numbers) of the rows found dependent
    dropped_columns: np.ndarray  # columns of D the face does not determine

    @property
    def singular(self) -> bool:
        return bool(self.dropped_rows.size or self.dropped_columns.size)


def independent_cholesky(H: np.ndarray, rtol: float = PIVOT_RTOL) -> tuple[tuple[np.ndarray, bool], np.ndarray]:
    """The Cholesky factor (``scipy.linalg.cho_factor`` form) of H restricted to a largest independent set of its
    rows, and those rows' positions (sorted). Plain Cholesky when every pivot exceeds ``rtol`` max diag(H); else
    the pivoted one (``dpstrf``) decides the rank and which rows depend on the others."""
    n = H.shape[0]
    top = float(np.max(np.diag(H))) if n else 0.0
    if n == 0 or not top > 0.0:
        return (np.zeros((0, 0)), True), np.zeros(0, dtype=np.int64)
    try:
        cf = sla.cho_factor(H, lower=True, check_finite=False)
        if np.diag(cf[0]).min() ** 2 > rtol * top:
            return cf, np.arange(n)
    except (np.linalg.LinAlgError, sla.LinAlgError):
        pass
    _, piv, rank, _ = lapack.dpstrf(H, tol=rtol * top, lower=1)
    keep = np.sort(piv[:rank] - 1).astype(np.int64)
    return sla.cho_factor(H[np.ix_(keep, keep)], lower=True, check_finite=False), keep


def solve_face(H: np.ndarray, rhs: np.ndarray, DI: np.ndarray | None = None,
               rhs2: np.ndarray | None = None) -> FaceSolution:
    """Solve the face system of the module docstring, dropping dependent rows and undetermined columns of D."""
    n = H.shape[0]
    cf, keep = independent_cholesky(H)
    dropped_rows = np.setdiff1d(np.arange(n), keep)
    x = np.zeros(n)
    if DI is None:
        if keep.size:
            x[keep] = sla.cho_solve(cf, rhs[keep], check_finite=False)
        return FaceSolution(x, None, dropped_rows, np.zeros(0, dtype=np.int64))
    k = DI.shape[1]
    delta = np.zeros(k)
    if dropped_rows.size and (whole := _bordered(H, DI, rhs, rhs2)) is not None:
        return FaceSolution(whole[:n], whole[n:], np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64))
    if keep.size == 0:
        return FaceSolution(x, delta, dropped_rows, np.arange(k))
    Dk = DI[keep]
    X = sla.cho_solve(cf, np.column_stack([rhs[keep], Dk]), check_finite=False)
    Sd = Dk.T @ X[:, 1:]
    Sd = 0.5 * (Sd + Sd.T)
    # a column of D that no kept row sees has S_d's row and column exactly 0: the rank check drops it
    cd, cols = independent_cholesky(Sd) if k else ((np.zeros((0, 0)), True), np.zeros(0, dtype=np.int64))
    if cols.size:
        delta[cols] = sla.cho_solve(cd, (Dk.T @ X[:, 0] - rhs2)[cols], check_finite=False)
    x[keep] = X[:, 0] - X[:, 1:] @ delta
    return FaceSolution(x, delta, dropped_rows, np.setdiff1d(np.arange(k), cols))


def _bordered(H: np.ndarray, DI: np.ndarray, rhs: np.ndarray, rhs2: np.ndarray) -> np.ndarray | None:
    """[x; δ] from the whole bordered system [[H, D], [Dᵀ, 0]] [x; δ] = [rhs; rhs2] when it is regular although H
    is not: rows a clamp holds (S_ii = 0) whose forces the prescribed force P alone determines (a plane pushed with
    1 N onto a clamped edge). None when the bordered matrix is singular too (then rows and columns are dropped).

    One LU factorisation both solves and tests regularity, by LAPACK's estimate of the reciprocal condition number
    from those factors (``gecon``, O(n²)): regular when it exceeds √``PIVOT_RTOL``. Before, an SVD tested and an LU
    solved (two O(n³) decompositions)."""
    n, k = DI.shape
    M = np.block([[H, DI], [DI.T, np.zeros((k, k))]])
    lu, piv, info = lapack.dgetrf(M)
    if info != 0:  # a pivot exactly 0
        return None
    rcond, info = lapack.dgecon(lu, float(np.abs(M).sum(axis=0).max()), norm="1")
    if info != 0 or not rcond > PIVOT_RTOL ** 0.5:
        return None
    return sla.lu_solve((lu, piv), np.concatenate([rhs, rhs2]), check_finite=False)
