"""Case files (TOML): the declarative schema of every table, and parsing into a validated ``Case``.

Every key is declared once below (``schema.Key``: kind, unit, default, range, meaning); parsing,
the error messages (``InputError`` naming ``section.key`` and what is allowed), the "did you mean"
hints and the key tables of docs/case-file.md all come from these declarations. Angles are in
degrees in case files and in radians everywhere inside the package. Below this module nothing sees
a raw dictionary or a key name: the ``Case`` holds typed, frozen objects (``Shell``, ``Supports``,
``MeshSpec``, ``Loads``, ``SolverOptions``, ``PunchSpec``).
"""

from __future__ import annotations

import dataclasses
import math
import os
import sys
import tomllib
from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..contact.punches import EXTENT, HALF_SPACE, PUNCH, SHAPES, ZONE, PunchSpec, parse_punches
from ..contact.punches.friction_spec import FRICTION
from ..errors import InputError
from ..inputs.arguments import described, expect_path, expect_strings
from ..inputs.hints import angle_unit_error
from ..inputs.schema import Key, Table, check_unknown
from ..inputs.user_functions import CodeConsent, code_consent, consent_for, current_consent
from ..linalg import BACKENDS
from ..shell.geometry import Shell
from ..shell.loads import LineLoad, Loads, PointLoad
from ..shell.material import MATERIALS, Material, check_stiffness_range
from ..shell.mesh import PATTERNS, MeshSpec
from ..shell.supports import SUPPORTS, Supports
from ..solvers.methods import METHODS
from ..units import SYSTEMS
from .options import PATHS, SolverOptions

_NUMBER_OR_FUNCTION = "string `\"module:function\"`: a function t(x, phi) (NumPy, φ in radians)"
#: the allowed column of every modulus (material.check_stiffness_range)
_MODULUS = "> 0, with E·t and E·t³ in [1e-100, 1e100]"

SHELL = Table("shell", (
    Key("radius", "number", "radius a of the middle surface", unit="length", lo=0.0, open=("lo",)),
    Key("length", "number", "axial length (2H in MODEL.md)", unit="length", lo=0.0, open=("lo",)),
    Key("x_start", "number", "axial coordinate of the edge `x_min`; the default centres the shell on x = 0",
        unit="length", default=None, default_doc="−length/2"),
    Key("angle", "pair", "angular range [α, β] of a panel", angle=True, lo=-720.0, hi=720.0, default=None,
        default_doc="required unless `full`", allowed="α < β, β − α ≤ 360, both in [−720, 720]"),
    Key("full", "bool", "full cylinder: φ ∈ [0°, 360°] with the φ-edges identified; do not give `angle` as well",
        default=False),
    Key("thickness", "number_or_function", "thickness t = 2e; a function is sampled on a 9 × 9 grid at load "
        "time", unit="length", lo=0.0, open=("lo",), allowed="0 < t < radius, or " + _NUMBER_OR_FUNCTION),
    Key("young", "number", "Young's modulus E of an isotropic shell (or `[material]`)", unit="force/length²",
        lo=0.0, open=("lo",), default=None, default_doc="required without `[material]`", allowed=_MODULUS),
    Key("poisson", "number", "Poisson's ratio μ of an isotropic shell (or `[material]`)", lo=-1.0, hi=0.5,
        open=("lo", "hi"), default=None, default_doc="required without `[material]`"),
))

MATERIAL = Table("material", (
    Key("model", "choice", "the material law (MODEL.md §3)", choices=tuple(MATERIALS), default="isotropic"),
    Key("young", "number", "isotropic: Young's modulus E", unit="force/length²", lo=0.0, open=("lo",),
        default=None, default_doc="required (isotropic)", allowed=_MODULUS),
    Key("poisson", "number", "isotropic: Poisson's ratio μ", lo=-1.0, hi=0.5, open=("lo", "hi"), default=None,
        default_doc="required (isotropic)"),
    Key("e1", "number", "orthotropic: modulus along the axis x", unit="force/length²", lo=0.0, open=("lo",),
        default=None, default_doc="required (orthotropic)", allowed=_MODULUS),
    Key("e2", "number", "orthotropic: modulus along the circumference", unit="force/length²", lo=0.0,
        open=("lo",), default=None, default_doc="required (orthotropic)", allowed=_MODULUS),
    Key("g12", "number", "orthotropic: in-plane shear modulus", unit="force/length²", lo=0.0, open=("lo",),
        default=None, default_doc="required (orthotropic)", allowed=_MODULUS),
    Key("nu12", "number", "orthotropic: Poisson's ratio ν12 (ν21 = ν12 E2/E1)", default=None,
        default_doc="required (orthotropic)", allowed="ν12² E2/E1 < 1"),
    Key("yield_stress", "number", "von Mises stress at which the material yields: the summary and fields.vtu "
        "report the utilisation σ_v/yield_stress, and a utilisation above 1 is warned about (the linear elastic "
        "result is then beyond yield). May be the only key, beside `shell.young`/`shell.poisson`",
        unit="force/length²", lo=0.0, open=("lo",), default=None, default_doc="none"),
))

SUPPORTS_TABLE = Table("supports", tuple(
    Key(edge, "choice", f"condition on the edge {where}", choices=SUPPORTS, default="clamped",
        default_doc=default)
    for edge, where, default in (
        ("x_min", "x = x_start", '`"clamped"`'),
        ("x_max", "x = x_start + length", '`"clamped"`'),
        ("phi_min", "φ = α", '`"clamped"` (a panel), `"periodic"` (`full = true`)'),
        ("phi_max", "φ = β", '`"clamped"` (a panel), `"periodic"` (`full = true`)'),
    )
))

GRADING = Table("grading", (
    Key("x", "numbers", "focus points along x", unit="length", default=()),
    Key("phi", "numbers", "focus points along φ", angle=True, default=()),
    Key("ratio", "number", "largest / smallest interval next to a focus point (1: uniform); beyond 1000 the "
        "slivers' stiffness (bending terms grow as the ratio⁴) loses every digit in the factorisation", lo=1.0,
        hi=1000.0, default=1.0),
))

MESH = Table("mesh", (
    Key("nx", "integer", "number of intervals along x (about; see grading)", lo=1, default=16),
    Key("nphi", "integer", "number of intervals along φ (≥ 3 for a full cylinder)", lo=1, default=16),
    Key("refine", "integer", "nested uniform (red) refinements applied after building the mesh", lo=0, default=0),
    Key("pattern", "choice", "diagonal pattern of each cell: alternating, all one way, all the other way, or four "
        "triangles around the cell centre", choices=PATTERNS, default="alternate"),
    Key("grading", "table", "grading toward points (`x`, `phi`, `ratio`); focus points become node lines",
        table=GRADING, default=None),
    Key("x_lines", "numbers", "x values that must be node lines", unit="length", default=(),
        allowed="inside [x_min, x_max]"),
    Key("phi_lines", "numbers", "φ values that must be node lines", angle=True, default=(), allowed="inside [α, β]"),
    Key("file", "string", "unstructured triangulation in coordinates (x, s), s = radius·φ (φ in radians), "
        "readable by meshio; relative to the case file. `nx`, `nphi`, grading and node lines are then ignored",
        default=None),
))

POINT_LOAD = Table("point", (
    Key("x", "number", "axial position", unit="length", allowed="in [x_min, x_max]"),
    Key("phi", "number", "angular position", angle=True, allowed="in [α, β]"),
    Key("force", "vector", "global force vector", unit="force"),
))

LINE_LOAD = Table("line", (
    Key("x", "number", "the line x = value (runs around the circumference)", unit="length", default=None),
    Key("phi", "number", "the line φ = value (runs along the axis)", angle=True, default=None),
    Key("force", "vector_or_function", "global force per unit length", unit="force/length",
        default=(0.0, 0.0, 0.0)),
    Key("normal", "number_or_function", "force per unit length along the outward normal", unit="force/length",
        default=0.0),
))

LOADS = Table("loads", (
    Key("normal", "number_or_function", "pressure along the outward normal n; internal pressure is positive",
        unit="force/length²", default=0.0),
    Key("surface", "vector_or_function", "global surface force per unit area of the middle surface, e.g. "
        "self-weight `[0, 0, −g ρ t]`", unit="force/length²", default=(0.0, 0.0, 0.0)),
    Key("point", "tables", "`[[loads.point]]`, below", table=POINT_LOAD, default=()),
    Key("line", "tables", "`[[loads.line]]`, below", table=LINE_LOAD, default=()),
))

PROBE = Table("probes", (
    Key("x", "number", "axial position", unit="length", allowed="in [x_min, x_max]"),
    Key("phi", "number", "angular position", angle=True, allowed="in [α, β]"),
))

SOLVER = Table("solver", (
    Key("method", "choice", "exact primal (primal–dual active set), the dual QP (7.9) (MPRGP), or the penalty method "
        "(6.7); `--method` overrides", choices=METHODS, default=SolverOptions.method),
    Key("tolerance", "number", "every scaled KKT residual must fall below it (penalty: the backward error of the "
        "penalised equation)", lo=0.0, hi=1.0, open=("lo", "hi"), default=SolverOptions.tolerance),
    Key("penalty", "number", "ε of the penalty method: springs of stiffness 1/ε per unit area; the penetration is "
        "ε × pressure. Used only by `\"penalty\"`", unit="length/pressure", lo=0.0, open=("lo",), default=None,
        default_doc="1e-6 · a²/(E t) (orthotropic: E2 for E)",
        allowed="> 0; with κ = ε·E t/a²: refused when κ + 2.2e-16/κ > 0.1, a warning above 1e-3 "
        "([solvers.md](solvers.md#choosing-ε-penalty))"),
    Key("continuation", "numbers", "penalty values solved first, in order, each warm-starting the next, before "
        "`penalty`", unit="length/pressure", lo=0.0, open=("lo",), default=()),
    Key("max_iterations", "integer", "iteration limit; the solver then fails with its residuals", lo=1, default=None,
        default_doc="active-set 100, dual 500, penalty 50 per ε"),
    Key("nested", "choice", "solve on `mesh.refine − 1` first (recursively) and start from that solution; its "
        "gaps on this mesh pick the rows of the bordered factorisation. `\"auto\"`: when the overlap's rule would "
        "border more than 4 000 rows (12 000 candidate rows: the demo case at 1.12M dofs) "
        "([solvers.md](solvers.md#nested-iteration-and-warm-starts))",
        choices=("auto", True, False), default=SolverOptions.nested),
    Key("backend", "choice", "sparse factorisation, shared by all solves (`shellcontact info` lists those "
        "installed)", choices=("auto", *BACKENDS), default=SolverOptions.backend),
    Key("out_of_core", "bool", "the `mumps` backend keeps its factors on disk (MUMPS's out-of-core mode, "
        "ICNTL(22) = 1; the directory is $MUMPS_OOC_TMPDIR on each rank, default /tmp): for a model whose factors "
        "do not fit in the ranks' memory ([scaling.md](scaling.md#one-model-on-several-processes-mumps-over-mpi)); "
        "other backends ignore it", default=False),
    Key("extended_precision", "bool", "refine the final solves U = A⁻¹(F + BᵀΛ) with residuals in extended "
        "precision (`numpy.longdouble`), then refine Λ on those gaps: the force is then not limited by cond(A)·ε "
        "(exact methods; costs a few solves; [solvers.md](solvers.md#accuracy-extended-precision-refinement))",
        default=False),
    Key("contact_points", "choice", "where Π ≥ 0 is imposed: also at the edge midpoints of the zone's triangles "
        "(weights from P1 on the red-refined triangles: \\|T\\|/12 per vertex, \\|T\\|/4 per midpoint), or only at "
        "the mesh vertices of the zone, the paper's choice (MODEL.md (8.6)), which lets the shell sink in between "
        "along a contact line round the circumference (the default by measured accuracy per second: "
        "[solvers.md](solvers.md#contact-points-vertices-or-vertices-and-midpoints))",
        choices=("vertices", "vertices+midpoints"),
        default=SolverOptions.contact_points),
    Key("substructure", "choice", "factorise A bordered by the contact rows predicted to touch, for the dense Schur "
        "complement (every method, PARDISO): `\"auto\"` from 40 000 unknowns on, `true` always, `false` never "
        "([solvers.md](solvers.md#large-problems-substructured-factorisation-and-screening))",
        choices=("auto", True, False), default=SolverOptions.substructure),
    Key("steps", "integer", "friction is path dependent: the punches' indentations and slides are applied in this "
        "many equal increments, each step's slip law acting on the slip since the last step (a punch in a fixed "
        "position is there from the first step); only with friction "
        "([theory.md](theory.md#9a-friction-modelmd-11-issue-26))", lo=1, hi=1000, default=SolverOptions.steps),
    Key("path", "choice", "the load path of `steps`: indentation and slide together (`\"proportional\"`), or "
        "`steps` increments of the indentation with no slide, then `steps` increments of the slide "
        "(`\"indent-then-slide\"`: a slide after the punch is pressed in, as an engineer loads a test)",
        choices=PATHS, default=SolverOptions.path),
))

UNITS = Table("units", (
    Key("system", "choice", "the units the case file's numbers are in: `\"SI\"` (N, m, Pa), `\"mm\"` (N, mm, MPa) "
        "or `\"none\"` (any consistent units, unlabelled). Only labels: no number is ever converted",
        choices=tuple(SYSTEMS), default="SI"),
))

#: the case file's top-level tables; ``[shell]`` is required
CASE = Table("", (
    Key("shell", "table", "geometry (and an isotropic material)", table=SHELL),
    Key("material", "table", "the material law", table=MATERIAL, default=None),
    Key("supports", "table", "edge conditions", table=SUPPORTS_TABLE, default=None),
    Key("mesh", "table", "the triangulation", table=MESH, default=None),
    Key("loads", "table", "applied loads", table=LOADS, default=None),
    Key("probes", "tables", "points reported in the summary", table=PROBE, default=()),
    Key("solver", "table", "solver options", table=SOLVER, default=None),
    Key("punch", "tables", "rigid punches", table=PUNCH, default=()),
    Key("units", "table", "the unit system, for the labels of every output", table=UNITS, default=None),
))

#: the tables of docs/case-file.md, by the name of their marker
DOC_TABLES: dict[str, Table] = {
    "shell": SHELL, "material": MATERIAL, "supports": SUPPORTS_TABLE, "mesh": MESH, "mesh.grading": GRADING,
    "loads": LOADS, "loads.point": POINT_LOAD, "loads.line": LINE_LOAD, "probes": PROBE, "solver": SOLVER,
    "punch": PUNCH, "punch.zone": ZONE, "punch.extent": EXTENT, "punch.extent.half_spaces": HALF_SPACE,
    "punch.friction": FRICTION, "units": UNITS,
    **{f"punch.{name}": Table(f"punch.{name}", shape.keys, shape.doc) for name, shape in SHAPES.items()},
}


@dataclass
class Case:
    """A validated problem description."""

    shell: Shell
    supports: Supports = field(default_factory=Supports)
    mesh: MeshSpec = field(default_factory=MeshSpec)
    loads: Loads = field(default_factory=Loads)
    probes: list[tuple[float, float]] = field(default_factory=list)  # (x, φ in radians)
    solver: SolverOptions = field(default_factory=SolverOptions)
    punches: tuple[PunchSpec, ...] = ()
    yield_stress: float | None = None  # [material] yield_stress: utilisation σ_v / yield_stress
    units: str = "SI"  # [units] system: the labels of every output (units.SYSTEMS); numbers are never converted
    source: Path | None = None
    raw: dict[str, Any] = field(default_factory=dict)
    code: CodeConsent | None = None  # the consent its "module:function" strings were imported under


def expect_case(value: Any, function: str) -> None:
    """``value`` must be a ``Case`` (a file name or a dictionary is read first): the API's first check."""
    if isinstance(value, Case):
        return
    hint = ""
    if isinstance(value, (str, os.PathLike)):
        hint = f"; read the file first: {function}(shellcontact.load_case({str(value)!r}))"
    elif isinstance(value, dict):
        hint = f"; validate the dictionary first: {function}(shellcontact.case_from_dict(data))"
    raise TypeError(f"{function}(): case must be a shellcontact.Case, got {described(value)}{hint}")


def parse_material(shell: dict[str, Any], raw: Any, v: dict[str, Any] | None = None) -> Material:
    """The elastic law (MODEL.md §3): a ``[material]`` table, or ``shell.young``/``shell.poisson`` (isotropic).

    ``shell`` holds the parsed ``[shell]`` values, ``v`` the parsed ``raw`` (if already parsed); a
    ``[material]`` table with only ``yield_stress`` leaves the law to ``[shell]``.
    """
    given = [f"shell.{k}" for k in ("young", "poisson") if shell[k] is not None]
    if isinstance(raw, dict) and set(raw) <= {"yield_stress"}:
        raw = None
    if raw is None:
        for k in ("young", "poisson"):
            if shell[k] is None:
                raise InputError(f"shell.{k}", "is required (or give a [material] table)")
        try:
            return MATERIALS["isotropic"](shell["young"], shell["poisson"])
        except InputError as exc:  # name the key the user wrote
            raise InputError(exc.field.replace("material.", "shell.", 1), exc.message) from None
    v = MATERIAL.parse(raw) if v is None else v
    if given:
        raise InputError("material", f"the material is given twice, in [material] and as {' and '.join(given)}; "
                         "keep one (a [material] table, or shell.young and shell.poisson)")
    cls = MATERIALS[v["model"]]
    keys = [f.name for f in dataclasses.fields(cls)]
    for k in raw:
        if k not in ("model", "yield_stress", *keys):
            raise InputError(f"material.{k}", f"is not a key of model = {v['model']!r}, whose keys are "
                             f"{', '.join(keys)}")
    for k in keys:
        if v[k] is None:
            raise InputError(f"material.{k}", f"is required for model = {v['model']!r}")
    return cls(*(v[k] for k in keys))


def parse_shell(d: Any, material: Any = None, material_values: dict[str, Any] | None = None) -> Shell:
    v = SHELL.parse(d)
    full = v["full"]
    if full and v["angle"] is not None:
        raise InputError("shell.angle", "give either 'angle' or 'full = true', not both")
    if not full and v["angle"] is None:
        raise InputError("shell.angle", "is required unless full = true (a list [alpha, beta] in degrees)")
    alpha, beta = (0.0, 2.0 * math.pi) if full else v["angle"]
    if not full and not alpha < beta:
        raise InputError("shell.angle", f"needs alpha < beta, got [{math.degrees(alpha):g}, {math.degrees(beta):g}]")
    shell = Shell(radius=v["radius"], length=v["length"], thickness=v["thickness"],
                  material=parse_material(v, material, material_values), alpha=alpha, beta=beta, full=full,
                  x_start=v["x_start"])
    t = shell.t(*np.meshgrid(np.linspace(shell.x_min, shell.x_max, 9), np.linspace(alpha, beta, 9)))
    try:
        check_stiffness_range(shell.material, float(t.min()), float(t.max()))
    except InputError as exc:  # name the key the user wrote
        field = exc.field if material is not None else exc.field.replace("material.", "shell.", 1)
        raise InputError(field, exc.message) from None
    return shell


def parse_mesh(d: Any) -> MeshSpec:
    v = MESH.parse(d)
    g = v["grading"] or {"x": (), "phi": (), "ratio": 1.0}
    return MeshSpec(nx=v["nx"], nphi=v["nphi"], refine=v["refine"], pattern=v["pattern"], file=v["file"],
                    grading_x=g["x"], grading_phi=g["phi"], grading_ratio=g["ratio"], x_lines=v["x_lines"],
                    phi_lines=v["phi_lines"])


def parse_loads(d: Any) -> Loads:
    v = LOADS.parse(d)
    points = tuple(PointLoad(p["x"], p["phi"], p["force"]) for p in v["point"])
    lines = []
    for i, p in enumerate(v["line"]):
        if (p["x"] is None) == (p["phi"] is None):
            raise InputError(f"loads.line.{i}", "give exactly one of 'x' or 'phi'")
        lines.append(LineLoad(force=p["force"], normal=p["normal"], x=p["x"], phi=p["phi"]))
    return Loads(normal=v["normal"], surface=v["surface"], lines=tuple(lines), points=points)


def parse_solver(d: Any) -> SolverOptions:
    if isinstance(d, dict) and d.get("continuation") is True:  # `continuation = true`: no extra ε values
        d = {**d, "continuation": []}
    v = SOLVER.parse(d)
    return SolverOptions(**v)


def _check_inside(shell: Shell, where: str, x: float, phi: float) -> None:
    """A probe or point load must lie on the shell (x in [x_min, x_max], phi in [alpha, beta])."""
    tol = 1e-9 * max(shell.length, 1.0)
    if not shell.x_min - tol <= x <= shell.x_max + tol:
        raise InputError(f"{where}.x", f"{x:.6g} lies outside [{shell.x_min:.6g}, {shell.x_max:.6g}]")
    if not shell.alpha - 1e-9 <= phi <= shell.beta + 1e-9:
        lo, hi, deg = math.degrees(shell.alpha), math.degrees(shell.beta), math.degrees(phi)
        raise InputError(f"{where}.phi", f"{deg:.6g} deg lies outside [{lo:.6g}, {hi:.6g}] deg")


def _check_mesh_lines(shell: Shell, ms: MeshSpec) -> None:
    """Grading foci and required node lines must lie on the shell."""
    tol = 1e-9 * max(shell.length, 1.0)
    for key, vals in (("mesh.grading.x", ms.grading_x), ("mesh.x_lines", ms.x_lines)):
        for v in vals:
            if not shell.x_min - tol <= v <= shell.x_max + tol:
                raise InputError(key, f"{v:.6g} lies outside [{shell.x_min:.6g}, {shell.x_max:.6g}]")
    for key, vals in (("mesh.grading.phi", ms.grading_phi), ("mesh.phi_lines", ms.phi_lines)):
        for v in vals:
            if not shell.alpha - 1e-9 <= v <= shell.beta + 1e-9:
                lo, hi = math.degrees(shell.alpha), math.degrees(shell.beta)
                raise InputError(key, f"{math.degrees(v):.6g} deg lies outside [{lo:.6g}, {hi:.6g}] deg")


def _check_angle_unit(shell: Shell, data: dict, probes: list[tuple[float, float]]) -> None:
    """``shell.angle`` in radians where degrees are expected, recognised by the punch centres and probes that
    lie between its numbers read as radians (input_hints.angle_unit_error), named before it fails as a probe
    outside the shell or an empty admissible set."""
    if shell.full:
        return
    raw = data.get("punch", [])
    points = [(f"punch.{k}'s centre", tuple(p["center"])) for k, p in enumerate(raw if isinstance(raw, list) else [])
              if isinstance(p, dict) and isinstance(p.get("center"), list | tuple)]
    # a probe's phi is in the same (mistaken) unit as the angle: compare it as given
    points += [(f"probes.{i}", (0.0, math.cos(math.radians(phi)), math.sin(math.radians(phi))))
               for i, (_, phi) in enumerate(probes)]
    text = angle_unit_error(math.degrees(shell.alpha), math.degrees(shell.beta), points)
    if text:
        raise InputError("shell.angle", text)


def case_from_dict(data: dict, source: str | Path | None = None, *, allow_code: bool = False,
                   allow_modules: Iterable[str] = ()) -> Case:
    """Validate a case given as a (TOML-shaped) dictionary; a relative mesh.file is read beside ``source``.

    A ``"module:function"`` value is imported only with consent (``user_functions``, the trust model):
    ``allow_code`` from the directory of ``source``, ``allow_modules`` by name from the Python path; without
    either, the consent in force (``code_consent``), else none."""
    if not isinstance(data, dict):
        raise TypeError(f"case_from_dict(): data must be a dict of case-file tables such as {{'shell': {{...}}}}, "
                        f"got {type(data).__name__}")
    expect_path(source, "case_from_dict", "source", optional=True)
    consent = consent_for(allow_code, allow_modules, source) or current_consent()
    with code_consent(consent):
        return _case_from_dict(data, source, consent)


def _case_from_dict(data: dict, source: str | Path | None, consent: CodeConsent | None) -> Case:
    check_unknown("", data, CASE.names())
    if "shell" not in data:
        raise InputError("shell", "section [shell] is required")
    material = MATERIAL.parse(data["material"]) if "material" in data else None
    shell = parse_shell(data["shell"], data.get("material"), material)
    sup = SUPPORTS_TABLE.parse(data.get("supports", {}))
    default = "periodic" if shell.full else "clamped"
    given = data.get("supports", {})
    supports = Supports(x_min=sup["x_min"], x_max=sup["x_max"],
                        phi_min=sup["phi_min"] if "phi_min" in given else default,
                        phi_max=sup["phi_max"] if "phi_max" in given else default)
    if shell.full and not supports.periodic:
        raise InputError("supports.phi_min", "a full cylinder needs phi_min = phi_max = 'periodic'")
    if supports.periodic and not shell.full:
        raise InputError("supports.phi_min", "'periodic' needs a full cylinder (shell.full = true)")
    probes = [(p["x"], p["phi"]) for p in CASE.key("probes").parse(data.get("probes", []), "probes")]
    _check_angle_unit(shell, data, probes)
    for i, pr in enumerate(probes):
        _check_inside(shell, f"probes.{i}", *pr)
    solver = parse_solver(data.get("solver", {}))
    punches = parse_punches(data.get("punch", []))
    if (solver.steps > 1 or solver.path != "proportional") and not any(p.drags for p in punches):
        raise InputError("solver.steps", "a load path (steps > 1, path) is used only with friction or a slide "
                                         "(punch.<i>.friction, punch.<i>.slide): a frictionless solve is path "
                                         "independent")
    pushed = [p for p in punches if p.tangential_force is not None]
    if len(pushed) > 1:
        raise InputError(f"{pushed[1].where}.tangential_force", "is allowed on one punch only (the others may slide)")
    if pushed and solver.steps > 1:
        raise InputError("solver.steps", "a load path (steps > 1) with a tangential force is not supported: give "
                                         "the punch a slide, or steps = 1")
    loads = parse_loads(data.get("loads", {}))
    loads.check_functions(shell)
    for i, pt in enumerate(loads.points):
        _check_inside(shell, f"loads.point.{i}", pt.x, pt.phi)
    mesh = parse_mesh(data.get("mesh", {}))
    _check_mesh_lines(shell, mesh)
    if source is not None and mesh.file and not Path(mesh.file).is_absolute():
        mesh = dataclasses.replace(mesh, file=str(Path(source).parent / mesh.file))
    return Case(
        shell=shell,
        supports=supports,
        mesh=mesh,
        loads=loads,
        probes=probes,
        solver=solver,
        punches=punches,
        yield_stress=None if material is None else material["yield_stress"],
        units=UNITS.parse(data.get("units", {}))["system"],
        source=None if source is None else Path(source),
        raw=data,
        code=consent,
    )


def read_case_dict(path: str | Path) -> dict[str, Any]:
    """The raw TOML dictionary of a case file, with clear errors for unreadable or malformed files."""
    path = Path(path)
    try:
        data = path.read_bytes()
    except OSError as exc:
        raise InputError("case", f"cannot read {str(path)!r}: {exc.strerror}") from None
    if data.startswith((b"\xff\xfe", b"\xfe\xff")):
        raise InputError("case", f"{str(path)!r} is UTF-16 (it starts with a UTF-16 byte-order mark); "
                         "save it as UTF-8")
    try:
        text = data.decode("utf-8-sig")  # a UTF-8 byte-order mark (Windows editors write one) is accepted
    except UnicodeDecodeError as exc:
        raise InputError("case", f"{str(path)!r} is not a UTF-8 text file (byte {exc.start} is not UTF-8)") from None
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise InputError("case", f"malformed TOML in {str(path)!r}: {exc}") from None
    except RecursionError:  # tomllib parses nested arrays and inline tables recursively
        raise InputError("case", f"{str(path)!r} nests arrays or inline tables too deeply to be read") from None
    except ValueError:  # int(): Python reads at most sys.get_int_max_str_digits() digits
        raise InputError("case", f"{str(path)!r} holds an integer of more than {sys.get_int_max_str_digits()} "
                         "digits, more than Python reads") from None


def load_case(path: str | Path, sets: Iterable[str] = (), *, allow_code: bool = False,
              allow_modules: Iterable[str] = ()) -> Case:
    """Read and validate a TOML case file; ``sets`` are ``key=value`` overrides (``--set``). Its
    ``"module:function"`` values are imported only with ``allow_code`` (from the file's own directory) or
    ``allow_modules`` (those modules, from the Python path): ``case_from_dict``."""
    expect_path(path, "load_case", "path")
    sets = expect_strings(sets, "load_case", "sets", "mesh.refine=1")
    data = read_case_dict(path)
    if sets:
        from ..inputs.overrides import apply_overrides, parse_assignment

        data = apply_overrides(data, [parse_assignment(s) for s in sets])
    return case_from_dict(data, source=Path(path), allow_code=allow_code, allow_modules=allow_modules)


#: the kind of quantity (units.py) of each schema unit
_UNIT_KINDS = {"length": "length", "force": "force", "force/length": "force/length", "force/length²": "pressure",
               "length/pressure": "length/pressure"}


def key_kind(path: str) -> str | None:
    """The kind of quantity (units.KINDS) of the case-file key ``path`` (e.g. ``punch.0.indentation`` → length),
    or None for a dimensionless or unknown key; array indices are skipped, a punch's key may be its shape's."""
    table: Table | None = CASE
    key: Key | None = None
    for part in (p for p in path.split(".") if not p.isdigit()):
        if table is None:
            return None
        try:
            key = table.key(part)
        except KeyError:
            shapes = [k for shape in SHAPES.values() for k in shape.keys if k.name == part] if table is PUNCH else []
            if not shapes:
                return None
            key = shapes[0]
        table = key.table
    if key is None:
        return None
    return "angle" if key.angle else _UNIT_KINDS.get(key.unit)


# -- docs/case-file.md: the key tables between the markers <!-- keys: NAME --> and <!-- /keys --> ---------------
def document(text: str) -> str:
    """``text`` with every marked key table regenerated from the schema (``DOC_TABLES``)."""
    out, pos = [], 0
    while (start := text.find("<!-- keys: ", pos)) >= 0:
        head_end = text.index("-->", start) + 3
        name = text[start + len("<!-- keys: "): head_end - 3].strip()
        end = text.index("<!-- /keys -->", head_end)
        table = DOC_TABLES[name]
        out += [text[pos:head_end], "\n", f"{table.doc}\n\n" if table.doc else "", table.markdown(), "\n"]
        pos = end
    return "".join(out) + text[pos:]



if __name__ == "__main__":  # python -m shellcontact.problem.case docs/case-file.md: regenerate the key tables
    import sys

    doc = Path(sys.argv[1])
    doc.write_text(document(doc.read_text()))
