"""Case files (TOML): parsing and validation into plain dataclasses.

Every error names the key (``section.key``) and what is allowed. Angles are in degrees in
case files and in radians everywhere inside the package. The reference of every key is
docs/case-file.md.
"""

from __future__ import annotations

import dataclasses
import difflib
import importlib
import math
import tomllib
from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from .errors import InputError
from .geometry import Shell
from .loads import LineLoad, Loads, PointLoad
from .mesh import PATTERNS, ShellMesh, from_file, graded_nodes, structured
from .supports import Supports

SCHEMA: dict[str, set[str]] = {
    "shell": {"radius", "length", "angle", "full", "thickness", "young", "poisson", "x_start"},
    "supports": {"x_min", "x_max", "phi_min", "phi_max"},
    "mesh": {"nx", "nphi", "refine", "pattern", "file", "grading", "x_lines", "phi_lines"},
    "loads": {"normal", "surface", "point", "line"},
    "probes": {"x", "phi"},
    "solver": {"method", "tolerance", "penalty", "max_iterations", "backend", "continuation", "nested",
               "contact_points", "extended_precision"},
    "punch": set(),  # validated by the contact layer
}
REQUIRED = ("shell",)


def _unknown(section: str, keys, allowed) -> None:
    for k in keys:
        if k not in allowed:
            near = difflib.get_close_matches(k, sorted(allowed), n=1)
            hint = f"; did you mean '{near[0]}'?" if near else f"; allowed: {', '.join(sorted(allowed))}"
            raise InputError(f"{section}.{k}" if section else k, f"unknown key{hint}")


def number(d: dict, key: str, where: str, default: Any = None, *, positive=False, integer=False, minimum=None):
    """Fetch a number with type and range checks."""
    if key not in d:
        if default is None:
            raise InputError(f"{where}.{key}", "is required")
        return default
    v = d[key]
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        kind = "an integer" if integer else "a number"
        raise InputError(f"{where}.{key}", f"must be {kind}, got {type(v).__name__} {v!r}")
    if integer and not isinstance(v, int):
        raise InputError(f"{where}.{key}", f"must be an integer, got {v!r}")
    if not math.isfinite(v):
        raise InputError(f"{where}.{key}", f"must be finite, got {v!r}")
    if positive and v <= 0:
        raise InputError(f"{where}.{key}", f"must be > 0, got {v!r}")
    if minimum is not None and v < minimum:
        raise InputError(f"{where}.{key}", f"must be >= {minimum}, got {v!r}")
    return v


def vector(d: dict, key: str, where: str, default=None, length: int = 3) -> tuple[float, ...]:
    if key not in d:
        if default is None:
            raise InputError(f"{where}.{key}", "is required")
        return default
    v = d[key]
    if (
        not isinstance(v, list)
        or len(v) != length
        or any(isinstance(c, bool) or not isinstance(c, (int, float)) or not math.isfinite(c) for c in v)
    ):
        raise InputError(f"{where}.{key}", f"must be a list of {length} finite numbers, got {v!r}")
    return tuple(float(c) for c in v)


def callable_from_string(spec: str, where: str):
    """'package.module:function' → the function (user code for thickness, punch shapes)."""
    if not isinstance(spec, str) or ":" not in spec:
        raise InputError(where, f"must be 'module:callable', got {spec!r}")
    mod, _, name = spec.partition(":")
    try:
        obj = getattr(importlib.import_module(mod), name)
    except (ImportError, AttributeError) as exc:
        raise InputError(where, f"cannot import {spec!r}: {exc}") from None
    if not callable(obj):
        raise InputError(where, f"{spec!r} is not callable")
    return obj


@dataclass(frozen=True)
class MeshSpec:
    nx: int = 16
    nphi: int = 16
    refine: int = 0
    pattern: str = "alternate"
    file: str | None = None
    grading_x: tuple[float, ...] = ()
    grading_phi: tuple[float, ...] = ()  # radians
    grading_ratio: float = 1.0
    x_lines: tuple[float, ...] = ()
    phi_lines: tuple[float, ...] = ()  # radians


@dataclass
class Case:
    """A validated problem description."""

    shell: Shell
    supports: Supports = field(default_factory=Supports)
    mesh: MeshSpec = field(default_factory=MeshSpec)
    loads: Loads = field(default_factory=Loads)
    probes: list[tuple[float, float]] = field(default_factory=list)  # (x, φ in radians)
    solver: dict[str, Any] = field(default_factory=dict)
    punches: list[dict[str, Any]] = field(default_factory=list)  # raw [[punch]] tables
    source: Path | None = None
    raw: dict[str, Any] = field(default_factory=dict)


def parse_shell(d: dict) -> Shell:
    if not isinstance(d, dict):
        raise InputError("shell", "must be a table")
    _unknown("shell", d, SCHEMA["shell"])
    full = d.get("full", False)
    if not isinstance(full, bool):
        raise InputError("shell.full", f"must be true or false, got {full!r}")
    if full and "angle" in d:
        raise InputError("shell.angle", "give either 'angle' or 'full = true', not both")
    if not full and "angle" not in d:
        raise InputError("shell.angle", "is required unless full = true (a list [alpha, beta] in degrees)")
    alpha, beta = (0.0, 360.0) if full else vector(d, "angle", "shell", length=2)
    if not full and not -720.0 <= alpha < beta <= 720.0:
        raise InputError("shell.angle", f"needs alpha < beta within [-720, 720] degrees, got [{alpha}, {beta}]")
    th = d.get("thickness")
    if isinstance(th, str):
        th = callable_from_string(th, "shell.thickness")
    else:
        th = number(d, "thickness", "shell", positive=True)
    return Shell(
        radius=number(d, "radius", "shell", positive=True),
        length=number(d, "length", "shell", positive=True),
        thickness=th,
        young=number(d, "young", "shell", positive=True),
        poisson=number(d, "poisson", "shell"),
        alpha=math.radians(alpha),
        beta=math.radians(beta),
        full=full,
        x_start=number(d, "x_start", "shell") if "x_start" in d else None,
    )


def _floats(d: dict, key: str, where: str) -> tuple[float, ...]:
    v = d.get(key, [])
    if not isinstance(v, list) or any(isinstance(c, bool) or not isinstance(c, (int, float)) for c in v):
        raise InputError(f"{where}.{key}", f"must be a list of numbers, got {v!r}")
    return tuple(float(c) for c in v)


def parse_mesh(d: dict) -> MeshSpec:
    if not isinstance(d, dict):
        raise InputError("mesh", "must be a table")
    _unknown("mesh", d, SCHEMA["mesh"])
    g = d.get("grading", {})
    if not isinstance(g, dict):
        raise InputError("mesh.grading", "must be a table {x = [...], phi = [...], ratio = r}")
    _unknown("mesh.grading", g, {"x", "phi", "ratio"})
    pattern = d.get("pattern", "alternate")
    if pattern not in PATTERNS:
        raise InputError("mesh.pattern", f"must be one of {', '.join(PATTERNS)}, got {pattern!r}")
    file = d.get("file")
    if file is not None and not isinstance(file, str):
        raise InputError("mesh.file", f"must be a path string, got {file!r}")
    return MeshSpec(
        nx=number(d, "nx", "mesh", 16, integer=True, minimum=1),
        nphi=number(d, "nphi", "mesh", 16, integer=True, minimum=1),
        refine=number(d, "refine", "mesh", 0, integer=True, minimum=0),
        pattern=pattern,
        file=file,
        grading_x=_floats(g, "x", "mesh.grading"),
        grading_phi=tuple(math.radians(v) for v in _floats(g, "phi", "mesh.grading")),
        grading_ratio=number(g, "ratio", "mesh.grading", 1.0, minimum=1.0),
        x_lines=_floats(d, "x_lines", "mesh"),
        phi_lines=tuple(math.radians(v) for v in _floats(d, "phi_lines", "mesh")),
    )


def _field(d: dict, key: str, where: str, parse, default):
    """A load value: a constant, or 'module:callable' for a function of (x, phi) (phi in radians)."""
    value = d.get(key)
    if isinstance(value, str):
        if ":" not in value:
            kind = "a number" if parse is number else "a list of 3 numbers"
            raise InputError(f"{where}.{key}", f"must be {kind} (or 'module:callable', a function of (x, phi)), "
                             f"got {value!r}")
        return callable_from_string(value, f"{where}.{key}")
    return parse(d, key, where, default)


def parse_loads(d: dict) -> Loads:
    if not isinstance(d, dict):
        raise InputError("loads", "must be a table")
    _unknown("loads", d, SCHEMA["loads"])
    points = []
    for i, p in enumerate(d.get("point", [])):
        where = f"loads.point.{i}"
        if not isinstance(p, dict):
            raise InputError(where, "must be a table with x, phi, force")
        _unknown(where, p, {"x", "phi", "force"})
        points.append(
            PointLoad(number(p, "x", where), math.radians(number(p, "phi", where)), vector(p, "force", where))
        )
    lines = []
    for i, p in enumerate(d.get("line", [])):
        where = f"loads.line.{i}"
        if not isinstance(p, dict):
            raise InputError(where, "must be a table with x or phi, and force and/or normal")
        _unknown(where, p, {"x", "phi", "force", "normal"})
        if ("x" in p) == ("phi" in p):
            raise InputError(where, "give exactly one of 'x' or 'phi'")
        lines.append(
            LineLoad(
                force=_field(p, "force", where, vector, (0.0, 0.0, 0.0)),
                normal=_field(p, "normal", where, number, 0.0),
                x=number(p, "x", where) if "x" in p else None,
                phi=math.radians(number(p, "phi", where)) if "phi" in p else None,
            )
        )
    return Loads(
        normal=_field(d, "normal", "loads", number, 0.0),
        surface=_field(d, "surface", "loads", vector, (0.0, 0.0, 0.0)),
        lines=tuple(lines),
        points=tuple(points),
    )


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


def case_from_dict(data: dict, source: str | Path | None = None) -> Case:
    """Validate a case given as a (TOML-shaped) dictionary; a relative mesh.file is read beside ``source``."""
    _unknown("", data, SCHEMA)
    for sec in REQUIRED:
        if sec not in data:
            raise InputError(sec, f"section [{sec}] is required")
    shell = parse_shell(data["shell"])
    sup = data.get("supports", {})
    if not isinstance(sup, dict):
        raise InputError("supports", "must be a table")
    _unknown("supports", sup, SCHEMA["supports"])
    default = "periodic" if shell.full else "clamped"
    supports = Supports(
        x_min=sup.get("x_min", "clamped"),
        x_max=sup.get("x_max", "clamped"),
        phi_min=sup.get("phi_min", default),
        phi_max=sup.get("phi_max", default),
    )
    if shell.full and not supports.periodic:
        raise InputError("supports.phi_min", "a full cylinder needs phi_min = phi_max = 'periodic'")
    if supports.periodic and not shell.full:
        raise InputError("supports.phi_min", "'periodic' needs a full cylinder (shell.full = true)")
    probes = []
    for i, p in enumerate(data.get("probes", [])):
        if not isinstance(p, dict):
            raise InputError(f"probes.{i}", "must be a table {x, phi}")
        _unknown(f"probes.{i}", p, SCHEMA["probes"])
        probes.append((number(p, "x", f"probes.{i}"), math.radians(number(p, "phi", f"probes.{i}"))))
        _check_inside(shell, f"probes.{i}", *probes[-1])
    solver = data.get("solver", {})
    if not isinstance(solver, dict):
        raise InputError("solver", "must be a table")
    _unknown("solver", solver, SCHEMA["solver"])
    punches = data.get("punch", [])
    if not isinstance(punches, list):
        raise InputError("punch", "must be an array of tables [[punch]]")
    loads = parse_loads(data.get("loads", {}))
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
        solver=dict(solver),
        punches=[dict(p) for p in punches],
        source=None if source is None else Path(source),
        raw=data,
    )


def read_case_dict(path: str | Path) -> dict[str, Any]:
    """The raw TOML dictionary of a case file, with clear errors for unreadable or malformed files."""
    path = Path(path)
    try:
        text = path.read_text()
    except OSError as exc:
        raise InputError("case", f"cannot read {str(path)!r}: {exc.strerror}") from None
    except UnicodeDecodeError:
        raise InputError("case", f"{str(path)!r} is not a UTF-8 text file") from None
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise InputError("case", f"malformed TOML in {str(path)!r}: {exc}") from None


def load_case(path: str | Path, sets: Iterable[str] = ()) -> Case:
    """Read and validate a TOML case file; ``sets`` are ``key=value`` overrides (``--set``)."""
    data = read_case_dict(path)
    if sets:
        from .overrides import apply_overrides, parse_assignment

        data = apply_overrides(data, [parse_assignment(s) for s in sets])
    return case_from_dict(data, source=Path(path))


def build_mesh(case: Case, extra_x=(), extra_phi=()) -> ShellMesh:
    """The mesh of a case: structured (graded, with the required node lines) or from a file."""
    sh, ms = case.shell, case.mesh
    if ms.file:
        mesh = from_file(sh, ms.file)
    else:
        req_x = [
            *ms.x_lines,
            *extra_x,
            *(p.x for p in case.loads.points),
            *(ln.x for ln in case.loads.lines if ln.x is not None),
        ]
        req_phi = [
            *ms.phi_lines,
            *extra_phi,
            *(p.phi for p in case.loads.points),
            *(ln.phi for ln in case.loads.lines if ln.phi is not None),
        ]
        for name, vals, lo, hi in (("x", req_x, sh.x_min, sh.x_max), ("phi", req_phi, sh.alpha, sh.beta)):
            for v in vals:
                if not lo - 1e-12 <= v <= hi + 1e-12:
                    shown = v if name == "x" else math.degrees(v)
                    rng = (lo, hi) if name == "x" else (math.degrees(lo), math.degrees(hi))
                    raise InputError(
                        f"mesh.{name}", f"a required node line at {shown:.6g} lies outside [{rng[0]:.6g}, {rng[1]:.6g}]"
                    )
        xs = graded_nodes(sh.x_min, sh.x_max, ms.nx, ms.grading_x, ms.grading_ratio, req_x)
        ss = sh.radius * graded_nodes(sh.alpha, sh.beta, ms.nphi, ms.grading_phi, ms.grading_ratio, req_phi)
        mesh = structured(sh, len(xs) - 1, len(ss) - 1, ms.pattern, x_nodes=xs, s_nodes=ss)
    return mesh.refined(ms.refine)

