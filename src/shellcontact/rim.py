"""The line force along the rim of each contact zone: where a Kirchhoff shell carries a punch's load.

A Kirchhoff shell pressed by a rigid punch carries most of the load in a line force along the edge of the
contact zone (the rim of a sphere's zone, the edges of a band), while the inside of the zone barely touches.
The active constraint points that carry it do not form a curve that converges (their outline zig-zags with
the mesh), so the rim is taken from the gap instead: the level line Π = ``gap_tolerance`` of the linearised
gap (contact.linearised_gap, MODEL.md §5), sampled on a regular grid over the zone's extent
(``contact.contact_zone``) and closed along the candidate zone's edges, which converges with the
displacement field. Its length is measured on the middle surface (x, s = aφ).

The contact forces Λᵢ|∇Zᵢ| (nodal forces, MODEL.md §8) of the constraint points within three element widths
(of the element holding the point, measured across the line) of that line are the rim's; each is placed at
its nearest point of the line, and their sum per arc-length bin (bins of about two element widths) divided
by the bin's length is the line force per unit length. What the other points carry is the interior force
(the pressure inside a band, for instance): rim force + interior force is the punch's total normal force.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from .contact import GAP_QUANTITIES, ContactOperator, facing_body, linearised_gap
from .punches import Punch
from .spaces import ShellSpace

SAMPLES = (33, 257)  # grid points along each side of a zone's sampling box: 4 per element, within these
PER_ELEMENT = 4
MARGIN = 0.15  # the box extends the zone's extent by this fraction on each side (within the candidate zone)
MAX_BINS = 72  # line-force bins per rim line
RIM_WIDTH = 3.0  # points within this many element widths (across the rim) of it carry the rim's force


def rim_line_force(space: ShellSpace, punches: Sequence[Punch], operator: ContactOperator, Lam: np.ndarray,
                   U: np.ndarray, delta: np.ndarray | None, zones: Sequence[dict]
                   ) -> tuple[list[dict | None], list[list[np.ndarray]]]:
    """Per punch (None where it does not touch): ``length`` of the rim, its ``force`` and the ``interior_force``,
    ``peak_line_force`` and ``mean_line_force`` (= force / length), the number of rim ``lines`` and ``samples``
    [{x, phi (degrees), line_force}] at the centres of the arc-length bins; and per punch the rim's polylines
    (n, 2) in (x, s = aφ), for the figures."""
    forced = [k for k, p in enumerate(punches) if p.mode == "force"]
    normal = np.linalg.norm(operator.grad, axis=0) * np.asarray(Lam, float)
    out: list[dict | None] = []
    polylines: list[list[np.ndarray]] = []
    for k, (p, zone) in enumerate(zip(punches, zones)):
        rows = operator.rows(k)
        step = float(np.asarray(delta, float)[forced.index(k)]) if p.mode == "force" and delta is not None else None
        lines = _rim_lines(space, p, zone, U, step or 0.0, zone["gap_tolerance"]) if "x" in zone else []
        polylines.append(lines)
        if not lines or not np.any(normal[rows] > 0.0):
            out.append(None)
            continue
        out.append(_distribute(space, lines, operator.x[rows], operator.phi[rows], normal[rows]))
    return out, polylines


def _rim_lines(space: ShellSpace, p: Punch, zone: dict, U: np.ndarray, step: float, tol: float
               ) -> list[np.ndarray]:
    """Polylines (n, 2) in (x, s) of the level Π = tol, closed along the candidate zone's edges."""
    import contourpy

    sh = space.mesh.shell
    a = sh.radius
    phi0, phi1 = np.radians(zone["phi"])
    interval = next(((lo, hi) for lo, hi in p.zone.phi if lo - 1e-12 <= phi0 and phi1 <= hi + 1e-12),
                    p.zone.phi[0])
    x0, x1 = zone["x"]
    mx, mp = MARGIN * max(x1 - x0, 1e-9 * a), MARGIN * max(phi1 - phi0, 1e-9)
    bx = (max(x0 - mx, p.zone.x[0]), min(x1 + mx, p.zone.x[1]))
    bp = (max(phi0 - mp, interval[0]), min(phi1 + mp, interval[1]))
    nx, nphi = _sample_counts(space, bx, bp)
    xs, ps = np.linspace(*bx, nx), np.linspace(*bp, nphi)
    X, P = np.meshgrid(xs, ps)
    ops = space.point_operators(X.ravel(), a * P.ravel(), GAP_QUANTITIES)
    fields = {q: op @ U for q, op in ops.items()}
    f = (linearised_gap(sh, p, X.ravel(), P.ravel(), fields, step) - tol).reshape(X.shape)
    # off a finite body (punch extent) nothing touches either
    off = ~facing_body(space, p, X.ravel(), a * P.ravel()).reshape(X.shape)
    f[off] = float(np.max(np.abs(f))) + 1.0
    # outside the candidate zone nothing touches: a border of "not touching" closes the rim along the zone's
    # edges — except across the seam of a zone that runs all the way round a full cylinder
    around = sh.full and interval[1] - interval[0] >= sh.beta - sh.alpha - 1e-9
    pad_x = 1e-9 * (bx[1] - bx[0])
    pad_p = 0.0 if around else 1e-9 * (bp[1] - bp[0])
    big = float(np.max(np.abs(f))) + 1.0
    xs = np.concatenate([[bx[0] - pad_x], xs, [bx[1] + pad_x]])
    f = np.pad(f, ((0, 0), (1, 1)), constant_values=big)
    if pad_p:
        ps = np.concatenate([[bp[0] - pad_p], ps, [bp[1] + pad_p]])
        f = np.pad(f, ((1, 1), (0, 0)), constant_values=big)
    lines = contourpy.contour_generator(xs, a * ps, f).lines(0.0)
    return [np.asarray(line, float) for line in lines if len(line) >= 2]


def _sample_counts(space: ShellSpace, bx: tuple[float, float], bp: tuple[float, float]) -> tuple[int, int]:
    """PER_ELEMENT samples per element along x and φ in the box (median element extents there), within SAMPLES:
    the P5 gap is smooth inside an element, so the sampled level line follows the mesh's resolution."""
    m = space.mesh
    a = m.shell.radius
    corners = m.p[:, m.t]  # (2, 3, nelements)
    c = corners.mean(axis=1)
    inside = (c[0] >= bx[0]) & (c[0] <= bx[1]) & (c[1] >= a * bp[0]) & (c[1] <= a * bp[1])
    if not inside.any():
        return SAMPLES[0], SAMPLES[0]
    ext = np.ptp(corners[:, :, inside], axis=1)
    counts = []
    for width, h in ((bx[1] - bx[0], np.median(ext[0])), (a * (bp[1] - bp[0]), np.median(ext[1]))):
        n = math.ceil(PER_ELEMENT * width / h) + 1 if h > 0 else SAMPLES[0]
        counts.append(int(min(max(n, SAMPLES[0]), SAMPLES[1])))
    return counts[0], counts[1]


def _distribute(space: ShellSpace, lines: list[np.ndarray], x: np.ndarray, phi: np.ndarray,
                force: np.ndarray) -> dict:
    a = space.mesh.shell.radius
    total = float(force.sum())
    seg0 = np.concatenate([ln[:-1] for ln in lines])
    seg1 = np.concatenate([ln[1:] for ln in lines])
    seg_line = np.concatenate([np.full(len(ln) - 1, i) for i, ln in enumerate(lines)])
    seg_len = np.linalg.norm(seg1 - seg0, axis=1)
    start = np.concatenate([np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(ln, axis=0), axis=1))[:-1]])
                            for ln in lines])  # arc length at each segment's start, along its line
    line_len = np.array([float(np.linalg.norm(np.diff(ln, axis=0), axis=1).sum()) for ln in lines])
    carrying = force > 0.0
    pts = np.stack([x[carrying], a * phi[carrying]], axis=1)
    f = force[carrying]
    j, t, nearest = _nearest_segment(pts, seg0, seg1)
    tangent = (seg1 - seg0)[j] / np.maximum(seg_len[j], 1e-300)[:, None]
    h = _width_across(space, pts, np.stack([-tangent[:, 1], tangent[:, 0]], axis=1))
    on_rim = nearest <= RIM_WIDTH * h
    rim_force = float(f[on_rim].sum())
    length = float(line_len.sum())
    where = start[j] + t * seg_len[j]  # arc length along the nearest line
    samples, peak = [], 0.0
    size = float(np.median(h[on_rim])) if on_rim.any() else float(np.median(h))  # bins ≈ 2 widths long
    for i, ln in enumerate(lines):
        nb = int(min(MAX_BINS, max(1, math.floor(line_len[i] / (2.0 * size)))))
        edges = np.linspace(0.0, line_len[i], nb + 1)
        mine = on_rim & (seg_line[j] == i)
        per_bin = np.bincount(np.clip(np.searchsorted(edges, where[mine], side="right") - 1, 0, nb - 1),
                              weights=f[mine], minlength=nb)
        density = per_bin / np.diff(edges)
        peak = max(peak, float(density.max()))
        centres = _points_at(ln, 0.5 * (edges[:-1] + edges[1:]))
        samples += [{"x": float(c[0]), "phi": float(math.degrees(c[1] / a)), "line_force": float(v)}
                    for c, v in zip(centres, density)]
    return {"length": length, "force": rim_force, "interior_force": total - rim_force,
            "peak_line_force": peak, "mean_line_force": rim_force / length if length > 0 else 0.0,
            "lines": len(lines), "samples": samples}


def _nearest_segment(pts: np.ndarray, seg0: np.ndarray, seg1: np.ndarray,
                     chunk: int = 1024) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """For each point: its nearest segment, the projection parameter t ∈ [0, 1] on it and the distance."""
    d = seg1 - seg0
    len2 = np.maximum(np.einsum("sk,sk->s", d, d), 1e-300)
    j, t, dist = (np.zeros(len(pts), int), np.zeros(len(pts)), np.zeros(len(pts)))
    for lo in range(0, len(pts), chunk):
        q = pts[lo:lo + chunk, None, :] - seg0[None]
        tt = np.clip(np.einsum("nsk,sk->ns", q, d) / len2, 0.0, 1.0)
        dd = np.linalg.norm(q - tt[..., None] * d[None], axis=2)
        jj = np.argmin(dd, axis=1)
        rows = np.arange(len(jj))
        j[lo:lo + chunk], t[lo:lo + chunk], dist[lo:lo + chunk] = jj, tt[rows, jj], dd[rows, jj]
    return j, t, dist


def _width_across(space: ShellSpace, pts: np.ndarray, normal: np.ndarray) -> np.ndarray:
    """The width (in x, s) of the element containing each point, measured along ``normal`` (unit, (n, 2)):
    the mesh's resolution across the rim, also on the long thin elements of a mesh graded in one direction."""
    m = space.mesh
    e = space.locate(pts[:, 0], pts[:, 1])
    corners = m.p[:, m.t[:, e]]  # (2, 3, n)
    along = np.einsum("kcn,nk->cn", corners, normal)
    return np.ptp(along, axis=0)


def _points_at(line: np.ndarray, arc: np.ndarray) -> np.ndarray:
    """Points of a polyline at the given arc lengths."""
    cum = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(line, axis=0), axis=1))])
    return np.stack([np.interp(arc, cum, line[:, 0]), np.interp(arc, cum, line[:, 1])], axis=1)
