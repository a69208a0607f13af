"""CSR helpers of the factorisations: row chunks, ‖A‖∞, the upper triangle, symmetric equilibration.

The passes over large matrices go by chunks of rows (``CHUNK`` entries each): a temporary of that
size instead of one as large as A.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from ..errors import SolverError

#: entries per chunk of the row-wise passes over large CSR matrices: a temporary of that size instead
#: of one as large as A (at 1.1M dofs a 0.9 GB temporary costs more in first-touch page faults than
#: the arithmetic)
CHUNK = 1 << 20


def row_chunks(A: sp.csr_matrix):
    """Row ranges [r0, r1) of A holding about CHUNK entries each."""
    n = A.shape[0]
    bounds = np.searchsorted(A.indptr, np.arange(0, A.nnz + CHUNK, CHUNK), side="right") - 1
    bounds = np.unique(np.clip(bounds, 0, n))
    bounds[-1] = n
    if bounds[0] != 0:
        bounds = np.concatenate([[0], bounds])
    return zip(bounds[:-1], bounds[1:])


def row_sums(values: np.ndarray, indptr: np.ndarray, dtype=None) -> np.ndarray:
    """Per-row sums of ``values`` (the entries of rows r0..r1, ``indptr`` = A.indptr[r0 : r1 + 1]);
    0 for empty rows (``reduceat`` alone would repeat the next entry there)."""
    counts = np.diff(indptr)
    out = np.zeros(counts.size, dtype=dtype or values.dtype)
    full = counts > 0
    if values.size:
        out[full] = np.add.reduceat(values, indptr[:-1][full] - indptr[0], dtype=dtype)
    return out


def norm_inf(A: sp.csr_matrix) -> float:
    """‖A‖∞ = max_i Σ_j |A_ij|, by chunks of rows."""
    if not A.nnz:
        return 0.0
    best = 0.0
    for r0, r1 in row_chunks(A):
        p0, p1 = A.indptr[r0], A.indptr[r1]
        if p1 > p0:
            best = max(best, float(row_sums(np.abs(A.data[p0:p1]), A.indptr[r0 : r1 + 1]).max()))
    return best


def triu(A: sp.csr_matrix, scale: np.ndarray | None = None) -> sp.csr_matrix:
    """The upper triangle of a CSR matrix (times diag(scale) on both sides if given).

    Built from the arrays by chunks of rows: one allocation for the result and chunk-sized
    temporaries (at 1.1M dofs ``sp.triu`` followed by the scaling took 3.5 s in a fresh process,
    almost all of it first-touch page faults of its whole-matrix temporaries). The first pass keeps
    each chunk's mask (1 byte per entry) for the second, which copies. Explicit zeros are kept: the
    assembled pattern holds ~2 % of them, and dropping them broke PARDISO's supernodes (216k dofs:
    1221 blocked Schur columns 27 s → 46 s)."""
    if not A.has_sorted_indices:  # the result keeps A's order within rows; PARDISO needs it sorted
        A = A.sorted_indices()
    n = A.shape[0]
    ip = A.indptr
    kept = np.zeros(n, dtype=np.int64)
    masks = []
    for r0, r1 in row_chunks(A):  # pass 1: which entries each row keeps
        p0, p1 = ip[r0], ip[r1]
        rows = np.repeat(np.arange(r0, r1, dtype=A.indices.dtype), np.diff(ip[r0 : r1 + 1]))
        mask = A.indices[p0:p1] >= rows
        kept[r0:r1] = row_sums(mask.view(np.int8), ip[r0 : r1 + 1], dtype=np.int64)
        masks.append((r0, r1, mask))
    indptr = np.zeros(n + 1, dtype=np.int64)
    np.cumsum(kept, out=indptr[1:])
    indices = np.empty(int(indptr[-1]), dtype=A.indices.dtype)
    data = np.empty(int(indptr[-1]), dtype=np.float64)
    for r0, r1, mask in masks:  # pass 2: the kept entries of rows r0..r1 fill indptr[r0]..indptr[r1] in order
        p0, p1 = ip[r0], ip[r1]
        q0, q1 = indptr[r0], indptr[r1]
        indices[q0:q1] = A.indices[p0:p1][mask]
        vals = A.data[p0:p1][mask]
        if scale is not None:
            vals *= np.repeat(scale[r0:r1], kept[r0:r1]) * scale[indices[q0:q1]]
        data[q0:q1] = vals
    if indptr[-1] < np.iinfo(np.int32).max:
        indptr = indptr.astype(np.int32)
    return sp.csr_matrix((data, indices, indptr), shape=A.shape, copy=False)


def upper(A: sp.csr_matrix) -> sp.csr_matrix:
    """The upper triangle of A in CSR with sorted indices: A itself when it holds no entry below
    the diagonal (checked in O(n) on the first entry of each row), else ``triu(A)``."""
    A.sort_indices()
    rows = np.flatnonzero(np.diff(A.indptr) > 0)
    if np.all(A.indices[A.indptr[rows]] >= rows):
        return A
    return triu(A)


def checked_upper(As: sp.csr_matrix) -> sp.csr_matrix:
    """``upper(As)`` for a direct solver that takes the upper triangle (PARDISO, MUMPS): a row without an entry
    there is a singular matrix, said before the solver sees it."""
    U = upper(As)
    if np.any(np.diff(U.indptr) == 0):
        raise SolverError("matrix has an empty row: singular")
    return U


def equilibrate(A: sp.csr_matrix, upper: bool = False) -> tuple[np.ndarray, sp.csr_matrix]:
    """scale = diag(A)^-½ and S A S, or with ``upper`` only its upper triangle (all PARDISO reads:
    half the entries to copy and scale; 3 s of the factorisation stage at 1.1M dofs otherwise)."""
    d = A.diagonal()
    if np.any(d <= 0) or not np.all(np.isfinite(d)):
        raise SolverError(
            "stiffness matrix is not positive definite: the supports leave a rigid-body motion free "
            f"({int(np.sum(d <= 0))} dofs with no stiffness)"
        )
    scale = 1.0 / np.sqrt(d)
    if upper:
        return scale, triu(A, scale)
    As = A.copy()
    # S A S on the CSR arrays directly (row scale by repeat of indptr, column scale by indices)
    As.data *= np.repeat(scale, np.diff(As.indptr)) * scale[As.indices]
    return scale, As


def same_entries(B1: sp.spmatrix, B2: sp.spmatrix) -> bool:
    """Whether two sparse matrices have the same shape and entries."""
    if B1.shape != B2.shape:
        return False
    d = sp.csr_matrix(B1) - sp.csr_matrix(B2)
    return d.nnz == 0 or float(np.abs(d.data).max()) == 0.0
