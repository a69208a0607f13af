"""CHOLMOD supernodal Cholesky (``scikit-sparse``, optional extra ``shellcontact[cholmod]``; needs the
SuiteSparse headers, e.g. Debian's libsuitesparse-dev, and scikit-sparse < 0.5 with SuiteSparse 5; a
fast BLAS such as libopenblas-dev matters). The symbolic analysis is kept for ``refactor``.
"""

from __future__ import annotations

import importlib.util

import numpy as np
import scipy.sparse as sp

from ..errors import SolverError
from .protocol import Factorization


def available() -> bool:
    """Whether scikit-sparse is installed and its CHOLMOD binding loads."""
    if importlib.util.find_spec("sksparse") is None:
        return False
    try:
        import sksparse.cholmod  # noqa: F401
    except Exception:  # noqa: BLE001 — a broken build (missing libcholmod) means "not available"
        return False
    return True


class Cholmod(Factorization):
    """CHOLMOD on the whole equilibrated matrix (CSC, sorted indices)."""

    backend = "cholmod"

    def _factor(self, As: sp.csr_matrix) -> None:
        from sksparse.cholmod import CholmodError, cholesky

        self._error, self._cholesky = CholmodError, cholesky
        M = sp.csc_matrix(As)
        M.sort_indices()
        self._pattern = (M.indptr.copy(), M.indices.copy())
        try:
            self._chol = cholesky(M)
        except CholmodError as exc:
            raise SolverError(f"CHOLMOD: {exc} (not positive definite)") from None

    def _refactor(self, As: sp.csr_matrix) -> None:
        M = sp.csc_matrix(As)
        M.sort_indices()
        same = np.array_equal(M.indptr, self._pattern[0]) and np.array_equal(M.indices, self._pattern[1])
        try:
            if same:  # the symbolic analysis (ordering, supernodes) is reused
                self._chol.cholesky_inplace(M)
            else:
                self._chol = self._cholesky(M)
                self._pattern = (M.indptr.copy(), M.indices.copy())
        except self._error as exc:
            raise SolverError(f"CHOLMOD: {exc} (not positive definite)") from None

    def _solve_factors(self, b: np.ndarray) -> np.ndarray:
        return self._chol(b)

    def _factor_info(self) -> dict:
        return {"factor_nnz": int(self._chol.L().nnz)}

    def free(self) -> None:
        pass  # the factor is a Python object
