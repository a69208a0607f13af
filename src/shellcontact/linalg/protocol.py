"""``Factorization``: what every backend offers, and the equilibration and refinement they share.

A backend subclasses ``Factorization`` and implements the factor phases on the equilibrated matrix
S A S (S = diag(A)^{-1/2}): ``_factor``, ``_solve_factors``, ``_refactor``, ``_factor_info``,
``free``; a backend that computes the Schur complement of a bordered matrix in its numeric phase
also sets ``supports_schur = True`` and implements ``_factor_bordered`` (the weighted border of
``bordered``) or ``_factor_schur`` (S itself, from the factors of A). Everything
callers use is defined here: ``solve``, ``solve_many``, ``schur``, ``refactor``, ``info``, ``free``.
"""

from __future__ import annotations

import time
from abc import ABC, abstractmethod
from typing import ClassVar

import numpy as np
import scipy.sparse as sp

from ..errors import InputError, SolverError
from .bordered import DenseSchur, SchurComplement, border_weight
from .sparse import equilibrate, norm_inf


class Factorization(ABC):
    """A factorised SPD matrix A (MODEL.md §8); built by ``linalg.factorize``.

    ``residual`` holds the relative residual ‖b − A x‖₂/‖b‖₂ of the last refined solve (max over
    columns), ``backward_error`` its normwise backward error, ``refinements`` the number of
    refinement steps it took, ``seconds`` the (last) factorisation time. ``schur`` is the Schur
    complement S = B A⁻¹ Bᵀ of the rows B given as ``factorize(A, border=B)`` (None without a border,
    when T was not positive definite, and after ``refactor``).
    """

    #: the backend's name in the registry
    backend: ClassVar[str]
    #: whether ``factorize(A, backend, border=B)`` works: the numeric phase yields the Schur
    #: complement of A bordered by B (``bordered``)
    supports_schur: ClassVar[bool] = False
    #: whether the backend reads only the upper triangle of the equilibrated matrix (then only that
    #: is built: half the entries to copy and scale)
    upper_triangle: ClassVar[bool] = False

    def __init__(self, A: sp.csr_matrix, scale: np.ndarray, As: sp.csr_matrix,
                 border: sp.csr_matrix | None = None, refine_steps: int = 3,
                 border_flexibility: float | None = None) -> None:
        """Factorise ``As`` = S A S (``sparse.equilibrate(A, upper=self.upper_triangle)`` with its
        ``scale``), bordered by ``border`` (rows of A's size, unscaled) if given, with the weight
        ``bordered.border_weight(Bs, border_flexibility)``."""
        self.A = A
        self.scale = scale
        self.refine_steps = refine_steps
        self.residual = float("nan")
        self.backward_error = float("nan")
        self.refinements = 0
        self.schur: SchurComplement | DenseSchur | None = None
        self._norm: tuple = (None, 0.0)
        self._along: tuple = (None, None)  # (A, A in extended precision)
        if border is None:
            t0 = time.perf_counter()
            self._factor(As)
        else:
            Bs = (border @ sp.diags(scale)).tocsr()
            t0 = time.perf_counter()
            S = self._factor_schur(As, Bs)
            if S is not None:  # Bs As⁻¹ Bsᵀ = B A⁻¹ Bᵀ: the scaling cancels
                self.schur = DenseSchur(B=border, S=S)
            else:
                rho = border_weight(Bs, border_flexibility)
                T = self._factor_bordered(As, Bs, rho)
                t1 = time.perf_counter()
                self.schur = SchurComplement.from_bordered(border, rho, T)
                if self.schur is not None:
                    self.schur.seconds = time.perf_counter() - t1
        self.seconds = time.perf_counter() - t0

    # -- what a backend implements ------------------------------------------------------------------
    @abstractmethod
    def _factor(self, As: sp.csr_matrix) -> None:
        """Symbolic and numeric factorisation of the equilibrated matrix; SolverError if it is not SPD."""

    def _factor_bordered(self, As: sp.csr_matrix, Bs: sp.csr_matrix, rho: float) -> np.ndarray:
        """Factorise M (``bordered``) for the equilibrated ``As`` and ``Bs``; returns the dense Schur
        complement T of M's last m rows. Solves then use M's factors (A⁻¹b = (M⁻¹[b; 0])[:n])."""
        raise InputError("border", f"the {self.backend} backend does not compute Schur complements")

    def _factor_schur(self, As: sp.csr_matrix, Bs: sp.csr_matrix) -> np.ndarray | None:
        """Factorise ``As`` and return S = Bs As⁻¹ Bsᵀ (m × m, dense) from the backend's own Schur option; None
        (the default): the backend borders A instead (``_factor_bordered``)."""
        return None

    @abstractmethod
    def _solve_factors(self, b: np.ndarray) -> np.ndarray:
        """x with S A S x = b by the factors (b: a vector or an (n, k) block)."""

    @abstractmethod
    def _refactor(self, As: sp.csr_matrix) -> None:
        """Numeric refactorisation of a new equilibrated matrix (the symbolic analysis reused when the
        pattern is unchanged)."""

    @abstractmethod
    def _factor_info(self) -> dict:
        """Backend figures for ``info`` (at least ``factor_nnz``)."""

    @abstractmethod
    def free(self) -> None:
        """Release the factors' memory held outside Python (idempotent)."""

    # -- what callers use ---------------------------------------------------------------------------
    @property
    def norm_inf(self) -> float:
        """‖A‖∞ of the stored matrix (recomputed if A was replaced)."""
        if self._norm[0] is not self.A:
            self._norm = (self.A, norm_inf(self.A))
        return self._norm[1]

    def solve(self, b: np.ndarray, refine_steps: int | None = None, extended: bool = False) -> np.ndarray:
        """x with A x = b (one right-hand side), refined against A until the backward error is at
        round-off.

        Refinement stops (LAPACK's rule) when the normwise backward error
        ‖r‖∞ / (‖A‖∞‖x‖∞ + ‖b‖∞) reaches a few ulps, or stops halving; a backward error that
        stays large (> 1e-8) means the matrix is numerically singular: SolverError.

        ``extended``: the residuals r = b − A x in extended precision (``numpy.longdouble``; b may
        be given in it), corrections in double, until the correction is below round-off or stops
        halving (mixed-precision refinement: the forward error then reaches the working precision
        instead of cond(A)·ε; ~1e8-1e11 for these fourth-order systems).
        """
        if np.ndim(b) != 1:
            raise InputError("b", "solve takes one right-hand side (a vector); solve_many takes a block")
        if extended:
            return self._solve_extended(b, self.refine_steps + 2 if refine_steps is None else refine_steps)
        return self._solve_refined(np.asarray(b, dtype=float), refine_steps)

    def solve_many(self, B: np.ndarray, refine: bool = True) -> np.ndarray:
        """X with A X = B for a block of right-hand sides (n × k), refined as ``solve`` (the backward
        error the largest over columns). ``refine=False``: the factors' solution alone, no residual
        and no check (for callers that correct the round-off themselves: ``solvers.schur``)."""
        B = np.asarray(B, dtype=float)
        if B.ndim != 2:
            raise InputError("B", f"solve_many takes an (n, k) block, got shape {B.shape}")
        if not refine:
            sc = self.scale[:, None]
            return sc * self._solve_factors(sc * B)
        return self._solve_refined(B, None)

    def _solve_refined(self, b: np.ndarray, refine_steps: int | None) -> np.ndarray:
        steps = self.refine_steps if refine_steps is None else refine_steps
        sc = self.scale if b.ndim == 1 else self.scale[:, None]
        x = sc * self._solve_factors(sc * b)
        r = b - self.A @ x
        berr = self._backward_error(x, r, b)
        self.refinements = 0
        while self.refinements < steps and berr > 8.0 * np.finfo(float).eps and np.isfinite(berr):
            x_new = x + sc * self._solve_factors(sc * r)
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
        if self._along[0] is not self.A:
            self._along = (self.A, self.A.astype(np.longdouble))
        Al = self._along[1]
        x = self.scale * self._solve_factors(self.scale * bl.astype(float))
        prev = np.inf
        self.refinements = 0
        for _ in range(steps):
            r = (bl - Al @ x.astype(np.longdouble)).astype(float)
            d = self.scale * self._solve_factors(self.scale * r)
            x = x + d
            self.refinements += 1
            size = float(np.max(np.abs(d)))
            if size <= 4.0 * np.finfo(float).eps * float(np.max(np.abs(x))) or size > 0.5 * prev:
                break
            prev = size
        r = (bl - Al @ x.astype(np.longdouble)).astype(float)
        return self._accept(x, r, bl.astype(float))

    def refactor(self, A_new: sp.spmatrix) -> Factorization:
        """Numeric refactorisation of a matrix with the same sparsity pattern (symbolic analysis
        reused); a bordered factorisation drops its border and its Schur complement."""
        A_new = sp.csr_matrix(A_new, dtype=float)
        if A_new.shape != self.A.shape:
            raise InputError("matrix", f"refactor needs shape {self.A.shape}, got {A_new.shape}")
        self.scale, As = equilibrate(A_new, upper=self.upper_triangle)
        t0 = time.perf_counter()
        self._refactor(As)
        self.seconds = time.perf_counter() - t0
        self.A = A_new
        self.schur = None
        return self

    def info(self) -> dict:
        return {"backend": self.backend, "n": self.A.shape[0], "nnz": int(self.A.nnz), "seconds": self.seconds,
                **self._factor_info()}

    def __del__(self) -> None:
        try:
            self.free()
        except Exception:  # noqa: BLE001 — interpreter shutdown, or a constructor that failed early
            pass
