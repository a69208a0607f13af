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
import functools
import logging
import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import scipy.sparse as sp

from ..shell import model
from ..inputs.arguments import expect_callable, expect_choice
from ..problem.case import Case, expect_case
from ..contact.operator import ContactOperator, contact_operator, contact_zone, penetration_outside, row_flexibility
from ..errors import InputError, SolverError
from ..contact.floating import Floating
from ..contact.floating import analyse as analyse_floating
from .friction import attach_friction, has_friction, solve_friction
from ..linalg import BACKENDS, Factorization, factorize
from ..linalg.mpi import parallel_summary
from ..linalg.mumps import configure as configure_mumps
from ..shell.loads import load_vector
from ..shell.mesh import ShellMesh, build_mesh
from ..problem.options import SolverOptions
from ..contact.punches import Punch, check_linear_range, place_punches
from ..outputs.results import ShellSolution
from ..contact.rim import rim_line_force
from ..problem.sizing import check_size, mesh_lines
from ..solvers import ContactQP, ContactSolution
from ..solvers.methods import METHODS
from ..solvers.screening import coarse_start_pays, factorize_screened, solve_screened
from ..solvers.substructure import MIN_UNKNOWNS
from ..shell.spaces import ShellSpace
from ..shell.supports import Reduction, edge_constrained_dofs
from ..units import summary_units, with_unit
from .validity import ResultWarning, case_warnings, equilibrium_warnings, floating_warnings, record, unit_hint_on_error

KKT_KEYS = ("stationarity", "penetration", "dual_feasibility", "complementarity", "duality_gap")

log = logging.getLogger("shellcontact")

#: the penalty ratio κ = ε·E₂t/a² (``penalty_ratio``) predicts the penalty method's relative force error
#: κ + ε_mach/κ (penetration over deflection; gap round-off over penetration). Above ``PENALTY_WARN`` a
#: warning, above ``PENALTY_REFUSE`` the penalty is refused (docs/solvers.md, "Choosing ε (penalty)")
PENALTY_WARN = 1e-3
PENALTY_REFUSE = 1e-1


class Timer:
    """Accumulates wall-clock seconds per named stage."""

    def __init__(self) -> None:
        self.times: dict[str, float] = {}
        self._t0 = time.perf_counter()

    def stage(self, name: str):
        timer = self

        class _Stage:
            def __enter__(self):
                self.t = time.perf_counter()

            def __exit__(self, *exc):
                timer.times[name] = timer.times.get(name, 0.0) + time.perf_counter() - self.t

        return _Stage()

    def total(self) -> dict[str, float]:
        """Seconds per stage; ``output`` is 0 until the result is written (outputs.write_outputs adds it)."""
        return {"output": 0.0, **self.times, "total": time.perf_counter() - self._t0}


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


@dataclass
class ContactResult:
    """The contact part of a solution (row arrays are per constraint, in ``operator`` order)."""

    operator: ContactOperator
    solution: ContactSolution  # of the reduced QP
    Lambda: np.ndarray  # nodal forces Λ ≥ 0
    active: np.ndarray  # bool
    gap: np.ndarray  # G + B U (+ D δ)
    delta: np.ndarray | None  # force-control travel
    outside: np.ndarray  # per punch: largest penetration at vertices outside its candidate zone
    between: np.ndarray  # per punch: largest penetration at edge midpoints between constraint points
    #: () → (zone, rim, rim_lines): computed when first read (``zone``, ``rim``, ``rim_lines``)
    derive: Callable[[], tuple[list, list, list]] | None = field(default=None, repr=False)
    friction: list[dict] | None = None  # per punch, with friction (friction_case.attach_friction)
    _derived: tuple[list, list, list] | None = field(default=None, init=False, repr=False)

    def _post(self) -> tuple[list, list, list]:
        if self._derived is None:
            self._derived = self.derive() if self.derive is not None else ([], [], [])
        return self._derived

    @property
    def zone(self) -> list[dict]:
        """Per punch: where it touches (``contact.contact_zone``)."""
        return self._post()[0]

    @property
    def rim(self) -> list[dict | None]:
        """Per punch: the rim's line force (``rim.rim_line_force``)."""
        return self._post()[1]

    @property
    def rim_lines(self) -> list[list[np.ndarray]]:
        """Per punch: the rim's polylines in (x, s)."""
        return self._post()[2]

    @property
    def pressure(self) -> np.ndarray:
        return self.operator.pressure(self.Lambda)

    def summary(self) -> list[dict]:
        out = self.operator.summary(self.Lambda, self.active, self.delta)
        rims = self.rim or [None] * len(out)
        for entry, pen, mid, zone, rim in zip(out, self.outside, self.between, self.zone, rims):
            entry["penetration_outside_zone"] = float(pen)
            entry["penetration_between_points"] = float(mid)
            # where the punch carries force but no sampled point is within the tolerance (a point contact on a
            # coarse mesh), say so rather than report an area of 0 that reads as no contact
            state = "none" if entry["total_normal_force"] <= 0.0 else "area" if zone["area"] > 0.0 else "point"
            entry["zone"] = {**zone, "state": state}
            if rim is not None:
                entry["rim"] = rim
        for entry, fr in zip(out, self.friction or []):
            entry["friction"] = fr
        return out

    def warnings(self, units: str = "SI") -> list[str]:
        """Contact beyond a candidate zone: the zone was too small and must be widened (lengths in ``units``)."""
        scale = max(float(np.max(np.abs(self.operator.G), initial=0.0)), 1e-300)
        length = with_unit("", "length", units).strip()  # the label after each number (none: "")
        out = [ResultWarning(
            "contact_outside_zone", f"punch.{k}: the shell penetrates the punch by {pen:.3e} {length} outside its "
            f"candidate zone; widen punch.{k}.zone") for k, pen in enumerate(self.outside) if pen > 1e-8 * scale]
        out += [ResultWarning(
            "contact_between_points", f"punch.{k}: the shell penetrates the punch by {pen:.3e} {length} between the "
            f"constraint points ({pen / scale:.1%} of the overlap); set solver.contact_points = "
            "'vertices+midpoints' or refine") for k, pen in enumerate(self.between) if pen > 1e-2 * scale]
        return out


@dataclass
class Result:
    """The outcome of ``solve(case)``: the solution, its contact state and a JSON-ready summary."""

    case: Case
    solution: ShellSolution
    timings: dict[str, float]
    info: dict[str, Any] = field(default_factory=dict)
    contact: ContactResult | None = None
    punches: list[Punch] = field(default_factory=list)
    discretization: Discretization | None = None  # the reduced operators (e.g. ``.qp()``)
    #: the summary's check of finite values (and the logging of the warnings) waits for the first ``summary()``
    #: (``contact_result(lazy=True)``)
    check_pending: bool = field(default=False, repr=False)

    # -- outputs (thin wrappers over outputs, writers, fields, plots and report) ---------------------------------
    def write(self, directory, *, overwrite: bool = False, **kw) -> dict:
        """Write the run directory (summary.json, fields.vtu, results.npz, figures, report.html).

        It appears whole or not at all; a non-empty ``directory`` is refused unless ``overwrite``.
        """
        from ..outputs.run import write_outputs

        return write_outputs(self, directory, overwrite=overwrite, **kw)

    def to_vtu(self, path):
        """The 3D shell surface with all vertex fields, for ParaView (via meshio)."""
        from ..outputs.writers import write_vtu

        return write_vtu(self, path)

    def to_npz(self, path):
        from ..outputs.writers import write_npz

        return write_npz(self, path)

    def vertex_fields(self) -> dict[str, np.ndarray]:
        from ..outputs.fields import vertex_fields

        return vertex_fields(self)

    def plot_deflection(self, path=None):
        from ..outputs.figures.run import plot_deflection

        return plot_deflection(self, path)

    def plot_deformed(self, path=None, scale=None):
        from ..outputs.figures.run import plot_deformed

        return plot_deformed(self, path, scale)

    def plot_pressure(self, path=None):
        """Contact-pressure map with the contact boundary (None without contact)."""
        from ..outputs.figures.run import plot_pressure

        return plot_pressure(self, path)

    def plot_pressure_profiles(self, path=None, x=None, phi=None):
        from ..outputs.figures.run import plot_pressure_profiles

        return plot_pressure_profiles(self, path, x, phi)

    def report(self, path):
        """A self-contained HTML page of this run."""
        from ..outputs.report import write_report

        return write_report(self, path)

    @functools.cached_property
    def stresses(self) -> dict[str, dict]:
        """Per surface (bottom, middle, top): the largest von Mises stress and where, the extreme principal
        stresses, and the utilisation with ``[material] yield_stress`` (``ShellSolution.stress_extremes``)."""
        return self.solution.stress_extremes(self.case.yield_stress)

    def edge_reactions(self) -> dict[str, dict[str, list[float]]]:
        """Per supported edge: the force and moment the support exerts on the shell (global frame), the moment
        about the edge's centre (x-edge: the ring centre (x, 0, 0); φ-edge: the generator's midpoint).
        A dof constrained by two edges (a corner) counts with the first of x_min, x_max, phi_min, phi_max."""
        sol, sh = self.solution, self.case.shell
        R = sol.reactions()
        seen = np.zeros(R.size, bool)
        out = {}
        for edge, dofs in edge_constrained_dofs(sol.space, self.case.supports).items():
            dofs = dofs[~seen[dofs]]
            seen[dofs] = True
            part = np.zeros_like(R)
            part[dofs] = R[dofs]
            force, moment = sol.resultant(part)
            if edge.startswith("x"):
                centre = np.array([sh.x_min if edge == "x_min" else sh.x_max, 0.0, 0.0])
            else:
                centre = sh.point(0.5 * (sh.x_min + sh.x_max), sh.alpha if edge == "phi_min" else sh.beta)
            out[edge] = {"force": [float(c) for c in force],
                         "moment": [float(c) for c in moment - np.cross(centre, force)],
                         "about": [float(c) for c in centre]}
        return out

    def equilibrium(self) -> dict[str, Any]:
        """Global balance of the shell: applied loads + contact forces + support reactions = residual, as forces
        and moments about the origin (generalised forces on the interpolated rigid motions). The residual is
        U·A·I_h(r), r a rigid motion: zero up to round-off for the motions the space represents exactly (the
        translation along x) and of the order of the interpolation error of the others; it falls under refinement.
        ``relative_residual``: the largest force residual relative to the largest gross force balance
        Σ |f_d r_d| over the three translations, and likewise for the moments. Not each balance by its own gross
        size: one the load does not load (the ring between plates along y: 0.3 N gross against 400 N along z)
        would turn the interpolation error of a gauge reaction (2.6 mN) into 0.9 %."""
        sol = self.solution
        parts = {"applied": sol.F, "reactions": sol.reactions()}
        if sol.extra_forces is not None:
            parts["contact"] = sol.extra_forces
        out: dict[str, Any] = {}
        total = np.zeros(6)
        gross = np.zeros(6)  # Σ |f_d r_d| per rigid motion: the size of each balance without cancellation
        for name, vec in parts.items():
            f, m = sol.resultant(vec)
            out[name] = {"force": [float(c) for c in f], "moment": [float(c) for c in m]}
            total += np.concatenate([f, m])
            gross += np.abs(sol.rigid_modes) @ np.abs(vec)
        out["residual"] = {"force": [float(c) for c in total[:3]], "moment": [float(c) for c in total[3:]]}
        out["relative_residual"] = max(float(np.abs(total[:3]).max() / max(float(gross[:3].max()), 1e-300)),
                                       float(np.abs(total[3:]).max() / max(float(gross[3:].max()), 1e-300)))
        return out
    def warnings(self) -> list[str]:
        """What the user must know about this result: a penalty parameter outside its accurate range,
        KKT residuals above the requested tolerance, contact beyond the candidate zones or between the
        constraint points, stresses beyond ``[material] yield_stress``."""
        out = case_warnings(self.case) + list(self.info.get("warnings", [])) + self._yield_warnings()
        if self.contact is None:
            return out
        cs, tol = self.contact.solution, self.info.get("tolerance")
        scaled = cs.info.get("scaled_residuals", {})
        above = {k: v for k, v in scaled.items() if tol is not None and v > tol}
        if above:
            what = ", ".join(f"{k} {v:.2e}" for k, v in above.items())
            why = (" (the penalty solution satisfies the contact conditions only to O(ε); the tolerance "
                   "applies to its penalised equation)" if cs.method == "penalty" else "")
            out.append(ResultWarning("kkt_residual", f"KKT: scaled residuals above the tolerance {tol:g}: {what}{why}"))
        out += floating_warnings(self.case, self.info.get("rigid_motion"), self.contact.summary(), self.case.units)
        return out + self.contact.warnings(self.case.units)

    def _yield_warnings(self) -> list[str]:
        """Outside the linear thin-shell range: t/a, deflection/t, rotations, yield (``validity``)."""
        from .validity import range_warnings

        return (range_warnings(self.solution, self.stresses, self.case.yield_stress, self.case.units)
                + equilibrium_warnings(self.equilibrium()["relative_residual"]))

    def summary(self) -> dict[str, Any]:
        sol = self.solution
        out: dict[str, Any] = {
            "dofs": int(sol.space.ndofs),
            "unknowns": int(self.info.get("unknowns", sol.space.ndofs)),
            "elements": int(sol.space.mesh.nelements),
            "vertices": int(sol.space.mesh.nvertices),
            "energy": sol.energy,
            "max_abs_w": sol.max_abs_w,
            "probes": [sol.probe(x, phi) for x, phi in self.case.probes],
            "stresses": self.stresses,
            "reaction_resultant": [float(c) for c in sol.reaction_resultant()],
            "reactions": self.edge_reactions(),
            "equilibrium": self.equilibrium(),
        }
        if self.contact is not None:
            cs = self.contact.solution
            out["contact"] = self.contact.summary()
            out["kkt"] = {k: float(cs.residuals[k]) for k in KKT_KEYS if k in cs.residuals}
            if "force_balance" in cs.residuals:  # force control (docs/solvers.md, KKT residuals)
                out["kkt"]["force_balance"] = float(cs.residuals["force_balance"])
            # the scaled residuals are what the solver compares with [solver] tolerance
            out["kkt_scaled"] = {k: float(v) for k, v in cs.info.get("scaled_residuals", {}).items()}
            out["tolerance"] = self.info.get("tolerance")
            out["solver"] = cs.method
            out["iterations"] = int(cs.iterations)
            if "penalty" in self.info:
                out["penalty"] = self.info["penalty"]
            if "rigid_motion" in self.info:
                out["rigid_motion"] = self.info["rigid_motion"]
        out["warnings"] = [record(w) for w in self.warnings()]  # {"code", "message"} (validity.py)
        out["backend"] = self.info.get("backend")
        if out["backend"] == "mumps" and (parallel := parallel_summary()) is not None:  # ranks, peak memory of each
            out["parallel"] = parallel
        out["timings"] = dict(self.timings)
        out["unit_system"] = self.case.units
        out["units"] = summary_units(out, self.case.units)
        if self.check_pending:
            _check_summary(self, out)
            self.check_pending = False
        return out


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


@dataclass
class Discretization:
    """The discrete problem of a case: V_h, A, F, the support reduction and the contact rows."""

    space: ShellSpace
    A: sp.csr_matrix  # full stiffness
    F: np.ndarray  # full load vector
    reduction: Reduction
    Ar: sp.csr_matrix  # Pᵀ A P
    Fr: np.ndarray  # Pᵀ F
    punches: list[Punch]
    operator: ContactOperator | None  # None without punches
    Br: sp.csr_matrix | None  # B P
    floating: Floating | None = None  # the free rigid motions when contact alone holds the shell
    #: |Ar| (``ContactQP.abs_A``), computed once for every QP of this discretisation and of copies of it
    #: (``dataclasses.replace`` keeps the dict: the points of a curve share their stiffness)
    shared: dict = field(default_factory=dict, repr=False, compare=False)

    def qp(self) -> ContactQP:
        """The reduced contact QP of MODEL.md §8; a floating shell's restrained rigid motions are unknowns
        after the force-controlled travels (columns of D, loads in P: floating.py)."""
        op = self.operator
        if op is None:
            raise InputError("punch", "the case has no punch: there is no contact problem")
        D, P = op.D, op.forces if op.D is not None else None
        labels = [f"punch.{k}.force" for k in op.force_punches]
        fl = self.floating
        if fl is not None and fl.P.size:
            D = fl.D if D is None else np.hstack([D, fl.D])
            P = fl.P if P is None else np.concatenate([P, fl.P])
            labels += [f"rigid motion: {name}" for name in fl.names]
        rows = self.shared.get("rows")  # the labels and flexibilities of the rows B: the same for a force curve
        if rows is None or rows[0] is not op.B:
            rows = self.shared["rows"] = (op.B, _row_labels(op), row_flexibility(self.space.mesh.shell, op))
        qp = ContactQP(self.Ar, self.Fr, self.Br, op.G, op.weights, D=D, P=P, row_labels=rows[1],
                       force_labels=labels if D is not None else None, symmetric=True, flexibility=rows[2],
                       finite=self.shared.get("finite_A") is self.Ar)
        self.shared["finite_A"] = self.Ar  # checked
        if "abs_A" not in self.shared:
            self.shared["abs_A"] = qp.abs_A
        qp._abs_A = self.shared["abs_A"]
        return qp


def case_mesh(case: Case, punches: list[Punch] | tuple[()] = ()) -> ShellMesh:
    """The mesh of a case: node lines at the loads and at the punches' fitted lines (zone edges,
    first-contact lines), graded toward first contact when ``[mesh.grading]`` has a ratio but no focus."""
    return build_mesh(case.shell, case.mesh, *mesh_lines(case, punches))


def discretize(case: Case, contact_points: str = SolverOptions.contact_points, timer: Timer | None = None,
               punches: list[Punch] | None = None) -> Discretization:
    """Mesh (fitted to the punches), space, assembly, supports and contact operator of ``case``
    (``punches``: the case's punches already placed)."""
    timer = timer or Timer()
    with timer.stage("mesh"):
        if punches is None:
            punches = place_punches(case.punches, case.shell, case.units)
        space = ShellSpace(case_mesh(case, punches))
    with timer.stage("assembly"):
        A = model.stiffness(space)
        F = load_vector(space, case.loads)
        red = Reduction.build(space, case.supports, floating=bool(punches))
        op = contact_operator(space, punches, contact_points) if punches else None
        floating = analyse_floating(space, red, op, F) if op is not None and red.motions.size else None
        return Discretization(space, A, F, red, red.reduce_matrix(A), red.reduce_vector(F), punches, op,
                              None if op is None else op.B @ red.P, floating)


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
                      max_memory: float | str | None = None, factorizer: Factorizer | None = None) -> Result:
    """``solve`` from the discretisation ``d`` of ``case`` on: factorisation (by ``factorizer``), the linear
    or contact solve, post-processing."""
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
    if has_friction(case):  # friction_case: the frictionless path below stays as it was
        with timer.stage("solve"):
            cs, friction = solve_friction(case, d, setup, opts.method, opts.tolerance)
        result = contact_result(case, d, opts, timer, setup.info, cs, lazy=True)
        attach_friction(result, friction)
        result.check_pending = False
        return _checked(result)
    with timer.stage("solve"):
        cs = _solve_contact(setup.qp, opts, setup.factorization, setup.initial_U, setup.initial_active, setup.eps,
                            progress, setup.screen)
    return contact_result(case, d, opts, timer, setup.info, cs)


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
            start = solve(coarse, method=opts.method, backend=opts.backend, max_memory=max_memory)
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
            # the rim's outline stays the gap's level line over that zone's box (rim.py: on the wider box of a
            # fixed punch's carrying zone its arc length repeats points and np.gradient gives NaN)
            outline = contact_zone(space, punches, U, delta) if any(p.mode == "fixed" for p in punches) else zone
            rim, lines = rim_line_force(space, punches, op, Lam, U, delta, outline)
            return zone, rim, lines

        contact = ContactResult(operator=op, solution=cs, Lambda=Lam, active=active,
                                gap=op.gap(U, delta), delta=delta,
                                outside=penetration_outside(space, punches, U, delta),
                                between=_penetration_between(space, punches, opts.contact_points, U, delta,
                                                             d.shared, op),
                                derive=derive)
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


def non_finite(data: Any, path: str = "") -> list[str]:
    """The paths (``contact.0.force``) of the NaNs and infinities in a JSON-like structure."""
    if isinstance(data, float | np.floating):
        return [] if math.isfinite(data) else [path or "(value)"]
    if isinstance(data, dict):
        return [p for k, v in data.items() for p in non_finite(v, f"{path}.{k}" if path else str(k))]
    if isinstance(data, list | tuple):
        return [p for i, v in enumerate(data) for p in non_finite(v, f"{path}.{i}" if path else str(i))]
    if isinstance(data, np.ndarray) and data.dtype.kind == "f":
        return [] if np.isfinite(data).all() else [path]
    return []


def _checked(result: Result) -> Result:
    """The result, once its summary is finite (else SolverError naming the quantities); its warnings are
    logged (stderr from the command line and, without logging set up, from Python)."""
    _check_summary(result, result.summary())
    return result


def _check_summary(result: Result, summary: dict[str, Any]) -> None:
    bad = non_finite(summary)
    if bad:
        raise SolverError(f"non-finite result: {', '.join(bad[:8])}{' …' if len(bad) > 8 else ''}")
    for w in summary["warnings"]:
        log.warning("warning: %s", w["message"])


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


def _row_labels(op: ContactOperator) -> list[str]:
    deg = np.degrees(op.phi)
    return [f"punch.{k} point (x={x:.6g}, phi={p:.6g} deg)" for k, x, p in zip(op.punch, op.x, deg)]
