"""The discrete contact QP of MODEL.md §8, its solution record, and the admissible-set check.

    minimise ½ UᵀAU − FᵀU − Pᵀδ   subject to   g = G + B U + D δ ≥ 0

δ (k unknowns, the rigid translations of force-controlled punches) and the term −Pᵀδ are
present only with force control (MODEL.md §5); the KKT conditions then include DᵀΛ = −P.
"""

from __future__ import annotations

import copy
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import scipy.sparse as sp

from ..errors import InputError, SolverError


@dataclass
class ContactQP:
    """Data of the contact QP (MODEL.md §8). A: n×n sparse SPD (supports already reduced),
    F: n, B: m×n sparse (row i = linearised Π at contact vertex i), G: m (Z at the vertices),
    weights: m vertex areas ω_i > 0. Force control: D (m×k, the δ-columns of the gap) and P
    (k prescribed forces). ``row_labels`` / ``force_labels`` name constraints and force
    columns in error messages (e.g. "punch.0 vertex 17 (x=0.1, phi=0.2)", "punch.0.force")."""

    A: Any
    F: np.ndarray
    B: Any
    G: np.ndarray
    weights: np.ndarray
    D: Any = None
    P: np.ndarray | None = None
    row_labels: list[str] | None = None
    force_labels: list[str] | None = None
    #: an estimate of S_ii = B_i A⁻¹ B_iᵀ per row (None: unknown), which weighs the border of a bordered
    #: factorisation (``substructure.factorize_contact``); the solution does not depend on it
    flexibility: np.ndarray | None = None
    #: skip the check max|A − Aᵀ| ≤ 1e-10 max|A| (2-3 s at 1.1M dofs) for a matrix symmetric by
    #: construction (``analysis.Discretization.qp``: Pᵀ A P of an assembled stiffness)
    symmetric: bool = field(default=False, repr=False)
    #: (k,) bool: the δ columns that only friction holds (a shell's rigid motion no gap sees, D_j = 0): their
    #: balance is the friction's, which the friction solvers check; the frictionless feasibility check skips them
    friction_held: np.ndarray | None = None
    #: skip the check that A is finite too (``analysis.Discretization.qp`` checks its reduced stiffness once for
    #: every QP it builds: two passes over 20M entries, 14 ms, per point of a curve at 211k unknowns)
    finite: bool = field(default=False, repr=False)
    _abs_A: Any = field(default=None, init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        if not sp.issparse(self.A):
            raise InputError("qp.A", "must be a scipy.sparse matrix")
        # a CSR stiffness of doubles stays the very object given (the points of a curve share it: ``screening``)
        A = self.A if type(self.A) is sp.csr_matrix and self.A.dtype == float else sp.csr_matrix(self.A, dtype=float)
        n = A.shape[0]
        if A.shape != (n, n) or n == 0:
            raise InputError("qp.A", f"must be square and non-empty, got shape {A.shape}")
        if not (self.finite and self.symmetric):
            amax = max(float(A.data.max()), -float(A.data.min())) if A.nnz else 0.0  # (a NaN propagates; no copy)
            if not np.isfinite(amax):
                raise InputError("qp.A", "has non-finite entries")
            asym = 0.0 if self.symmetric or not A.nnz else abs(A - A.T).max()
            if asym > 1e-10 * amax:
                raise InputError("qp.A", f"must be symmetric (max |A - Aᵀ| = {asym:.3e}, max |A| = {amax:.3e})")
        self.A = A
        self.F = _vector("qp.F", self.F, n)
        B = sp.csr_matrix(self.B, dtype=float) if sp.issparse(self.B) else sp.csr_matrix(np.atleast_2d(self.B))
        if B.shape[1] != n:
            raise InputError("qp.B", f"must have {n} columns (one per unknown), got shape {B.shape}")
        if B.nnz and not np.all(np.isfinite(B.data)):
            raise InputError("qp.B", "has non-finite entries")
        B.sum_duplicates()
        B.sort_indices()
        self.B = B
        m = B.shape[0]
        self.G = _vector("qp.G", self.G, m)
        self.weights = _vector("qp.weights", self.weights, m)
        if np.any(self.weights <= 0):
            raise InputError("qp.weights", "vertex weights must be > 0")
        if self.flexibility is not None:
            self.flexibility = _vector("qp.flexibility", self.flexibility, m)
            if np.any(self.flexibility < 0):
                raise InputError("qp.flexibility", "row flexibilities must be ≥ 0")
        if (self.D is None) != (self.P is None):
            raise InputError("qp.D", "force control needs both D (m×k) and P (k), or neither")
        if self.D is not None:
            D = self.D.toarray() if sp.issparse(self.D) else np.asarray(self.D, dtype=float)
            if D.ndim == 1:
                D = D[:, None]
            if D.shape[0] != m:
                raise InputError("qp.D", f"must have {m} rows (one per constraint), got shape {D.shape}")
            if not np.all(np.isfinite(D)):
                raise InputError("qp.D", "has non-finite entries")
            self.D = np.ascontiguousarray(D, dtype=float)
            self.P = _vector("qp.P", self.P, D.shape[1])
        if self.row_labels is not None and len(self.row_labels) != m:
            raise InputError("qp.row_labels", f"needs {m} labels, got {len(self.row_labels)}")
        if self.force_labels is not None and len(self.force_labels) != self.k:
            raise InputError("qp.force_labels", f"needs {self.k} labels, got {len(self.force_labels)}")

    @property
    def n(self) -> int:
        return self.A.shape[0]

    @property
    def m(self) -> int:
        return self.B.shape[0]

    @property
    def k(self) -> int:
        return 0 if self.D is None else self.D.shape[1]

    def gap(self, U: np.ndarray, delta: np.ndarray | None = None) -> np.ndarray:
        """g = G + B U (+ D δ): the linearised Π at the contact vertices."""
        g = self.G + self.B @ U
        if self.D is not None and delta is not None:
            g = g + self.D @ delta
        return g

    def energy(self, U: np.ndarray, delta: np.ndarray | None = None) -> float:
        """𝓔(U) = ½UᵀAU − FᵀU (− Pᵀδ under force control)."""
        e = 0.5 * float(U @ (self.A @ U)) - float(self.F @ U)
        if self.P is not None and delta is not None:
            e -= float(self.P @ delta)
        return e

    @property
    def abs_A(self) -> sp.csr_matrix:
        """|A| entrywise (for backward errors), computed once; shares A's index arrays."""
        if self._abs_A is None:
            A = sp.csr_matrix(self.A)
            self._abs_A = sp.csr_matrix((np.abs(A.data), A.indices, A.indptr), shape=A.shape, copy=False)
        return self._abs_A

    def restrict(self, rows: np.ndarray) -> ContactQP:
        """The same QP with only the constraints ``rows`` (in that order); A and F are shared,
        not copied or validated again."""
        rows = np.asarray(rows, dtype=np.int64)
        self.abs_A  # noqa: B018 — computed here once, shared by every restriction
        sub = copy.copy(self)
        sub.B = self.B[rows]
        sub.G = self.G[rows]
        sub.weights = self.weights[rows]
        if self.flexibility is not None:
            sub.flexibility = self.flexibility[rows]
        if self.D is not None:
            sub.D = np.ascontiguousarray(self.D[rows])
        if self.row_labels is not None:
            sub.row_labels = [self.row_labels[i] for i in rows]
        return sub

    def label(self, i: int) -> str:
        return self.row_labels[i] if self.row_labels is not None else f"constraint {i}"

    def force_label(self, j: int) -> str:
        return self.force_labels[j] if self.force_labels is not None else f"force column {j}"


def check_arguments(tol: float, max_iterations: int) -> None:
    """The solvers' common arguments (a direct API: the case file has validated its own values)."""
    if not (np.isfinite(tol) and tol > 0):
        raise InputError("tol", f"must be a positive number, got {tol!r}")
    if int(max_iterations) != max_iterations or max_iterations < 1:
        raise InputError("max_iterations", f"must be a positive integer, got {max_iterations!r}")


def as_mask(active: np.ndarray, m: int) -> np.ndarray:
    """A starting active set given as a boolean mask or as row indices → a boolean mask of length m."""
    a = np.asarray(active)
    if a.dtype == bool:
        if a.shape != (m,):
            raise InputError("initial_active", f"boolean mask must have length {m}, got {a.shape}")
        return a.copy()
    mask = np.zeros(m, dtype=bool)
    idx = a.astype(np.int64).reshape(-1)
    if idx.size and (idx.min() < 0 or idx.max() >= m):
        raise InputError("initial_active", f"indices must lie in [0, {m})")
    mask[idx] = True
    return mask


def check_growth(growth: float) -> None:
    """The working-set growth θ of the active-set and dual methods (``schur.default_growth``)."""
    if not (0.0 <= growth < 1.0):
        raise InputError("growth", f"must lie in [0, 1), got {growth!r}")


def _vector(name: str, v: Any, size: int) -> np.ndarray:
    a = np.asarray(v, dtype=float).reshape(-1)
    if a.shape != (size,):
        raise InputError(name, f"must have length {size}, got {a.size}")
    if not np.all(np.isfinite(a)):
        raise InputError(name, "has non-finite entries")
    return a


class History(list):
    """Per-iteration records of a solver; ``callback(record)`` sees each one as it is appended."""

    def __init__(self, callback: Callable[[dict[str, Any]], None] | None = None) -> None:
        super().__init__()
        self.callback = callback

    def append(self, record: dict[str, Any]) -> None:
        super().append(record)
        if self.callback is not None:
            self.callback(record)


@dataclass
class ContactSolution:
    """What every contact solver returns.

    U, Lambda (nodal contact forces Λ ≥ 0), pressure = Λ/ω, active (bool, m: the constraints
    held as equalities with Λ_i > 0; for the penalty method the penetrating ones), delta
    (force-control translations or None), iterations, residuals (see ``kkt.kkt_residuals``),
    method, history (one dict per iteration), timings (seconds: factorization, schur = the
    blocked solves for columns of S = B A⁻¹ Bᵀ, solve, total; plus n_solves = right-hand
    sides solved with the factorisation), energy 𝓔(U) (− Pᵀδ), dual_value q(Λ)."""

    U: np.ndarray
    Lambda: np.ndarray
    pressure: np.ndarray
    active: np.ndarray
    delta: np.ndarray | None
    iterations: int
    residuals: dict[str, float]
    method: str
    history: list[dict[str, Any]] = field(default_factory=list)
    timings: dict[str, float] = field(default_factory=dict)
    energy: float = float("nan")
    dual_value: float = float("nan")
    info: dict[str, Any] = field(default_factory=dict)

    @property
    def gap(self) -> np.ndarray:
        return self.info["gap"]


class InfeasibleProblemError(SolverError):
    """The admissible set {G + BU + Dδ ≥ 0} is empty (e.g. a punch overlapping a clamped edge),
    or under force control the prescribed force cannot be carried (DᵀΛ = −P, Λ ≥ 0 has no
    solution). ``constraints`` lists the indices of an infeasible subset."""

    def __init__(self, message: str, constraints: list[int], residuals: dict | None = None) -> None:
        self.constraints = list(constraints)
        super().__init__(message, residuals=residuals)


def _zero_rows(qp: ContactQP) -> np.ndarray:
    """Rows of B (and D) that vanish, relative to the largest row norm."""
    rn = np.sqrt(np.asarray(qp.B.multiply(qp.B).sum(axis=1)).ravel())
    if qp.D is not None:
        rn = np.sqrt(rn**2 + np.sum(qp.D**2, axis=1))
    ref = rn.max() if rn.size else 0.0
    return rn <= 1e-14 * ref if ref > 0 else np.ones(qp.m, dtype=bool)


def _describe(qp: ContactQP, idx: np.ndarray, limit: int = 8) -> str:
    names = [f"{qp.label(int(i))} (G={qp.G[i]:.4g})" for i in idx[:limit]]
    more = f" and {len(idx) - limit} more" if len(idx) > limit else ""
    return "; ".join(names) + more


def check_feasibility(qp: ContactQP) -> np.ndarray:
    """Raise ``InfeasibleProblemError`` if no (U, δ) satisfies G + BU + Dδ ≥ 0, or (force
    control) no Λ ≥ 0 satisfies DᵀΛ = −P. Returns the mask of "live" rows (rows of B and D
    that do not vanish); vanishing rows with G_i ≥ 0 are always satisfied and carry Λ_i = 0.

    Tests, cheapest first: (1) a vanishing row with G_i < 0 (the punch overlaps a clamped
    point); (2) G ≥ 0, or every live row owns a column no other live row touches (then B has
    full row rank): feasible; (3) otherwise the LP  min t  s.t.  G + BU + Dδ + t ≥ 0, t ≥ 0
    over the columns B touches (HiGHS); t* > 0 is the least achievable penetration, and the
    rows with positive LP multipliers form the infeasible subset (a Farkas certificate)."""
    zero = _zero_rows(qp)
    bad = np.flatnonzero(zero & (qp.G < 0))
    if bad.size:
        raise InfeasibleProblemError(
            "empty admissible set: the contact constraint cannot be met because its row of B vanishes "
            "(the point cannot move: clamped support) while the punch overlaps the undeformed shell there: "
            + _describe(qp, bad),
            bad.tolist(),
            residuals={"penetration": float(-qp.G[bad].min())},
        )
    live = ~zero
    if qp.k:
        _check_force_feasible(qp, live)
    if np.all(qp.G[live] >= 0):
        return live
    Bl = qp.B[live]
    Bc = Bl.tocsc()
    Bc.eliminate_zeros()
    counts = np.diff(Bc.indptr)
    private = Bc[:, counts == 1].tocsr()
    if np.all(np.diff(private.indptr) > 0):
        return live
    from scipy.optimize import linprog

    used = np.flatnonzero(counts > 0)
    M = Bc[:, used]
    cols = [M]
    if qp.D is not None:
        cols.append(sp.csr_matrix(qp.D[live]))
    ml = int(live.sum())
    cols.append(sp.csr_matrix(np.ones((ml, 1))))
    Aub = -sp.hstack(cols, format="csr")
    gs = float(np.abs(qp.G).max())
    nv = Aub.shape[1]
    c = np.zeros(nv)
    c[-1] = 1.0
    bounds = [(None, None)] * (nv - 1) + [(0, None)]
    res = linprog(c, A_ub=Aub, b_ub=qp.G[live] / gs, bounds=bounds, method="highs")
    if res.status == 0 and res.fun > 1e-9:
        y = -np.asarray(res.ineqlin.marginals)
        rows = np.flatnonzero(live)[y > 1e-9 * max(y.max(), 1e-300)]
        raise InfeasibleProblemError(
            f"empty admissible set: no displacement satisfies all contact constraints; the least achievable "
            f"penetration is {res.fun * gs:.4g}, forced by the constraints " + _describe(qp, rows),
            rows.tolist(),
            residuals={"penetration": float(res.fun * gs)},
        )
    return live


def _check_force_feasible(qp: ContactQP, live: np.ndarray) -> None:
    normal = np.ones(qp.k, bool) if qp.friction_held is None else ~np.asarray(qp.friction_held, bool)
    D = qp.D[live]
    for j in np.flatnonzero(normal):
        if qp.P[j] > 0 and not np.any(D[:, j] < 0):
            raise InfeasibleProblemError(
                f"{qp.force_label(j)}: the prescribed force {qp.P[j]:.4g} cannot be carried: no candidate contact "
                "vertex lies ahead of the punch along its direction",
                [],
            )
        if qp.P[j] < 0 and not np.any(D[:, j] > 0):
            raise InfeasibleProblemError(
                f"{qp.force_label(j)}: the prescribed force {qp.P[j]:.4g} pulls the punch away from the shell; "
                "frictionless contact without adhesion cannot carry it",
                [],
            )
    if normal.sum() > 1:
        from scipy.optimize import linprog

        res = linprog(np.zeros(D.shape[0]), A_eq=D[:, normal].T, b_eq=-qp.P[normal], bounds=[(0, None)] * D.shape[0],
                      method="highs")
        if res.status == 2:
            raise InfeasibleProblemError(
                "the prescribed punch forces cannot be carried together by compressive contact forces "
                f"({', '.join(qp.force_label(j) for j in range(qp.k))})",
                [],
            )
