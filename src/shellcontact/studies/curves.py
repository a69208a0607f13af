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
* **What is shared.** Below ``substructure.MIN_UNKNOWNS`` unknowns the factorisation of A alone, for
  every point. Above it every method factorises A bordered by the rows
  predicted to touch (``solvers.screening``); that factorisation is shared by the points whose border
  rows are equal — a force-controlled curve (the punch sits where it first touches, whatever the force:
  B, G and the Schur complement are the same at every point, only the prescribed force changes). On an
  indentation curve of a curved punch B changes with the indentation (row i is ∇Z(M_i)·U(M_i), and ∇Z at
  the contact points turns as the punch moves), and with the punch's position: with a warm start one
  factorisation then still serves every point, bordered by the Cartesian displacement rows of all points'
  screened contact points (``Cartesian``: B = W K, so S = W (K A⁻¹ Kᵀ) Wᵀ; three border rows per point,
  equal to the points' own Schur blocks to round-off); without one (bit-identical Results) each new
  border is factorised again.
* **Warm start** (``warm_start=True``): each point starts from its predecessor's active set (the same
  rows) or from the rows its predecessor's displacements close (other rows), and the Schur columns
  solved for rows beyond the screened ones are kept for the next point. The final result is the KKT
  point at ``[solver] tolerance`` of a strictly convex QP, which is unique: it does not depend on the
  start beyond the tolerance and round-off (the tests hold fields and forces to 1e-8 of their size).
  A warm point on a shared bordered factorisation stops at its KKT check on the true gaps, without the
  lone solve's extra face refinement (``SchurComplement.refine_converged``): two solves fewer per point.
* **A force curve's points finish together** (``_solve_curve``, with the warm start, when the points' QPs
  differ only in their prescribed forces — the same rows B and gaps G — and the method is exact): every
  point's multipliers first, each warm-started from its predecessor's, then the final checks of all points
  with their solves in blocks (``screening.solve_screened_curve``: one block solve for the points' U, one for
  their duality-gap terms; at 211k unknowns 25 ms per point and solve instead of 68 ms). A point whose check
  fails, or whose rows outside the border penetrate, runs the lone screened solve. The Results come after the
  last point's multipliers (a point that fails is raised after the points before it), and each point's
  contact zone, rim and summary (stresses at every vertex, reactions, equilibrium) are made when first asked
  for (``analysis.contact_result(lazy=True)``: a non-finite value is refused at that first ``summary()``); a
  curve read for its forces and travels does not pay for them. A point's punches that differ from the first
  point's in their force only reuse its contact rows (``_operator``).
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
from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp

from ..analysis.discretization import Discretization, Timer, discretize
from ..analysis.pipeline import Factorizer, contact_result, prepare_contact, solve_discretized, solver_callback
from ..analysis.result import Result
from ..contact.operator import ContactOperator, contact_operator, point_flexibility
from ..contact.punches import Punch, place_punches
from ..errors import InputError, SolverError
from ..inputs.arguments import expect_callable, expect_choice
from ..linalg import BACKENDS, Factorization, factorize
from ..linalg.bordered import SchurRows
from ..linalg.sparse import same_entries
from ..problem.case import Case, expect_case
from ..problem.options import SolverOptions
from ..problem.sizing import check_size, mesh_lines
from ..shell.mesh import node_lines
from ..solvers import ContactQP
from ..solvers.methods import METHODS
from ..solvers.screening import initial_rows, solve_screened_curve
from ..solvers.substructure import MIN_UNKNOWNS, borders, factorize_contact

#: (point index, solver iteration, numeric fields of the solver's record)
FamilyProgress = Callable[[int, int, dict], None]


def family_key(case: Case) -> str:
    """A digest equal for cases that may share one factorisation: the same shell, material, supports,
    loads, solver options and mesh (its node lines, which follow the placed punches). Probes and
    ``[units]`` are not part of it (each Result keeps its own case). A shell or load given by a Python
    function enters by its identity, so such keys agree only within one process."""
    expect_case(case, "family_key")
    return _key(case, place_punches(case.punches, case.shell, case.units))


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
    A alone, or A bordered by the screened rows, kept while the points' border rows stay equal; with
    ``cartesian`` (set by ``solve_family`` with a warm start) points whose rows differ use one factorisation
    bordered by the Cartesian displacement rows of all points' screened contact points (``Cartesian``)."""

    def __init__(self, keep_columns: bool) -> None:
        self.keep_columns = keep_columns
        self.plain: Factorization | None = None
        self.bordered: tuple[sp.csr_matrix, Factorization] | None = None
        self.built = 0
        #: the current point's contact operator and the family's Cartesian border (``solve_family`` sets them)
        self.operator: ContactOperator | None = None
        self.cartesian: Cartesian | None = None

    @property
    def factorizations(self) -> int:
        """How many factorisations the family has built so far."""
        return self.built + (self.cartesian.factorizations if self.cartesian is not None else 0)

    def linear(self, Ar: sp.csr_matrix, backend: str) -> Factorization:
        if self.plain is None:
            self.plain = factorize(Ar, backend)
            self.built += 1
        return self.plain

    def contact(self, qp: ContactQP, groups: np.ndarray, initial_active: np.ndarray | None,
                opts: SolverOptions,
                predicted_gap: np.ndarray | None = None) -> tuple[Factorization, np.ndarray | None]:
        """As ``Factorizer.contact`` for a cold start (``screening.factorize_screened`` without a warm
        active set or a predicted gap, so that the border does not follow the start), reused when the border
        is equal."""
        min_unknowns = 0 if opts.substructure is True else MIN_UNKNOWNS
        if opts.substructure is False:
            return self.linear(qp.A, opts.backend), None
        rows = initial_rows(qp.G, groups)
        if not borders(qp.n, rows.size, opts.backend, min_unknowns=min_unknowns):
            return self.linear(qp.A, opts.backend), None
        border = sp.csr_matrix(qp.B[rows])
        if self.bordered is not None and same_entries(self.bordered[0], border):
            fac = self.bordered[1]
        else:
            if self.cartesian is not None and self.operator is not None:
                shared = self.cartesian.schur(qp, border, self.operator, rows, opts, min_unknowns)
                if shared is not None:
                    return shared, rows
            self.bordered = None  # the previous border's factors go before the new ones are built
            fac = factorize_contact(qp.A, border, opts.backend, min_unknowns=min_unknowns,
                                    flexibility=None if qp.flexibility is None else qp.flexibility[rows])
            self.built += 1
            self.bordered = (border, fac)
        if fac.schur is None:  # T not positive definite: A's factors alone, no screening (as solve does)
            return fac, None
        if not self.keep_columns:  # the columns a previous point solved for: a cold start has none
            fac.schur.extra = None
        # a warm point stops at its KKT check (tolerance met on the true gaps): the extra face refinement
        # and its two solves per point were half the cost of a force curve's points; a cold one runs as solve
        fac.schur.refine_converged = not self.keep_columns
        return fac, rows


def _same_borders(operators: list[ContactOperator | None]) -> bool:
    """Whether every point screens the same rows B[initial_rows] (a force curve: one border serves all)."""
    ops = [op for op in operators if op is not None]
    first = ops[0].B[initial_rows(ops[0].G, ops[0].punch)] if ops else None
    return all(same_entries(op.B[initial_rows(op.G, op.punch)], first) for op in ops[1:])


def _row_key(op: ContactOperator, i: int) -> tuple:
    """The contact point of row i: its vertex or edge and its surface (equal keys, equal Cartesian rows),
    then its (x, φ)."""
    return int(op.vertex[i]), int(op.facet[i]), float(op.zeta[i]), float(op.x[i]), float(op.phi[i])


class Cartesian:
    """One factorisation for points whose contact rows differ (an indentation curve, punch positions).

    Row i of B is ∇Z(M_i)·U(M_i) = Σ_c ∂_cZ(M_i) K_c,i U with K_c the Cartesian displacement components at
    the contact point M_i (``contact.contact_operator`` with the punch replaced by the plane of normal e_c).
    So for any point, B_r = W K_R over the rows R of every point's screened contact points, and
    S_rr = B_r A⁻¹ B_rᵀ = W (K_R A⁻¹ K_Rᵀ) Wᵀ: one factorisation of A bordered by K_R (3 rows per contact
    point) gives X = K_R A⁻¹ K_Rᵀ, and every point's dense Schur block follows by two sparse products.
    S differs from B A⁻¹ Bᵀ by round-off (~1e-10 relative, as the dense Schur complement of one border),
    which ``schur.Workspace.finish_exact`` corrects on the true gaps."""

    def __init__(self, space, reduction, operators: list[ContactOperator], points: str) -> None:
        self.space, self.reduction, self.points = space, reduction, points
        self.operators = operators
        self.factorizations = 0
        self._ready = False
        self._keys: dict[tuple, int] = {}
        self._X: np.ndarray | None = None
        self._fac: Factorization | None = None

    def _rows(self, op: ContactOperator) -> list[sp.csr_matrix]:
        """K_x, K_y, K_z of ``op``'s rows (same order)."""
        out = []
        for c in range(3):
            e = np.eye(3)[c]

            def plane(X: np.ndarray, c: int = c, e: np.ndarray = e) -> tuple[np.ndarray, np.ndarray]:
                return X[c], np.repeat(e[:, None], X.shape[1], axis=1)

            planes = [dataclasses.replace(p, body=plane, inverted=False, offset=np.zeros(3), mode="fixed")
                      for p in op.punches]
            out.append(contact_operator(self.space, planes, self.points).B)
        return out

    def _build(self, qp: ContactQP, opts: SolverOptions, min_unknowns: int) -> None:
        self._ready = True
        blocks: list[list[sp.csr_matrix]] = [[], [], []]
        cache: dict[tuple, list[sp.csr_matrix]] = {}
        for op in self.operators:
            if op is None:
                continue
            zones = tuple((p.zone, p.side) for p in op.punches)
            if zones not in cache:
                cache[zones] = self._rows(op)
            K = cache[zones]
            for i in initial_rows(op.G, op.punch):
                key = _row_key(op, int(i))
                if key not in self._keys:
                    self._keys[key] = len(self._keys)
                    for c in range(3):
                        blocks[c].append(K[c][int(i)])
        M = len(self._keys)
        if not borders(qp.n, 3 * M, opts.backend, min_unknowns=min_unknowns):
            return
        R = sp.vstack([sp.vstack(b) for b in blocks]).tocsr() @ self.reduction.P
        x, phi = np.array([k[3] for k in self._keys]), np.array([k[4] for k in self._keys])
        fac = factorize_contact(qp.A, R, opts.backend, min_unknowns=min_unknowns,
                                flexibility=point_flexibility(self.space.mesh.shell, x, phi))
        self.factorizations += 1
        if fac.schur is None:
            return
        sch = fac.schur
        X = sch.full()
        self._X, self._fac = 0.5 * (X + X.T), fac

    def schur(self, qp: ContactQP, border: sp.csr_matrix, op: ContactOperator, rows: np.ndarray,
              opts: SolverOptions, min_unknowns: int) -> Factorization | None:
        """The family's factorisation carrying the dense Schur block of ``border`` = B[rows] (None: the
        Cartesian border does not serve this point)."""
        if not self._ready:
            self._build(qp, opts, min_unknowns)
        if self._X is None or self._fac is None:
            return None
        try:
            idx = np.array([self._keys[_row_key(op, int(i))] for i in rows], dtype=np.int64)
        except KeyError:
            return None
        M = len(self._keys)
        r = np.repeat(np.arange(rows.size), 3)
        cols = (idx[:, None] + M * np.arange(3)[None, :]).ravel()
        W = sp.csr_matrix((op.grad[:, rows].T.ravel(), (r, cols)), shape=(rows.size, 3 * M))
        S = np.asarray((W @ np.asarray(W @ self._X).T).T)
        self._fac.schur = ProjectedSchur(border, 0.5 * (S + S.T))
        return self._fac


@dataclass
class ProjectedSchur(SchurRows):
    """S = B A⁻¹ Bᵀ of one point's screened rows B, from the family's ``Cartesian`` X: what
    ``schur.Workspace`` reads of a ``linalg.SchurComplement`` (m, matches, columns, extra)."""

    S: np.ndarray
    extra: tuple[sp.csr_matrix, np.ndarray] | None = field(default=None, repr=False)
    #: S is W X Wᵀ, off by round-off: the face refinement on the true gaps stays (``SchurComplement``)
    refine_converged: bool = True

    def columns(self, cols: np.ndarray) -> np.ndarray:
        return self.S[:, np.asarray(cols, dtype=np.int64)]


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
    placed = [place_punches(c.punches, c.shell, c.units) for c in cases]
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
    keep_memo = False
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
                with timer.stage("assembly"):  # every point's contact rows
                    operators = [d.operator] + [_operator(base.space, d.operator, placed[0], p, opts.contact_points)
                                                for p in placed[1:]]
                if warm_start and _one_qp(operators, opts):  # a force curve: its points' final solves in blocks
                    keep_memo = True  # the points make their zone, rim and summary when asked: on the memo
                    yield from _solve_curve(cases, placed, base, operators, timer, method, backend, max_memory,
                                            progress, factorizer)
                    return
                if warm_start and not _same_borders(operators):  # equal to round-off: one border for differing rows
                    factorizer.cartesian = Cartesian(base.space, base.reduction, operators, opts.contact_points)
            else:
                op = operators[i]
                d = dataclasses.replace(base, punches=punches, operator=op,
                                        Br=None if op is None else op.B @ base.reduction.P)
            factorizer.operator = d.operator
            step = None if progress is None else (lambda it, res, i=i: progress(i, it, res))
            result = solve_discretized(case, d, opts, timer, warm_start=previous if warm_start else None,
                                       progress=step, max_memory=max_memory, factorizer=factorizer)
            result.info["family"] = {"index": i, "points": len(cases), "factorizations": factorizer.factorizations}
            previous = result
            yield result
    finally:  # the Results keep the space, not its memo, unless they make their post-processing later
        if base is not None and not keep_memo:
            base.space.memo = None


def _same_data(a: object, b: object) -> bool:
    """Equal values, arrays and (frozen) dataclasses compared field by field."""
    if dataclasses.is_dataclass(a) and not isinstance(a, type):
        return type(a) is type(b) and all(_same_data(getattr(a, f.name), getattr(b, f.name))
                                          for f in dataclasses.fields(a))
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        return isinstance(a, np.ndarray) and isinstance(b, np.ndarray) and np.array_equal(a, b)
    if isinstance(a, list | tuple):
        return type(a) is type(b) and len(a) == len(b) and all(_same_data(x, y) for x, y in zip(a, b))  # type: ignore[arg-type]
    return a is b or a == b


def _operator(space, first: ContactOperator | None, first_punches: list[Punch], punches: list[Punch],
              points: str) -> ContactOperator | None:
    """The contact rows of a point: those of the first point with the new prescribed forces when the punches
    differ in their forces only (a force curve: the punch sits where it first touches, whatever the force),
    else ``contact.contact_operator`` (18 ms a point at 211k unknowns)."""
    if not punches:
        return None
    if first is not None and len(punches) == len(first_punches) and all(
            _same_data(dataclasses.replace(p, force=q.force), q) for p, q in zip(punches, first_punches)):
        return dataclasses.replace(first, punches=punches, forces=np.array(
            [punches[k].force for k in first.force_punches], dtype=float))
    return contact_operator(space, punches, points)


def _one_qp(operators: list[ContactOperator | None], opts: SolverOptions) -> bool:
    """Whether the points' QPs differ only in their prescribed forces (the same rows B and gaps G) and are
    solved by an exact method without extended precision: then ``_solve_curve`` makes their final checks
    together."""
    first = operators[0]
    return (len(operators) > 1 and METHODS[opts.method].exact and not opts.extended_precision
            and first is not None and all(op is not None and (op is first or (same_entries(op.B, first.B)
                                                                              and np.array_equal(op.G, first.G)))
                                          for op in operators))


def _solve_curve(cases: list[Case], placed: list[list[Punch]], base: Discretization,
                 operators: list[ContactOperator | None], timer: Timer, method: str | None, backend: str | None,
                 max_memory: float | str | None, progress: FamilyProgress | None,
                 factorizer: SharedFactorizer) -> Iterator[Result]:
    """A warm-started family whose QPs differ only in P (``_one_qp``): every point's multipliers on the one
    factorisation, warm-started from its predecessor, then the final checks of all points with their solves
    in blocks (``screening.solve_screened_curve``); each Result's contact zone, rim and summary are made when
    first asked for (``analysis.contact_result(lazy=True)``), with the space's memo, which the Results keep
    (at most ``spaces.MEMO_ENTRIES`` evaluations: 0.47 GB at 216k dofs; without it the 20 summaries of the
    benchmark's curve took 9.6 s instead of 2.2 s)."""
    setups, timers, options = [], [], []
    for i, (case, punches) in enumerate(zip(cases, placed)):
        opts = case.solver.with_method(method)
        if backend is not None:
            opts = dataclasses.replace(opts, backend=backend)
        t = timer if i == 0 else Timer()
        d = base if i == 0 else dataclasses.replace(base, punches=punches, operator=operators[i],
                                                    Br=operators[i].B @ base.reduction.P)
        factorizer.operator = d.operator
        setups.append((case, d, prepare_contact(case, d, opts, t, max_memory=max_memory, factorizer=factorizer)))
        timers.append(t)
        options.append(opts)
    opts = options[0]
    fac, screen = setups[0][2].factorization, setups[0][2].screen
    if any(s.factorization is not fac or not _same_rows(s.screen, screen) for _, _, s in setups):
        raise SolverError("curve: the points do not share one factorisation and row set")  # _one_qp rules it out
    kw: dict = {} if opts.max_iterations is None else {"max_iterations": opts.max_iterations}
    callbacks = [None if progress is None else solver_callback(lambda it, res, i=i: progress(i, it, res))
                 for i in range(len(cases))]
    solutions = solve_screened_curve([s.qp for _, _, s in setups], screen, METHODS[opts.method].load(), fac,
                                     tol=opts.tolerance, callbacks=callbacks, **kw)
    for i, ((case, d, setup), cs, t, o) in enumerate(zip(setups, solutions, timers, options)):
        t.times["solve"] = t.times.get("solve", 0.0) + cs.timings.get("total", 0.0)
        result = contact_result(case, d, o, t, setup.info, cs, lazy=True)
        result.timings["total"] = sum(v for k, v in result.timings.items() if k not in ("total", "output"))
        result.info["family"] = {"index": i, "points": len(cases), "factorizations": factorizer.factorizations}
        yield result


def _same_rows(a: np.ndarray | None, b: np.ndarray | None) -> bool:
    return (a is None and b is None) or (a is not None and b is not None and np.array_equal(a, b))


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
