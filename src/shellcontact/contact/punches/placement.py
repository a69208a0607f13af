"""Placing a punch (MODEL.md §5): from its ``PunchSpec`` and the shell to a ``Punch`` at its final position.

Placement: nothing (the given position is final; overlap with the undeformed contact surface is a
prescribed interference), or ``indentation = d >= 0``: the punch is translated along
``direction`` to where it just touches the undeformed contact surface in its candidate zone,
then d further; or ``force = P > 0``: the punch starts at the just-touching position and its
rigid translation δ along ``direction`` is an unknown (Π = Z − δ ∇Z·d + ∇Z·U, energy −P δ).
``direction`` defaults to the plane's normal, otherwise the direction from the punch centre toward
the shell axis (side = "outer") or away from it (side = "inner"); it is required for custom shapes
and for centres on the shell axis. The just-touching translation t solves min_M Z(M − t d) = 0
over the contact surface of the zone (sphere tracing + Newton to a bracket, then Brent); a punch
given in overlap backs off (t < 0).

Without ``zone.x``/``zone.phi`` the zone is automatic: the bounding box in (x, φ) of {Z < g} on the
contact surface (``zones.automatic_zone``), Z of the placed punch (for force control the
just-touching one), with g = ``zone.gap`` or max(2·overlap, 0.2·size), overlap = −min Z ≥ 0, size
= the punch's smallest radius (the shell radius for a plane or custom shape) capped by the shell
radius. For force control the travel is unknown in advance: if the contact zone reaches the edge
of the automatic zone, give a larger gap or an explicit zone.

A punch of finite ``extent`` is a body: placement and the first contact use Z only where the body is
(``Punch.Z_on_body``, +inf elsewhere), and the zone (given or automatic) is cut to the part of it
opposite the body (``zones.body_zone``), so the body's edges become zone edges and node lines. A body
that faces nothing where it is written travels first to where it faces the shell (``_facing_travel``),
so that where its centre is written along ``direction`` does not change the placement.

Refused (InputError naming the key): a zone outside Ω or empty, a punch that never touches the
shell moving along ``direction``, a punch whose smallest gap over its zone is not below g, an
overlap larger than the shell can take (> 0.2·a, or > 10·t: far outside linear shell theory), a
body whose extent faces no point of the contact surface in the zone (anywhere along its travel, when it
moves), or meets it side-on, a custom function that
raises, returns wrong shapes or non-finite values on the shell, and an indentation between 0 and
``INDENTATION_DIGITS`` × the gap's round-off (1e-9 m on the paper's panel: the force would be wrong).
"""

from __future__ import annotations

import contextlib
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np

from ...errors import InputError
from ...shell.geometry import Shell, frame
from ...units import with_unit
from .extent import Extent
from .shapes import Custom
from .spec import PunchSpec, parse_punch
from .zones import Zone, automatic_zone, body_zone, contact_surface, given_zone, surface_minimum, whole_shell

OVERLAP_RADIUS_FRACTION = 0.2  # overlap must stay below this fraction of the shell radius
OVERLAP_THICKNESSES = 10.0  # ... and below this many shell thicknesses
ZONE_OVERLAP_FACTOR = 2.0  # automatic zone threshold g = max(2 overlap, 0.2 size)
ZONE_SIZE_FRACTION = 0.2
RESOLUTION_THICKNESS = 1e-6  # the round-off of Z on the shell must stay below this fraction of the thickness
EDGE_CONTACT_FRACTION = 1e-4  # a finite body's first contact this close (× zone size) to a zone edge is on it
#: an overlap below this fraction of the radius is the round-off of the placement, not an overlap: a plate centred
#: at a + t/2 "overlapped" the ring example by 1.4e-17 m, and a fixed punch's zone tolerance (1e-3 × its
#: overlap) was then 1.4e-20 m instead of following the shell's motion toward it (contact.contact_zone)
TOUCH_ROUNDOFF = 1e-12
#: Z of a placed punch is known to this many ulps of its largest coordinate (``place``: the polished minimiser)
Z_ROUNDOFF_ULPS = 64.0
#: the smallest indentation is this many times the gap's round-off (``_check_indentation_resolved``)
INDENTATION_DIGITS = 1e3


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
    extent: Extent | None = None  # a body of finite size (in shape coordinates); None: unbounded

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

    def body_distance(self, X: np.ndarray) -> np.ndarray:
        """Where the body is (``extent``): ≤ 0 at points X (3, n) whose foot on the shape lies in the extent."""
        X = np.asarray(X, dtype=float).reshape(3, -1)
        if self.extent is None:
            return np.full(X.shape[1], -np.inf)
        return _foot_distance(self.body, self.extent, X - self.offset[:, None])

    def on_body(self, X: np.ndarray, tol: float = 0.0) -> np.ndarray:
        """Points X (3, n) opposite the body: there, and only there, the contact condition applies."""
        return self.body_distance(X) <= tol

    def Z_on_body(self, X: np.ndarray) -> np.ndarray:
        """Z where the body is, +inf elsewhere: the gap to the finite body, for placement and zones."""
        Z = self.Z(X)[0]
        return Z if self.extent is None else np.where(self.on_body(X), Z, np.inf)

    def zeta(self, shell: Shell, x: np.ndarray, phi: np.ndarray) -> np.ndarray:
        return 0.5 * self.side_sign * shell.t(np.asarray(x, float), phi)



def _foot_distance(body, extent: Extent, X: np.ndarray) -> np.ndarray:
    """``extent.distance`` of the foot F = X − Z ∇Z/|∇Z|² of the points X (shape coordinates) on {Z = 0}."""
    Z, g = body(X)
    g2 = np.sum(g * g, axis=0)
    return extent.distance(X - g * (Z / np.where(g2 > 0.0, g2, 1.0)))


def _faces_nothing(punch: Punch, where: str) -> InputError:
    extent = punch.extent.describe() if punch.extent is not None else "unbounded"
    return InputError(f"{where}.extent", f"no point of the {punch.side} contact surface in the zone "
                      f"({punch.zone.describe()}) faces the body ({extent})")


def _check_custom(body: Custom, shell: Shell) -> None:
    """Evaluate a custom Z on a 3 × 3 grid of the shell: a bad function fails by its key before any work."""
    x = np.linspace(shell.x_min, shell.x_max, 3)
    phi = np.linspace(shell.alpha, shell.beta, 3)
    body(shell.point(*np.meshgrid(x, phi, indexing="ij"), 0.0).reshape(3, -1))


def _check_resolution(body, center: np.ndarray, shell: Shell, where: str) -> None:
    """Z = |X − c| − r (and the like) is known to ε·max(|c|, r) only: that must stay far below the thickness."""
    scale = max(float(np.linalg.norm(center)), float(body.size) if math.isfinite(body.size) else 0.0)
    x, phi = np.meshgrid(np.linspace(shell.x_min, shell.x_max, 5), np.linspace(shell.alpha, shell.beta, 5))
    t = float(np.min(shell.t(x, phi)))
    if np.finfo(float).eps * scale > RESOLUTION_THICKNESS * t:
        raise InputError(where, f"a punch of size {float(body.size):.3g} with its centre {scale:.3g} from the axis "
                         f"resolves the gap only to {np.finfo(float).eps * scale:.2g}, not far below the shell "
                         f"thickness {t:.3g}: use a smaller punch nearer the shell, or a plane for a very flat one")


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
    ta, fa, xa, pa = 0.0, f0, x0, p0
    if not math.isfinite(f0):  # a finite body written away from the shell faces it only once it travels
        ta = _facing_travel(punch, shell, body_Z)
        fa, xa, pa = f(ta)
        if fa < 0.0:
            raise InputError(f"{where}.direction", f"moving along {np.round(d, 6).tolist()} the body "
                             f"({punch.extent.describe() if punch.extent else 'unbounded'}) reaches the "
                             f"{punch.side} contact surface side-on, overlapping it as soon as it faces it; "
                             "check center, direction and extent")
    sgn = 1.0 if fa > 0 else -1.0  # not touching: move forward; overlapping: back off
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

    try:
        t = float(brentq(lambda t: f(t)[0], min(ta, tb), max(ta, tb), xtol=tol, rtol=1e-15, maxiter=200))
    except RuntimeError:  # Z is noise on the shell's scale: its digits are lost to the punch's own size
        raise InputError(where, "the position where the punch just touches the shell cannot be resolved in double "
                         "precision: its Z varies erratically on the shell; use a smaller punch nearer the shell, or a "
                         "plane for a very flat one") from None
    return _newton_travel(f, slope, t, tol)


def _newton_travel(f, slope, t: float, tol: float) -> float:
    """Brent's root to round-off: Newton steps t ← t − f/f' with f' = −∇Z·d at the minimiser (envelope
    theorem), kept while |f| falls. Brent stops within ``tol`` = 1e-12 × the case's size (4e-12 m on a 4 m
    pipe): the same punch written at the surface (t = 0) or farther out then differed by that in its
    overlap, 4e-8 of a 0.1 mm indentation's force."""
    ft, xt, pt = f(t)
    for _ in range(4):
        c = slope(t, xt, pt)
        if not (math.isfinite(ft) and abs(c) > 0.0) or ft == 0.0:
            break
        tn = t - ft / c
        fn, xn, pn = f(tn)
        if not abs(fn) < abs(ft) or abs(tn - t) > tol:
            break
        t, ft, xt, pt = tn, fn, xn, pn
    return t


#: the steps of the scan for the travel at which a finite body begins to face the shell, per body size
FACING_STEPS_PER_SIZE = 20


def _facing_travel(punch: Punch, shell: Shell, body_Z) -> float:
    """The least travel t ≥ 0 along ``direction`` at which the finite body faces a point of the contact surface
    in the zone: scanned in steps of 1/``FACING_STEPS_PER_SIZE`` of its size (a coarse surface minimum each) as
    far as its reference point passes the shell's axis by a radius and two sizes, then bisected to 1e-9 of a
    step. Before, a body written 0.5 m out along its direction was refused ("no point ... faces the body")
    where the same body written touching was placed (issue 23, item 5)."""
    d, zone = punch.direction, punch.zone

    def faces(t: float) -> bool:
        return math.isfinite(surface_minimum(lambda M: body_Z(M - t * d[:, None])[0], shell, punch.side_sign,
                                             zone, n=41, levels=0)[0])

    size = min(punch.size, shell.radius) if math.isfinite(punch.size) else shell.radius
    c = np.asarray(punch.center, float)
    # where the reference point comes nearest the axis (x along it): the shell lies within a + t of it
    perp = np.array([0.0, d[1], d[2]])
    reach = float(-(c[1] * d[1] + c[2] * d[2]) / (perp @ perp)) if perp @ perp > 1e-24 else 0.0
    thick = float(np.max(shell.t(np.linspace(shell.x_min, shell.x_max, 5), np.full(5, shell.alpha))))
    span = max(reach, 0.0) + shell.radius + thick + 2.0 * size
    h = size / FACING_STEPS_PER_SIZE
    prev = 0.0
    for k in range(1, int(math.ceil(span / h)) + 1):
        t = k * h
        if faces(t):
            lo, hi = prev, t
            while hi - lo > 1e-9 * h:
                mid = 0.5 * (lo + hi)
                lo, hi = (lo, mid) if faces(mid) else (mid, hi)
            return hi
        prev = t
    raise _faces_nothing(punch, f"{punch.where}")


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
                with contextlib.suppress(RuntimeError):  # not converged: keep the grid minimiser
                    c[k] = float(brentq(f, lo, hi, xtol=1e-15 * max(1.0, abs(c[k])), rtol=1e-15))
    M = contact_surface(shell, np.array([c[0]]), np.array([c[1]]), side)
    return float(punch.Z_on_body(M)[0]), c[0], c[1]


def _length(value: float, units: str, spec: str = ".4g") -> str:
    return with_unit(format(value, spec), "length", units)


def _check_indentation_resolved(depth: float, body, center: np.ndarray, shell: Shell, where: str,
                                units: str = "SI") -> None:
    """Refuse an indentation the gap cannot resolve: Z is known to ε·scale (``_check_resolution``) and an overlap
    below ``TOUCH_ROUNDOFF``·a counts as touching, so 1e-15 m on the paper's panel gave a force 11 % off and
    1e-16 m a force of 0. Above ``INDENTATION_DIGITS`` × that the force's relative error stays below 1e-3."""
    if depth <= 0.0:
        return
    scale = max(float(np.linalg.norm(center)), float(body.size) if math.isfinite(body.size) else 0.0, shell.radius)
    least = INDENTATION_DIGITS * max(float(np.finfo(float).eps) * scale, TOUCH_ROUNDOFF * shell.radius)
    if depth < least:
        eps = float(np.finfo(float).eps)
        raise InputError(f"{where}.indentation", f"{_length(depth, units, '.3g')} is below what the gap resolves: Z "
                         f"is known to {_length(eps * scale, units, '.2g')} (round-off at "
                         f"{_length(scale, units, '.3g')} from the axis) and an overlap below "
                         f"{_length(TOUCH_ROUNDOFF * shell.radius, units, '.2g')} counts as touching, so the force "
                         f"would be wrong; give 0 (just touching) or at least {_length(least, units, '.2g')}")


def check_linear_range(depth: float, shell: Shell, key: str, what: str, units: str = "SI") -> None:
    """Refuse a depth (an overlap, or a force-controlled punch's travel) beyond linear shell theory:
    more than ``OVERLAP_RADIUS_FRACTION`` × radius or ``OVERLAP_THICKNESSES`` thicknesses."""
    tmax = float(
        np.max(shell.t(np.linspace(shell.x_min, shell.x_max, 9)[:, None], np.linspace(shell.alpha, shell.beta, 9)))
    )
    if depth > OVERLAP_RADIUS_FRACTION * shell.radius:
        raise InputError(
            key,
            f"{what} {_length(depth, units)}, more than {OVERLAP_RADIUS_FRACTION} x radius = "
            f"{_length(OVERLAP_RADIUS_FRACTION * shell.radius, units)}: far beyond a linear shell",
        )
    if depth > OVERLAP_THICKNESSES * tmax:
        raise InputError(
            key,
            f"{what} {_length(depth, units)}, more than {OVERLAP_THICKNESSES:g} thicknesses "
            f"({_length(OVERLAP_THICKNESSES * tmax, units)}): "
            "far beyond a linear shell",
        )


def place(spec: PunchSpec, shell: Shell, units: str = "SI") -> Punch:
    """The punch of ``spec`` at its final position on ``shell`` (see the module docstring); lengths in messages
    labelled in the unit system ``units``."""
    where, body, mode = spec.where, spec.body, spec.mode
    if isinstance(body, Custom):
        _check_custom(body, shell)
    direction = spec.direction
    if direction is None and mode != "fixed":
        direction = _default_direction(body, spec.shape, spec.side, shell, where)
    given = given_zone(spec.zone_x, spec.zone_phi, shell, f"{where}.zone") if spec.zone_given else None
    center = np.asarray(getattr(body, "center", np.zeros(3)), dtype=float)
    _check_resolution(body, center, shell, where)
    size = min(float(body.size), shell.radius)
    punch = Punch(
        index=spec.index,
        shape=spec.shape,
        body=body,
        inverted=spec.inverted,
        side=spec.side,
        mode=mode,
        direction=direction,
        indentation=spec.indentation,
        force=spec.force,
        zone=given or whole_shell(shell),
        center=center.copy(),
        size=size,
        extent=spec.extent,
    )
    sgn = -1.0 if spec.inverted else 1.0

    def body_Z(X):  # shape coordinates; +inf where the finite body is not
        Z, g = body(X)
        Z = sgn * Z
        if spec.extent is not None:
            Z = np.where(_foot_distance(body, spec.extent, X) <= 0.0, Z, np.inf)
        return Z, sgn * g

    if mode == "indentation":
        _check_indentation_resolved(spec.indentation, body, center, shell, where, units)
    if mode != "fixed":
        t0 = _touch_travel(punch, shell, body_Z, where)
        punch.touch_travel = t0
        travel = t0 + (spec.indentation if mode == "indentation" else 0.0)
        punch.offset = travel * direction
        punch.center = center + punch.offset
    zmin, xm, pm = surface_minimum(punch.Z_on_body, shell, punch.side_sign, punch.zone)
    if not math.isfinite(zmin):
        raise _faces_nothing(punch, where)
    zp, xp, pp = _polish_minimum(punch, shell, xm, pm, 1e-4)
    # the polished point zeroes ∂Z (known to full relative precision); Z itself only to its round-off, which
    # near a minimum hides ~1e-7 rad: compared exactly, a round-off-larger Z kept the grid minimiser 1e-7 rad
    # off the cradle's symmetry line (written 0.5 m out), a node line next to the grading's at 270 deg
    z_round = Z_ROUNDOFF_ULPS * np.finfo(float).eps * max(float(np.linalg.norm(center)),
                                                           float(np.linalg.norm(punch.offset)), size, shell.radius)
    if zp <= zmin + z_round:
        zmin, xm, pm = min(zp, zmin), xp, pp
    punch.min_gap, punch.first_contact = zmin, (xm, pm)
    punch.overlap = -zmin if -zmin > TOUCH_ROUNDOFF * shell.radius else 0.0
    check_linear_range(punch.overlap, shell, f"{where}.indentation" if mode == "indentation" else where,
                       "the punch overlaps the undeformed shell by", units)
    gap = spec.zone_gap if spec.zone_gap is not None else max(
        ZONE_OVERLAP_FACTOR * punch.overlap, ZONE_SIZE_FRACTION * size)
    zone = given or automatic_zone(lambda M: punch.Z(M)[0], shell, punch.side_sign, gap, punch.first_contact, zmin)
    if zone is not None and spec.extent is not None:
        whole = zone
        zone = body_zone(punch.body_distance, shell, punch.side_sign, zone)
        if zone is None:
            raise InputError(f"{where}.extent", f"the body ({spec.extent.describe()}) faces the shell only in a "
                             f"strip too narrow to sample in the zone ({whole.describe()}), let alone to mesh: "
                             "widen the extent")
    if zone is None or zmin >= gap:
        x, p = punch.first_contact
        raise InputError(
            where,
            f"the punch does not touch the {spec.side} surface of the shell: smallest gap {_length(zmin, units)} "
            f"(at x = {_length(x, units, '.6g')}, phi = {math.degrees(p):.6g} deg) is not below the zone threshold "
            f"{_length(gap, units)}; "
            "move it or give 'indentation' or 'force'",
        )
    punch.zone = zone
    punch.varies_x, punch.varies_phi = _variation(punch, shell)
    return punch


def place_punches(specs: Sequence[PunchSpec], shell: Shell, units: str = "SI") -> list[Punch]:
    """Every punch of a case, placed (``units``: the case's system, for the lengths in messages)."""
    return [place(s, shell, units) for s in specs]


def punch_from_dict(raw: dict, shell: Shell, index: int = 0) -> Punch:
    """Parse and place one ``[[punch]]`` table (a convenience for scripts and tests)."""
    return place(parse_punch(raw, index), shell)


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
    xs = [_on_edge(p.first_contact[0], p.zone.x, p) for p in punches
          if p.varies_x and math.isfinite(p.first_contact[0])]
    ps = [_on_edge(p.first_contact[1], [v for ab in p.zone.phi for v in ab], p) for p in punches
          if p.varies_phi and math.isfinite(p.first_contact[1])]
    return xs, ps


def _on_edge(value: float, edges, punch: Punch) -> float:
    """A finite body first touching at its rim: the first-contact line is the zone edge found for the rim
    (the two are located separately and differ by round-off; two node lines 1e-9 apart would be degenerate)."""
    if punch.extent is None:
        return value
    span = max(abs(b - a) for a, b in zip(edges[::2], edges[1::2], strict=True)) if len(edges) > 1 else 1.0
    near = [e for e in edges if abs(e - value) <= EDGE_CONTACT_FRACTION * span]
    return near[0] if near else value


def fitted_lines(punches: Sequence[Punch], shell: Shell) -> tuple[list[float], list[float]]:
    """Node lines (x values, φ values in radians) for ``mesh.build_mesh``.

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
