"""Sparse direct factorisation of symmetric positive definite matrices, behind one protocol.

``factorize(A)`` equilibrates A symmetrically (S A S with S = diag(A)^{-1/2}: the Argyris
dofs mix values, first and second derivatives, so the raw diagonal spans many orders of
magnitude), factorises it once with the best available backend, and returns a
``Factorization`` (``protocol``): ``solve`` (one right-hand side) and ``solve_many`` (a block)
reuse the factors and apply iterative refinement against the original matrix (``extended=True``:
residuals in extended precision); ``refactor(A_new)`` redoes only the numeric factorisation when
the sparsity pattern is unchanged; ``info()``; ``free()``. ``factorize(A, backend, border=B)``
also yields the Schur complement S = B A⁻¹ Bᵀ (``Factorization.schur``, ``bordered``) on a
backend whose class says ``supports_schur``.

Backends (``backend=`` or the case file's ``[solver] backend``; "auto" takes the first available by
priority): the registry ``BACKENDS`` (``registry``) names each with its class, availability check,
one-line description and priority. ``pardiso`` (MKL PARDISO), ``cholmod`` (CHOLMOD), ``superlu``
(SciPy's SuperLU): one module each.

Adding a backend: a module here with a ``Factorization`` subclass (``backend`` name, the
``_factor``, ``_solve_factors``, ``_refactor``, ``_factor_info`` and ``free`` methods, and
``supports_schur``/``_factor_bordered`` if it can) and an ``available()`` check, plus one ``Backend``
entry in ``registry.BACKENDS`` (or ``register(Backend(...))`` from a plug-in); ``shellcontact info``
and the docs' table follow the registry.

A matrix that is singular or not positive definite raises SolverError whatever the backend.
"""

from .bordered import DenseSchur, SchurComplement
from .protocol import Factorization
from .registry import BACKENDS, Backend, available_backends, default_backend, factorize, register, resolve_backend

__all__ = [
    "BACKENDS",
    "Backend",
    "DenseSchur",
    "Factorization",
    "SchurComplement",
    "available_backends",
    "default_backend",
    "factorize",
    "register",
    "resolve_backend",
]
