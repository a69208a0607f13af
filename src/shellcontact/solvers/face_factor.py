"""The Cholesky factor of the last face S_II, kept and updated for the next face instead of refactorised.

An exact method's working set I changes by a few rows per iteration once it is near the answer (the active set at
1.12M dofs: 5 193 rows, 22 faces), and every face costs a dense Cholesky factorisation, |I|³/3 flops. The factor
of the last face is kept with its rows in the order they joined (the rows held longest first: they are the ones
least likely to leave). For the next face I', with p the position of the first row that leaves:

* the leading p × p block L₁₁ (rows that all stay) is the Cholesky factor of its block of S unchanged (the cached
  columns of S are never rewritten once computed: ``schur.Workspace.ensure``);
* the trailing rows T (the rows after p that stay, then the rows that join, in that order) get
  L_T1 = S_T1 L₁₁⁻ᵀ (rows that stay: the old factor's rows already; rows that join: one triangular solve) and
  L_TT = chol(S_TT − L_T1 L_T1ᵀ).

This is a blocked Cholesky factorisation of S[I', I'] in that order whose first block was computed before: the
same arithmetic as a fresh factorisation of the permuted block, so no error accumulates from face to face (no
up/downdating rotations). It costs |T|³/3 + |T|²p + p²·|joining| flops instead of |I'|³/3; when that is not
cheaper, the face is factorised afresh (in the same order). Whatever the path, a pivot below ``face.PIVOT_RTOL``
times the largest diagonal entry hands the face to ``face.solve_face`` (pivoted, rows dropped), and the cache is
cleared.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import scipy.linalg as sla

from .face import PIVOT_RTOL

#: gather(rows, cols) → S[rows][:, cols] (dense, float64)
Gather = Callable[[np.ndarray, np.ndarray], np.ndarray]


class FaceFactor:
    """Cholesky factor L (lower) of S[order][:, order] for the last face (``order``: its row numbers in the order
    they joined)."""

    def __init__(self) -> None:
        self.order: np.ndarray | None = None
        self.L: np.ndarray | None = None
        self.updates = 0  # faces whose factor was updated from the last one (or reused unchanged)
        self.fresh = 0  # faces factorised afresh
        self.updated = False  # whether the last factor came from an update (else: afresh)

    def clear(self) -> None:
        self.order, self.L = None, None

    def factor(self, idx: np.ndarray, gather: Gather, diagonal: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
        """(order, L) with L Lᵀ = S[order][:, order] and ``order`` a permutation of the face ``idx`` (sorted row
        numbers, ``diagonal`` their S_ii); None when the face's Cholesky factor has a pivot at round-off (a
        dependent row: the caller solves the face with the pivoted factorisation)."""
        idx = np.asarray(idx, dtype=np.int64)
        if self.order is None or self.L is None or idx.size == 0:
            return self._fresh(idx, gather, diagonal)
        old, L = self.order, self.L
        stays = np.isin(old, idx, assume_unique=True)
        joining = np.setdiff1d(idx, old, assume_unique=True)
        leaving = np.flatnonzero(~stays)
        p = int(leaving[0]) if leaving.size else old.size
        tail_old = old[p:][stays[p:]]
        order = np.concatenate([old[:p], tail_old, joining])
        t = order.size - p
        n = order.size
        if t == 0:  # the same face, or only rows leaving from the end
            self.order, self.L = order, np.asfortranarray(L[:p, :p]) if p < old.size else L
            self.updates += 1
            self.updated = True
            return self._checked(diagonal)
        if t ** 3 / 3 + t * t * p + p * p * joining.size >= n ** 3 / 3:
            return self._fresh(order, gather, diagonal)
        Lp = np.empty((t, p))
        Lp[: tail_old.size] = L[p:, :p][stays[p:]]
        L11 = L[:p, :p]
        if joining.size:
            Lp[tail_old.size :] = sla.solve_triangular(L11, gather(old[:p], joining), lower=True,
                                                       check_finite=False).T
        tail = order[p:]
        M = gather(tail, tail)
        M -= Lp @ Lp.T
        try:
            L22 = sla.cholesky(0.5 * (M + M.T), lower=True, check_finite=False)
        except (np.linalg.LinAlgError, sla.LinAlgError):
            self.clear()
            return None
        new = np.zeros((n, n), order="F")
        new[:p, :p] = L11
        new[p:, :p] = Lp
        new[p:, p:] = L22
        self.order, self.L = order, new
        self.updates += 1
        self.updated = True
        return self._checked(diagonal)

    def _fresh(self, order: np.ndarray, gather: Gather, diagonal: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
        self.fresh += 1
        self.updated = False
        try:
            L = sla.cholesky(gather(order, order), lower=True, check_finite=False, overwrite_a=True)
        except (np.linalg.LinAlgError, sla.LinAlgError):
            self.clear()
            return None
        self.order, self.L = order, L
        return self._checked(diagonal)

    def _checked(self, diagonal: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
        """The factor, unless a pivot L_jj² is at or below ``PIVOT_RTOL`` max S_ii (``face``'s test);
        ``diagonal``: S_ii of the face's rows."""
        order, L = self.order, self.L
        assert order is not None and L is not None
        if order.size and not np.einsum("ii->i", L).min() ** 2 > PIVOT_RTOL * float(diagonal.max()):
            self.clear()
            return None
        return order, L
