"""Substructuring: when to factorise A bordered by the contact rows B, so that the factorisation also
yields the whole Schur complement S = B A⁻¹ Bᵀ (``linalg.factorize(A, backend, border=B)``; the
method is in ``linalg.bordered``).

The contact rows B touch only the dofs of the contact-zone vertices, so S needs A⁻¹ only there, and
a column of S then costs two dense triangular solves of order m instead of a sparse solve. The
dense m × m block costs memory and time, so it pays only from a problem size on and up to a number
of rows (measured below).

``factorize_contact(A, B)`` returns a ``linalg.Factorization`` whose ``schur`` is the Schur
complement of B, or a plain ``factorize(A)`` (``schur`` None) when the backend cannot compute it
(``supports_schur``), or m or n is outside the limits; ``schur.Workspace`` uses ``schur`` when its
rows equal (a prefix of) the QP's B.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from ..errors import InputError
from ..linalg import BACKENDS, Factorization, factorize, resolve_backend

#: fewest unknowns for which ``factorize_contact`` builds the Schur complement by default: measured
#: on the demo case (1 thread), factorisation + active-set solve through ``analysis.solve``, plain vs
#: substructured with screening (best of 2): 26k unknowns 0.38 vs 0.40 s, 52k 1.05 vs 0.80 s,
#: 87k 2.25 vs 1.71 s, 130k 4.67 vs 2.88 s
MIN_UNKNOWNS = 40_000

#: largest number of contact rows for the dense Schur complement (T and its Cholesky: 2 m² doubles);
#: measured at 1.12M dofs with m = 9409: 174 s and 11.5 GB end to end, against 379 s without it
MAX_ROWS = 12000


def factorize_contact(A: sp.spmatrix, B: sp.spmatrix, backend: str = "auto", max_rows: int = MAX_ROWS,
                      min_unknowns: int = MIN_UNKNOWNS, flexibility: np.ndarray | None = None) -> Factorization:
    """``linalg.factorize(A)``, bordered by the contact rows B when that pays.

    When the backend ``supports_schur``, 0 < m ≤ ``max_rows`` and n ≥ ``min_unknowns``, this is
    ``factorize(A, backend, border=B)`` (``schur`` is S's dense Cholesky form, or None if T was not
    positive definite); otherwise ``factorize(A, backend)``. Solves and refinement are those of
    ``Factorization``. ``flexibility``: estimates of S_ii per row of B (``ContactQP.flexibility``); their mean
    weighs the border (``linalg.factorize``'s ``border_flexibility``).
    """
    name = resolve_backend(backend)
    A = sp.csr_matrix(A, dtype=float)
    B = sp.csr_matrix(B, dtype=float)
    if A.shape[0] != A.shape[1]:
        raise InputError("matrix", f"must be square, got {A.shape}")
    m, n = B.shape[0], A.shape[0]
    if B.shape[1] != n:
        raise InputError("B", f"must have {n} columns, got {B.shape[1]}")
    if not borders(n, m, name, max_rows, min_unknowns):
        return factorize(A, name)
    flexibility = None if flexibility is None else np.asarray(flexibility, float)
    positive = None if flexibility is None else flexibility[flexibility > 0]  # rows with ∇Z = 0 see nothing
    scale = float(np.mean(positive)) if positive is not None and positive.size else None
    return factorize(A, name, border=B, border_flexibility=scale)


def borders(n: int, m: int, backend: str = "auto", max_rows: int = MAX_ROWS, min_unknowns: int = MIN_UNKNOWNS) -> bool:
    """Whether ``factorize_contact`` borders A (n unknowns) by m rows, or factorises A alone."""
    return BACKENDS[resolve_backend(backend)].supports_schur and 0 < m <= max_rows and n >= min_unknowns
