"""Rigid punches as implicit surfaces Z (MODEL.md §5): shapes, placement, candidate zones.

The punch is the set {Z < 0}; Z > 0 outside. Every shape returns ``(Z, gradZ)`` for points
X of shape (3, n), vectorised. Z is the exact signed distance for the sphere, the infinite
cylinder, the plane and the torus (|∇Z| = 1), so the linearised gap Π = Z + ∇Z·U of
MODEL.md §5 is in length units and contact multipliers are forces. The ellipsoid uses the
first-order distance Z = (q − 1)/|∇q|, q = |A⁻¹ Qᵀ (X − c)| (A = diag(radii), Q = axes): its
zero set is exactly the ellipsoid, Z < 0 inside, |∇Z| = 1 on the surface and Z agrees with the
signed distance to first order there (and Z is monotone along rays from the centre, since ∇q is
homogeneous of degree 0). A ``custom`` shape is any callable ``f(X) -> (Z, gradZ)``.
``inverted = true`` makes the punch the outside of the shape (Z → −Z): a sleeve, a die, a saddle.

API (the lead calls these; names are stable)::

    punches = punches_from_case(case.punches, case.shell)   # validated Punch objects
    xs, phis = fitted_lines(punches, shell)                 # node lines (x, φ in radians) for build_mesh
    fx, fphi = focus_lines(punches)                         # first-contact lines, for mesh grading
    mesh = fitted_mesh(case, punches)                       # build_mesh with those lines (and grading)

Case-file keys of one ``[[punch]]`` table (``punch.<i>.<key>`` in error messages):

* ``shape`` — sphere | cylinder | plane | ellipsoid | torus | custom, and its keys: sphere
  ``center, radius``; cylinder ``center`` (a point of the axis), ``axis, radius``; plane ``center``
  (a point of it), ``normal`` (pointing out of the punch); ellipsoid ``center, radii, axes`` (three
  orthonormal vectors; default the global axes); torus ``center, axis, major_radius, minor_radius``
  (0 < minor_radius < major_radius); custom ``function = "module:callable"``.
* ``inverted`` (default false), ``side = "outer" | "inner"`` (ζ_c = +e or −e, e = t/2).
* Placement: nothing (the given position is final; overlap with the undeformed contact surface is a
  prescribed interference), or ``indentation = d >= 0``: the punch is translated along
  ``direction`` to where it just touches the undeformed contact surface in its candidate zone,
  then d further; or ``force = P > 0``: the punch starts at the just-touching position and its
  rigid translation δ along ``direction`` is an unknown (Π = Z − δ ∇Z·d + ∇Z·U, energy −P δ).
  ``direction`` (normalised here) defaults to: the plane's ``normal``; otherwise the direction from
  the punch centre toward the shell axis (side = "outer") or away from it (side = "inner"); it is
  required for custom shapes and for centres on the shell axis. ``direction`` without
  ``indentation``/``force`` is an error (it would be ignored). The just-touching translation t
  solves min_M Z(M − t d) = 0 over the contact surface of the zone (sphere tracing + Newton to a
  bracket, then Brent); a punch given in overlap backs off (t < 0).
* ``zone = { x = [x0, x1], phi = [p0, p1] }`` (degrees; either range may be omitted = whole
  range; on a full cylinder a φ range may cross the seam, e.g. [-30, 30]). Without ``x``/``phi`` the
  zone is automatic: the bounding box in (x, φ) of {Z < g} on the contact surface, Z of the placed
  punch (for force control the just-touching one), its edges located by root finding (so symmetric
  configurations give symmetric zones) and snapped to the shell edges when within 2 % of them,
  with the threshold g = max(2·overlap, 0.2·size), overlap = −min Z ≥ 0, size = the punch's
  smallest radius (sphere/cylinder radius, torus minor radius, smallest ellipsoid radius; the
  shell radius for a plane or custom shape) capped by the shell radius. ``zone = { gap = g }``
  overrides g. For force control the travel is unknown in advance: if the contact zone reaches
  the edge of the automatic zone, give a larger gap or an explicit zone.

Checks (InputError naming the key): unknown shape or key, bad numbers/vectors, radius <= 0,
zero axis/normal/direction, non-orthonormal ellipsoid axes, minor_radius >= major_radius,
indentation together with force, negative indentation, force <= 0, a zone outside Ω or empty, a
punch that never touches the shell moving along ``direction``, a punch whose smallest gap over its
zone is not below g (nowhere near the shell), an overlap larger than the shell can take: overlap > 0.2·a
(comparable to the radius) or overlap > 10·t (ten thicknesses: far outside linear shell theory),
and a custom function that is not callable or returns wrong shapes / non-finite values.

The undeformed contact surface is sampled on a fine (x, φ) grid over the zone (not at mesh
vertices, which do not exist yet), with repeated zooming around the minimiser, so first contact,
overlap and the automatic zone are mesh-independent.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np

from .errors import InputError
from .geometry import Shell, frame

SHAPES = ("sphere", "cylinder", "plane", "ellipsoid", "torus", "custom")
COMMON_KEYS = {"shape", "inverted", "side", "direction", "indentation", "force", "zone"}
SHAPE_KEYS = {
    "sphere": {"center", "radius"},
    "cylinder": {"center", "axis", "radius"},
    "plane": {"center", "normal"},
    "ellipsoid": {"center", "radii", "axes"},
    "torus": {"center", "axis", "major_radius", "minor_radius"},
    "custom": {"function"},
}
OVERLAP_RADIUS_FRACTION = 0.2  # overlap must stay below this fraction of the shell radius
OVERLAP_THICKNESSES = 10.0  # ... and below this many shell thicknesses
ZONE_OVERLAP_FACTOR = 2.0  # automatic zone threshold g = max(2 overlap, 0.2 size)
ZONE_SIZE_FRACTION = 0.2
ZONE_SNAP = 0.02  # automatic zone edges within 2 % of a shell edge are moved onto it

ZFunction = Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]]


# --------------------------------------------------------------------------------------------
# shapes (all in their given position; Punch adds the placement translation and the inversion)
# --------------------------------------------------------------------------------------------
def _unit(v: np.ndarray, where: str) -> np.ndarray:
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
    function: ZFunction
    name: str = "custom"

    def __call__(self, X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        Z, g = self.function(X)
        return np.asarray(Z, dtype=float).reshape(X.shape[1]), np.asarray(g, dtype=float).reshape(3, X.shape[1])

    size = math.inf


# --------------------------------------------------------------------------------------------
# zones and surface sampling
# --------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Zone:
    """Candidate zone Ω_c: x ∈ [x0, x1] and φ in one of ``phi`` intervals (radians, inside [α, β])."""

    x: tuple[float, float]
    phi: tuple[tuple[float, float], ...]
    automatic: bool = False
    gap: float | None = None  # the threshold g of an automatic zone

    def contains(self, x: np.ndarray, phi: np.ndarray, tol: float = 0.0) -> np.ndarray:
        x, phi = np.asarray(x, float), np.asarray(phi, float)
        inx = (x >= self.x[0] - tol) & (x <= self.x[1] + tol)
        inp = np.zeros(np.shape(phi), dtype=bool)
        for p0, p1 in self.phi:
            inp |= (phi >= p0 - tol) & (phi <= p1 + tol)
        return inx & inp

    def area(self, radius: float) -> float:
        """Mid-surface area a·Δx·Δφ."""
        return radius * (self.x[1] - self.x[0]) * sum(p1 - p0 for p0, p1 in self.phi)

    def describe(self) -> str:
        ph = ", ".join(f"[{math.degrees(a):.6g}, {math.degrees(b):.6g}]" for a, b in self.phi)
        return f"x in [{self.x[0]:.6g}, {self.x[1]:.6g}], phi in {ph} deg"


def contact_surface(shell: Shell, x: np.ndarray, phi: np.ndarray, side_sign: float) -> np.ndarray:
    """Points Φ(x, φ) + ζ_c n(φ), ζ_c = ±t(x, φ)/2, shape (3, ...)."""
    zeta = 0.5 * side_sign * shell.t(np.asarray(x, float), phi)
    return shell.point(x, phi, zeta)


def _grid_counts(shell: Shell, xr, pr, n: int) -> tuple[int, int]:
    lx, ls = xr[1] - xr[0], shell.radius * (pr[1] - pr[0])
    if lx <= 0 or ls <= 0:
        return max(n, 2) if lx > 0 else 1, max(n, 2) if ls > 0 else 1
    ratio = math.sqrt(lx / ls)
    nx = int(np.clip(round(n * ratio), 16, 4 * n))
    nphi = int(np.clip(round(n / ratio), 16, 4 * n))
    return nx, nphi


def surface_minimum(
    fun: Callable[[np.ndarray], np.ndarray],
    shell: Shell,
    side_sign: float,
    zone: Zone,
    n: int = 161,
    levels: int = 6,
) -> tuple[float, float, float]:
    """min over the contact surface in ``zone`` of fun(M) (fun: (3, k) → (k,)), and its (x, φ).

    A grid of about n × n points, then ``levels`` zooms (21 × 21 points over ±1 cell around the
    current minimiser), each gaining a factor 10 in resolution.
    """
    best = (math.inf, math.nan, math.nan)
    for pr0 in zone.phi:
        xr, pr = zone.x, pr0
        nx, nphi = _grid_counts(shell, xr, pr, n)
        for level in range(levels + 1):
            xs = np.linspace(xr[0], xr[1], nx) if xr[1] > xr[0] else np.array([xr[0]])
            ps = np.linspace(pr[0], pr[1], nphi) if pr[1] > pr[0] else np.array([pr[0]])
            X, P = np.meshgrid(xs, ps, indexing="ij")
            vals = np.asarray(fun(contact_surface(shell, X.ravel(), P.ravel(), side_sign)), float)
            if not np.all(np.isfinite(vals)):
                vals = np.where(np.isfinite(vals), vals, np.inf)
            k = int(np.argmin(vals))
            i, j = np.unravel_index(k, X.shape)
            if vals[k] < best[0]:
                best = (float(vals[k]), float(X[i, j]), float(P[i, j]))
            if level == levels:
                break
            dx = (xs[1] - xs[0]) if xs.size > 1 else 0.0
            dp = (ps[1] - ps[0]) if ps.size > 1 else 0.0
            xr = (max(zone.x[0], X[i, j] - dx), min(zone.x[1], X[i, j] + dx))
            pr = (max(pr0[0], P[i, j] - dp), min(pr0[1], P[i, j] + dp))
            nx = nphi = 21
    return best


# --------------------------------------------------------------------------------------------
# the placed punch
# --------------------------------------------------------------------------------------------
@dataclass
class Punch:
    """A validated, placed rigid punch (MODEL.md §5).

    ``Z(X)`` includes the placement translation ``offset`` (Z(X) = ±Z_shape(X − offset)) and the
    inversion. ``mode`` is "fixed", "indentation" or "force"; for force control the punch sits at
    the just-touching position and ``direction``/``force`` define the unknown travel δ.
    """

    index: int
    shape: str
    body: Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]]
    inverted: bool
    side: str
    mode: str
    direction: np.ndarray | None
    indentation: float
    force: float
    zone: Zone
    offset: np.ndarray = field(default_factory=lambda: np.zeros(3))
    touch_travel: float = 0.0  # translation along direction from the given to the just-touching position
    center: np.ndarray = field(default_factory=lambda: np.zeros(3))  # reference point (placed)
    overlap: float = 0.0  # −min Z ≥ 0 on the undeformed contact surface (prescribed interference)
    min_gap: float = 0.0  # min Z on the contact surface in the zone (= −overlap when overlapping)
    first_contact: tuple[float, float] = (math.nan, math.nan)  # (x, φ) of min Z
    # whether Z varies along x (at φ of first contact) / along φ (at x of first contact): False for
    # the generator of a parallel roller (x) or the circle of a ring (φ); such lines are not fitted
    varies_x: bool = True
    varies_phi: bool = True
    size: float = math.inf

    @property
    def where(self) -> str:
        return f"punch.{self.index}"

    @property
    def side_sign(self) -> float:
        return 1.0 if self.side == "outer" else -1.0

    @property
    def force_controlled(self) -> bool:
        return self.mode == "force"

    def Z(self, X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(Z, ∇Z) of the placed punch at points X (3, n)."""
        X = np.asarray(X, dtype=float).reshape(3, -1)
        Z, g = self.body(X - self.offset[:, None])
        if self.inverted:
            return -Z, -g
        return Z, g

    def __call__(self, X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return self.Z(X)

    def zeta(self, shell: Shell, x: np.ndarray, phi: np.ndarray) -> np.ndarray:
        return 0.5 * self.side_sign * shell.t(np.asarray(x, float), phi)


# --------------------------------------------------------------------------------------------
# parsing
# --------------------------------------------------------------------------------------------
def _orthonormal_axes(raw, where: str) -> np.ndarray:
    if (
        not isinstance(raw, list)
        or len(raw) != 3
        or any(not isinstance(r, list) or len(r) != 3 for r in raw)
        or any(isinstance(c, bool) or not isinstance(c, (int, float)) or not math.isfinite(c) for r in raw for c in r)
    ):
        raise InputError(where, f"must be three 3-vectors [[..], [..], [..]], got {raw!r}")
    Q = np.array([_unit(r, where) for r in raw])
    if np.max(np.abs(Q @ Q.T - np.eye(3))) > 1e-6:
        raise InputError(where, "the three axes must be mutually orthogonal")
    return Q


def _zone(raw, shell: Shell, where: str) -> Zone | float | None:
    """A given rectangle → Zone; {gap = g} → g; nothing → None."""
    from .case import _unknown, number, vector

    if raw is None:
        return None
    if not isinstance(raw, dict):
        raise InputError(where, "must be a table { x = [x0, x1], phi = [p0, p1] } (phi in degrees)")
    _unknown(where, raw, {"x", "phi", "gap"})
    if "gap" in raw:
        if "x" in raw or "phi" in raw:
            raise InputError(f"{where}.gap", "give either the ranges x/phi or an automatic-zone gap, not both")
        return float(number(raw, "gap", where, positive=True))
    tol = 1e-9 * max(shell.length, shell.radius, abs(shell.x_min), abs(shell.x_max))
    x0, x1 = vector(raw, "x", where, (shell.x_min, shell.x_max), length=2)
    if not x0 < x1:
        raise InputError(f"{where}.x", f"needs x0 < x1, got [{x0}, {x1}]")
    if x0 < shell.x_min - tol or x1 > shell.x_max + tol:
        raise InputError(f"{where}.x", f"[{x0}, {x1}] lies outside the shell x in [{shell.x_min}, {shell.x_max}]")
    x0, x1 = max(x0, shell.x_min), min(x1, shell.x_max)
    alpha, beta = shell.alpha, shell.beta
    if "phi" in raw:
        p0d, p1d = vector(raw, "phi", where, length=2)
        p0, p1 = math.radians(p0d), math.radians(p1d)
        if not p0 < p1:
            raise InputError(f"{where}.phi", f"needs p0 < p1, got [{p0d}, {p1d}]")
        atol = 1e-9
        if shell.full:
            if p1 - p0 >= 2 * math.pi - atol:
                phis: tuple[tuple[float, float], ...] = ((alpha, beta),)
            else:
                k = math.floor((p0 - alpha) / (2 * math.pi))
                p0, p1 = p0 - 2 * math.pi * k, p1 - 2 * math.pi * k
                if p1 <= beta + atol:
                    phis = ((p0, min(p1, beta)),)
                else:  # the interval crosses the seam φ = α ≡ β
                    phis = ((alpha, p1 - 2 * math.pi), (p0, beta))
        else:
            if p0 < alpha - atol or p1 > beta + atol:
                raise InputError(
                    f"{where}.phi",
                    f"[{p0d}, {p1d}] deg lies outside the shell phi in "
                    f"[{math.degrees(alpha):.6g}, {math.degrees(beta):.6g}] deg",
                )
            phis = ((max(p0, alpha), min(p1, beta)),)
    else:
        phis = ((alpha, beta),)
    return Zone(x=(float(x0), float(x1)), phi=tuple((float(a), float(b)) for a, b in phis))


def _parse_body(d: dict, shape: str, where: str):
    from .case import callable_from_string, number, vector

    if shape == "sphere":
        return Sphere(np.array(vector(d, "center", where)), float(number(d, "radius", where, positive=True)))
    if shape == "cylinder":
        return Cylinder(
            np.array(vector(d, "center", where)),
            _unit(vector(d, "axis", where), f"{where}.axis"),
            float(number(d, "radius", where, positive=True)),
        )
    if shape == "plane":
        return Plane(np.array(vector(d, "center", where)), _unit(vector(d, "normal", where), f"{where}.normal"))
    if shape == "torus":
        R = float(number(d, "major_radius", where, positive=True))
        r = float(number(d, "minor_radius", where, positive=True))
        if r >= R:
            raise InputError(f"{where}.minor_radius", f"must be < major_radius ({R}) (a ring), got {r}")
        return Torus(np.array(vector(d, "center", where)), _unit(vector(d, "axis", where), f"{where}.axis"), R, r)
    if shape == "ellipsoid":
        radii = vector(d, "radii", where)
        if min(radii) <= 0:
            raise InputError(f"{where}.radii", f"must be three numbers > 0, got {list(radii)}")
        axes = _orthonormal_axes(d["axes"], f"{where}.axes") if "axes" in d else np.eye(3)
        return Ellipsoid(np.array(vector(d, "center", where)), np.array(radii, float), axes)
    if shape == "custom":
        spec = d.get("function")
        if spec is None:
            raise InputError(f"{where}.function", "is required for a custom shape ('module:callable')")
        if callable(spec):  # programmatic use
            return Custom(spec, getattr(spec, "__name__", "custom"))
        return Custom(callable_from_string(spec, f"{where}.function"), str(spec))
    raise AssertionError(shape)


def _check_custom(body: Custom, shell: Shell, where: str) -> None:
    x = np.linspace(shell.x_min, shell.x_max, 3)
    phi = np.linspace(shell.alpha, shell.beta, 3)
    X = shell.point(*np.meshgrid(x, phi, indexing="ij"), 0.0).reshape(3, -1)
    try:
        Z, g = body.function(X)
        Z, g = np.asarray(Z, dtype=float), np.asarray(g, dtype=float)
    except Exception as exc:  # user code may raise anything
        raise InputError(
            f"{where}.function", f"calling {body.name} on points X of shape (3, n) failed: {exc!r}"
        ) from None
    if Z.shape != (X.shape[1],) or g.shape != X.shape:
        raise InputError(
            f"{where}.function",
            f"must return (Z, gradZ) of shapes (n,) and (3, n) for X of shape (3, n); got {Z.shape} and {g.shape}",
        )
    if not (np.all(np.isfinite(Z)) and np.all(np.isfinite(g))):
        raise InputError(f"{where}.function", "returned non-finite values on the shell")


def _default_direction(body, shape: str, side: str, shell: Shell, where: str) -> np.ndarray:
    if shape == "plane":
        return body.normal.copy()
    if shape == "custom":
        raise InputError(f"{where}.direction", "is required for a custom shape with indentation or force")
    c = np.asarray(body.center, float)
    perp = np.array([0.0, c[1], c[2]])
    if np.linalg.norm(perp) < 1e-9 * shell.radius:
        raise InputError(
            f"{where}.direction",
            "is required: the punch centre lies on the shell axis, so 'toward the axis' is undefined",
        )
    perp /= np.linalg.norm(perp)
    return -perp if side == "outer" else perp


def _touch_travel(punch: Punch, shell: Shell, body_Z, where: str) -> float:
    """Translation t along ``direction`` with min over the contact surface of Z(M − t d) = 0."""
    d = punch.direction
    zone = punch.zone

    def f(t: float) -> tuple[float, float, float]:
        return surface_minimum(lambda M: body_Z(M - t * d[:, None])[0], shell, punch.side_sign, zone)

    def slope(t: float, x: float, phi: float) -> float:
        M = contact_surface(shell, np.array([x]), np.array([phi]), punch.side_sign)
        return float(-(body_Z(M - t * d[:, None])[1][:, 0] @ d))

    scale = max(shell.length, shell.radius, float(np.max(np.abs(punch.center))))
    tmax = 20.0 * scale
    tol = 1e-12 * scale
    f0, x0, p0 = f(0.0)
    if abs(f0) <= tol:
        return 0.0
    sgn = 1.0 if f0 > 0 else -1.0  # not touching: move forward; overlapping: back off
    ta, fa, xa, pa = 0.0, f0, x0, p0
    for _ in range(400):
        c = abs(slope(ta, xa, pa))
        step = abs(fa) / max(c, 0.1)
        step = min(max(step, abs(fa)), 10.0 * abs(fa))
        tb = ta + sgn * step
        fb, xb, pb = f(tb)
        if abs(fb) <= tol:
            return tb
        if np.sign(fb) != np.sign(fa):
            break
        ta, fa, xa, pa = tb, fb, xb, pb
        if abs(ta) > tmax:
            tb = math.nan
            break
    else:
        tb = math.nan
    if not math.isfinite(tb):
        what = "touches" if sgn > 0 else "separates from"
        raise InputError(
            f"{where}.direction",
            f"moving the punch along {np.round(d, 6).tolist()} it never {what} the {punch.side} contact surface "
            f"in the zone ({zone.describe()}); check center, direction and side",
        )
    from scipy.optimize import brentq

    return float(brentq(lambda t: f(t)[0], min(ta, tb), max(ta, tb), xtol=tol, rtol=1e-15, maxiter=200))


def _edge(h: Callable[[float], float], inside: float, outside: float) -> float:
    """The boundary of {h < 0} between a grid point inside and one outside (conservative fallback)."""
    from scipy.optimize import brentq

    if h(outside) <= 0.0:
        return outside
    return float(brentq(h, inside, outside, xtol=1e-14 * max(1.0, abs(inside)), rtol=1e-15))


def _automatic_zone(punch: Punch, shell: Shell, gap: float, n: int = 201) -> Zone | None:
    """Bounding box (x, φ) of {Z < gap} on the contact surface; None if empty.

    The set is found on a grid of about n × n points; each edge of its bounding box is then
    located by root finding on min_φ Z(x, ·) − gap (resp. min_x Z(·, φ) − gap), so that symmetric
    configurations give symmetric zones. Edges within 2 % of a shell edge (or of the seam of a full
    cylinder) are moved onto it, so that no thin strip of elements appears.
    """
    nx, nphi = _grid_counts(shell, (shell.x_min, shell.x_max), (shell.alpha, shell.beta), n)
    xs = np.linspace(shell.x_min, shell.x_max, nx)
    ps = np.linspace(shell.alpha, shell.beta, nphi)
    X, P = np.meshgrid(xs, ps, indexing="ij")
    Zv = punch.Z(contact_surface(shell, X.ravel(), P.ravel(), punch.side_sign))[0].reshape(X.shape)
    mask = Zv < gap
    fx, fp = punch.first_contact
    if math.isfinite(fx) and punch.min_gap < gap:  # the cell of the deepest point
        mask[int(np.argmin(np.abs(xs - fx))), int(np.argmin(np.abs(ps - fp)))] = True
    if not np.any(mask):
        return None
    side = punch.side_sign
    whole_x = (shell.x_min, shell.x_max)

    def h_x(x: float) -> float:
        z = Zone((x, x), ((shell.alpha, shell.beta),))
        return surface_minimum(lambda M: punch.Z(M)[0], shell, side, z, levels=4)[0] - gap

    def h_p(phi: float) -> float:
        phi = shell.alpha + (phi - shell.alpha) % (2 * math.pi) if shell.full else phi
        z = Zone(whole_x, ((phi, phi),))
        return surface_minimum(lambda M: punch.Z(M)[0], shell, side, z, levels=4)[0] - gap

    mx = np.nonzero(mask.any(axis=1))[0]
    i0, i1 = int(mx[0]), int(mx[-1])
    x0 = shell.x_min if i0 == 0 else _edge(h_x, xs[i0], xs[i0 - 1])
    x1 = shell.x_max if i1 == nx - 1 else _edge(h_x, xs[i1], xs[i1 + 1])
    snap_x = ZONE_SNAP * shell.length
    x0 = shell.x_min if x0 - shell.x_min < snap_x else x0
    x1 = shell.x_max if shell.x_max - x1 < snap_x else x1
    xr = (float(x0), float(x1))
    snap_p = ZONE_SNAP * (shell.beta - shell.alpha)
    dp = ps[1] - ps[0]
    mp = mask.any(axis=0)
    if not shell.full:
        j = np.nonzero(mp)[0]
        j0, j1 = int(j[0]), int(j[-1])
        p0 = shell.alpha if j0 == 0 else _edge(h_p, ps[j0], ps[j0 - 1])
        p1 = shell.beta if j1 == nphi - 1 else _edge(h_p, ps[j1], ps[j1 + 1])
        p0 = shell.alpha if p0 - shell.alpha < snap_p else p0
        p1 = shell.beta if shell.beta - p1 < snap_p else p1
        return Zone(xr, ((float(p0), float(p1)),), True, gap)
    cov = mp[:-1] | (mp[-1] & (np.arange(nphi - 1) == 0))  # periodic: ps[-1] is ps[0]
    m = cov.size
    if cov.all():
        return Zone(xr, ((shell.alpha, shell.beta),), True, gap)
    # the longest run of uncovered samples; the covered arc runs from just after it to just before it
    free = ~cov
    best_len, best_end, run = 0, 0, 0
    for k in range(2 * m):
        run = run + 1 if free[k % m] else 0
        if run > best_len:
            best_len, best_end = run, k
    j_lo = (best_end + 1) % m  # first covered index after the gap
    j_hi = (best_end - best_len) % m  # last covered index before the gap
    lo = shell.alpha + j_lo * dp
    hi = shell.alpha + j_hi * dp
    if hi < lo:
        hi += 2 * math.pi
    lo = _edge(h_p, lo, lo - dp)
    hi = _edge(h_p, hi, hi + dp)
    if lo < shell.alpha:
        lo, hi = lo + 2 * math.pi, hi + 2 * math.pi
    if hi - lo >= 2 * math.pi - 2 * snap_p:
        return Zone(xr, ((shell.alpha, shell.beta),), True, gap)
    if lo - shell.alpha < snap_p:
        lo = shell.alpha
    elif shell.beta - lo < snap_p:
        lo, hi = shell.alpha, hi - 2 * math.pi
    if abs(hi - shell.beta) < snap_p or (hi > shell.beta and hi - 2 * math.pi - shell.alpha < snap_p):
        hi = shell.beta
    lo, hi = float(lo), float(hi)
    if hi <= shell.beta:
        return Zone(xr, ((lo, hi),), True, gap)
    return Zone(xr, ((shell.alpha, hi - 2 * math.pi), (lo, shell.beta)), True, gap)


def _polish_minimum(punch: Punch, shell: Shell, x: float, phi: float, width: float) -> tuple[float, float, float]:
    """Refine the grid minimiser of Z on the contact surface by zeroing ∂Z/∂x and ∂Z/∂φ in turn."""
    from scipy.optimize import brentq

    a, side = shell.radius, punch.side_sign

    def dZ(xv: float, pv: float, coord: int) -> float:
        x1, p1 = np.array([xv]), np.array([pv])
        M = contact_surface(shell, x1, p1, side)
        g = punch.Z(M)[1][:, 0]
        e1, e2, n = (v[:, 0] for v in frame(p1))
        h = 1e-6 * max(shell.length, a)
        if coord == 0:
            dzeta = (punch.zeta(shell, x1 + h, p1) - punch.zeta(shell, x1 - h, p1))[0] / (2 * h)
            return float(g @ (e1 + dzeta * n))
        dzeta = (punch.zeta(shell, x1, p1 + h / a) - punch.zeta(shell, x1, p1 - h / a))[0] / (2 * h / a)
        zeta = punch.zeta(shell, x1, p1)[0]
        return float(g @ ((a + zeta) * e2 + dzeta * n))

    prange = next(((p0, p1) for p0, p1 in punch.zone.phi if p0 <= phi <= p1), (phi, phi))
    lims = ((punch.zone.x[0], punch.zone.x[1]), prange)
    widths = (width * max(shell.length, 1e-300), width * (shell.beta - shell.alpha))
    c = [x, phi]
    for _ in range(2):
        for k in (0, 1):
            lo, hi = max(lims[k][0], c[k] - widths[k]), min(lims[k][1], c[k] + widths[k])
            if not lo < hi:
                continue

            def f(v: float, k: int = k) -> float:
                cc = list(c)
                cc[k] = v
                return dZ(cc[0], cc[1], k)

            flo, fhi = f(lo), f(hi)
            if flo < 0.0 < fhi:
                c[k] = float(brentq(f, lo, hi, xtol=1e-15 * max(1.0, abs(c[k])), rtol=1e-15))
    M = contact_surface(shell, np.array([c[0]]), np.array([c[1]]), side)
    return float(punch.Z(M)[0][0]), c[0], c[1]


def punch_from_dict(d: dict, shell: Shell, index: int = 0) -> Punch:
    """Validate one raw [[punch]] table and place the punch (see the module docstring)."""
    from .case import _unknown, number, vector

    where = f"punch.{index}"
    if not isinstance(d, dict):
        raise InputError(where, "must be a table")
    shape = d.get("shape")
    if shape is None:
        raise InputError(f"{where}.shape", f"is required: one of {', '.join(SHAPES)}")
    if shape not in SHAPES:
        raise InputError(f"{where}.shape", f"must be one of {', '.join(SHAPES)}, got {shape!r}")
    _unknown(where, d, COMMON_KEYS | SHAPE_KEYS[shape])
    inverted = d.get("inverted", False)
    if not isinstance(inverted, bool):
        raise InputError(f"{where}.inverted", f"must be true or false, got {inverted!r}")
    side = d.get("side", "outer")
    if side not in ("outer", "inner"):
        raise InputError(f"{where}.side", f"must be 'outer' or 'inner', got {side!r}")
    if "indentation" in d and "force" in d:
        raise InputError(f"{where}.force", "give either 'indentation' or 'force', not both")
    mode = "indentation" if "indentation" in d else "force" if "force" in d else "fixed"
    indentation = float(number(d, "indentation", where, 0.0, minimum=0.0)) if mode == "indentation" else 0.0
    force = float(number(d, "force", where, positive=True)) if mode == "force" else 0.0
    body = _parse_body(d, shape, where)
    if isinstance(body, Custom):
        _check_custom(body, shell, where)
    direction = None
    if "direction" in d:
        if mode == "fixed":
            raise InputError(f"{where}.direction", "is used only with 'indentation' or 'force' (it would be ignored)")
        direction = _unit(vector(d, "direction", where), f"{where}.direction")
    elif mode != "fixed":
        direction = _default_direction(body, shape, side, shell, where)
    zone_or_gap = _zone(d.get("zone"), shell, f"{where}.zone")
    given_zone = zone_or_gap if isinstance(zone_or_gap, Zone) else None
    whole = Zone((shell.x_min, shell.x_max), ((shell.alpha, shell.beta),))
    center = np.asarray(getattr(body, "center", np.zeros(3)), dtype=float)
    size = min(float(body.size), shell.radius)
    punch = Punch(
        index=index,
        shape=shape,
        body=body,
        inverted=inverted,
        side=side,
        mode=mode,
        direction=direction,
        indentation=indentation,
        force=force,
        zone=given_zone or whole,
        center=center.copy(),
        size=size,
    )
    sgn = -1.0 if inverted else 1.0

    def body_Z(X):
        Z, g = body(X)
        return sgn * Z, sgn * g

    if mode != "fixed":
        t0 = _touch_travel(punch, shell, body_Z, where)
        punch.touch_travel = t0
        travel = t0 + (indentation if mode == "indentation" else 0.0)
        punch.offset = travel * direction
        punch.center = center + punch.offset
    zmin, xm, pm = surface_minimum(lambda M: punch.Z(M)[0], shell, punch.side_sign, punch.zone)
    zp, xp, pp = _polish_minimum(punch, shell, xm, pm, 1e-4)
    if zp <= zmin:
        zmin, xm, pm = zp, xp, pp
    punch.min_gap, punch.first_contact = zmin, (xm, pm)
    punch.overlap = max(0.0, -zmin)
    # overlap larger than the shell can take
    tmax = float(
        np.max(shell.t(np.linspace(shell.x_min, shell.x_max, 9)[:, None], np.linspace(shell.alpha, shell.beta, 9)))
    )
    key = f"{where}.indentation" if mode == "indentation" else where
    if punch.overlap > OVERLAP_RADIUS_FRACTION * shell.radius:
        raise InputError(
            key,
            f"the punch overlaps the undeformed shell by {punch.overlap:.4g}, more than "
            f"{OVERLAP_RADIUS_FRACTION} x radius = {OVERLAP_RADIUS_FRACTION * shell.radius:.4g}: "
            "far beyond a linear shell",
        )
    if punch.overlap > OVERLAP_THICKNESSES * tmax:
        raise InputError(
            key,
            f"the punch overlaps the undeformed shell by {punch.overlap:.4g}, more than {OVERLAP_THICKNESSES:g} "
            f"thicknesses ({OVERLAP_THICKNESSES * tmax:.4g}): far beyond a linear shell",
        )
    gap = (
        zone_or_gap
        if isinstance(zone_or_gap, float)
        else max(ZONE_OVERLAP_FACTOR * punch.overlap, ZONE_SIZE_FRACTION * size)
    )
    zone = _automatic_zone(punch, shell, gap) if given_zone is None else given_zone
    if zone is None or zmin >= gap:
        x, p = punch.first_contact
        raise InputError(
            where,
            f"the punch does not touch the {side} surface of the shell: smallest gap {zmin:.4g} (at "
            f"x = {x:.6g}, phi = {math.degrees(p):.6g} deg) is not below the zone threshold {gap:.4g}; "
            "move it or give 'indentation' or 'force'",
        )
    punch.zone = zone
    punch.varies_x, punch.varies_phi = _variation(punch, shell)
    return punch


def _variation(punch: Punch, shell: Shell, n: int = 64) -> tuple[bool, bool]:
    """Does Z change along the x-line and the φ-circle through the first-contact point (in the zone)?"""
    x, phi = punch.first_contact
    if not (math.isfinite(x) and math.isfinite(phi)):
        return False, False
    tol = 1e-9 * min(punch.size, shell.radius)
    xs = np.linspace(punch.zone.x[0], punch.zone.x[1], n)
    zx = punch.Z(contact_surface(shell, xs, np.full(n, phi), punch.side_sign))[0]
    ps = np.concatenate([np.linspace(p0, p1, n) for p0, p1 in punch.zone.phi])
    zp = punch.Z(contact_surface(shell, np.full(ps.size, x), ps, punch.side_sign))[0]
    return bool(np.ptp(zx) > tol), bool(np.ptp(zp) > tol)


def punches_from_case(raw: Sequence[dict], shell: Shell) -> list[Punch]:
    """Validated, placed punches from the raw [[punch]] tables (``Case.punches``)."""
    if not isinstance(raw, (list, tuple)):
        raise InputError("punch", "must be an array of tables [[punch]]")
    return [punch_from_dict(d, shell, i) for i, d in enumerate(raw)]


# --------------------------------------------------------------------------------------------
# meshes that fit the punch
# --------------------------------------------------------------------------------------------
def _dedupe(values: list[float], lo: float, hi: float, tol: float) -> list[float]:
    out: list[float] = []
    for v in sorted(v for v in values if lo + tol < v < hi - tol):
        if not out or v - out[-1] > tol:
            out.append(v)
    return out


def focus_lines(punches: Sequence[Punch]) -> tuple[list[float], list[float]]:
    """x and φ (radians) of each punch's point of first contact / deepest overlap (grading focus).

    A coordinate along which Z does not vary (a ring: φ; a parallel roller: x; a coaxial sleeve:
    both) gives no line.
    """
    xs = [p.first_contact[0] for p in punches if p.varies_x and math.isfinite(p.first_contact[0])]
    ps = [p.first_contact[1] for p in punches if p.varies_phi and math.isfinite(p.first_contact[1])]
    return xs, ps


def fitted_lines(punches: Sequence[Punch], shell: Shell) -> tuple[list[float], list[float]]:
    """Node lines (x values, φ values in radians) for ``case.build_mesh(extra_x=, extra_phi=)``.

    The edges of every candidate zone, and the x- and φ-lines through each punch's point of first
    contact (deepest overlap): for a sphere the point itself, for a ring around the pipe its plane
    x = const, for a parallel roller its generator φ = const, for a transverse bar the line under it.
    Lines on or within 1e-9·extent of the shell edges or of each other are merged.
    """
    xs: list[float] = []
    ps: list[float] = []
    for p in punches:
        xs += list(p.zone.x)
        for a, b in p.zone.phi:
            ps += [a, b]
    fx, fp = focus_lines(punches)
    xs += fx
    ps += fp
    tx = 1e-9 * max(shell.length, 1.0)
    tp = 1e-9 * (shell.beta - shell.alpha)
    return _dedupe(xs, shell.x_min, shell.x_max, tx), _dedupe(ps, shell.alpha, shell.beta, tp)


def fitted_mesh(case, punches: Sequence[Punch], grade: bool = True):
    """``case.build_mesh`` with the fitted node lines of the punches.

    With ``grade`` and a grading ratio > 1 in [mesh.grading] but no explicit focus there, the
    mesh is graded toward the first-contact lines (focus_lines).
    """
    from dataclasses import replace

    from .case import build_mesh

    xs, ps = fitted_lines(punches, case.shell)
    ms = case.mesh
    if grade and ms.grading_ratio > 1.0 and not ms.grading_x and not ms.grading_phi:
        fx, fp = focus_lines(punches)
        ms = replace(ms, grading_x=tuple(fx), grading_phi=tuple(fp))
    return build_mesh(replace(case, mesh=ms), extra_x=xs, extra_phi=ps)
