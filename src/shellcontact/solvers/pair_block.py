"""The friction pairs' products without a solve per pair: A bordered by the normal AND the tangential rows.

The semismooth Newtons of ``tresca_newton`` and ``coulomb_newton`` need, per pair j of the system,
B A⁻¹C_jᵀ and C A⁻¹C_jᵀ. Solving A⁻¹C_jᵀ costs a sparse solve per column (0.043 CPU s at 211k unknowns:
≈ 43 s for the 493 pairs of the panel's contact set). ``factorize_pairs`` instead factorises A bordered by
R = [B_r; C_r] of the rows r (``linalg.bordered``: PARDISO's Schur complement of the border), so that
W = R A⁻¹ Rᵀ — the normal block S, the cross block B A⁻¹Cᵀ and the tangential block C A⁻¹Cᵀ of those rows —
comes from the dense Cholesky factor of T, 2 (3k)² flops per column, and its factors serve every solve with A.
The factorisation's ``schur`` is the normal part (``NormalView``: ``schur.Workspace`` reads S from it as from
the frictionless pipeline's border), ``pair_schur`` the whole W.

``PairBlock`` gives the pair products of a QP whose first k rows are r (``tresca_screened``: r first, then rows
that joined); the rows e after them get their part by one blocked solve A⁻¹[B_e; C_e]ᵀ per row set.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp

from ..linalg import Factorization, SchurComplement
from ..linalg.bordered import SchurRows
from .qp import ContactQP
from .substructure import factorize_contact


def pair_rows(rows: np.ndarray) -> np.ndarray:
    """The rows 2j, 2j+1 of C of the rows j."""
    return np.stack([2 * rows, 2 * rows + 1], axis=1).ravel().astype(int)


@dataclass
class NormalView(SchurRows):
    """The normal block S = B_r A⁻¹ B_rᵀ (the first k rows) of the joint Schur complement ``joint`` of
    [B_r; C_r], with the fields ``schur.Workspace`` reads of a ``SchurComplement``."""

    joint: SchurComplement = field(repr=False, default=None)  # type: ignore[assignment]
    extra: tuple[sp.csr_matrix, np.ndarray] | None = field(default=None, repr=False)
    refine_converged: bool = True
    seconds: float = 0.0

    def columns(self, cols: np.ndarray) -> np.ndarray:
        return self.joint.columns(np.asarray(cols, dtype=np.int64))[: self.m]

    def full(self) -> np.ndarray:
        return self.columns(np.arange(self.m))


#: the rows of the joint border per row in contact in the frictionless start: with a slide the contact moves
#: (68k unknowns, μ = 0.3: 110 rows in frictionless contact, and the Newton's solution on them penetrated 323 rows
#: outside, each then three solves A⁻¹[B_e; C_e]ᵀ: 29 of 39 CPU s)
MARGIN = 2.0


def border_rows(Lam: np.ndarray, gap: np.ndarray, margin: float = MARGIN) -> np.ndarray:
    """The rows of the joint border: those in contact (Λ > 0) and, of the others, the nearest to contact (the
    smallest gaps), ``margin`` × as many rows in all; sorted."""
    touching = Lam > 0
    count = int(np.ceil(margin * touching.sum())) - int(touching.sum())
    others = np.flatnonzero(~touching)
    near = others[np.argsort(gap[others], kind="stable")[:max(count, 0)]]
    return np.sort(np.concatenate([np.flatnonzero(touching), near]))


def factorize_pairs(qp: ContactQP, C: sp.csr_matrix, rows: np.ndarray, backend: str = "auto") -> Factorization | None:
    """A bordered by [B_rows; C_rows] (module docstring), or None where the backend computes no Schur complement
    (or T was not positive definite): then the pairs are solved for."""
    rows = np.asarray(rows, dtype=np.int64)
    R = sp.vstack([qp.B[rows], C[pair_rows(rows)]], format="csr")
    flex = None if qp.flexibility is None else qp.flexibility[rows]
    fac = factorize_contact(qp.A, R, backend, max_rows=3 * max(rows.size, 1), min_unknowns=0, flexibility=flex)
    if not isinstance(fac.schur, SchurComplement):
        return None
    joint = fac.schur
    fac.schur = NormalView(B=qp.B[rows], joint=joint, seconds=joint.seconds)
    fac.pair_schur = joint  # type: ignore[attr-defined]
    return fac


class PairBlock:
    """B A⁻¹C_jᵀ (m × 2) and C A⁻¹C_jᵀ (2m × 2) of the pairs j < k of ``qp`` (whose first k rows are the joint
    border's rows) from the joint Schur complement; the rows after the k by one blocked solve A⁻¹[B_e; C_e]ᵀ per
    row e, kept by the row's index in the whole QP (``rows``: qp's rows there) in ``tail`` (a dict the caller
    keeps across row sets: a row set that grows solves only for its new rows)."""

    def __init__(self, qp: ContactQP, C: sp.csr_matrix, fac: Factorization, rows: np.ndarray,
                 tail: dict | None = None) -> None:
        self.joint: SchurComplement = fac.pair_schur  # type: ignore[attr-defined]
        self.k = fac.schur.m
        self.qp, self.C, self.fac, self.rows = qp, C, fac, np.asarray(rows, dtype=np.int64)
        self.tail: dict = {} if tail is None else tail

    @staticmethod
    def applies(qp: ContactQP, fac: Factorization) -> bool:
        """Whether ``fac`` is a ``factorize_pairs`` factorisation whose rows are the first rows of ``qp``."""
        sch = getattr(fac, "pair_schur", None)
        return sch is not None and fac.schur.m <= qp.m and fac.schur.matches(qp.B[: fac.schur.m])

    def _tail_products(self) -> tuple[np.ndarray, np.ndarray]:
        """C_k A⁻¹B_eᵀ (2k × e) and C_k A⁻¹C_eᵀ (2k × 2e) for the rows e after the first k."""
        k, m = self.k, self.qp.m
        local = np.arange(k, m)
        new = local[[int(r) not in self.tail for r in self.rows[local]]]
        if new.size:
            RT = sp.vstack([self.qp.B[new], self.C[pair_rows(new)]], format="csr").T.tocsc()
            Z = self.fac.solve_many(RT.toarray(), refine=False)
            CZ = self.C[: 2 * k] @ Z
            for i, e in enumerate(new):
                self.tail[int(self.rows[e])] = (CZ[:, i], CZ[:, new.size + 2 * i:new.size + 2 * i + 2])
        TB = np.empty((2 * k, local.size))
        TC = np.empty((2 * k, 2 * local.size))
        for i, e in enumerate(self.rows[local]):
            TB[:, i], TC[:, 2 * i:2 * i + 2] = self.tail[int(e)]
        return TB, TC

    def products(self, pairs: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(B A⁻¹C_Pᵀ (m × 2p), C A⁻¹C_Pᵀ (2m × 2p)) for pairs P, all < k, columns in the order of P."""
        k, m = self.k, self.qp.m
        W = self.joint.columns(k + pair_rows(pairs))  # 3k × 2p
        BX, CX = np.empty((m, W.shape[1])), np.empty((2 * m, W.shape[1]))
        BX[:k], CX[: 2 * k] = W[:k], W[k:]
        if m > k:
            TB, TC = self._tail_products()
            BX[k:], CX[2 * k:] = TB[pair_rows(pairs)].T, TC[pair_rows(pairs)].T
        return BX, CX
