"""Substructuring: the whole Schur complement S = B A⁻¹ Bᵀ from the factorisation itself.

The contact rows B touch only the dofs of the contact-zone vertices, so S needs A⁻¹ only there.
Rather than m solves with the full factors (one per column of S), the multipliers' space is
glued to A as m extra unknowns y = B U with a stiffness ρ (MODEL.md §8 QP, equilibrated):

    M = [[A + ρ BᵀB, −ρ Bᵀ],          Schur complement of M on y:
         [−ρ B,        ρ I ]]           T = ρI − ρ²B(A + ρBᵀB)⁻¹Bᵀ = (ρ⁻¹I + S)⁻¹   (Woodbury)

M is symmetric positive definite, and PARDISO computes its dense Schur complement T on the rows
y during the numeric factorisation (iparm[35] = 2, ``perm`` marking y: the y rows are ordered
last), together with the full factors of M. Then

* S[:, J] = T⁻¹[:, J] − ρ⁻¹ I[:, J]: one dense Cholesky of T (m³/3 flops) and 2m² flops per column
  instead of one sparse solve per column;
* A⁻¹b = the first n entries of M⁻¹[b; 0] (eliminating y gives A U = b), so the same factors serve
  every solve with A: one factorisation for both (``Factorization.solve`` refines against A).

ρ = 1 / mean(‖B_i‖²) in the equilibrated variables; the recovered S agreed with blocked solves to
≈1e-10 relative for ρ·S_ii from 1e-4 to 1e4 on the demo case (the round-off of those solves).

``factorize_contact(A, B)`` returns a ``linalg.Factorization`` (PARDISO) with the extra attribute
``schur`` (a ``ContactSchur``), or a plain ``factorize(A)`` when the backend is not PARDISO or m is
too large for a dense m × m block; ``schur.Workspace`` uses ``schur`` when its rows equal the QP's B.
"""

from __future__ import annotations

import ctypes
import os
import time
from dataclasses import dataclass, field

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp

from ..errors import InputError, SolverError
from ..linalg import Factorization, _check_backend, _equilibrate, _mkl_pardiso, _Pardiso, default_backend, factorize

#: environment variable: "0" turns the substructured factorisation off in ``analysis.solve``
ENV_VAR = "SHELLCONTACT_SUBSTRUCTURE"

#: fewest unknowns for which ``factorize_contact`` builds the Schur complement by default: measured
#: on the demo case (1 thread), factorisation + active-set solve through ``analysis.solve``, plain vs
#: substructured with screening (best of 2): 26k unknowns 0.38 vs 0.40 s, 52k 1.05 vs 0.80 s,
#: 87k 2.25 vs 1.71 s, 130k 4.67 vs 2.88 s
MIN_UNKNOWNS = 40_000

#: largest number of contact rows for the dense Schur complement (T and its Cholesky: 2 m² doubles);
#: measured at 1.12M dofs with m = 9409: 174 s and 11.5 GB end to end, against 379 s without it
MAX_ROWS = 12000


def substructure_enabled() -> bool:
    """Whether ``analysis.solve`` factorises with the contact Schur complement (SHELLCONTACT_SUBSTRUCTURE != 0)."""
    return os.environ.get(ENV_VAR, "1").strip().lower() not in ("0", "false", "no", "off")


@dataclass
class ContactSchur:
    """The dense Cholesky factor of T = (ρ⁻¹I + S)⁻¹ for the rows ``B`` (unscaled, as given)."""

    B: sp.csr_matrix
    rho: float
    chol: tuple
    impl: _PardisoSchur = field(repr=False)
    seconds: float = 0.0
    #: (rows R after the m Schur rows, the block S[: m + |R|, m : m + |R|] of the QP with rows [B; R])
    #: as a ``schur.Workspace`` solved for it: reused when the next QP's rows extend [B; R]
    extra: tuple[sp.csr_matrix, np.ndarray] | None = field(default=None, repr=False)

    @property
    def valid(self) -> bool:
        """False once the factorisation was refactorised with another matrix (T is then stale)."""
        return self.impl.inner is None

    @property
    def m(self) -> int:
        return self.B.shape[0]

    def matches(self, B: sp.spmatrix) -> bool:
        """Whether ``B`` is the matrix this Schur complement was built for (same entries)."""
        return same_rows(B, self.B)

    def columns(self, cols: np.ndarray) -> np.ndarray:
        """S[:, cols] = T⁻¹[:, cols] − ρ⁻¹ I[:, cols]  (m × len(cols))."""
        cols = np.asarray(cols, dtype=np.int64)
        E = np.zeros((self.m, cols.size))
        E[cols, np.arange(cols.size)] = 1.0
        X = sla.cho_solve(self.chol, E, check_finite=False)
        X[cols, np.arange(cols.size)] -= 1.0 / self.rho
        return X


def _bordered_upper(As: sp.csr_matrix, Bs: sp.csr_matrix, rho: float) -> sp.csr_matrix:
    """The upper triangle of M = [[A + ρBᵀB, −ρBᵀ], [−ρB, ρI]] (``As``: the upper triangle of the
    equilibrated A with sorted indices, as ``linalg._equilibrate(A, upper=True)`` returns it; its data
    receive ρBᵀB in place) in CSR with sorted indices.

    B's rows touch a few dofs each (one contact point), so ρBᵀB lies inside A's pattern and is added
    at its positions, and only the rows of those dofs get border entries: the output is As's arrays
    copied in runs of rows with the border entries placed after them, one allocation in all (at 1.1M
    dofs 1.2 s instead of 3.8 s with a sparse sum and whole-matrix position arrays)."""
    n, m = As.shape[0], Bs.shape[0]
    K = sp.triu(rho * (Bs.T @ Bs), format="coo")
    if not _add_inside(As, K):
        As = As + K.tocsr()
        As.sort_indices()
    C = (-rho * Bs).T.tocsr()  # n × m, nonzero only in the rows of the contact dofs
    C.sort_indices()
    nk, nc = np.diff(As.indptr).astype(np.int64), np.diff(C.indptr).astype(np.int64)
    indptr = np.zeros(n + m + 1, dtype=np.int64)
    np.cumsum(nk + nc, out=indptr[1 : n + 1])
    indptr[n + 1 :] = indptr[n] + np.arange(1, m + 1)
    nnz = int(indptr[-1])
    data = np.empty(nnz)
    indices = np.empty(nnz, dtype=np.int64 if n + m > np.iinfo(np.int32).max else np.int32)
    # rows of A between two border rows keep A's layout shifted by the border entries before them
    brows = np.flatnonzero(nc)
    starts = np.concatenate([[0], brows + 1])
    stops = np.concatenate([brows + 1, [n]])
    for r0, r1 in zip(starts, stops):
        if r1 > r0:
            a0, a1, shift = As.indptr[r0], As.indptr[r1], indptr[r0] - As.indptr[r0]
            data[a0 + shift : a1 + shift] = As.data[a0:a1]
            indices[a0 + shift : a1 + shift] = As.indices[a0:a1]
    # border entries after the A part of their row
    crow = np.repeat(np.arange(n), nc)
    cpos = indptr[crow] + nk[crow] + (np.arange(C.nnz) - C.indptr[crow])
    data[cpos], indices[cpos] = C.data, C.indices + n
    data[indptr[n] :], indices[indptr[n] :] = rho, np.arange(n, n + m)
    return sp.csr_matrix((data, indices, indptr), shape=(n + m, n + m), copy=False)


def _add_inside(As: sp.csr_matrix, K: sp.coo_matrix) -> bool:
    """As.data += K at K's positions when every entry of K lies in As's pattern (As: CSR, sorted
    indices); False, with As unchanged, otherwise."""
    if K.nnz == 0:
        return True
    rows = np.unique(K.row)
    lens = np.diff(As.indptr)[rows].astype(np.int64)
    pos = np.repeat(As.indptr[rows].astype(np.int64) - np.concatenate([[0], np.cumsum(lens)[:-1]]), lens)
    pos += np.arange(pos.size)
    n = np.int64(As.shape[1])
    keys = np.repeat(rows.astype(np.int64), lens) * n + As.indices[pos]  # sorted: rows ascending, sorted columns
    if keys.size == 0:
        return False
    want = K.row.astype(np.int64) * n + K.col
    loc = np.minimum(np.searchsorted(keys, want), keys.size - 1)
    if not np.array_equal(keys[loc], want):
        return False
    np.add.at(As.data, pos[loc], K.data)
    return True


def same_rows(B1: sp.spmatrix, B2: sp.spmatrix) -> bool:
    """Whether two sparse matrices have the same shape and entries."""
    if B1.shape != B2.shape:
        return False
    d = sp.csr_matrix(B1) - sp.csr_matrix(B2)
    return d.nnz == 0 or float(np.abs(d.data).max()) == 0.0


class _PardisoSchur(_Pardiso):
    """PARDISO factors of M (above) with the dense Schur complement T of its last m rows.

    ``solve`` pads b with zeros for y and returns the first n entries (= A⁻¹b). ``refactor`` (a new
    A, e.g. the augmented solver's K) drops the Schur part and factorises A alone.
    """

    def __init__(self, As: sp.csr_matrix, Bs: sp.csr_matrix, rho: float) -> None:  # noqa: D107
        self._ctypes = ctypes
        self._mkl = _mkl_pardiso()
        self.pt = np.zeros(64, dtype=np.int64)
        self.iparm = np.zeros(64, dtype=np.int32)
        self.inner: _Pardiso | None = None
        n, m = As.shape[0], Bs.shape[0]
        self.n_a, self.m = n, m
        U = _bordered_upper(As, Bs, rho)
        ip = self.iparm
        ip[0] = 1
        ip[1] = 0 if n + m < 500_000 else 2  # as linalg._Pardiso
        ip[7] = 0
        ip[9] = 13
        ip[17] = -1
        ip[34] = 1
        ip[35] = 2  # dense Schur complement of the rows marked in perm, and the factors of the whole M
        self.n = n + m
        self.perm = np.zeros(self.n, dtype=np.int32)
        self.perm[n:] = 1
        self.data = np.ascontiguousarray(U.data, dtype=np.float64)
        self.ia = U.indptr.astype(np.int32)
        self.ja = U.indices.astype(np.int32)
        self.T = np.zeros((m, m))
        try:
            self._call(11)
            self._call(22, out=self.T)
        except SolverError:
            self.free()
            raise

    def solve(self, b: np.ndarray) -> np.ndarray:
        if self.inner is not None:
            return self.inner.solve(b)
        pad = np.zeros((self.n,) + b.shape[1:], order="F")
        pad[: self.n_a] = b
        return self._call(33, pad)[: self.n_a]

    def refactor(self, A: sp.csr_matrix) -> None:
        if self.inner is not None:
            self.inner.refactor(A)
            return
        self.free()
        self.T = None
        self.inner = _Pardiso(A)

    def info(self) -> dict:
        if self.inner is not None:
            return self.inner.info()
        return {**super().info(), "schur_rows": self.m}

    def free(self) -> None:
        if self.inner is not None:
            self.inner.free()
        super().free()


def factorize_contact(A: sp.spmatrix, B: sp.spmatrix, backend: str = "auto", max_rows: int = MAX_ROWS,
                      min_unknowns: int = MIN_UNKNOWNS) -> Factorization:
    """``linalg.factorize(A)``, with the dense Schur complement of the contact rows B when possible.

    With PARDISO, 0 < m ≤ ``max_rows`` and n ≥ ``min_unknowns`` the returned Factorization factorises M
    (module docstring) and carries ``schur`` (``ContactSchur``); otherwise it is ``factorize(A,
    backend)`` with ``schur = None``. Solves and refinement are those of ``Factorization``.
    """
    name = default_backend() if backend in ("auto", None, "") else _check_backend(str(backend).lower())
    A = sp.csr_matrix(A, dtype=float)
    B = sp.csr_matrix(B, dtype=float)
    if A.shape[0] != A.shape[1]:
        raise InputError("matrix", f"must be square, got {A.shape}")
    m, n = B.shape[0], A.shape[0]
    if B.shape[1] != n:
        raise InputError("B", f"must have {n} columns, got {B.shape[1]}")
    if name != "pardiso" or m == 0 or m > max_rows or n < min_unknowns:
        fac = factorize(A, name)
        fac.schur = None
        return fac
    scale, As = _equilibrate(A, upper=True)
    Bs = (B @ sp.diags(scale)).tocsr()
    b2 = np.asarray(Bs.multiply(Bs).sum(axis=1)).ravel()
    rho = 1.0 / float(np.mean(b2[b2 > 0])) if np.any(b2 > 0) else 1.0
    t0 = time.perf_counter()
    try:
        impl = _PardisoSchur(As, Bs, rho)
    except SolverError as exc:
        raise SolverError(
            f"pardiso factorisation failed: {exc} (are the supports enough to fix all rigid motions?)"
        ) from None
    fac = Factorization(A=A, backend=name, scale=scale, impl=impl, seconds=time.perf_counter() - t0)
    t1 = time.perf_counter()
    T = impl.T
    try:
        chol = sla.cho_factor(0.5 * (T + T.T), lower=True, overwrite_a=True, check_finite=False)
    except (np.linalg.LinAlgError, sla.LinAlgError):
        chol = None
    impl.T = None
    fac.schur = None if chol is None else ContactSchur(B=B, rho=rho, chol=chol, impl=impl,
                                                       seconds=time.perf_counter() - t1)
    fac.seconds = time.perf_counter() - t0
    return fac
