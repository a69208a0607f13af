"""Unit labels: ``[units] system`` names the units the case file's numbers are in.

The package never converts a number: a case written in N, mm and MPa gives results in N, mm and
MPa. The system only decides the labels printed beside the numbers (console, figures, report) and
the ``units`` map of summary.json (``summary_units``: the unit of every numeric summary key that has
a dimension). With ``"none"`` the numbers are in any consistent units and stay unlabelled; the
summary's map then names each key's dimension instead. Angles are in degrees in every system.
"""

from __future__ import annotations

from collections.abc import Mapping
from fnmatch import fnmatchcase
from typing import Any

#: unit systems: the label of each kind of quantity ("none": the dimension, never shown beside a number)
SYSTEMS: dict[str, dict[str, str]] = {
    "SI": {
        "length": "m", "force": "N", "pressure": "Pa", "force/length": "N/m", "moment": "N·m",
        "moment/length": "N·m/m", "area": "m²", "energy": "J", "length/pressure": "m/Pa",
        "strain": "–", "angle": "deg", "time": "s",
    },
    "mm": {
        "length": "mm", "force": "N", "pressure": "MPa", "force/length": "N/mm", "moment": "N·mm",
        "moment/length": "N·mm/mm", "area": "mm²", "energy": "N·mm", "length/pressure": "mm/MPa",
        "strain": "–", "angle": "deg", "time": "s",
    },
    "none": {
        "length": "length", "force": "force", "pressure": "force/length²", "force/length": "force/length",
        "moment": "force·length", "moment/length": "force·length/length", "area": "length²",
        "energy": "force·length", "length/pressure": "length/pressure", "strain": "–", "angle": "deg",
        "time": "s",
    },
}
KINDS = tuple(SYSTEMS["SI"])
DEFAULT = "SI"


def label(kind: str, system: str = DEFAULT) -> str:
    """The unit of a kind of quantity in ``system`` ("" for a dimensioned quantity with ``"none"``)."""
    if system == "none" and kind not in ("strain", "angle", "time"):
        return ""
    return SYSTEMS[system][kind]


def bracket(kind: str, system: str = DEFAULT) -> str:
    """`` [unit]`` to append to a column title or an axis label ("" when unlabelled or dimensionless)."""
    unit = label(kind, system)
    return f" [{unit}]" if unit and unit != "–" else ""


def with_unit(value: str, kind: str, system: str = DEFAULT) -> str:
    """A formatted number followed by its unit ("" when unlabelled or dimensionless)."""
    unit = label(kind, system)
    return f"{value} {unit}" if unit and unit != "–" else value


# -- summary.json: the kind of every numeric key (dotted path, list indices dropped; first match wins) ---------
SUMMARY_KINDS: tuple[tuple[str, str | None], ...] = (
    # dimensionless or counts: no entry in the units map
    ("dofs", None), ("unknowns", None), ("elements", None), ("vertices", None), ("iterations", None),
    ("tolerance", None), ("kkt_scaled.*", None), ("equilibrium.relative_residual", None),
    ("contact.constraints", None), ("contact.rim.lines", None), ("contact.active_vertices", None),
    ("contact.active_points", None), ("contact.rim.samples.line", None),  # a sample's line: an index into per_line
    ("stresses.*.utilisation_max", None),
    ("kkt.stationarity", None), ("kkt.complementarity", None), ("kkt.duality_gap", None),
    ("kkt.force_balance", None),
    # with a dimension
    ("energy", "energy"), ("max_abs_w", "length"), ("penalty", "length/pressure"), ("timings.*", "time"),
    ("kkt.penetration", "length"), ("kkt.dual_feasibility", "force"),
    ("probes.phi", "angle"), ("probes.stress.*", "pressure"), ("probes.strain.*", "strain"), ("probes.*", "length"),
    ("stresses.*.at.phi", "angle"), ("stresses.*.at.x", "length"), ("stresses.*", "pressure"),
    ("reaction_resultant", "force"),
    ("reactions.*.force", "force"), ("reactions.*.moment", "moment"), ("reactions.*.about", "length"),
    ("equilibrium.*.force", "force"), ("equilibrium.*.moment", "moment"),
    ("contact.rim.samples.phi", "angle"), ("contact.rim.samples.x", "length"), ("contact.rim.length", "length"),
    ("contact.rim.interior_area", "area"), ("contact.rim.per_line.length", "length"),
    ("contact.rim.line_loads.length", "length"),
    ("contact.rim.mean_interior_pressure", "pressure"), ("contact.rim.*interior_pressure", "pressure"),
    ("contact.rim.carrying_area", "area"), ("contact.rim.interior_resolved", None),
    ("contact.rim.point_forces.phi", "angle"),
    ("contact.rim.point_forces.x", "length"), ("contact.rim.point_forces.position", "length"),
    ("contact.rim.per_line.end_forces.phi", "angle"), ("contact.rim.per_line.end_forces.x", "length"),
    ("contact.rim.*line_force", "force/length"), ("contact.rim.*force", "force"),
    ("contact.zone.area", "area"), ("contact.zone.phi", "angle"), ("contact.zone.*", "length"),
    ("contact.area", "area"), ("contact.peak_pressure", "pressure"), ("contact.moment", "moment"),
    ("contact.force*", "force"), ("contact.total_normal_force", "force"),
    ("contact.punch_travel", "length"), ("contact.penetration_*", "length"),
    # run --estimate / --accuracy (accuracy.py): relative estimates, orders, levels; a value has its quantity's unit
    ("accuracy.*.estimate", None), ("accuracy.*.order", None), ("refinement.levels.seconds", "time"),
    ("refinement.*", None),
)


def kind_of(path: str) -> str | None:
    """The kind of the summary key ``path`` (None: dimensionless); KeyError for a key nobody classified."""
    if path.startswith("accuracy.") and path.endswith(".value"):  # accuracy.<headline path>.value
        return kind_of(".".join(p for p in path[len("accuracy."):-len(".value")].split(".") if not p.isdigit()))
    for pattern, kind in SUMMARY_KINDS:
        if fnmatchcase(path, pattern):
            return kind
    raise KeyError(path)


def unit_kind(path: str) -> str | None:
    """The kind of the summary key ``path`` where it has a dimension; None where it has none or nobody classified it
    (``kind_of`` tells the two apart)."""
    try:
        return kind_of(path)
    except KeyError:
        return None


def numeric_paths(data: Any, prefix: str = "") -> list[str]:
    """Dotted paths of the numeric leaves of a JSON-like value (list items share their list's path)."""
    if isinstance(data, Mapping):
        return [p for k, v in data.items() for p in numeric_paths(v, f"{prefix}{k}.")]
    if isinstance(data, (list, tuple)):
        return list(dict.fromkeys(p for v in data for p in numeric_paths(v, prefix)))
    if isinstance(data, (int, float)) and not isinstance(data, bool):
        return [prefix.rstrip(".")]
    return []


def summary_units(summary: Mapping[str, Any], system: str = DEFAULT) -> dict[str, str]:
    """summary.json's ``units``: the unit of every numeric key that has a dimension (``"none"``: its dimension).

    Keys are dotted paths; the entries of a list (probes, punches) share one path, e.g. ``contact.force``.
    """
    out = {}
    for path in numeric_paths({k: v for k, v in summary.items() if k not in ("units", "unit_system")}):
        kind = unit_kind(path)  # a key nobody classified is left out (tests/test_units.py keeps the list complete)
        if kind is not None:
            out[path] = SYSTEMS[system][kind]
    return out
