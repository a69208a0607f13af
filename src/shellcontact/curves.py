"""Curves at the price of one solve: cases that differ only in their punches share one discretisation.

A *family* is a set of cases with the same shell, material, supports, loads, solver options and the
same mesh; only their ``[[punch]]`` tables (indentation, force, position, shape) and probes differ
(``family_key``). ``solve_family`` meshes and assembles the family once and factorises the reduced
stiffness once, and solves every point on it; each point gets its own contact rows B, gaps G and
Schur blocks (MODEL.md §8), and its Result is that of ``analysis.solve`` of its case alone:

* **The mesh must be the same.** The mesh is fitted to the punches (zone edges and first-contact
  lines are node lines, ``punches.fitted_lines``), so the key contains the node lines of the case's
  mesh: moving a sphere along x moves its first-contact line and makes another family, while an
  indentation or force change (same first contact, an explicit or unchanged zone), or a position change
  on a mesh read from a file, stays in one. A mesh fitted to all points would change every point's
  result, so families are never merged that way.
* **What is shared.** Below ``substructure.MIN_UNKNOWNS`` unknowns (and for the penalty method) the
  factorisation of A alone, for every point. Above it the exact methods factorise A bordered by the rows
  predicted to touch (``solvers.screening``); that factorisation is shared by the points whose border
  rows are equal — a force-controlled curve (the punch sits where it first touches, whatever the force:
  B, G and the Schur complement are the same at every point, only the prescribed force changes) — and
  rebuilt when they change: on an indentation curve of a curved punch B changes with the indentation
  (row i is ∇Z(M_i)·U(M_i), and ∇Z at the contact points turns as the punch moves).
* **Warm start** (``warm_start=True``): each point starts from its predecessor's active set (the same
  rows) or from the rows its predecessor's displacements close (other rows), and the Schur columns
  solved for rows beyond the screened ones are kept for the next point. The final result is the KKT
  point at ``[solver] tolerance`` of a strictly convex QP, which is unique: it does not depend on the
  start beyond the tolerance and round-off (the tests hold fields and forces to 1e-8 of their size).
  ``warm_start=False``: every point runs exactly as ``analysis.solve`` of its case alone, on a
  factorisation of the same matrix, so its Result is bit-identical to it (for a backend whose
  factorisation and solves are deterministic: the single-threaded ones here are) and independent of the
  other points — what a resumable study needs.
"""

from __future__ import annotations

import dataclasses
import hashlib
import os
from collections.abc import Callable, Iterator, Sequence

import numpy as np
import scipy.sparse as sp

from .analysis import Discretization, Factorizer, Result, Timer, discretize, solve_discretized
from .arguments import expect_callable, expect_choice
from .case import Case, expect_case
from .contact import contact_operator
from .errors import InputError
from .linalg import BACKENDS, Factorization, factorize
from .linalg.sparse import same_entries
from .mesh import node_lines
from .options import SolverOptions
from .punches import Punch, place_punches
from .sizing import check_size, mesh_lines
from .solvers import ContactQP
from .solvers.methods import METHODS
from .solvers.screening import initial_rows
from .solvers.substructure import MIN_UNKNOWNS, borders, factorize_contact

#: (point index, solver iteration, numeric fields of the solver's record)
FamilyProgress = Callable[[int, int, dict], None]


def family_key(case: Case) -> str:
    """A digest equal for cases that may share one factorisation: the same shell, material, supports,
    loads, solver options and mesh (its node lines, which follow the placed punches). Probes and
    ``[units]`` are not part of it (each Result keeps its own case). A shell or load given by a Python
    function enters by its identity, so such keys agree only within one process."""
    expect_case(case, "family_key")
    return _key(case, place_punches(case.punches, case.shell))


def _key(case: Case, punches: Sequence[Punch]) -> str:
    h = hashlib.sha256()
    h.update(repr((case.shell, case.supports, case.mesh, case.loads, case.solver)).encode())
    if case.mesh.file:  # the mesh is the file's: no fitted lines
        path = os.path.abspath(case.mesh.file)
        h.update(path.encode())
        try:
            with open(path, "rb") as f:
                h.update(hashlib.sha256(f.read()).digest())
        except OSError:
            pass  # the solve names the unreadable file
    else:
        for nodes in node_lines(case.shell, case.mesh, *mesh_lines(case, punches)):
            h.update(np.ascontiguousarray(nodes, dtype=float).tobytes())
            h.update(b"|")
    return h.hexdigest()


class SharedFactorizer(Factorizer):
    """One factorisation of the reduced stiffness for every point of a family (see the module docstring):
    A alone, or A bordered by the screened rows, kept while the points' border rows stay equal."""

    def __init__(self, keep_columns: bool) -> None:
        self.keep_columns = keep_columns
        self.plain: Factorization | None = None
        self.bordered: tuple[sp.csr_matrix, Factorization] | None = None
        self.factorizations = 0

    def linear(self, Ar: sp.csr_matrix, backend: str) -> Factorization:
        if self.plain is None:
            self.plain = factorize(Ar, backend)
            self.factorizations += 1
        return self.plain

    def contact(self, qp: ContactQP, groups: np.ndarray, initial_active: np.ndarray | None,
                opts: SolverOptions) -> tuple[Factorization, np.ndarray | None]:
        """As ``Factorizer.contact`` for a cold start (``screening.factorize_screened`` without a warm
        active set, so that the border does not follow the start), reused when the border is equal."""
        min_unknowns = 0 if opts.substructure is True else MIN_UNKNOWNS
        if not METHODS[opts.method].exact or opts.substructure is False:
            return self.linear(qp.A, opts.backend), None
        rows = initial_rows(qp.G, groups)
        if not borders(qp.n, rows.size, opts.backend, min_unknowns=min_unknowns):
            return self.linear(qp.A, opts.backend), None
        border = sp.csr_matrix(qp.B[rows])
        if self.bordered is not None and same_entries(self.bordered[0], border):
            fac = self.bordered[1]
        else:
            self.bordered = None  # the previous border's factors go before the new ones are built
            fac = factorize_contact(qp.A, border, opts.backend, min_unknowns=min_unknowns)
            self.factorizations += 1
            self.bordered = (border, fac)
        if fac.schur is None:  # T not positive definite: A's factors alone, no screening (as solve does)
            return fac, None
        if not self.keep_columns:  # the columns a previous point solved for: a cold start has none
            fac.schur.extra = None
        return fac, rows


def solve_family(cases: Sequence[Case], *, method: str | None = None, backend: str | None = None,
                 max_memory: float | str | None = None, progress: FamilyProgress | None = None,
                 warm_start: bool = True) -> Iterator[Result]:
    """Solve cases of one family (equal ``family_key``) on one mesh, assembly and factorisation; yields
    each case's Result in order, equal to ``analysis.solve(case, method=, backend=)`` (module docstring:
    to the tolerance with ``warm_start``, bit for bit without).

    ``progress(index, iteration, residuals)`` after every contact-solver iteration of point ``index``.
    ``max_memory`` bounds every point as in ``analysis.solve``. Cases of different families: InputError
    naming ``cases``.
    """
    cases = list(cases)
    for case in cases:
        expect_case(case, "solve_family")
    expect_choice(method, "solve_family", "method", METHODS)
    expect_choice(backend, "solve_family", "backend", ("auto", *BACKENDS))
    expect_callable(progress, "solve_family", "progress")
    if not isinstance(warm_start, bool):
        raise TypeError(f"solve_family(): warm_start must be True or False, got {type(warm_start).__name__}")
    placed = [place_punches(c.punches, c.shell) for c in cases]
    keys = [_key(c, p) for c, p in zip(cases, placed)]
    for i, k in enumerate(keys):
        if k != keys[0]:
            raise InputError("cases", f"case {i} is not of the family of case 0 (another shell, material, supports, "
                             "loads, solver options or mesh; family_key tells them apart): solve it on its own")
    return _solve_family(cases, placed, method, backend, max_memory, progress, warm_start)


def _solve_family(cases: list[Case], placed: list[list[Punch]], method: str | None, backend: str | None,
                  max_memory: float | str | None, progress: FamilyProgress | None,
                  warm_start: bool) -> Iterator[Result]:
    factorizer = SharedFactorizer(keep_columns=warm_start)
    base: Discretization | None = None
    previous: Result | None = None
    checked: list[tuple] = []  # the punch zones whose size was checked: the rows, and so the memory, follow them
    try:
        for i, (case, punches) in enumerate(zip(cases, placed)):
            opts = case.solver.with_method(method)
            if backend is not None:
                opts = dataclasses.replace(opts, backend=backend)
            timer = Timer()
            zones = tuple(p.zone for p in punches)
            if zones not in checked:
                with timer.stage("mesh"):
                    check_size(case, punches, max_memory, opts.method, opts.backend)
                checked.append(zones)
            if base is None:  # the family's mesh, space, stiffness, loads and supports
                d = base = discretize(case, opts.contact_points, timer, punches)
                base.space.memo = {}  # every point's post-processing evaluates the same points
            else:  # only this point's contact rows
                with timer.stage("assembly"):
                    op = contact_operator(base.space, punches, opts.contact_points) if punches else None
                d = dataclasses.replace(base, punches=punches, operator=op,
                                        Br=None if op is None else op.B @ base.reduction.P)
            step = None if progress is None else (lambda it, res, i=i: progress(i, it, res))
            result = solve_discretized(case, d, opts, timer, warm_start=previous if warm_start else None,
                                       progress=step, max_memory=max_memory, factorizer=factorizer)
            result.info["family"] = {"index": i, "points": len(cases), "factorizations": factorizer.factorizations}
            previous = result
            yield result
    finally:  # the Results keep the space: not its memo
        if base is not None:
            base.space.memo = None


def solve_families(cases: Sequence[Case], *, max_memory: float | str | None = None,
                   warm_start: bool = False) -> Iterator[tuple[int, Result]]:
    """Every case solved, those of one family (``family_key``) together by ``solve_family``: yields
    (index into ``cases``, Result), family by family in the order of their first case. Without a warm
    start (the default) each Result is bit-identical to ``analysis.solve`` of its case alone."""
    groups: dict[str, list[int]] = {}
    for i, case in enumerate(cases):
        try:
            key = family_key(case)
        except InputError:  # a punch that cannot be placed: its own solve reports it, in its turn
            key = f"alone {i}"
        groups.setdefault(key, []).append(i)
    for members in groups.values():
        results = solve_family([cases[i] for i in members], max_memory=max_memory, warm_start=warm_start)
        yield from zip(members, results)
