"""Punch shapes as implicit surfaces Z (MODEL.md §5), and the registry of shapes.

The punch is the set {Z < 0}; Z > 0 outside. Every shape returns ``(Z, gradZ)`` for points X
of shape (3, n), vectorised. Z is the exact signed distance for the sphere, the infinite
cylinder, the plane and the torus (|∇Z| = 1), so the linearised gap Π = Z + ∇Z·U of MODEL.md §5
is in length units and contact multipliers are forces. The ellipsoid uses the first-order
distance Z = (q − 1)/|∇q|, q = |A⁻¹ Qᵀ (X − c)| (A = diag(radii), Q = axes): its zero set is
exactly the ellipsoid, Z < 0 inside, |∇Z| = 1 on the surface and Z agrees with the signed
distance to first order there (and Z is monotone along rays from the centre, since ∇q is
homogeneous of degree 0). A ``custom`` shape is any callable ``f(X) -> (Z, gradZ)``.

Adding a shape: a frozen dataclass with ``__call__(X) -> (Z, gradZ)`` and ``size`` (its smallest
radius, ``math.inf`` if it has none), a ``from_values(values, where)`` constructor from its
validated keys, and one ``register(ShapeType(...))`` line naming its keys (``schema.Key``) and
its documentation; the case file, the docs' key table and ``shellcontact info`` follow.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from ...errors import InputError
from ...inputs.schema import Key
from ...inputs.user_functions import UserFunction, user_function

ZFunction = Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]]


# --------------------------------------------------------------------------------------------
# shapes (all in their given position; Punch adds the placement translation and the inversion)
# --------------------------------------------------------------------------------------------
def unit(v, where: str) -> np.ndarray:
    v = np.asarray(v, dtype=float)
    nrm = float(np.linalg.norm(v))
    if not nrm > 0.0 or not math.isfinite(nrm):
        raise InputError(where, f"must be a nonzero vector, got {v.tolist()}")
    return v / nrm


def _safe_unit(d: np.ndarray, fallback: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Columns of d normalised (fallback where |d| = 0) and |d|."""
    r = np.linalg.norm(d, axis=0)
    tiny = r <= 1e-300
    out = d / np.where(tiny, 1.0, r)
    if np.any(tiny):
        out[:, tiny] = np.asarray(fallback, float).reshape(3, 1)
    return out, r


def _perpendicular(a: np.ndarray) -> np.ndarray:
    """Some unit vector perpendicular to the unit vector a."""
    trial = np.eye(3)[int(np.argmin(np.abs(a)))]
    p = trial - a * (trial @ a)
    return p / np.linalg.norm(p)


@dataclass(frozen=True)
class Sphere:
    center: np.ndarray
    radius: float

    def __call__(self, X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        g, r = _safe_unit(X - self.center[:, None], np.array([0.0, 0.0, 1.0]))
        return r - self.radius, g

    @property
    def size(self) -> float:
        return self.radius


@dataclass(frozen=True)
class Cylinder:
    """Infinite circular cylinder: axis through ``center`` along the unit vector ``axis``."""

    center: np.ndarray
    axis: np.ndarray
    radius: float

    def __call__(self, X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        d = X - self.center[:, None]
        d = d - self.axis[:, None] * (self.axis @ d)
        g, r = _safe_unit(d, _perpendicular(self.axis))
        return r - self.radius, g

    @property
    def size(self) -> float:
        return self.radius


@dataclass(frozen=True)
class Plane:
    """Half-space {(X − c)·n < 0}; ``normal`` points out of the punch."""

    center: np.ndarray
    normal: np.ndarray

    def __call__(self, X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        Z = self.normal @ (X - self.center[:, None])
        return Z, np.broadcast_to(self.normal[:, None], X.shape).copy()

    size = math.inf


@dataclass(frozen=True)
class Torus:
    """Solid torus: centre line a circle of radius R about ``axis`` through ``center``; tube radius r."""

    center: np.ndarray
    axis: np.ndarray
    major_radius: float
    minor_radius: float

    def __call__(self, X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        d = X - self.center[:, None]
        h = self.axis @ d
        radial, rho = _safe_unit(d - self.axis[:, None] * h, _perpendicular(self.axis))
        # vector from the nearest point of the centre circle to X
        q = (rho - self.major_radius) * radial + h * self.axis[:, None]
        g, dist = _safe_unit(q, self.axis)
        return dist - self.minor_radius, g

    @property
    def size(self) -> float:
        return self.minor_radius


@dataclass(frozen=True)
class Ellipsoid:
    """Z = (q − 1)/|∇q|, q = |A⁻¹ Qᵀ (X − c)|: exact zero set, |∇Z| = 1 on the surface."""

    center: np.ndarray
    radii: np.ndarray  # (3,)
    axes: np.ndarray  # (3, 3), row k = unit axis of radii[k]

    def __call__(self, X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        y = self.axes @ (X - self.center[:, None])  # local coordinates (3, n)
        r2 = self.radii[:, None] ** 2
        s2 = np.sum(y**2 / r2, axis=0)
        s4 = np.sum(y**2 / r2**2, axis=0)
        tiny = s2 <= 1e-300
        s2 = np.where(tiny, 1.0, s2)
        s4 = np.where(tiny, 1.0, s4)
        q = np.sqrt(s2)
        h = np.sqrt(s2 / s4)  # 1/|∇q|
        gq = y / (r2 * q)  # ∇q in local coordinates
        dh = (y / h) * (s4 / r2 - s2 / r2**2) / s4**2
        Z = (q - 1.0) * h
        gl = h * gq + (q - 1.0) * dh
        if np.any(tiny):  # the centre: Z = −(1/|∇q|) is direction-dependent; use the smallest radius
            Z = np.where(tiny, -float(np.min(self.radii)), Z)
            gl[:, tiny] = np.eye(3)[int(np.argmin(self.radii))][:, None]
        return Z, self.axes.T @ gl

    @property
    def size(self) -> float:
        return float(np.min(self.radii))


@dataclass(frozen=True)
class Custom:
    """A user's Z: ``function(X) -> (Z, gradZ)`` for X of shape (3, n)."""

    function: ZFunction
    name: str = "custom"

    def __post_init__(self) -> None:
        if not isinstance(self.function, UserFunction):
            object.__setattr__(self, "function", user_function(self.function, "punch.function"))

    def __call__(self, X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(Z, ∇Z), checked on every call: the user's function fails by its key, wherever it is evaluated."""
        f = self.function
        out = f(X)
        n = X.shape[1]
        if not isinstance(out, (tuple, list)) or len(out) != 2:
            raise InputError(f.where, f"{f.spec} must return a pair (Z, gradZ), got {type(out).__name__}")
        shapes = [np.shape(np.asarray(v, dtype=object)) for v in out]
        if shapes != [(n,), (3, n)]:
            raise InputError(f.where, f"{f.spec} must return (Z, gradZ) of shapes ({n},) and (3, {n}) for X of "
                             f"shape (3, {n}); got {shapes[0]} and {shapes[1]}")
        return f.array(out[0], (n,), "numbers Z"), f.array(out[1], (3, n), "numbers gradZ")

    size = math.inf




def _orthonormal_axes(rows: tuple[tuple[float, ...], ...], where: str) -> np.ndarray:
    Q = np.array([unit(r, where) for r in rows])
    if np.max(np.abs(Q @ Q.T - np.eye(3))) > 1e-6:
        raise InputError(where, "the three axes must be mutually orthogonal")
    return Q


# --------------------------------------------------------------------------------------------
# the registry
# --------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class ShapeType:
    """A registered shape: its case-file name, keys, documentation and constructor."""

    name: str
    doc: str
    keys: tuple[Key, ...]
    build: Callable[[dict[str, Any], str], Any]  # (validated values, key path) -> shape


SHAPES: dict[str, ShapeType] = {}


def register(shape: ShapeType) -> ShapeType:
    if shape.name in SHAPES:
        raise ValueError(f"shape {shape.name!r} is registered twice")
    SHAPES[shape.name] = shape
    return shape


_CENTER = Key("center", "vector", "the centre (sphere, ellipsoid, torus), a point of the axis (cylinder) or of "
              "the plane", unit="length")


def _radius(doc: str) -> Key:
    return Key("radius", "number", doc, unit="length", lo=0.0, open=("lo",))


def _axis(doc: str) -> Key:
    return Key("axis", "vector", doc, allowed="nonzero")


def _torus(v: dict[str, Any], where: str) -> Torus:
    R, r = v["major_radius"], v["minor_radius"]
    if r >= R:
        raise InputError(f"{where}.minor_radius", f"must be < major_radius ({R}) (a ring), got {r}")
    return Torus(np.array(v["center"]), unit(v["axis"], f"{where}.axis"), R, r)


def _ellipsoid(v: dict[str, Any], where: str) -> Ellipsoid:
    axes = np.eye(3) if v["axes"] is None else _orthonormal_axes(v["axes"], f"{where}.axes")
    return Ellipsoid(np.array(v["center"]), np.array(v["radii"], float), axes)


def _custom(v: dict[str, Any], where: str) -> Custom:
    f = user_function(v["function"], f"{where}.function")
    return Custom(f, f.spec if v["spec"] is None else v["spec"])


register(ShapeType("sphere", "`sphere`: exact signed distance \\|X − c\\| − r",
                   (_CENTER, _radius("radius of the sphere")),
                   lambda v, w: Sphere(np.array(v["center"]), v["radius"])))
register(ShapeType("cylinder", "`cylinder` (infinite): exact signed distance; `axis = [1, 0, 0]` is a roller "
                   "parallel to the pipe, `axis = [0, 1, 0]` a transverse bar",
                   (_CENTER, _axis("direction of the axis"), _radius("radius of the cylinder")),
                   lambda v, w: Cylinder(np.array(v["center"]), unit(v["axis"], f"{w}.axis"), v["radius"])))
register(ShapeType("plane", "`plane` (half-space): exact signed distance (X − c)·n",
                   (_CENTER, Key("normal", "vector", "normal pointing out of the punch", allowed="nonzero")),
                   lambda v, w: Plane(np.array(v["center"]), unit(v["normal"], f"{w}.normal"))))
register(ShapeType("ellipsoid", "`ellipsoid`: first-order distance (q − 1)/\\|∇q\\|: exact zero set, "
                   "\\|∇Z\\| = 1 on the surface",
                   (_CENTER, Key("radii", "vector", "the three semi-axes", unit="length", lo=0.0, open=("lo",)),
                    Key("axes", "matrix3", "three orthonormal axes (rows), for `radii` in order", default=None,
                        default_doc="the global axes", allowed="orthonormal")),
                   _ellipsoid))
register(ShapeType("torus", "`torus` (ring): exact signed distance; a ring pressed onto a pipe "
                   "(`side = \"outer\"`) or inside it (`side = \"inner\"`)",
                   (_CENTER, _axis("axis of the ring"),
                    Key("major_radius", "number", "radius of the centre circle", unit="length", lo=0.0, open=("lo",)),
                    Key("minor_radius", "number", "radius of the tube", unit="length", lo=0.0, open=("lo",),
                        allowed="> 0, < `major_radius`")),
                   _torus))
register(ShapeType("custom", "`custom`: any `f(X) -> (Z, gradZ)` with X of shape (3, n), Z of shape (n,), "
                   "gradZ (3, n); a signed distance is recommended (then Λ are forces and Λ/ω pressures)",
                   (Key("function", "function", "`\"module:function\"` returning (Z, gradZ) of shapes (n,), (3, n)"),),
                   _custom))
