"""Sparse direct factorisation of symmetric positive definite matrices, behind one interface.

``factorize(A)`` equilibrates A symmetrically (S A S with S = diag(A)^{-1/2}: the Argyris
dofs mix values, first and second derivatives, so the raw diagonal spans many orders of
magnitude), factorises it once with the best available backend, and returns an object
whose ``solve`` reuses the factorisation and applies iterative refinement against the
original matrix. Backends (``backend=``): "pardiso" (MKL via pypardiso), "cholmod"
(scikit-sparse), "superlu" (SciPy, configured for symmetric matrices: its defaults take
minutes and tens of GB on these fourth-order systems). "auto" takes the first available.
"""

from __future__ import annotations

import importlib.util
import os
from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from .errors import InputError, SolverError

BACKENDS = ("pardiso", "cholmod", "superlu")


def available_backends() -> list[str]:
    out = []
    if importlib.util.find_spec("pypardiso") is not None:
        out.append("pardiso")
    if importlib.util.find_spec("sksparse") is not None:
        out.append("cholmod")
    out.append("superlu")
    return out


def default_backend() -> str:
    forced = os.environ.get("SHELLCONTACT_BACKEND")
    if forced:
        return forced
    return available_backends()[0]


class _Pardiso:
    def __init__(self, A: sp.csr_matrix) -> None:
        import pypardiso

        self.solver = pypardiso.PyPardisoSolver(mtype=2)  # real symmetric positive definite
        self.solver.set_iparm(1, 1)
        self.upper = sp.triu(A, format="csr")
        self.upper.sort_indices()
        self.solver.factorize(self.upper)

    def solve(self, b: np.ndarray) -> np.ndarray:
        return self.solver.solve(self.upper, b)

    def free(self) -> None:
        self.solver.free_memory(everything=True)


class _Cholmod:
    def __init__(self, A: sp.csr_matrix) -> None:
        from sksparse.cholmod import cholesky

        self.factor = cholesky(A.tocsc())

    def solve(self, b: np.ndarray) -> np.ndarray:
        return self.factor(b)

    def free(self) -> None:
        pass


class _SuperLU:
    def __init__(self, A: sp.csr_matrix) -> None:
        self.lu = spla.splu(
            A.tocsc(), permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0, options={"SymmetricMode": True}
        )

    def solve(self, b: np.ndarray) -> np.ndarray:
        return self.lu.solve(b)

    def free(self) -> None:
        pass


_IMPL = {"pardiso": _Pardiso, "cholmod": _Cholmod, "superlu": _SuperLU}


@dataclass
class Factorization:
    """A factorised SPD matrix; ``solve`` works on vectors or (n, k) blocks."""

    A: sp.csr_matrix
    backend: str
    scale: np.ndarray
    impl: object = field(repr=False)
    refine_steps: int = 2
    rtol: float = 1e-13

    def solve(self, b: np.ndarray) -> np.ndarray:
        b = np.asarray(b, dtype=float)
        sc = self.scale if b.ndim == 1 else self.scale[:, None]
        x = sc * self.impl.solve(sc * b)
        bn = np.linalg.norm(b, axis=0)
        for _ in range(self.refine_steps):
            r = b - self.A @ x
            if np.all(np.linalg.norm(r, axis=0) <= self.rtol * np.maximum(bn, 1e-300)):
                break
            x = x + sc * self.impl.solve(sc * r)
        return x

    def __del__(self) -> None:
        try:
            self.impl.free()
        except Exception:  # noqa: BLE001 — interpreter shutdown
            pass


def factorize(A: sp.spmatrix, backend: str = "auto") -> Factorization:
    """Equilibrate and factorise the SPD matrix A."""
    name = default_backend() if backend == "auto" else backend
    if name not in BACKENDS:
        raise InputError("solver.backend", f"must be one of auto, {', '.join(BACKENDS)}, got {name!r}")
    if name not in available_backends():
        raise InputError(
            "solver.backend", f"{name!r} is not installed here; available: {', '.join(available_backends())}"
        )
    A = sp.csr_matrix(A, dtype=float)
    d = A.diagonal()
    if np.any(d <= 0) or not np.all(np.isfinite(d)):
        raise SolverError(
            "stiffness matrix is not positive definite: the supports leave a rigid-body motion free "
            f"({int(np.sum(d <= 0))} dofs with no stiffness)"
        )
    scale = 1.0 / np.sqrt(d)
    As = sp.csr_matrix(A.multiply(scale[:, None]).multiply(scale[None, :]))
    try:
        impl = _IMPL[name](As)
    except Exception as exc:  # backend-specific failure types
        raise SolverError(
            f"{name} factorisation failed: {exc} (are the supports enough to fix all rigid motions?)"
        ) from None
    return Factorization(A=A, backend=name, scale=scale, impl=impl)
