"""Rigid punches (MODEL.md §5): shapes, their case-file tables, candidate zones and placement.

    specs = parse_punches(raw["punch"])            # validated PunchSpec objects (spec)
    punches = place_punches(specs, shell)          # placed Punch objects (placement)
    xs, phis = fitted_lines(punches, shell)        # node lines for mesh.build_mesh
    fx, fphi = focus_lines(punches)                # first-contact lines, for mesh grading

Modules: ``shapes`` (implicit surfaces Z and the shape registry ``SHAPES``), ``extent`` (the box and
half-spaces that make a shape a body of finite size), ``spec`` (one ``[[punch]]`` table →
``PunchSpec``), ``zones`` (candidate zones, sampling of the contact surface, the automatic zone, the
part of a zone opposite a finite body), ``placement`` (first contact, indentation/force placement, checks).
"""

from .extent import EXTENT, HALF_SPACE, Extent, parse_extent
from .placement import Punch, check_linear_range, fitted_lines, focus_lines, place, place_punches, punch_from_dict
from .shapes import SHAPES, Custom, Cylinder, Ellipsoid, Plane, ShapeType, Sphere, Torus, register
from .spec import PUNCH, ZONE, PunchSpec, parse_punch, parse_punches
from .zones import Zone, contact_surface, surface_minimum

__all__ = [
    "EXTENT",
    "HALF_SPACE",
    "PUNCH",
    "SHAPES",
    "ZONE",
    "Custom",
    "Cylinder",
    "Ellipsoid",
    "Extent",
    "Plane",
    "Punch",
    "PunchSpec",
    "ShapeType",
    "Sphere",
    "Torus",
    "Zone",
    "check_linear_range",
    "contact_surface",
    "fitted_lines",
    "focus_lines",
    "parse_extent",
    "parse_punch",
    "parse_punches",
    "place",
    "place_punches",
    "punch_from_dict",
    "register",
    "surface_minimum",
]
