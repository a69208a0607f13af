"""The backend registry: every backend's name, class, availability check, one-line description and
priority for "auto", in one table (``BACKENDS``); ``factorize`` builds a factorisation from it.
``shellcontact info`` prints it and docs/solvers.md lists it (``tests/test_linalg.py`` checks that).
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from ..errors import InputError, SolverError
from . import cholmod, mumps, pardiso, superlu
from .protocol import Factorization
from .sparse import equilibrate


@dataclass(frozen=True)
class Backend:
    """One registered backend."""

    name: str
    factorization: type[Factorization]
    available: Callable[[], bool]  # whether it works on this machine (may import libraries: called once)
    doc: str  # one line
    priority: int  # "auto" takes the available backend with the smallest
    details: Callable[[], str] | None = None  # version and set-up, for ``shellcontact info`` (when available)

    @property
    def supports_schur(self) -> bool:
        return self.factorization.supports_schur


BACKENDS: dict[str, Backend] = {b.name: b for b in sorted((
    Backend("pardiso", pardiso.Pardiso, pardiso.available,
            "MKL PARDISO (package pypardiso): supernodal Cholesky; computes Schur complements (the substructured "
            "path, bordered with a weight)", 0),
    Backend("cholmod", cholmod.Cholmod, cholmod.available,
            "CHOLMOD supernodal Cholesky (package scikit-sparse, extra shellcontact[cholmod]; needs the "
            "SuiteSparse headers)", 1),
    Backend("superlu", superlu.SuperLU, superlu.available,
            "SciPy's SuperLU with a symmetric ordering and diagonal pivots; always installed, the slowest", 2),
    Backend("mumps", mumps.Mumps, mumps.available,
            "MUMPS over MPI (libmumps-dev, extra shellcontact[mpi]): one model's factors spread over the ranks of "
            "`mpiexec -n N shellcontact run`; Schur complements by MUMPS's ICNTL(19); never chosen by \"auto\"", 9,
            mumps.describe),
), key=lambda b: b.priority)}


def register(backend: Backend) -> Backend:
    """Add a backend (a module of this package or a plug-in) to ``BACKENDS``."""
    if backend.name in BACKENDS or backend.name == "auto":
        raise ValueError(f"backend {backend.name!r} is registered already")
    BACKENDS[backend.name] = backend
    _available.cache_clear()
    return backend


@functools.cache
def _available() -> tuple[str, ...]:
    return tuple(name for name, b in BACKENDS.items() if b.available())


def available_backends() -> list[str]:
    """Backends that work on this machine, in the order "auto" prefers them."""
    return list(_available())


def default_backend() -> str:
    """The backend "auto" resolves to: the first available."""
    return _available()[0]


def resolve_backend(name: str | None, where: str = "solver.backend") -> str:
    """The backend called ``name`` ("auto", None or "" for the default); InputError at ``where`` if it
    is unknown or not installed here."""
    if name in ("auto", None, ""):
        return default_backend()
    name = str(name).lower()
    if name not in BACKENDS:
        raise InputError(where, f"must be one of auto, {', '.join(BACKENDS)}, got {name!r}")
    if name not in _available():
        raise InputError(where, f"{name!r} is not installed here; available: {', '.join(_available())}")
    return name


def factorize(A: sp.spmatrix, backend: str = "auto", border: sp.spmatrix | None = None,
              border_flexibility: float | None = None) -> Factorization:
    """Equilibrate and factorise the SPD matrix A (MODEL.md §8: A symmetric positive definite).

    ``border``: rows B (m × n) whose Schur complement S = B A⁻¹ Bᵀ the factorisation also yields
    (``Factorization.schur``, ``bordered``); only for backends with ``supports_schur`` (InputError
    otherwise). ``border_flexibility``: the typical size of S_ii if known; the border's weight is then
    ρ = 1/it (``bordered.border_weight``)."""
    name = resolve_backend(backend)
    cls = BACKENDS[name].factorization
    A = sp.csr_matrix(A, dtype=float)
    if A.shape[0] != A.shape[1]:
        raise InputError("matrix", f"must be square, got {A.shape}")
    if border_flexibility is not None and not (np.isfinite(border_flexibility) and border_flexibility > 0):
        raise InputError("border_flexibility", f"must be a positive number, got {border_flexibility!r}")
    if border is not None:
        border = sp.csr_matrix(border, dtype=float)
        if border.shape[1] != A.shape[0]:
            raise InputError("border", f"must have {A.shape[0]} columns, got {border.shape[1]}")
        if not cls.supports_schur:
            raise InputError("border", f"the {name} backend does not compute Schur complements")
    scale, As = equilibrate(A, upper=cls.upper_triangle)
    try:
        return cls(A, scale, As, border, border_flexibility=border_flexibility)
    except SolverError as exc:
        raise SolverError(
            f"{name} factorisation failed: {exc} (are the supports enough to fix all rigid motions?)"
        ) from None
    except Exception as exc:  # noqa: BLE001 — backend-specific failure types
        raise SolverError(
            f"{name} factorisation failed: {exc} (are the supports enough to fix all rigid motions?)"
        ) from None
