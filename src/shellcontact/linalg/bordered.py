"""The whole Schur complement S = B A⁻¹ Bᵀ of given rows B from one factorisation of A bordered by B.

When B's rows touch only a few dofs each (contact rows), S needs A⁻¹ only there. Rather than m
solves with the full factors (one per column of S), the rows' space is glued to A as m extra
unknowns y = B U with a stiffness ρ (in the equilibrated variables):

    M = [[A + ρ BᵀB, −ρ Bᵀ],          Schur complement of M on y:
         [−ρ B,        ρ I ]]           T = ρI − ρ²B(A + ρBᵀB)⁻¹Bᵀ = (ρ⁻¹I + S)⁻¹   (Woodbury)

M is symmetric positive definite. A backend that computes the dense Schur complement T of M's last
m rows during its numeric factorisation (``Factorization.supports_schur``: PARDISO) factorises M
once for ``factorize(A, border=B)``. Then

* S[:, J] = T⁻¹[:, J] − ρ⁻¹ I[:, J]: one dense Cholesky of T (m³/3 flops) and 2m² flops per column
  instead of one sparse solve per column (``SchurComplement.columns``);
* A⁻¹b = the first n entries of M⁻¹[b; 0] (eliminating y gives A U = b), so the same factors serve
  every solve with A.

ρ = 1 / mean(‖B_i‖²) in the equilibrated variables (``border_weight``); the recovered S agreed with
blocked solves to ≈1e-10 relative for ρ·S_ii from 1e-4 to 1e4 on the demo case (the round-off of
those solves).

A backend whose Schur option leaves the border rows uneliminated (MUMPS, ICNTL(19)) needs no weight:
the Schur complement of [[A, Bᵀ], [B, 0]] on its last m rows is −S itself, and the factors of A alone
serve the solves (``DenseSchur``, ``Factorization._factor_schur``).
"""

from __future__ import annotations

import threading
from dataclasses import dataclass, field

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sp

from .sparse import same_entries

#: most rows for which ``SchurComplement`` keeps the columns of S it solved for (m² doubles: 128 MB at 4000)
CACHED_ROWS = 4000


@dataclass
class SchurRows:
    """The rows ``B`` a dense S = B A⁻¹ Bᵀ is held for: what ``solvers.schur.Workspace`` checks before
    it reads columns of S (``SchurComplement`` here, ``curves.ProjectedSchur``)."""

    B: sp.csr_matrix

    @property
    def m(self) -> int:
        return self.B.shape[0]

    def matches(self, B: sp.spmatrix) -> bool:
        """Whether ``B`` is the matrix this Schur complement was built for (same entries)."""
        return same_entries(B, self.B)


@dataclass
class SchurComplement(SchurRows):
    """S = B A⁻¹ Bᵀ for the rows ``B`` (unscaled, as given) through the dense Cholesky factor of
    T = (ρ⁻¹I + S)⁻¹."""

    rho: float
    chol: tuple
    seconds: float = 0.0
    #: (rows R after the m rows of B, the block S[: m + |R|, m : m + |R|] of the rows [B; R]), stored by
    #: the caller that solved for it (``solvers.schur.Workspace``) so that a later caller whose rows
    #: extend [B; R] reuses it
    extra: tuple[sp.csr_matrix, np.ndarray] | None = field(default=None, repr=False)
    #: whether ``solvers.schur.Workspace.finish_exact`` makes one face refinement on the true gaps even when
    #: its KKT check already passes (the dense S differs from the solves' by round-off); a warm-started
    #: curve (``curves.solve_family``) turns it off: its points stop at the KKT check, two solves fewer each
    refine_converged: bool = True

    @classmethod
    def from_bordered(cls, B: sp.csr_matrix, rho: float, T: np.ndarray) -> SchurComplement | None:
        """From the Schur complement T of M on the border rows; None when T is not numerically
        positive definite (then the caller solves for the columns of S instead)."""
        try:  # one triangle of T (symmetric to round-off) is read: the transpose view needs no copy
            chol = sla.cho_factor(T.T, lower=True, overwrite_a=True, check_finite=False)
        except (np.linalg.LinAlgError, sla.LinAlgError):
            return None
        return cls(B=B, rho=rho, chol=chol)

    #: S's columns solved for so far ("S", m × m, allocated on first use) and which they are ("known"): every
    #: QP on these rows reads them (the points of a curve, ``curves.solve_family``, each need the same
    #: columns); a shallow copy (``batched.SharedFactorization``) shares them
    _cache: dict = field(default_factory=dict, init=False, repr=False)
    _lock: threading.Lock = field(default_factory=threading.Lock, init=False, repr=False)

    def full(self) -> np.ndarray:
        """The whole S (m × m) = T⁻¹ − ρ⁻¹I."""
        S = sla.cho_solve(self.chol, np.eye(self.m), check_finite=False)
        S[np.diag_indices_from(S)] -= 1.0 / self.rho
        return S

    def columns(self, cols: np.ndarray) -> np.ndarray:
        """S[:, cols] = T⁻¹[:, cols] − ρ⁻¹ I[:, cols]  (m × len(cols)), each column solved for once."""
        cols = np.asarray(cols, dtype=np.int64)
        if self.m > CACHED_ROWS:
            return self._solve_columns(cols)
        with self._lock:
            if not self._cache:
                self._cache.update(S=np.empty((self.m, self.m)), known=np.zeros(self.m, dtype=bool))
            S, known = self._cache["S"], self._cache["known"]
            new = np.unique(cols[~known[cols]])
            if new.size:
                S[:, new] = self._solve_columns(new)
                known[new] = True
            return S[:, cols]

    def _solve_columns(self, cols: np.ndarray) -> np.ndarray:
        E = np.zeros((self.m, cols.size))
        E[cols, np.arange(cols.size)] = 1.0
        X = sla.cho_solve(self.chol, E, check_finite=False)
        X[cols, np.arange(cols.size)] -= 1.0 / self.rho
        return X


@dataclass
class DenseSchur(SchurRows):
    """S = B A⁻¹ Bᵀ for the rows ``B`` held whole (a backend's Schur option computed it directly), with the
    fields ``solvers.schur.Workspace`` reads of a ``SchurComplement``."""

    S: np.ndarray
    seconds: float = 0.0
    extra: tuple[sp.csr_matrix, np.ndarray] | None = field(default=None, repr=False)
    refine_converged: bool = True

    def full(self) -> np.ndarray:
        return self.S

    def columns(self, cols: np.ndarray) -> np.ndarray:
        return self.S[:, np.asarray(cols, dtype=np.int64)]


def border_weight(Bs: sp.csr_matrix, flexibility: float | None = None) -> float:
    """ρ = 1 / ``flexibility`` (an estimate of the typical S_ii, which y = B U shares with the unscaled
    rows), else 1 / mean(‖B_i‖²) over the nonzero rows of the equilibrated border ``Bs`` (1 if none).

    S = T⁻¹ − ρ⁻¹I loses about log₁₀(ρ S_ii) digits to T's round-off when ρ S_ii ≫ 1, and log₁₀(1/(ρ S_ii))
    when ≪ 1. Paper panel at 211k unknowns, 2641 rows, S against refined solves: ρ S_ii = 3.6e6, 3.6e3, 36,
    3.6, 1.1, 0.36, 0.11 gave 2.1e-7, 1.7e-8, 5.4e-10, 3.6e-10, 5.8e-10, 7.0e-10, 1.1e-9 relative; the default
    (in the equilibrated variables) gave ρ S_ii = 3.6e3 there and grows under refinement."""
    if flexibility is not None:
        return 1.0 / flexibility
    b2 = np.asarray(Bs.multiply(Bs).sum(axis=1)).ravel()
    return 1.0 / float(np.mean(b2[b2 > 0])) if np.any(b2 > 0) else 1.0


def bordered_upper(As: sp.csr_matrix, Bs: sp.csr_matrix, rho: float) -> sp.csr_matrix:
    """The upper triangle of M = [[A + ρBᵀB, −ρBᵀ], [−ρB, ρI]] (``As``: the upper triangle of the
    equilibrated A with sorted indices, as ``sparse.equilibrate(A, upper=True)`` returns it; its data
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
