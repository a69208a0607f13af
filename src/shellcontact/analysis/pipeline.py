"""From a validated case to a solution: mesh → space → assembly → (contact) solve, with timings.

Without punches this is one linear solve. With punches the discrete problem is the QP of
MODEL.md §8, solved in the reduced space U = P U_r by the method of ``[solver] method``:

* ``"active-set"`` — exact primal: primal–dual active set / semismooth Newton (default);
* ``"dual"`` — the dual QP (7.9) on the multipliers, MPRGP with exact face solves;
* ``"penalty"`` — (6.7)–(6.8) with penalty ε (``[solver] penalty``), optional continuation.

All three share one factorisation of the reduced stiffness. ``nested = true`` first solves the
case on the next coarser mesh (``mesh.refine`` − 1, recursively) and starts from that solution
interpolated onto the fine mesh; ``warm_start=`` does the same from any earlier Result.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
import scipy.sparse as sp

from ..contact.operator import ContactOperator, contact_operator, contact_zone, penetration_outside
from ..contact.punches import Punch, check_linear_range, place_punches
from ..contact.rim import rim_line_force
from ..errors import InputError, SolverError
from ..inputs.arguments import expect_callable, expect_choice
from ..linalg import BACKENDS, Factorization, factorize
from ..linalg.mumps import configure as configure_mumps
from ..outputs.results import ShellSolution
from ..problem.case import Case, expect_case
from ..problem.options import SolverOptions
from ..problem.sizing import check_size
from ..shell.spaces import ShellSpace
from ..solvers import ContactQP, ContactSolution
from ..solvers.methods import METHODS
from ..solvers.screening import coarse_start_pays, factorize_screened, solve_screened
from ..solvers.substructure import MIN_UNKNOWNS
from ..units import with_unit
from .discretization import Discretization, Timer, discretize
from .friction import attach_friction, has_friction, solve_friction
from .result import ContactResult, Result, _checked
from .validity import ResultWarning, unit_hint_on_error

#: the penalty ratio κ = ε·E₂t/a² (``penalty_ratio``) predicts the penalty method's relative force error
#: κ + ε_mach/κ (penetration over deflection; gap round-off over penetration). Above ``PENALTY_WARN`` a
#: warning, above ``PENALTY_REFUSE`` the penalty is refused (docs/solvers.md, "Choosing ε (penalty)")
PENALTY_WARN = 1e-3
PENALTY_REFUSE = 1e-1


def default_penalty(case: Case) -> float:
    """ε = 1e-6 · a²/(E₂ t): springs 10⁶ times stiffer than the membrane ring stiffness E₂ t/a² of the shell.

    E₂ is the material's hoop modulus σ22/ε22 at σ11 = σ12 = 0: Young's modulus E of an isotropic
    shell, the circumferential modulus E2 of an orthotropic one.
    """
    return 1e-6 / penalty_ratio(case, 1.0)


def penalty_ratio(case: Case, eps: float) -> float:
    """κ = ε·E₂t/a²: the shell's ring stiffness E₂t/a² over the springs' stiffness 1/ε per unit area.

    The penetration is about κ times the deflection (the model error of the penalty solution), and
    the gaps' round-off, ε_mach times the deflection, is ε_mach/κ of the penetration, from which the
    pressure (penetration/ε) is computed: the relative force error is about κ + ε_mach/κ (measured on
    the paper panel at κ = 1e-14 … 1e2: docs/solvers.md). The default ε gives κ = 1e-6.
    """
    sh = case.shell
    t = float(np.mean(sh.t(np.array([sh.x_min, sh.x_max]), np.array([sh.alpha, sh.beta]))))
    return eps * sh.material.hoop_modulus * t / sh.radius**2


def check_penalty(case: Case, eps: float, continuation: tuple[float, ...] = ()) -> list[str]:
    """Refuse an ε whose predicted force error κ + ε_mach/κ exceeds ``PENALTY_REFUSE`` (InputError
    naming ``solver.penalty`` or ``solver.continuation``); the warnings for one above ``PENALTY_WARN``."""
    eps_mach = float(np.finfo(float).eps)

    def error(e: float) -> tuple[float, float]:
        kappa = penalty_ratio(case, e)
        return kappa, kappa + eps_mach / kappa

    def between(limit: float) -> str:  # the ε range whose predicted error stays (about) below limit
        return f"between {_eps_for(case, eps_mach / limit):.3g} and {_eps_for(case, limit):.3g}"

    for key, values in (("solver.continuation", continuation), ("solver.penalty", (eps,))):
        for e in values:
            kappa, err = error(e)
            if not err <= PENALTY_REFUSE:
                why = ("the penetration is comparable to the deflection" if kappa > eps_mach / kappa else
                       "the gaps' round-off is comparable to the penetration")
                raise InputError(key, f"ε = {e:.4g} gives κ = ε·E₂t/a² = {kappa:.3g} and a predicted force error "
                                 f"κ + ε_mach/κ = {err:.2g} > {PENALTY_REFUSE:g}: {why}; ε must lie "
                                 f"{between(PENALTY_REFUSE)} (default {default_penalty(case):.3g})")
    kappa, err = error(eps)
    if err > PENALTY_WARN:
        return [ResultWarning(
            "penalty_accuracy", f"solver.penalty: ε = {eps:.4g} (κ = ε·E₂t/a² = {kappa:.3g}) predicts a relative "
            f"force error of about {err:.2g} (κ + ε_mach/κ); {between(PENALTY_WARN)} it stays below {PENALTY_WARN:g}")]
    return []


def _eps_for(case: Case, kappa: float) -> float:
    return kappa / penalty_ratio(case, 1.0)


def solver_callback(progress: Callable[[int, dict], None]) -> Callable[[dict], None]:
    """The solvers' ``callback(record)`` as ``progress(iteration, numeric fields of the record)``."""
    return lambda rec: progress(int(rec.get("iteration", 0)), {k: v for k, v in rec.items() if isinstance(v, float)})


def _solve_contact(qp: ContactQP, opts: SolverOptions, fac, initial_U_r: np.ndarray | None,
                   initial_active: np.ndarray | None, eps: float, progress=None, screen: np.ndarray | None = None):
    """Run the registered method ``opts.method`` (solvers.methods) on the reduced QP."""
    kw: dict[str, Any] = {"tol": opts.tolerance, "factorization": fac}
    if progress is not None:
        kw["callback"] = solver_callback(progress)
    if opts.max_iterations is not None:
        kw["max_iterations"] = opts.max_iterations
    method = METHODS[opts.method]
    if not method.exact:
        return solve_screened(qp, screen, method.load(), exact=False, epsilon=eps,
                              continuation=list(opts.continuation) or None, initial_U=initial_U_r, **kw)
    return solve_screened(qp, screen, method.load(), initial_active=initial_active,
                          extended=opts.extended_precision, **kw)


def solve(case: Case, method: str | None = None, backend: str | None = None,
          warm_start: Result | None = None, progress: Callable[[int, dict], None] | None = None,
          max_memory: float | str | None = None) -> Result:
    """Solve ``case``: the linear shell problem, or the contact problem when it has punches.

    ``progress(iteration, residuals)`` is called after every contact-solver iteration. Before anything
    is built, the memory the case needs is estimated (``sizing``) and a case needing more than
    ``max_memory`` (bytes, or a size such as ``"8G"``; default: the memory available) is refused
    (InputError naming the mesh key).
    """
    expect_case(case, "solve")
    expect_choice(method, "solve", "method", METHODS)
    expect_choice(backend, "solve", "backend", ("auto", *BACKENDS))
    if warm_start is not None and not isinstance(warm_start, Result):
        raise TypeError(f"solve(): warm_start must be a Result of an earlier solve or None, got "
                        f"{type(warm_start).__name__}")
    expect_callable(progress, "solve", "progress")
    opts = case.solver.with_method(method)
    if backend is not None:
        opts = dataclasses.replace(opts, backend=backend)
    timer = Timer()
    with unit_hint_on_error(case):
        with timer.stage("mesh"):
            punches = place_punches(case.punches, case.shell, case.units)
            check_size(case, punches, max_memory, opts.method, opts.backend)
        d = discretize(case, opts.contact_points, timer, punches)
        return solve_discretized(case, d, opts, timer, warm_start=warm_start, progress=progress,
                                 max_memory=max_memory)


class Factorizer:
    """How ``solve_discretized`` factorises: afresh for every case (``solve``). A subclass may lend one
    factorisation to several cases on the same mesh (``curves.SharedFactorizer``)."""

    def linear(self, Ar: sp.csr_matrix, backend: str) -> Factorization:
        return factorize(Ar, backend)

    def contact(self, qp: ContactQP, groups: np.ndarray, initial_active: np.ndarray | None,
                opts: SolverOptions,
                predicted_gap: np.ndarray | None = None) -> tuple[Factorization, np.ndarray | None]:
        """The factorisation of the reduced stiffness and the screened rows (None: the whole QP directly): A bordered
        by the rows predicted to touch (``solvers.screening``; by a coarser level's ``predicted_gap``), every method."""
        if opts.substructure is not False:
            return factorize_screened(qp, groups, initial_active, opts.backend,
                                      0 if opts.substructure is True else MIN_UNKNOWNS, predicted_gap)
        return factorize(qp.A, opts.backend), None


def solve_discretized(case: Case, d: Discretization, opts: SolverOptions, timer: Timer, *,
                      warm_start: Result | None = None, progress: Callable[[int, dict], None] | None = None,
                      max_memory: float | str | None = None, factorizer: Factorizer | None = None,
                      lazy: bool = False) -> Result:
    """``solve`` from the discretisation ``d`` of ``case`` on: factorisation (by ``factorizer``), the linear
    or contact solve, post-processing (``lazy``: a frictionless contact result's zone, rim and checks wait until
    asked for, ``contact_result``)."""
    factorizer = factorizer or Factorizer()
    configure_mumps(out_of_core=opts.out_of_core)
    space, A, F, red, op = d.space, d.A, d.F, d.reduction, d.operator
    info: dict[str, Any] = {"unknowns": int(d.Ar.shape[0])}
    if op is None:
        with timer.stage("factorization"):
            fac = factorizer.linear(d.Ar, opts.backend)
        info["backend"] = fac.backend
        _check_finite("the load vector F", d.Fr)
        with timer.stage("solve"):
            U = red.expand(fac.solve(d.Fr))
        _check_finite("the displacements U", U)
        timings = timer.total()
        sol = ShellSolution(space=space, U=U, A=A, F=F)
        return _checked(Result(case=case, solution=sol, timings=timings, info=info, discretization=d))

    setup = prepare_contact(case, d, opts, timer, warm_start=warm_start, max_memory=max_memory, factorizer=factorizer)
    if has_friction(case):  # analysis.friction: the frictionless path below stays as it was
        with timer.stage("solve"):
            cs, friction = solve_friction(case, d, setup, opts)
        result = contact_result(case, d, opts, timer, setup.info, cs, lazy=True)
        attach_friction(result, friction)
        result.check_pending = False
        return _checked(result)
    with timer.stage("solve"):
        cs = _solve_contact(setup.qp, opts, setup.factorization, setup.initial_U, setup.initial_active, setup.eps,
                            progress, setup.screen)
    return contact_result(case, d, opts, timer, setup.info, cs, lazy=lazy)


@dataclass
class ContactSetup:
    """What a contact solve of one case starts from (``prepare_contact``)."""

    qp: ContactQP
    factorization: Factorization
    screen: np.ndarray | None  # the screened rows (None: the whole QP)
    initial_U: np.ndarray | None  # a warm start's reduced displacements
    initial_active: np.ndarray | None  # a warm start's active rows
    eps: float  # the penalty parameter (the penalty method)
    info: dict[str, Any]


def prepare_contact(case: Case, d: Discretization, opts: SolverOptions, timer: Timer, *,
                    warm_start: Result | None = None, max_memory: float | str | None = None,
                    factorizer: Factorizer | None = None) -> ContactSetup:
    """The reduced QP of ``case``, its factorisation (by ``factorizer``) and its start: ``warm_start`` (a Result)
    or a nested coarser solve (``solver.nested``)."""
    factorizer = factorizer or Factorizer()
    space, red, op = d.space, d.reduction, d.operator
    info: dict[str, Any] = {"unknowns": int(d.Ar.shape[0])}
    start = warm_start
    # "auto": when the overlap's rule would border too many rows; a coarser level predicts them better
    nested = opts.nested if opts.nested != "auto" else op is not None and coarse_start_pays(op.B.shape[0])
    if start is None and nested and case.mesh.refine > 0:
        coarse = dataclasses.replace(case, mesh=dataclasses.replace(case.mesh, refine=case.mesh.refine - 1))
        with timer.stage("nested"):
            start = _solve_coarse(coarse, opts, max_memory)
        info["nested_iterations"] = [start.info.get("nested_iterations", []), start.contact.solution.iterations]
    initial_U_r = initial_active = None
    if start is not None:
        U0 = start.solution.U if start.solution.space is space else start.solution.prolongate(space)
        initial_U_r = U0[red.free]
        if _same_rows(start, op):  # e.g. the previous step of a sweep: its active set is the best guess
            initial_active = start.contact.active
    start = None  # a coarser level's Result (its stiffness, factors, fields) is not kept during this solve
    with timer.stage("assembly"):
        qp = d.qp()
    exact = METHODS[opts.method].exact
    predicted = None if initial_U_r is None or warm_start is not None else qp.gap(initial_U_r)
    if initial_active is None and initial_U_r is not None and exact:
        initial_active = (qp.gap(initial_U_r) if predicted is None else predicted) <= 0.0
    # every method: the dense Schur complement of the rows predicted to touch (solvers.screening)
    with timer.stage("factorization"):
        fac, screen = factorizer.contact(qp, op.punch, initial_active, opts, predicted_gap=predicted)
    info["backend"] = fac.backend
    eps = opts.penalty if opts.penalty is not None else default_penalty(case)
    info["tolerance"] = opts.tolerance
    if not exact:
        info["penalty"] = eps
        info["warnings"] = check_penalty(case, eps, opts.continuation)
    _check_finite("the load vector F", d.Fr)
    return ContactSetup(qp, fac, screen, initial_U_r, initial_active, eps, info)


def _solve_coarse(case: Case, opts: SolverOptions, max_memory: float | str | None) -> Result:
    """The coarser level of a nested start (``solver.nested``): ``solve`` without what only a reported result needs
    (its contact zone, rim and summary: ~5 CPU s at 281k dofs, and the summary's warnings repeated the fine
    level's on stderr). Its displacements, rows and iterations are what the finer level reads; the finer level's
    size check covered it."""
    timer = Timer()
    with unit_hint_on_error(case):
        with timer.stage("mesh"):
            punches = place_punches(case.punches, case.shell, case.units)
        d = discretize(case, opts.contact_points, timer, punches)
        return solve_discretized(case, d, opts, timer, max_memory=max_memory, lazy=True)


def contact_result(case: Case, d: Discretization, opts: SolverOptions, timer: Timer, info: dict[str, Any],
                   cs: ContactSolution, *, lazy: bool = False) -> Result:
    """The Result of a contact solve: the solver's checks of finite values and of the linear range, the gaps
    everywhere and the penetration checks outside the rows. ``lazy``: the contact zone and the rim's line
    force, and the summary's check of finite values and the logging of the warnings, wait until first asked
    for (the points of a curve, ``curves.solve_family``, most of which only their force and travel are read
    of); otherwise they are made here, as ``solve`` does."""
    space, A, F, red, op, punches = d.space, d.A, d.F, d.reduction, d.operator, d.punches
    info = {**info, "solver_timings": dict(cs.timings)}
    _check_finite("the displacements U", cs.U)
    _check_finite("the contact forces Λ", cs.Lambda)
    delta, alpha = cs.delta, None
    if cs.delta is not None:
        _check_finite("the punch travels δ", cs.delta)
        kf = len(op.force_punches)  # the travels, then a floating shell's rigid-motion amplitudes
        delta, alpha = (cs.delta[:kf] if kf else None), cs.delta[kf:]
        for j, k in enumerate(op.force_punches):  # the same linear-theory range as an indentation
            check_linear_range(float(delta[j]), case.shell, f"punch.{k}.force",
                               f"the force {with_unit(f'{op.forces[j]:.4g}', 'force', case.units)} moves the "
                               "punch past first contact by", case.units)
    with timer.stage("postprocess"):  # the gaps everywhere, penetration checks outside the rows
        U = red.expand(cs.U)
        rigid = None
        Lam, active = np.asarray(cs.Lambda, float), np.asarray(cs.active, bool)
        if d.floating is not None:  # U = elastic part + rigid part, without the balanced and gauged motions
            fl = d.floating
            coefficients = fl.columns.T @ (alpha if alpha is not None else np.zeros(0))
            kappa = penalty_ratio(case, info["penalty"]) if "penalty" in info else None  # forces to κ + ε/κ
            accuracy = opts.tolerance if kappa is None else 10.0 * (kappa + float(np.finfo(float).eps) / kappa)
            change, opened = fl.settle(space, U + fl.modes @ coefficients, Lam,
                                       op.gap(U + fl.modes @ coefficients, delta), accuracy)
            coefficients, active = coefficients + change, active & ~opened
            rigid = fl.modes @ coefficients
            U = U + rigid
            info["rigid_motion"] = fl.summary(fl.free.T @ fl.fit(space, U))

        def derive() -> tuple[list, list, list]:
            zone = contact_zone(space, punches, U, delta, carrying=(op, Lam, op.gap(U, delta)))
            rim, lines = rim_line_force(space, punches, op, Lam, U, delta, zone)
            return zone, rim, lines

        contact = ContactResult(operator=op, solution=cs, Lambda=Lam, active=active,
                                gap=op.gap(U, delta), delta=delta,
                                outside=penetration_outside(space, punches, U, delta),
                                between=_penetration_between(space, punches, opts.contact_points, U, delta,
                                                             d.shared, op),
                                derive=derive, space=space)
        if not lazy:
            contact.zone  # noqa: B018 — made now, inside the post-processing stage
        sol = ShellSolution(space=space, U=U, A=A, F=F, extra_forces=op.B.T @ Lam, rigid=rigid)
    result = Result(case=case, solution=sol, timings=timer.total(), info=info, contact=contact, punches=punches,
                    discretization=d)
    if lazy:
        result.check_pending = True
        return result
    return _checked(result)


def _check_finite(what: str, values: np.ndarray) -> None:
    """SolverError (exit 3) naming ``what`` when it has a NaN or an infinity."""
    bad = ~np.isfinite(values)
    if bad.any():
        raise SolverError(f"non-finite result: {what} has {int(bad.sum())} non-finite entries of {bad.size} "
                          f"(first at index {int(np.argmax(bad))})")


def _penetration_between(space: ShellSpace, punches: list[Punch], points: str, U: np.ndarray,
                         delta: np.ndarray | None, shared: dict | None = None,
                         rows: ContactOperator | None = None) -> np.ndarray:
    """Largest [Π]₋ per punch at the zone's edge midpoints (zero when they are constrained too).

    Constraints at vertices only (the paper's K_h, MODEL.md §7) let the shell bend into the punch
    between them; on a ring contact around a coarse circumference this can be most of the overlap.
    ``shared`` (``Discretization.shared``) keeps the midpoints' operator for the next point whose rows are
    ``rows``' very rows (a force curve: ``curves._operator``).
    """
    if points != "vertices":
        return np.zeros(len(punches))
    kept = None if shared is None else shared.get("between")
    if kept is not None and rows is not None and kept[0] is rows.B:
        op = kept[1]
    else:
        op = contact_operator(space, punches, "vertices+midpoints")
        if shared is not None and rows is not None:
            shared["between"] = (rows.B, op)
    gap = op.gap(U, delta)
    mid = op.facet >= 0
    return np.array([float(np.max(-gap[mid & (op.punch == k)], initial=0.0)) for k in range(len(punches))]).clip(0)


def _same_rows(start: Result, op: ContactOperator) -> bool:
    """Whether an earlier result has the same constraint points (same mesh and zones)."""
    prev = start.contact.operator if start.contact is not None else None
    return (prev is not None and prev.m == op.m and np.array_equal(prev.punch, op.punch)
            and np.allclose(prev.x, op.x) and np.allclose(prev.phi, op.phi))


