"""The outcome of a solve: ``Result`` (the shell solution, its contact state, the JSON-ready summary and
the warnings, thin wrappers over the outputs) and ``ContactResult`` (per constraint row and per punch)."""

from __future__ import annotations

import functools
import logging
import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..contact.nodal_pressure import nodal_pressure, on_vertices, unit_pressure_loads
from ..contact.operator import ContactOperator
from ..contact.punches import Punch
from ..errors import SolverError
from ..linalg.mpi import parallel_summary
from ..outputs.results import ShellSolution
from ..problem.case import Case
from ..shell.spaces import ShellSpace
from ..shell.supports import edge_constrained_dofs
from ..solvers import ContactSolution
from ..units import summary_units, unit_kind, with_unit
from .discretization import Discretization
from .validity import ResultWarning, case_warnings, equilibrium_warnings, floating_warnings, record

log = logging.getLogger("shellcontact")


KKT_KEYS = ("stationarity", "penetration", "dual_feasibility", "complementarity", "duality_gap")


def _unscaled(key: str, residuals: dict[str, Any], system: str) -> str:
    """' (= 1.01e-07 m)': a dimensioned KKT residual as summary.json's ``kkt`` (and the demo's table) give it."""
    kind = unit_kind(f"kkt.{key}")  # dimensionless or unclassified: its scaled value alone
    return f" (= {with_unit(f'{residuals[key]:.2e}', kind, system)})" if kind and key in residuals else ""


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
    friction: list[dict] | None = None  # per punch, with friction (analysis.friction.attach_friction)
    space: ShellSpace | None = field(default=None, repr=False)  # for the nodal pressure
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
        """Per row Λᵢ/ωᵢ (not a pressure on a uniform load: ``nodal_pressure`` is)."""
        return self.operator.pressure(self.Lambda)

    @functools.cached_property
    def unit_loads(self) -> np.ndarray | None:
        """(npunch, nv): the load of a unit pressure on each vertex's value dof (``unit_pressure_loads``), None
        without the space."""
        return None if self.space is None else unit_pressure_loads(self.space, self.operator)

    def on_vertices(self, values: np.ndarray) -> np.ndarray:
        """Row values (m, …) as loads on the vertices' value dofs, per punch (``contact.nodal_pressure``)."""
        return on_vertices(self.operator, values)

    @functools.cached_property
    def nodal_pressure(self) -> np.ndarray | None:
        """(npunch, nv): each punch's pressure at the mesh vertices (``contact.nodal_pressure``), None without
        the space."""
        if self.space is None:
            return None
        return nodal_pressure(self.space, self.operator, self.Lambda, self.unit_loads)

    def summary(self) -> list[dict]:
        out = self.operator.summary(self.Lambda, self.active, self.delta)
        if self.nodal_pressure is not None:  # the peak of the map's field, not of the rows' Λ/ω
            for entry, p in zip(out, self.nodal_pressure):
                entry["peak_pressure"] = float(p.max(initial=0.0))
        rims = self.rim or [None] * len(out)
        for entry, pen, mid, zone, rim in zip(out, self.outside, self.between, self.zone, rims):
            entry["penetration_outside_zone"] = float(pen)
            entry["penetration_between_points"] = float(mid)
            # where the punch carries force but no sampled point is within the tolerance (a point contact on a
            # coarse mesh), say so rather than report an area of 0 that reads as no contact
            state = "none" if entry["total_normal_force"] <= 0.0 else "area" if zone["area"] > 0.0 else "point"
            if state == "none":  # no force, no zone: a punch placed on the shell at zero load touches it at a point,
                # whose nearest constraint point's cell read as an area (the paper panel at indentation 0: 5.6e-6 m²,
                # above its 4.9e-6 m² at 0.5 mm in a sweep)
                zone = {"area": 0.0, "gap_tolerance": zone["gap_tolerance"]}
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
        from ..outputs.figures.maps import plot_deflection

        return plot_deflection(self, path)

    def plot_deformed(self, path=None, scale=None):
        from ..outputs.figures.deformed import plot_deformed

        return plot_deformed(self, path, scale)

    def plot_pressure(self, path=None):
        """Contact-pressure map with the contact boundary (None without contact)."""
        from ..outputs.figures.contact import plot_pressure

        return plot_pressure(self, path)

    def plot_pressure_profiles(self, path=None, x=None, phi=None):
        from ..outputs.figures.contact import plot_pressure_profiles

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
            what = ", ".join(f"{k} {v:.2e}{_unscaled(k, cs.residuals, self.case.units)}" for k, v in above.items())
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
