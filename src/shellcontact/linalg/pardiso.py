"""MKL PARDISO, through the ``pypardiso`` package's MKL binding, called directly with explicit phases
(11 analysis, 22 numeric, 33 solve): real SPD (mtype 2) on the upper triangle in CSR with zero-based
indices. With ``supports_schur``: the numeric phase returns the dense Schur
complement of marked rows (iparm[35] = 2), used for ``factorize(A, border=B)`` (``bordered``).
"""

from __future__ import annotations

import ctypes
import importlib.util

import numpy as np
import scipy.sparse as sp

from ..errors import SolverError
from .bordered import bordered_upper
from .protocol import Factorization
from .sparse import checked_upper

_MKL_PARDISO = None


def mkl_pardiso():
    """MKL's pardiso entry point, found once through pypardiso (its lookup spawns ldconfig: slow)."""
    global _MKL_PARDISO
    if _MKL_PARDISO is None:
        import pypardiso

        _MKL_PARDISO = pypardiso.PyPardisoSolver(mtype=2)._mkl_pardiso
    return _MKL_PARDISO


def available() -> bool:
    """Whether pypardiso is installed and MKL loads."""
    if importlib.util.find_spec("pypardiso") is None:
        return False
    try:
        mkl_pardiso()
    except Exception:  # noqa: BLE001 — any failure to load MKL means "not available"
        return False
    return True


class _Session:
    """One PARDISO instance: its handle ``pt``, ``iparm`` and the CSR arrays of the upper triangle it
    factorised (PARDISO keeps pointers to them)."""

    def __init__(self, U: sp.csr_matrix, schur_rows: int = 0) -> None:
        """``U``: upper triangle, sorted indices. ``schur_rows`` > 0: the numeric phase also computes
        the dense Schur complement of the last ``schur_rows`` rows (``factor`` returns it)."""
        self._mkl = mkl_pardiso()
        self.pt = np.zeros(64, dtype=np.int64)
        self.iparm = np.zeros(64, dtype=np.int32)
        self.n = U.shape[0]
        ip = self.iparm  # 0-based here; the MKL documentation counts from 1
        ip[0] = 1  # use the values below
        # ordering: minimum degree below 500k unknowns, METIS above. Measured on shell stiffnesses
        # (1 thread): 432k unknowns MD 2.3 + 5.4 s (analysis + numeric, fill 97M) vs METIS 4.1 + 4.4 s
        # (101M); 984k: MD 5.7 + 20.4 s (264M) vs METIS 9.8 + 16.3 s (251M): METIS wins at scale and
        # whenever the numeric phase is repeated (refactor).
        ip[1] = 0 if self.n < 500_000 else 2
        ip[7] = 0  # PARDISO's own refinement off: the Factorization refines against A
        ip[9] = 13  # pivot perturbation (unused for SPD)
        ip[17] = -1  # report nnz(L)
        ip[34] = 1  # zero-based indices
        self.perm: np.ndarray | None = None  # rows marked for the Schur complement
        if schur_rows:
            ip[35] = 2  # dense Schur complement of the rows marked in perm, and the factors of the whole M
            self.perm = np.zeros(self.n, dtype=np.int32)
            self.perm[self.n - schur_rows :] = 1
        self._set_arrays(U)

    def _set_arrays(self, U: sp.csr_matrix) -> None:
        self.data = np.ascontiguousarray(U.data, dtype=np.float64)
        self.ia = U.indptr.astype(np.int32, copy=False)
        self.ja = U.indices.astype(np.int32, copy=False)

    def factor(self) -> np.ndarray | None:
        """Phases 11 and 22; returns the Schur complement when rows are marked. Frees the instance and
        raises SolverError if a phase fails."""
        m = 0 if self.perm is None else int(self.perm.sum())
        T = np.zeros((m, m)) if m else None
        try:
            self.call(11)  # ordering and symbolic factorisation
            self.call(22, out=T)  # numeric factorisation
        except SolverError:
            self.free()  # release MKL's internal memory before giving up
            raise
        return T

    def call(self, phase: int, b: np.ndarray | None = None, out: np.ndarray | None = None) -> np.ndarray | None:
        """One PARDISO phase; without b, ``out`` receives what the phase writes (a Schur complement)."""
        c = ctypes
        nrhs = 1 if b is None or b.ndim == 1 else b.shape[1]
        if b is None:
            bb = np.zeros(self.n)
            x = out if out is not None else np.zeros(self.n)
        else:
            bb = np.asfortranarray(b, dtype=np.float64)
            x = np.zeros_like(bb)
        err = c.c_int32(0)
        i32 = c.POINTER(c.c_int32)
        f64 = c.POINTER(c.c_double)
        self._mkl(
            self.pt.ctypes.data_as(c.POINTER(c.c_int64)),
            c.byref(c.c_int32(1)),
            c.byref(c.c_int32(1)),
            c.byref(c.c_int32(2)),
            c.byref(c.c_int32(phase)),
            c.byref(c.c_int32(self.n)),
            self.data.ctypes.data_as(f64),
            self.ia.ctypes.data_as(i32),
            self.ja.ctypes.data_as(i32),
            (self.perm if self.perm is not None else np.zeros(1, dtype=np.int32)).ctypes.data_as(i32),
            c.byref(c.c_int32(nrhs)),
            self.iparm.ctypes.data_as(i32),
            c.byref(c.c_int32(0)),
            bb.ctypes.data_as(f64),
            x.ctypes.data_as(f64),
            c.byref(err),
        )
        if err.value != 0:
            reason = {-4: "zero or negative pivot: not positive definite", -2: "out of memory"}.get(err.value, "")
            raise SolverError(f"PARDISO phase {phase} failed with error {err.value} {reason}".strip())
        return None if b is None else np.ascontiguousarray(x)

    def refactor(self, U: sp.csr_matrix) -> None:
        """Phase 22 with new values; phase 11 first when the pattern changed."""
        if U.nnz != self.data.size or not np.array_equal(U.indptr, self.ia) or not np.array_equal(U.indices, self.ja):
            self.free()
            self._set_arrays(U)
            self.call(11)
        else:
            self.data = np.ascontiguousarray(U.data, dtype=np.float64)
        self.call(22)

    def info(self) -> dict:
        return {"factor_nnz": int(self.iparm[17]), "peak_kb_symbolic": int(self.iparm[14]),
                "kb_factor": int(self.iparm[15] + self.iparm[16])}

    def free(self) -> None:
        if np.any(self.pt):
            try:
                self.call(-1)
            finally:
                self.pt[:] = 0


class Pardiso(Factorization):
    """MKL PARDISO; with a border, the factors of the bordered M serve the solves with A."""

    backend = "pardiso"
    supports_schur = True
    upper_triangle = True

    def _factor(self, As: sp.csr_matrix) -> None:
        self._n = As.shape[0]
        self._session = _Session(checked_upper(As))
        self._session.factor()

    def _factor_bordered(self, As: sp.csr_matrix, Bs: sp.csr_matrix, rho: float) -> np.ndarray:
        self._n = As.shape[0]
        self._session = _Session(bordered_upper(As, Bs, rho), schur_rows=Bs.shape[0])
        return self._session.factor()

    def _solve_factors(self, b: np.ndarray) -> np.ndarray:
        s = self._session
        if s.n == self._n:
            return s.call(33, b)
        pad = np.zeros((s.n,) + b.shape[1:], order="F")  # bordered: y = 0 on the border rows
        pad[: self._n] = b
        return s.call(33, pad)[: self._n]

    def _refactor(self, As: sp.csr_matrix) -> None:
        if self._session.n == self._n:
            self._session.refactor(checked_upper(As))
            return
        self._session.free()  # bordered: factorise A alone from now on
        self._session = _Session(checked_upper(As))
        self._session.factor()

    def _factor_info(self) -> dict:
        extra = {} if self._session.n == self._n else {"schur_rows": self._session.n - self._n}
        return {**self._session.info(), **extra}

    def free(self) -> None:
        self._session.free()
