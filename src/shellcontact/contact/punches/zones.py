"""Candidate contact zones Ω_c (MODEL.md §5) and sampling of the undeformed contact surface.

The undeformed contact surface is sampled on a fine (x, φ) grid over a zone (not at mesh
vertices, which do not exist yet), with repeated zooming around the minimiser, so first contact,
overlap and the automatic zone are mesh-independent.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from ...errors import InputError
from ...shell.geometry import Shell

ZONE_SNAP = 0.02  # automatic zone edges within 2 % of a shell edge are moved onto it


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




def whole_shell(shell: Shell) -> Zone:
    return Zone((shell.x_min, shell.x_max), ((shell.alpha, shell.beta),))


def given_zone(x: tuple[float, float] | None, phi: tuple[float, float] | None, shell: Shell, where: str) -> Zone:
    """The zone of ``zone = { x = [x0, x1], phi = [p0, p1] }`` (φ in radians; None = the whole range).

    On a full cylinder a φ range may cross the seam, e.g. [-30, 30] degrees.
    """
    tol = 1e-9 * max(shell.length, shell.radius, abs(shell.x_min), abs(shell.x_max))
    x0, x1 = (shell.x_min, shell.x_max) if x is None else x
    if not x0 < x1:
        raise InputError(f"{where}.x", f"needs x0 < x1, got [{x0}, {x1}]")
    if x0 < shell.x_min - tol or x1 > shell.x_max + tol:
        raise InputError(f"{where}.x", f"[{x0}, {x1}] lies outside the shell x in [{shell.x_min}, {shell.x_max}]")
    x0, x1 = max(x0, shell.x_min), min(x1, shell.x_max)
    alpha, beta = shell.alpha, shell.beta
    if phi is not None:
        p0, p1 = phi
        p0d, p1d = math.degrees(p0), math.degrees(p1)
        if not p0 < p1:
            raise InputError(f"{where}.phi", f"needs p0 < p1, got [{p0d:.6g}, {p1d:.6g}]")
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
                    f"[{p0d:.6g}, {p1d:.6g}] deg lies outside the shell phi in "
                    f"[{math.degrees(alpha):.6g}, {math.degrees(beta):.6g}] deg",
                )
            phis = ((max(p0, alpha), min(p1, beta)),)
    else:
        phis = ((alpha, beta),)
    return Zone(x=(float(x0), float(x1)), phi=tuple((float(a), float(b)) for a, b in phis))


def body_zone(distance: Callable[[np.ndarray], np.ndarray], shell: Shell, side_sign: float, zone: Zone,
              n: int = 201) -> Zone | None:
    """The part of ``zone`` opposite a body of finite extent: the x range and the φ arcs of {distance ≤ 0}
    on the contact surface within ``zone`` (distance: points (3, k) → (k,), ``Punch.body_distance``).

    ``zone`` itself when every sample is on the body; None when none is. Each edge inside the zone is
    located by root finding as in ``automatic_zone`` (min over the other coordinate), so that a body
    edge x = const or φ = const becomes a zone edge and hence a node line of the mesh
    (``placement.fitted_lines``); as there, an edge within 2 % of a shell edge is moved onto it (no
    thin strip of elements; the vertices beyond the body stay unconstrained). In φ each arc the body
    faces becomes one interval (on a full circle an arc across the seam φ = α ≡ β becomes the two
    intervals that meet there); arcs it does not face are dropped.
    """
    def grid(pr: tuple[float, float]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        nx, nphi = _grid_counts(shell, zone.x, pr, n)
        xs = np.linspace(zone.x[0], zone.x[1], nx)
        ps = np.linspace(pr[0], pr[1], nphi)
        X, P = np.meshgrid(xs, ps, indexing="ij")
        inside = distance(contact_surface(shell, X.ravel(), P.ravel(), side_sign)).reshape(X.shape) <= 0.0
        return xs, ps, inside

    grids = [grid(pr) for pr in zone.phi]
    if all(g[2].all() for g in grids):
        return zone
    if not any(g[2].any() for g in grids):
        return None
    snap_x, snap_p = ZONE_SNAP * shell.length, ZONE_SNAP * (shell.beta - shell.alpha)

    def snapped(v: float, lo: float, hi: float, tol: float) -> float:  # no thin strip at a shell edge
        return lo if v - lo < tol else hi if hi - v < tol else v

    def h_x(x: float) -> float:
        return surface_minimum(distance, shell, side_sign, Zone((x, x), zone.phi), levels=4)[0]

    x0, x1 = math.inf, -math.inf
    phis: list[tuple[float, float]] = []
    for xs, ps, inside in grids:
        if not inside.any():
            continue
        i = np.nonzero(inside.any(axis=1))[0]
        i0, i1 = int(i[0]), int(i[-1])
        x0 = min(x0, xs[0] if i0 == 0 else _edge(h_x, xs[i0], xs[i0 - 1]))
        x1 = max(x1, xs[-1] if i1 == xs.size - 1 else _edge(h_x, xs[i1], xs[i1 + 1]))

        def h_p(phi: float) -> float:
            return surface_minimum(distance, shell, side_sign, Zone(zone.x, ((phi, phi),)), levels=4)[0]

        for j0, j1 in _runs(inside.any(axis=0)):  # on a full circle a run may end at β and another start at α
            p0 = ps[0] if j0 == 0 else _edge(h_p, ps[j0], ps[j0 - 1])
            p1 = ps[-1] if j1 == ps.size - 1 else _edge(h_p, ps[j1], ps[j1 + 1])
            if not shell.full:
                p0, p1 = snapped(p0, shell.alpha, shell.beta, snap_p), snapped(p1, shell.alpha, shell.beta, snap_p)
            phis.append((float(p0), float(p1)))
    x0, x1 = snapped(x0, shell.x_min, shell.x_max, snap_x), snapped(x1, shell.x_min, shell.x_max, snap_x)
    return Zone((float(x0), float(x1)), tuple(phis), zone.automatic, zone.gap)


def _runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """First and last index of every run of True in ``mask``."""
    idx = np.nonzero(mask)[0]
    if idx.size == 0:
        return []
    breaks = np.nonzero(np.diff(idx) > 1)[0]
    starts = np.concatenate([[idx[0]], idx[breaks + 1]])
    ends = np.concatenate([idx[breaks], [idx[-1]]])
    return [(int(a), int(b)) for a, b in zip(starts, ends, strict=True)]


def _edge(h: Callable[[float], float], inside: float, outside: float) -> float:
    """The boundary of {h < 0} between a grid point inside and one outside (conservative fallback)."""
    from scipy.optimize import brentq

    if h(outside) <= 0.0 or not h(inside) < 0.0:  # no bracket (a grid far coarser than the punch): widen
        return outside
    try:
        return float(brentq(h, inside, outside, xtol=1e-14 * max(1.0, abs(inside)), rtol=1e-15))
    except RuntimeError:  # not converged (h is noise at this scale): the conservative end
        return outside


def automatic_zone(Z: Callable[[np.ndarray], np.ndarray], shell: Shell, side_sign: float, gap: float,
                   first_contact: tuple[float, float], min_gap: float, n: int = 201) -> Zone | None:
    """Bounding box (x, φ) of {Z < gap} on the contact surface (Z: points (3, k) → (k,)); None if empty.

    The set is found on a grid of about n × n points; each edge of its bounding box is then
    located by root finding on min_φ Z(x, ·) − gap (resp. min_x Z(·, φ) − gap), so that symmetric
    configurations give symmetric zones. Edges within 2 % of a shell edge (or of the seam of a full
    cylinder) are moved onto it, so that no thin strip of elements appears.
    """
    nx, nphi = _grid_counts(shell, (shell.x_min, shell.x_max), (shell.alpha, shell.beta), n)
    xs = np.linspace(shell.x_min, shell.x_max, nx)
    ps = np.linspace(shell.alpha, shell.beta, nphi)
    X, P = np.meshgrid(xs, ps, indexing="ij")
    Zv = Z(contact_surface(shell, X.ravel(), P.ravel(), side_sign)).reshape(X.shape)
    mask = Zv < gap
    fx, fp = first_contact
    if math.isfinite(fx) and min_gap < gap:  # the cell of the deepest point
        mask[int(np.argmin(np.abs(xs - fx))), int(np.argmin(np.abs(ps - fp)))] = True
    if not np.any(mask):
        return None
    side = side_sign
    whole_x = (shell.x_min, shell.x_max)

    def h_x(x: float) -> float:
        z = Zone((x, x), ((shell.alpha, shell.beta),))
        return surface_minimum(Z, shell, side, z, levels=4)[0] - gap

    def h_p(phi: float) -> float:
        phi = shell.alpha + (phi - shell.alpha) % (2 * math.pi) if shell.full else phi
        z = Zone(whole_x, ((phi, phi),))
        return surface_minimum(Z, shell, side, z, levels=4)[0] - gap

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
