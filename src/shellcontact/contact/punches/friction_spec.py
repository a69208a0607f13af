"""A punch's friction and slide keys (MODEL.md §11): ``punch.<i>.friction`` and ``punch.<i>.slide``.

``friction`` is either Coulomb's coefficient μ ≥ 0 (a number; 0, the default, is frictionless and gives
today's results bit for bit) or a table ``{ model = "tresca", bound = g }`` with the slip bound g ≥ 0 (Pa); a
table with a ``bound`` and no ``model`` is Tresca (so that ``--set punch.0.friction.bound=1e7`` is enough).
Tresca's ``surface``: "contact" (default) puts g on the points in contact of the solution itself (a fixed point
on the contact set, which may have no solution); "frictionless-contact" on the points in contact of the
frictionless solution, held fixed (the classical Tresca problem on a given surface: one convex problem).
``slide = [dx, dy, dz]`` (m, global frame) is a prescribed rigid translation of the punch tangent to its
surface; its component along the punch's direction of travel is refused (that is the indentation's job).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from ...errors import InputError
from ...inputs.schema import Key, Table

MODELS = ("coulomb", "tresca")
SURFACES = ("contact", "frictionless-contact")
#: the largest Coulomb coefficient accepted: beyond it no material pair is meant and the fixed point of the
#: static problem (whose uniqueness needs μ small) is not expected to contract
MU_MAX = 10.0

FRICTION = Table("friction", (
    Key("model", "choice", "the friction law: Coulomb (bound μ × the normal pressure) or Tresca (a given bound)",
        choices=MODELS, default="coulomb"),
    Key("coefficient", "number", "Coulomb's friction coefficient μ", lo=0.0, hi=MU_MAX, default=None,
        default_doc="–"),
    Key("bound", "number", "Tresca's slip bound g: the tangential traction where the face slides",
        unit="force/length²", lo=0.0, default=None, default_doc="–"),
    Key("surface", "choice", "where Tresca's bound acts: the points in contact of the solution (a fixed point on "
        "the contact set) or those of the frictionless solution, held fixed (one convex Tresca problem)",
        choices=SURFACES, default="contact"),
))

#: the keys ``spec.PUNCH`` declares (parsed here, before the rest of the punch table)
FRICTION_KEYS = (
    Key("friction", "number", "Coulomb's friction coefficient μ (0: frictionless), or the table "
        "`{ model = \"tresca\", bound = g }` (g in Pa)", lo=0.0, hi=MU_MAX, default=0.0,
        allowed=f"0 ≤ μ ≤ {MU_MAX:g}, or a table", table=FRICTION),  # its table's keys: ``case.key_kind``
    Key("slide", "vector", "a rigid translation of the punch tangent to its surface (friction drags the shell); "
        "its component along `direction` is refused", unit="length", default=None, default_doc="–"),
    Key("tangential_force", "vector", "the force-controlled counterpart of `slide`: the punch is pushed with this "
        "force (global frame) and slides along it until the friction force on the shell equals it; its "
        "component along `direction` is refused, and a force the friction cannot hold (the punch would slide "
        "without bound) is refused with the largest it holds", unit="force", default=None, default_doc="–"),
)


@dataclass(frozen=True)
class FrictionSpec:
    """A punch's friction law: ``model`` "coulomb" with ``coefficient`` μ, or "tresca" with ``bound`` g (Pa) on
    ``surface`` (module docstring)."""

    model: str = "coulomb"
    coefficient: float = 0.0
    bound: float = 0.0
    surface: str = "contact"

    @property
    def active(self) -> bool:
        return self.coefficient > 0.0 if self.model == "coulomb" else self.bound > 0.0


def parse_friction(raw: Any, where: str) -> FrictionSpec:
    """``punch.<i>.friction`` (module docstring); errors name the key and the allowed range."""
    if isinstance(raw, dict):
        if "model" not in raw and "bound" in raw and "coefficient" not in raw:  # ``--set punch.0.friction.bound=g``
            raw = {**raw, "model": "tresca"}
        v = FRICTION.parse(raw, where)
        if v["model"] == "tresca":
            if v["bound"] is None or v["coefficient"] is not None:
                raise InputError(f"{where}.bound", "the Tresca model needs `bound` (Pa, ≥ 0) and no `coefficient`")
            return FrictionSpec("tresca", 0.0, float(v["bound"]), v["surface"])
        if "surface" in raw:
            raise InputError(f"{where}.surface", "only the Tresca model has a `surface` (Coulomb's bound is μ × "
                                                 "the normal force wherever it acts)")
        if v["coefficient"] is None or v["bound"] is not None:
            raise InputError(f"{where}.coefficient",
                             f"the Coulomb model needs `coefficient` (0 ≤ μ ≤ {MU_MAX:g}) and no `bound`")
        return FrictionSpec("coulomb", float(v["coefficient"]), 0.0)
    mu = FRICTION_KEYS[0].parse(raw, where) if raw is not None else 0.0
    return FrictionSpec("coulomb", float(mu), 0.0)


def check_slide(slide: np.ndarray | None, direction: np.ndarray | None, where: str, rtol: float = 1e-9,
                key: str = "slide", unit: str = "m") -> None:
    """Refuse a slide (or a tangential force, ``key``) with a component along the punch's direction of travel
    (``where`` = ``punch.<i>``)."""
    if slide is None:
        return
    if key == "tangential_force" and not np.any(slide):
        raise InputError(f"{where}.{key}", "must be a nonzero vector (leave it out for none)")
    if direction is None:
        return
    along = float(np.dot(slide, direction))
    if abs(along) > rtol * float(np.linalg.norm(slide)):
        raise InputError(f"{where}.{key}", f"must be tangent: its component along the punch direction "
                                           f"{np.round(direction, 6).tolist()} is {along:.4g} {unit} (allowed: 0; "
                                           "the indentation or the force moves the punch along its direction)")
