"""One ``[[punch]]`` table of a case file → a validated, not yet placed ``PunchSpec``.

The keys common to every shape are declared here (``PUNCH``), each shape's own keys in its
registration (``shapes.SHAPES``). Checks that need the shell (zone ranges, the default direction,
a custom function sampled on the shell) are made when the punch is placed (``placement.place``).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from ...errors import InputError
from ...inputs.schema import Key, Table
from .extent import EXTENT, Extent, parse_extent
from .friction_spec import FRICTION_KEYS, FrictionSpec, check_slide, parse_friction
from .shapes import SHAPES, unit

ZONE = Table("zone", (
    Key("x", "pair", "axial range [x0, x1]", unit="length", default=None, default_doc="automatic"),
    Key("phi", "pair", "angular range [p0, p1]; on a full cylinder it may cross the seam", angle=True,
        default=None, default_doc="automatic"),
    Key("gap", "number", "threshold g of the automatic zone {Z < g} (instead of x/phi)", unit="length",
        lo=0.0, open=("lo",), default=None, default_doc="max(2·overlap, 0.2·size)"),
))

PUNCH = Table("punch", (
    Key("shape", "choice", "the body; its own keys below", choices=SHAPES),
    Key("inverted", "bool", "the punch is the **outside** of the shape (Z → −Z): an inverted coaxial cylinder is a "
        "sleeve around the pipe (or a die), an inverted cylinder below a pipe a saddle", default=False),
    Key("side", "choice", "the surface it acts on: ζ_c = +t/2 (outer) or −t/2 (inner)", choices=("outer", "inner"),
        default="outer"),
    Key("direction", "vector", "the direction of travel (normalised); only with `indentation` or `force`",
        default=None, default_doc="see below", allowed="nonzero"),
    Key("indentation", "number", "the punch is moved along `direction` until it just touches the undeformed "
        "contact surface in its zone, then this much further", unit="length", lo=0.0, default=None,
        default_doc="–"),
    Key("force", "number", "force control: the punch starts just touching and is pushed along `direction` with "
        "this force; its travel δ is an unknown (reported as `punch_travel`)", unit="force", lo=0.0, open=("lo",),
        default=None, default_doc="–"),
    Key("zone", "table", "the candidate contact zone Ω_c", table=ZONE, default=None, default_doc="automatic",
        allowed="see below"),
    Key("extent", "table", "a body of finite size: the shape is kept inside a box and half-spaces (global "
        "coordinates of the given position; they move with the punch); contact only where the body is",
        table=EXTENT, default=None, default_doc="unbounded", allowed="see below"),
    *FRICTION_KEYS,
))


@dataclass(frozen=True)
class PunchSpec:
    """A validated ``[[punch]]`` table: the shape in its given position and how it is placed.

    ``mode`` is "fixed" (the given position is final), "indentation" or "force".
    ``zone_x``/``zone_phi`` (radians) are None where the zone is automatic; ``zone_gap`` is its
    threshold if given. ``where`` is the key path used in messages (``punch.<index>``).
    """

    index: int
    shape: str
    body: Any
    inverted: bool = False
    side: str = "outer"
    mode: str = "fixed"
    direction: np.ndarray | None = None
    indentation: float = 0.0
    force: float = 0.0
    zone_x: tuple[float, float] | None = None
    zone_phi: tuple[float, float] | None = None
    zone_gap: float | None = None
    extent: Extent | None = None  # None: the shape is unbounded
    friction: FrictionSpec = FrictionSpec()  # frictionless by default
    slide: np.ndarray | None = None  # m, a tangential rigid translation (friction drags the shell)
    tangential_force: np.ndarray | None = None  # N, the force-controlled counterpart of ``slide``

    @property
    def where(self) -> str:
        return f"punch.{self.index}"

    @property
    def drags(self) -> bool:
        """Whether the punch acts along the surface too: friction, or a slide (a tangential force needs friction)."""
        return self.friction.active or self.slide is not None

    @property
    def zone_given(self) -> bool:
        return self.zone_x is not None or self.zone_phi is not None


def parse_punch(raw: Any, index: int = 0) -> PunchSpec:
    """Validate one raw ``[[punch]]`` table (errors name ``punch.<index>.<key>``)."""
    where = f"punch.{index}"
    if not isinstance(raw, dict):
        raise InputError(where, "must be a table")
    shape = raw.get("shape")
    if shape is None:
        raise InputError(f"{where}.shape", f"is required: one of {', '.join(SHAPES)}")
    kind = SHAPES.get(shape) if isinstance(shape, str) else None
    if kind is None:
        raise InputError(f"{where}.shape", f"must be one of {', '.join(SHAPES)}, got {shape!r}")
    friction = parse_friction(raw.get("friction"), f"{where}.friction")
    v = PUNCH.parse({k: val for k, val in raw.items() if k != "friction"}, where, keys=PUNCH.keys + kind.keys)
    if v["indentation"] is not None and v["force"] is not None:
        raise InputError(f"{where}.force", "give either 'indentation' or 'force', not both")
    mode = "indentation" if v["indentation"] is not None else "force" if v["force"] is not None else "fixed"
    direction = None
    if v["direction"] is not None:
        if mode == "fixed":
            raise InputError(f"{where}.direction", "is used only with 'indentation' or 'force' (it would be ignored)")
        direction = unit(v["direction"], f"{where}.direction")
    slide = None if v["slide"] is None else np.asarray(v["slide"], float)
    check_slide(slide, direction, where)
    tangential = None if v["tangential_force"] is None else np.asarray(v["tangential_force"], float)
    check_slide(tangential, direction, where, key="tangential_force", unit="N")
    if tangential is not None and slide is not None:
        raise InputError(f"{where}.tangential_force", "give either 'slide' or 'tangential_force', not both")
    if tangential is not None and not friction.active:
        raise InputError(f"{where}.tangential_force", "needs friction (punch.<i>.friction): without it no force "
                                                      "along the surface can be held")
    zone = v["zone"] or {"x": None, "phi": None, "gap": None}
    if zone["gap"] is not None and (zone["x"] is not None or zone["phi"] is not None):
        raise InputError(f"{where}.zone.gap", "give either the ranges x/phi or an automatic-zone gap, not both")
    spec = raw.get("function") if isinstance(raw.get("function"), str) else None
    body = kind.build({**v, "spec": spec}, where)
    return PunchSpec(
        index=index,
        shape=shape,
        body=body,
        inverted=v["inverted"],
        side=v["side"],
        mode=mode,
        direction=direction,
        indentation=v["indentation"] if mode == "indentation" else 0.0,
        force=v["force"] if mode == "force" else 0.0,
        zone_x=zone["x"],
        zone_phi=zone["phi"],
        zone_gap=zone["gap"],
        extent=parse_extent(v["extent"], f"{where}.extent"),
        friction=friction,
        slide=slide,
        tangential_force=tangential,
    )


def parse_punches(raw: Any) -> tuple[PunchSpec, ...]:
    """The ``[[punch]]`` array of a case file."""
    if not isinstance(raw, (list, tuple)):
        raise InputError("punch", "must be an array of tables [[punch]]")
    return tuple(parse_punch(d, i) for i, d in enumerate(raw))
