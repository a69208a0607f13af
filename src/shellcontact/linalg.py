"""Sparse direct factorisation of symmetric positive definite matrices, behind one interface.

``factorize(A)`` equilibrates A symmetrically (S A S with S = diag(A)^{-1/2}: the Argyris
dofs mix values, first and second derivatives, so the raw diagonal spans many orders of
magnitude), factorises it once with the best available backend, and returns a
``Factorization`` whose ``solve`` reuses the factors and applies iterative refinement against
the original matrix, and whose ``refactor(A_new)`` redoes only the numeric factorisation when
the sparsity pattern is unchanged (the symbolic analysis / fill-reducing ordering is reused).

Backends (``backend=`` or the environment variable SHELLCONTACT_BACKEND; "auto" takes the
first available in this order):

* "pardiso": MKL PARDISO through the ``pypardiso`` package's MKL binding, called directly
  with explicit phases (11 analysis, 22 numeric, 33 solve), real SPD (mtype 2) on the upper
  triangle, minimum-degree (< 500k unknowns) or METIS ordering, zero-based indices.
* "cholmod": CHOLMOD supernodal Cholesky (``scikit-sparse``, optional extra
  ``shellcontact[cholmod]``; needs the SuiteSparse headers, e.g. Debian's libsuitesparse-dev,
  and scikit-sparse < 0.5 with SuiteSparse 5; a fast BLAS such as libopenblas-dev matters).
* "superlu": SciPy's SuperLU, always there, configured for symmetric matrices
  (MMD on AᵀA+A, symmetric mode, diagonal pivoting): its defaults take minutes and tens of
  GB on these fourth-order systems.

A matrix that is singular or not positive definite raises SolverError whatever the backend.
"""

from __future__ import annotations

import importlib.util
import os
import time
from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from .errors import InputError, SolverError

BACKENDS = ("pardiso", "cholmod", "superlu")
ENV_VAR = "SHELLCONTACT_BACKEND"
_AVAILABLE: list[str] | None = None


_MKL_PARDISO = None


def _mkl_pardiso():
    """MKL's pardiso entry point, found once through pypardiso (its lookup spawns ldconfig: slow)."""
    global _MKL_PARDISO
    if _MKL_PARDISO is None:
        import pypardiso

        _MKL_PARDISO = pypardiso.PyPardisoSolver(mtype=2)._mkl_pardiso
    return _MKL_PARDISO


def _pardiso_loads() -> bool:
    if importlib.util.find_spec("pypardiso") is None:
        return False
    try:
        _mkl_pardiso()
    except Exception:  # noqa: BLE001 — any failure to load MKL means "not available"
        return False
    return True


def _cholmod_loads() -> bool:
    if importlib.util.find_spec("sksparse") is None:
        return False
    try:
        import sksparse.cholmod  # noqa: F401
    except Exception:  # noqa: BLE001 — a broken build (missing libcholmod) means "not available"
        return False
    return True


def available_backends() -> list[str]:
    """Backends that work on this machine, in the order "auto" prefers them."""
    global _AVAILABLE
    if _AVAILABLE is None:
        out = []
        if _pardiso_loads():
            out.append("pardiso")
        if _cholmod_loads():
            out.append("cholmod")
        out.append("superlu")
        _AVAILABLE = out
    return list(_AVAILABLE)


def default_backend() -> str:
    """The backend "auto" resolves to: SHELLCONTACT_BACKEND if set, else the first available."""
    forced = os.environ.get(ENV_VAR, "").strip().lower()
    if forced and forced != "auto":
        return _check_backend(forced, ENV_VAR)
    return available_backends()[0]


def _check_backend(name: str, where: str = "solver.backend") -> str:
    if name not in BACKENDS:
        raise InputError(where, f"must be one of auto, {', '.join(BACKENDS)}, got {name!r}")
    if name not in available_backends():
        raise InputError(where, f"{name!r} is not installed here; available: {', '.join(available_backends())}")
    return name


# -- backends -----------------------------------------------------------------------------------


class _Pardiso:
    """MKL PARDISO, real SPD (mtype 2), upper triangle in CSR with zero-based indices."""

    def __init__(self, A: sp.csr_matrix) -> None:
        import ctypes

        self._ctypes = ctypes
        self._mkl = _mkl_pardiso()
        self.pt = np.zeros(64, dtype=np.int64)
        self.iparm = np.zeros(64, dtype=np.int32)
        ip = self.iparm  # 0-based here; the MKL documentation counts from 1
        ip[0] = 1  # use the values below
        # ordering: minimum degree below 500k unknowns, METIS above. Measured on shell stiffnesses
        # (1 thread): 432k unknowns MD 2.3 + 5.4 s (analysis + numeric, fill 97M) vs METIS 4.1 + 4.4 s
        # (101M); 984k: MD 5.7 + 20.4 s (264M) vs METIS 9.8 + 16.3 s (251M): METIS wins at scale and
        # whenever the numeric phase is repeated (refactor).
        ip[1] = 0 if A.shape[0] < 500_000 else 2
        ip[7] = 0  # PARDISO's own refinement off: the Factorization refines against A
        ip[9] = 13  # pivot perturbation (unused for SPD)
        ip[17] = -1  # report nnz(L)
        ip[34] = 1  # zero-based indices
        self.n = A.shape[0]
        self._set_matrix(A)
        try:
            self._call(11)  # ordering and symbolic factorisation
            self._call(22)  # numeric factorisation
        except SolverError:
            self.free()  # release MKL's internal memory before giving up
            raise

    def _set_matrix(self, A: sp.csr_matrix) -> None:
        U = _upper(A)
        if np.any(np.diff(U.indptr) == 0):
            raise SolverError("matrix has an empty row: singular")
        self.data = np.ascontiguousarray(U.data, dtype=np.float64)
        self.ia = U.indptr.astype(np.int32, copy=False)
        self.ja = U.indices.astype(np.int32, copy=False)

    perm: np.ndarray | None = None  # rows marked for a Schur complement (solvers.substructure)

    def _call(self, phase: int, b: np.ndarray | None = None, out: np.ndarray | None = None) -> np.ndarray | None:
        """One PARDISO phase; without b, ``out`` receives what the phase writes (a Schur complement)."""
        c = self._ctypes
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

    def refactor(self, A: sp.csr_matrix) -> None:
        U = _upper(A)
        if U.nnz != self.data.size or not np.array_equal(U.indptr, self.ia) or not np.array_equal(U.indices, self.ja):
            self.free()
            self._set_matrix(A)
            self._call(11)
        else:
            self.data = np.ascontiguousarray(U.data, dtype=np.float64)
        self._call(22)

    def solve(self, b: np.ndarray) -> np.ndarray:
        return self._call(33, b)

    def info(self) -> dict:
        return {"factor_nnz": int(self.iparm[17]), "peak_kb_symbolic": int(self.iparm[14]),
                "kb_factor": int(self.iparm[15] + self.iparm[16])}

    def free(self) -> None:
        if np.any(self.pt):
            try:
                self._call(-1)
            finally:
                self.pt[:] = 0


class _Cholmod:
    """CHOLMOD supernodal Cholesky; the symbolic analysis is kept for refactor()."""

    def __init__(self, A: sp.csr_matrix) -> None:
        from sksparse.cholmod import CholmodError, cholesky

        self._error, self._cholesky = CholmodError, cholesky
        M = sp.csc_matrix(A)
        M.sort_indices()
        self._pattern = (M.indptr.copy(), M.indices.copy())
        try:
            self.factor = cholesky(M)
        except CholmodError as exc:
            raise SolverError(f"CHOLMOD: {exc} (not positive definite)") from None

    def refactor(self, A: sp.csr_matrix) -> None:
        M = sp.csc_matrix(A)
        M.sort_indices()
        same = np.array_equal(M.indptr, self._pattern[0]) and np.array_equal(M.indices, self._pattern[1])
        try:
            if same:  # the symbolic analysis (ordering, supernodes) is reused
                self.factor.cholesky_inplace(M)
            else:
                self.factor = self._cholesky(M)
                self._pattern = (M.indptr.copy(), M.indices.copy())
        except self._error as exc:
            raise SolverError(f"CHOLMOD: {exc} (not positive definite)") from None

    def solve(self, b: np.ndarray) -> np.ndarray:
        return self.factor(b)

    def info(self) -> dict:
        L = self.factor.L()
        return {"factor_nnz": int(L.nnz)}

    def free(self) -> None:
        pass


class _SuperLU:
    """SciPy SuperLU with a symmetric ordering and diagonal pivots; refactor() keeps the ordering."""

    OPTIONS = {"SymmetricMode": True}

    def __init__(self, A: sp.csr_matrix) -> None:
        self.lu = self._splu(sp.csc_matrix(A), "MMD_AT_PLUS_A")
        pc = self.lu.perm_c
        self.q = np.empty_like(pc)  # with B = A[q][:, q], SuperLU's natural order reproduces its ordering
        self.q[pc] = np.arange(pc.size)
        self.permuted = False

    def _splu(self, M: sp.csc_matrix, permc: str):
        try:
            lu = spla.splu(M, permc_spec=permc, diag_pivot_thresh=0.0, options=self.OPTIONS)
        except RuntimeError as exc:
            raise SolverError(f"SuperLU: {exc} (singular)") from None
        # SPD ⇔ the symmetric pivoting kept every pivot on the diagonal and all pivots are positive
        if not np.array_equal(lu.perm_r, lu.perm_c) or not np.all(lu.U.diagonal() > 0):
            raise SolverError("SuperLU: non-positive pivot, the matrix is not positive definite")
        return lu

    def refactor(self, A: sp.csr_matrix) -> None:
        self.lu = self._splu(sp.csc_matrix(sp.csr_matrix(A)[self.q][:, self.q]), "NATURAL")
        self.permuted = True

    def solve(self, b: np.ndarray) -> np.ndarray:
        if not self.permuted:
            return self.lu.solve(b)
        x = np.empty_like(b)
        x[self.q] = self.lu.solve(b[self.q])
        return x

    def info(self) -> dict:
        return {"factor_nnz": int(self.lu.L.nnz + self.lu.U.nnz)}

    def free(self) -> None:
        pass


_IMPL = {"pardiso": _Pardiso, "cholmod": _Cholmod, "superlu": _SuperLU}


@dataclass
class Factorization:
    """A factorised SPD matrix; ``solve`` works on vectors or (n, k) blocks.

    ``residual`` holds the relative residual ‖b − A x‖₂/‖b‖₂ of the last solve (max over columns),
    ``backward_error`` its normwise backward error, ``refinements`` the number of refinement steps
    it took, ``seconds`` the (last) factorisation time.
    """

    A: sp.csr_matrix
    backend: str
    scale: np.ndarray
    impl: object = field(repr=False)
    refine_steps: int = 3
    seconds: float = 0.0
    residual: float = float("nan")
    backward_error: float = float("nan")
    refinements: int = 0
    _norm: tuple = field(default=(None, 0.0), repr=False)
    _along: tuple = field(default=(None, None), repr=False)  # (A, A in extended precision)

    @property
    def norm_inf(self) -> float:
        """‖A‖∞ of the stored matrix (recomputed if A was replaced)."""
        if self._norm[0] is not self.A:
            self._norm = (self.A, _norm_inf(self.A))
        return self._norm[1]

    def solve(self, b: np.ndarray, refine_steps: int | None = None, extended: bool = False) -> np.ndarray:
        """x with A x = b, refined against A until the backward error is at round-off.

        Refinement stops (LAPACK's rule) when the normwise backward error
        ‖r‖∞ / (‖A‖∞‖x‖∞ + ‖b‖∞) reaches a few ulps, or stops halving; a backward error that
        stays large (> 1e-8) means the matrix is numerically singular: SolverError.

        ``extended``: the residuals r = b − A x in extended precision (``numpy.longdouble``; b may
        be given in it), corrections in double, until the correction is below round-off or stops
        halving (mixed-precision refinement: the forward error then reaches the working precision
        instead of cond(A)·ε; ~1e8-1e11 for these fourth-order systems). Vectors only.
        """
        if extended:
            return self._solve_extended(b, self.refine_steps + 2 if refine_steps is None else refine_steps)
        b = np.asarray(b, dtype=float)
        steps = self.refine_steps if refine_steps is None else refine_steps
        sc = self.scale if b.ndim == 1 else self.scale[:, None]
        x = sc * self.impl.solve(sc * b)
        r = b - self.A @ x
        berr = self._backward_error(x, r, b)
        self.refinements = 0
        while self.refinements < steps and berr > 8.0 * np.finfo(float).eps and np.isfinite(berr):
            x_new = x + sc * self.impl.solve(sc * r)
            r_new = b - self.A @ x_new
            berr_new = self._backward_error(x_new, r_new, b)
            self.refinements += 1
            if not berr_new < berr:  # no progress: keep the better iterate
                break
            x, r, progress, berr = x_new, r_new, berr / berr_new, berr_new
            if progress < 2.0:
                break
        return self._accept(x, r, b)

    def _backward_error(self, x: np.ndarray, r: np.ndarray, b: np.ndarray) -> float:
        """Normwise backward error ‖r‖∞ / (‖A‖∞‖x‖∞ + ‖b‖∞), the largest over columns."""
        return float(np.max(np.max(np.abs(r), axis=0) / np.maximum(
            self.norm_inf * np.max(np.abs(x), axis=0) + np.max(np.abs(b), axis=0), 1e-300)))

    def _accept(self, x: np.ndarray, r: np.ndarray, b: np.ndarray) -> np.ndarray:
        """Record the residual r = b − A x of the final x; a backward error that stays large
        (> 1e-8) means the matrix is numerically singular: SolverError."""
        bn = np.maximum(np.linalg.norm(b, axis=0), 1e-300)
        self.residual = float(np.max(np.linalg.norm(r, axis=0) / bn))
        self.backward_error = berr = self._backward_error(x, r, b)
        if not np.isfinite(berr) or berr > 1e-8:
            raise SolverError(
                f"{self.backend}: the solution does not satisfy the equations (numerically singular matrix?)",
                residuals={"backward_error": berr, "relative_residual": self.residual},
            )
        return x

    def _solve_extended(self, b: np.ndarray, steps: int) -> np.ndarray:
        bl = np.asarray(b, dtype=np.longdouble)
        if bl.ndim != 1:
            raise InputError("b", "extended-precision refinement takes one right-hand side")
        if self._along[0] is not self.A:
            self._along = (self.A, self.A.astype(np.longdouble))
        Al = self._along[1]
        x = self.scale * self.impl.solve(self.scale * bl.astype(float))
        prev = np.inf
        self.refinements = 0
        for _ in range(steps):
            r = (bl - Al @ x.astype(np.longdouble)).astype(float)
            d = self.scale * self.impl.solve(self.scale * r)
            x = x + d
            self.refinements += 1
            size = float(np.max(np.abs(d)))
            if size <= 4.0 * np.finfo(float).eps * float(np.max(np.abs(x))) or size > 0.5 * prev:
                break
            prev = size
        r = (bl - Al @ x.astype(np.longdouble)).astype(float)
        return self._accept(x, r, bl.astype(float))

    def refactor(self, A_new: sp.spmatrix) -> Factorization:
        """Numeric refactorisation of a matrix with the same sparsity pattern (symbolic analysis reused)."""
        A_new = sp.csr_matrix(A_new, dtype=float)
        if A_new.shape != self.A.shape:
            raise InputError("matrix", f"refactor needs shape {self.A.shape}, got {A_new.shape}")
        self.scale, As = _equilibrate(A_new, upper=self.backend == "pardiso")
        t0 = time.perf_counter()
        self.impl.refactor(As)
        self.seconds = time.perf_counter() - t0
        self.A = A_new
        return self

    def info(self) -> dict:
        return {"backend": self.backend, "n": self.A.shape[0], "nnz": int(self.A.nnz), "seconds": self.seconds,
                **self.impl.info()}

    def __del__(self) -> None:
        try:
            self.impl.free()
        except Exception:  # noqa: BLE001 — interpreter shutdown
            pass


#: entries per chunk of the row-wise passes over large CSR matrices: a temporary of that size instead
#: of one as large as A (at 1.1M dofs a 0.9 GB temporary costs more in first-touch page faults than
#: the arithmetic)
CHUNK = 1 << 20


def _row_chunks(A: sp.csr_matrix):
    """Row ranges [r0, r1) of A holding about CHUNK entries each."""
    n = A.shape[0]
    bounds = np.searchsorted(A.indptr, np.arange(0, A.nnz + CHUNK, CHUNK), side="right") - 1
    bounds = np.unique(np.clip(bounds, 0, n))
    bounds[-1] = n
    if bounds[0] != 0:
        bounds = np.concatenate([[0], bounds])
    return zip(bounds[:-1], bounds[1:])


def _row_sums(values: np.ndarray, indptr: np.ndarray, dtype=None) -> np.ndarray:
    """Per-row sums of ``values`` (the entries of rows r0..r1, ``indptr`` = A.indptr[r0 : r1 + 1]);
    0 for empty rows (``reduceat`` alone would repeat the next entry there)."""
    counts = np.diff(indptr)
    out = np.zeros(counts.size, dtype=dtype or values.dtype)
    full = counts > 0
    if values.size:
        out[full] = np.add.reduceat(values, indptr[:-1][full] - indptr[0], dtype=dtype)
    return out


def _norm_inf(A: sp.csr_matrix) -> float:
    """‖A‖∞ = max_i Σ_j |A_ij|, by chunks of rows."""
    if not A.nnz:
        return 0.0
    best = 0.0
    for r0, r1 in _row_chunks(A):
        p0, p1 = A.indptr[r0], A.indptr[r1]
        if p1 > p0:
            best = max(best, float(_row_sums(np.abs(A.data[p0:p1]), A.indptr[r0 : r1 + 1]).max()))
    return best


def _triu(A: sp.csr_matrix, scale: np.ndarray | None = None) -> sp.csr_matrix:
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
    for r0, r1 in _row_chunks(A):  # pass 1: which entries each row keeps
        p0, p1 = ip[r0], ip[r1]
        rows = np.repeat(np.arange(r0, r1, dtype=A.indices.dtype), np.diff(ip[r0 : r1 + 1]))
        mask = A.indices[p0:p1] >= rows
        kept[r0:r1] = _row_sums(mask.view(np.int8), ip[r0 : r1 + 1], dtype=np.int64)
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


def _upper(A: sp.csr_matrix) -> sp.csr_matrix:
    """The upper triangle of A in CSR with sorted indices: A itself when it holds no entry below
    the diagonal (checked in O(n) on the first entry of each row), else ``_triu(A)``."""
    A.sort_indices()
    rows = np.flatnonzero(np.diff(A.indptr) > 0)
    if np.all(A.indices[A.indptr[rows]] >= rows):
        return A
    return _triu(A)


def _equilibrate(A: sp.csr_matrix, upper: bool = False) -> tuple[np.ndarray, sp.csr_matrix]:
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
        return scale, _triu(A, scale)
    As = A.copy()
    # S A S on the CSR arrays directly (row scale by repeat of indptr, column scale by indices)
    As.data *= np.repeat(scale, np.diff(As.indptr)) * scale[As.indices]
    return scale, As


def factorize(A: sp.spmatrix, backend: str = "auto") -> Factorization:
    """Equilibrate and factorise the SPD matrix A (MODEL.md §8: A symmetric positive definite)."""
    name = default_backend() if backend in ("auto", None, "") else _check_backend(str(backend).lower())
    A = sp.csr_matrix(A, dtype=float)
    if A.shape[0] != A.shape[1]:
        raise InputError("matrix", f"must be square, got {A.shape}")
    scale, As = _equilibrate(A, upper=name == "pardiso")
    t0 = time.perf_counter()
    try:
        impl = _IMPL[name](As)
    except SolverError as exc:
        raise SolverError(
            f"{name} factorisation failed: {exc} (are the supports enough to fix all rigid motions?)"
        ) from None
    except Exception as exc:  # noqa: BLE001 — backend-specific failure types
        raise SolverError(
            f"{name} factorisation failed: {exc} (are the supports enough to fix all rigid motions?)"
        ) from None
    return Factorization(A=A, backend=name, scale=scale, impl=impl, seconds=time.perf_counter() - t0)
