"""SciPy's SuperLU, always there, configured for symmetric matrices (MMD on AᵀA+A, symmetric mode,
diagonal pivoting): its defaults take minutes and tens of GB on these fourth-order systems.
``refactor`` keeps the ordering.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from ..errors import SolverError
from .protocol import Factorization


def available() -> bool:
    """SciPy is a dependency: always."""
    return True


class SuperLU(Factorization):
    """SuperLU with a symmetric ordering and diagonal pivots; SPD checked on the pivots."""

    backend = "superlu"
    OPTIONS = {"SymmetricMode": True}

    def _factor(self, As: sp.csr_matrix) -> None:
        self._lu = self._splu(sp.csc_matrix(As), "MMD_AT_PLUS_A")
        pc = self._lu.perm_c
        self._q = np.empty_like(pc)  # with B = A[q][:, q], SuperLU's natural order reproduces its ordering
        self._q[pc] = np.arange(pc.size)
        self._permuted = False

    def _splu(self, M: sp.csc_matrix, permc: str):
        try:
            lu = spla.splu(M, permc_spec=permc, diag_pivot_thresh=0.0, options=self.OPTIONS)
        except RuntimeError as exc:
            raise SolverError(f"SuperLU: {exc} (singular)") from None
        # SPD ⇔ the symmetric pivoting kept every pivot on the diagonal and all pivots are positive
        if not np.array_equal(lu.perm_r, lu.perm_c) or not np.all(lu.U.diagonal() > 0):
            raise SolverError("SuperLU: non-positive pivot, the matrix is not positive definite")
        return lu

    def _refactor(self, As: sp.csr_matrix) -> None:
        self._lu = self._splu(sp.csc_matrix(sp.csr_matrix(As)[self._q][:, self._q]), "NATURAL")
        self._permuted = True

    def _solve_factors(self, b: np.ndarray) -> np.ndarray:
        if not self._permuted:
            return self._lu.solve(b)
        x = np.empty_like(b)
        x[self._q] = self._lu.solve(b[self._q])
        return x

    def _factor_info(self) -> dict:
        return {"factor_nnz": int(self._lu.L.nnz + self._lu.U.nnz)}

    def free(self) -> None:
        pass  # the factors are Python objects
