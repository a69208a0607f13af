"""MUMPS over MPI (the parallel ``libdmumps`` of Debian's libmumps-dev, driven through ``mumps_c``, and
mpi4py, extra ``shellcontact[mpi]``): symmetric positive definite (SYM = 1) multifrontal Cholesky, the
host taking part (PAR = 1), the matrix given centralised on rank 0 (ICNTL(5) = 0, ICNTL(18) = 0: the
upper triangle in coordinates) and the right-hand sides and solutions dense on rank 0 (ICNTL(20) = 0,
ICNTL(21) = 0). Under ``mpiexec -n N`` MUMPS distributes the factors and the work over the N ranks
(``mpi``); in one process it runs on one rank. The symbolic analysis is kept for ``refactor`` when the
pattern is unchanged (JOB 2 alone).

With a border (``factorize(A, border=B)``, ``supports_schur``) MUMPS's own Schur option gives S = B A⁻¹ Bᵀ:
the matrix [[A, Bᵀ], [B, 0]] (equilibrated) with its last m variables declared the Schur variables
(ICNTL(19) = 1, SIZE_SCHUR, LISTVAR_SCHUR: their rows are not eliminated) is factorised once; the Schur
complement on them, 0 − B A⁻¹ Bᵀ = −S, comes back centralised on rank 0 (its lower triangle by rows in the
user's ``schur`` array), and the solves use the factors of A alone (ICNTL(26) = 0: MUMPS solves the
internal problem A x = b and sets the Schur variables to 0).

``configure(out_of_core=True)`` (``[solver] out_of_core``) writes the factors to disk (ICNTL(22) = 1) in
the directory of the environment variable MUMPS_OOC_TMPDIR on each rank (MUMPS's default: /tmp).
"""

from __future__ import annotations

import ctypes
import ctypes.util
import importlib.util

import numpy as np
import scipy.sparse as sp

from ..errors import SolverError
from .protocol import Factorization
from .sparse import checked_upper

#: blocks of right-hand sides with fewer nonzeros than this fraction are given to MUMPS as sparse
#: (ICNTL(20) = 1). Measured on the demo at refine 1 (68k unknowns, 64 columns of Bᵀ, 1 rank): dense
#: 2.4 s, sparse 1.4-1.6 s (PARDISO's dense 1.8 s)
SPARSE_RHS = 0.05
_P_INT = ctypes.POINTER(ctypes.c_int)
_P_REAL = ctypes.POINTER(ctypes.c_double)
#: ICNTL values every instance starts its analysis with (index from 1), by ``configure``
_SETTINGS: dict[int, int] = {22: 0}


def configure(out_of_core: bool) -> None:
    """Whether the next MUMPS factorisations keep their factors on disk (ICNTL(22))."""
    _SETTINGS[22] = 1 if out_of_core else 0


def available() -> bool:
    """Whether mpi4py and the parallel libdmumps are installed (without initialising MPI)."""
    return importlib.util.find_spec("mpi4py") is not None and ctypes.util.find_library("dmumps") is not None


def describe() -> str:
    """MUMPS's version and the number of MPI ranks (initialises MPI: for ``shellcontact info``)."""
    from . import mpi

    instance = mpi.HostInstance({})
    try:
        return f"MUMPS {instance.mumps.version} on {mpi.ranks()} MPI rank(s)"
    finally:
        instance.free()


def _count(value: int) -> int:
    """A MUMPS count that may be negative: then minus the count in millions (users' guide, INFOG)."""
    return value if value >= 0 else -value * 1_000_000


def _negated_symmetric(L: np.ndarray, rows: int = 512) -> np.ndarray:
    """−(the symmetric matrix whose lower triangle L holds), in L's memory, a block of rows at a time (no
    m × m temporary). MUMPS leaves work values above the diagonal: they are overwritten."""
    for r0 in range(0, L.shape[0], rows):
        r1 = min(L.shape[0], r0 + rows)
        L[r0:r1] = np.tril(L[r0:r1], r0) + np.triu(L[:, r0:r1].T, r0 + 1)  # reads only below the diagonal
    return np.negative(L, out=L)


class Mumps(Factorization):
    """MUMPS on the upper triangle of the equilibrated matrix, all ranks of MPI's world taking part."""

    backend = "mumps"
    supports_schur = True
    upper_triangle = True

    def _factor(self, As: sp.csr_matrix) -> None:
        from . import mpi

        self._n = As.shape[0]
        self._instance = mpi.HostInstance(dict(_SETTINGS))
        self._set_matrix(checked_upper(As))
        self._run(4)  # analysis and factorisation

    def _factor_schur(self, As: sp.csr_matrix, Bs: sp.csr_matrix) -> np.ndarray:
        """S = Bs As⁻¹ Bsᵀ by MUMPS's Schur option on [[As, Bsᵀ], [Bs, 0]] (module docstring)."""
        from . import mpi

        n, m = As.shape[0], Bs.shape[0]
        self._n = n
        self._instance = mpi.HostInstance({**_SETTINGS, 19: 1})
        U, C = checked_upper(As).tocoo(), Bs.tocoo()  # Bsᵀ's entries (dof j, border n + i) lie above the diagonal
        self._set_coo(n + m, np.concatenate([U.row, C.col]), np.concatenate([U.col, C.row + n]),
                      np.concatenate([U.data, C.data]))
        self._pattern = None  # a refactor drops the border (``Factorization.refactor``)
        s = self._instance.mumps.s
        self._schur_vars = np.arange(n + 1, n + m + 1, dtype=np.int32)
        lower = np.zeros((m, m))  # MUMPS fills the lower triangle (C order) of −S on rank 0
        s.size_schur, s.schur_lld = m, m
        s.listvar_schur = self._schur_vars.ctypes.data_as(_P_INT)
        s.schur = lower.ctypes.data_as(_P_REAL)
        try:
            self._run(4)
        finally:
            s.schur = None
        return _negated_symmetric(lower)

    def _set_matrix(self, U: sp.csr_matrix) -> None:
        C = U.tocoo()
        self._set_coo(U.shape[0], C.row, C.col, C.data)
        self._pattern = (U.indptr.copy(), U.indices.copy())

    def _set_coo(self, order: int, rows: np.ndarray, cols: np.ndarray, values: np.ndarray) -> None:
        """The upper triangle in coordinates (zero-based ``rows``, ``cols``) of a matrix of ``order``."""
        s = self._instance.mumps.s
        # MUMPS keeps pointers to these arrays: they live as long as the factorisation
        self._irn = (rows + 1).astype(np.int32)
        self._jcn = (cols + 1).astype(np.int32)
        self._a = np.ascontiguousarray(values, dtype=np.float64)
        s.n, s.nnz = order, self._a.size
        s.irn = self._irn.ctypes.data_as(_P_INT)
        s.jcn = self._jcn.ctypes.data_as(_P_INT)
        s.a = self._a.ctypes.data_as(_P_REAL)

    def _run(self, job: int) -> None:
        if self._instance.job(job) < 0:
            raise SolverError(f"mumps JOB {job}: {self._instance.mumps.error()}")
        negative = int(self._instance.mumps.s.infog[11])
        if job != 3 and negative:  # SYM = 1 factorises L D Lᵀ without pivoting: INFOG(12) counts D's negative pivots
            raise SolverError(f"mumps: {negative} negative pivot(s) (INFOG(12)): not positive definite")

    def _solve_factors(self, b: np.ndarray) -> np.ndarray:
        s = self._instance.mumps.s
        if s.n == self._n:
            x = np.array(b, dtype=np.float64, order="F", copy=True)  # MUMPS overwrites the right-hand sides
        else:  # with the Schur variables: zero there (MUMPS solves A x = b alone and returns 0 there)
            x = np.zeros((s.n,) + np.shape(b)[1:], order="F")
            x[: self._n] = b
        s.nrhs = 1 if x.ndim == 1 else x.shape[1]
        s.lrhs = x.shape[0]
        s.rhs = x.ctypes.data_as(_P_REAL)
        sparse = x.ndim == 2 and np.count_nonzero(x) < SPARSE_RHS * x.size
        if sparse:  # columns of Bᵀ: MUMPS skips the forward elimination's zero blocks
            R = sp.csc_matrix(x)
            R.sort_indices()
            values, rows, starts = R.data, (R.indices + 1).astype(np.int32), (R.indptr + 1).astype(np.int32)
            s.nz_rhs = values.size
            s.rhs_sparse = values.ctypes.data_as(_P_REAL)
            s.irhs_sparse, s.irhs_ptr = rows.ctypes.data_as(_P_INT), starts.ctypes.data_as(_P_INT)
            self._instance.mumps.icntl(20, 1)
        try:
            self._run(3)
        finally:
            self._instance.mumps.icntl(20, 0)
            s.rhs = s.rhs_sparse = s.irhs_sparse = s.irhs_ptr = None
        return x[: self._n]

    def _refactor(self, As: sp.csr_matrix) -> None:
        if self._pattern is None:  # bordered: factorise A alone from now on
            self._instance.free()
            self._factor(As)
            return
        U = checked_upper(As)
        indptr, indices = self._pattern
        if np.array_equal(U.indptr, indptr) and np.array_equal(U.indices, indices):
            self._a[:] = U.tocoo().data
            self._run(2)  # numeric phase on the kept analysis
        else:
            self._set_matrix(U)
            self._run(4)

    def _factor_info(self) -> dict:
        inst = self._instance
        g = inst.mumps.s.infog
        return {"factor_nnz": _count(int(g[28])),  # INFOG(29): entries in the factors, all ranks
                "ranks": len(inst.factor_megabytes),
                "factor_megabytes_per_rank": list(inst.factor_megabytes),  # INFO(16) of each rank
                "out_of_core": bool(inst.mumps.s.icntl[21]),
                **({"schur_rows": inst.mumps.s.n - self._n} if inst.mumps.s.n != self._n else {}),
                "ordering": int(g[6])}  # INFOG(7): the ordering MUMPS chose

    def free(self) -> None:
        if hasattr(self, "_instance"):
            self._instance.free()
