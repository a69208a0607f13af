"""The decomposition of each punch's contact force: line force along the zone's rim, interior pressure, line load.

For a Kirchhoff–Love shell the contact multiplier is a measure (MODEL.md §8, docs/theory.md): a pressure inside
the contact zone, line forces along its boundary and point forces where a zone shrinks to a point. The nodal
forces Λᵢ|∇Zᵢ| converge to it only weakly, so a nodal force over a nodal weight does not converge; sums of them
over regions of fixed physical size do, and these are what this module reports (summary ``contact.<k>.rim``).

1. The zone's outline: the level line Π = ``gap_tolerance`` of the linearised gap (contact.linearised_gap,
   MODEL.md §5), sampled on a regular grid over the zone's extent (``contact.contact_zone``) and closed along the
   candidate zone's edges. It converges with the displacement field, but it lies OUTSIDE the contact by a
   distance that converges to a finite value (the gap grows like the squared distance from the contact:
   about 10 mm on the paper's panel), not by a fraction of h.
2. The rim (where the line force is): along each outline, in arc-length bins of about two element widths, the
   carrying points nearest to that bin; the rim's band are those within ``RIM_WIDTH`` element widths (across
   the line) of the bin's shallowest carrying point, and the rim passes through the force-weighted centroid of
   the band (the outline moved inward by that offset, smoothed along the line). The rim's ``force`` is the sum
   over the bands; it includes the interior pressure over a band of width O(h), which vanishes under refinement.
   For a fixed punch (whose outline bounds where it carries) the band takes at most RIM_SHARE of the depth to the
   zone's deepest carrying point nearby (a saddle two elements wide keeps its middle rows interior); where that
   narrowing holds most of the band's force, the interior is flagged unresolved (``interior_resolved``).
   A closed outline round at most one idle row, none carrying inside, is below the mesh's resolution: no rim.
   (A fixed punch's contact set is first closed by about one element, ``zone_points.fill_idle_rows``: one or two
   idle rows between carrying ones cut its outline into corner loops, split lines and fake lines.)
   ``length`` is the rim's length, ``mean_line_force`` = force / length; the line force along the rim
   (``samples``, ``peak_line_force``) is the band's forces smoothed with a hat kernel two element lengths wide
   along the line (the vertex and midpoint forces of a uniform load average out), per unit length of the rim.
   Outline segments along the shell's own edges (a symmetry plane, the shell's end) carry no rim: points nearest
   them are interior and they add no length; two stretches of the outline running opposite ways that the
   offset puts onto one line (the sides of a sliver of zone along a rim) count once in the length.
3. The interior: ``interior_force`` = total normal force − rim force − line loads over ``interior_area`` (the
   zone's area inside the rim) gives ``mean_interior_pressure``.
4. A line contact (per outline line; ``kind`` = "line" when every carrying line is one: a plate on a pipe): the
   outline is a thin strip round the line, at least eight times longer than wide, with the force on its middle
   line. Then its whole force is a line load: its length is the strip's long side (of the rectangle with the
   strip's perimeter and enclosed area), and the samples run along the line's direction (the forces' principal
   axis): at least LINE_SAMPLES bin centres over its length, scaled to integrate to its force. ``per_line``
   gives each line's kind, length, force and mean line force.
The headlines keep the two apart: ``force``, ``length``, ``mean_line_force`` and ``peak_line_force`` are the
area rim's (the boundary of a 2D zone; 0 for a pure line contact) and ``line_loads`` = {force, length,
mean_line_force, peak_line_force} the line loads' (a plate's or a horn's edge), so that force + line_loads.force
+ interior_force + point_force = the total normal force, and no headline mixes a line load with a rim.
Lengths are measured on the middle surface (x, s = aφ).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

import numpy as np

from ..shell.spaces import ShellSpace
from .fixed_outline import class_field, fixed_punch_points, in_zone_facing_body
from .interior import RESOLVED, interior_split
from .line_ends import attach_end_forces
from .operator import GAP_QUANTITIES, ContactOperator, facing_body, linearised_gap, zone_tolerance
from .outline_geometry import (
    closes_on_itself,
    enclosed_area,
    hat_sum,
    perimeter_of,
    points_at,
    smoothed_loop,
    unresolved_hole,
    vertex_normals,
)
from .point_forces import describe, point_force_clusters
from .punches import Punch
from .zone_points import fill_idle_rows, width_along

SAMPLES = (33, 257)  # grid points along each side of a zone's sampling box: 4 per element, within these
#: a fixed punch's outline (a distance field, cheap to sample): 4 per smallest element (its 5th percentile),
#: up to this many, so that a row of points along a graded mesh's finest elements (a horn) gets its strip
FIXED_SAMPLES = 2049
PER_ELEMENT = 4
MARGIN = 0.15  # the box extends the zone's extent by this fraction on each side (within the candidate zone)
MAX_BINS = 72  # line-force bins per rim line
RIM_WIDTH = 3.0  # the rim's band: this many element widths (across the rim) from its shallowest point
LINE_CONTACT = 0.7  # a thin zone whose force sits this deep (× half its width) or deeper is a line contact
LINE_SAMPLES = 3  # a line load's samples along its length: at least this many
RIM_SHARE = 0.4  # ... but at most this share of the depth from the rim's first point to the zone's deepest
STEP_WINDOW = 1.0  # a fixed punch's rim smoothed over a hat one element width either side along the line
OFFSET_WINDOW = 6.0  # the rim's offset from the outline: a hat this many element widths either side along the line


def rim_line_force(space: ShellSpace, punches: Sequence[Punch], operator: ContactOperator, Lam: np.ndarray,
                   U: np.ndarray, delta: np.ndarray | None, zones: Sequence[dict]
                   ) -> tuple[list[dict | None], list[list[np.ndarray]]]:
    """Per punch (None where it does not touch): ``kind`` ("area", "line" or "point"), ``length`` of the area
    rim, its ``force``, ``peak_line_force`` and ``mean_line_force`` (= force / length), the ``line_loads``
    {force, length, mean_line_force, peak_line_force}, the ``interior_force``, ``interior_area`` and
    ``mean_interior_pressure``, the number of outline ``lines`` and
    ``samples`` [{x, phi (degrees), line_force}] along the rim (module docstring); and per punch the rim's
    polylines (n, 2) in (x, s = aφ) where the line force acts, for the figures."""
    forced = [k for k, p in enumerate(punches) if p.mode == "force"]
    normal = np.linalg.norm(operator.grad, axis=0) * np.asarray(Lam, float)
    row_gap = operator.gap(U, delta)
    out: list[dict | None] = []
    polylines: list[list[np.ndarray]] = []
    for k, (p, zone) in enumerate(zip(punches, zones)):
        rows = operator.rows(k)
        step = float(np.asarray(delta, float)[forced.index(k)]) if p.mode == "force" and delta is not None else None
        touching = None
        if zone_tolerance(p, step) == 0.0:  # a fixed punch that only touches: its zone is where it carries
            sh = space.mesh.shell
            touching = fill_idle_rows(space, operator.x[rows], sh.radius * operator.phi[rows],
                                      (np.asarray(Lam, float)[rows] > 0.0) | (row_gap[rows] <= zone["gap_tolerance"]),
                                      2.0 * np.pi * sh.radius if sh.full else None)
        lines = (_rim_lines(space, p, zone, U, step or 0.0, zone["gap_tolerance"],
                            fixed_punch_points(space, p, operator, rows, touching)) if "x" in zone else [])
        polylines.append([])
        force = normal[rows].copy()
        if not np.any(force > 0.0):
            out.append(None)
            continue
        points = _point_forces(space, lines, operator.x[rows], operator.phi[rows], force)
        if not lines or not np.any(force > 0.0):  # no outline, or all of the force at points
            out.append(_only_points(points, force, zone["area"]))
            continue
        # a fixed punch's outline reaches half a point spacing past a row of points on the body's edge
        body = (lambda q, p=p: in_zone_facing_body(space, p, q[:, 0], q[:, 1])) if touching is not None else None
        entry, rim = _distribute(space, lines, operator.x[rows], operator.phi[rows], force, operator.weights[rows],
                                 zone["area"], body, touching)
        polylines[-1] = rim
        out.append({**entry, "point_forces": points})
        attach_end_forces(space, out[-1], rim)  # a point force at a line load's end is the line's (a corner force)
    return out, polylines


def _point_forces(space: ShellSpace, lines: list[np.ndarray], x: np.ndarray, phi: np.ndarray,
                  force: np.ndarray) -> list[dict]:
    """The point forces among the carrying rows (``point_forces``), whose forces are set to 0 in ``force``
    (in place) so that the line/interior split leaves them out."""
    carrying = np.flatnonzero(force > 0.0)
    pts = np.stack([x[carrying], space.mesh.shell.radius * phi[carrying]], axis=1)
    width = np.maximum(width_along(space, pts, np.tile([1.0, 0.0], (len(pts), 1))),
                       width_along(space, pts, np.tile([0.0, 1.0], (len(pts), 1))))
    sh = space.mesh.shell
    box = (sh.x_min, sh.x_max, sh.s_min, sh.s_min if sh.full else sh.s_max)
    # a cluster inside a thin strip of outline is on a line (a saddle's horn only two elements wide), not a point
    thin = [(area := enclosed_area([ln])) is not None and perimeter_of(ln) ** 2 >= 32.0 * area for ln in lines]
    wide = [ln for ln, strip in zip(lines, thin) if not strip]
    strips = [ln for ln, strip in zip(lines, thin) if strip]
    clusters = point_force_clusters(pts, force[carrying], width, wide, space.mesh.p, space.mesh.t, box, strips)
    points = describe(space.mesh.shell, pts, force[carrying], clusters)
    for g in clusters:
        force[carrying[g]] = 0.0
    return points


def _only_points(points: list[dict], rest: np.ndarray, zone_area: float) -> dict:
    """The decomposition of a punch without an outline: its force at points, and any rest (carrying rows that
    form neither an outline nor a point's cluster: a few scattered rows of a coarse mesh, e.g. a 30 mm thick
    vessel on its saddles at 40 × 48, six rows and 48 kN per saddle) counted as interior force, unresolved
    (``kind`` "unresolved" where no point holds any of it)."""
    interior = float(rest.sum())
    return {"kind": "point" if points else "unresolved", "interior_resolved": interior <= 0.0,
            "length": 0.0, "force": 0.0, "interior_force": interior, "peak_line_force": 0.0,
            "line_loads": {"force": 0.0, "length": 0.0, "mean_line_force": 0.0, "peak_line_force": 0.0,
                           "end_force": 0.0},
            "mean_line_force": 0.0, "lines": 0, "interior_area": zone_area,
            "mean_interior_pressure": interior / zone_area if zone_area > 0 else 0.0, "per_line": [],
            "samples": [], "point_force": sum(q["force"] for q in points), "point_forces": points}


def _rim_lines(space: ShellSpace, p: Punch, zone: dict, U: np.ndarray, step: float, tol: float,
               classes: tuple[np.ndarray, np.ndarray] | None = None) -> list[np.ndarray]:
    """Polylines (n, 2) in (x, s) of the level Π = tol, closed along the candidate zone's edges; for a fixed
    punch (``classes``: its constraint points and whether each touches) the zero set of ``_class_field``."""
    import contourpy

    sh = space.mesh.shell
    a = sh.radius
    phi0, phi1 = np.radians(zone["phi"])
    interval = next(((lo, hi) for lo, hi in p.zone.phi if lo - 1e-12 <= phi0 and phi1 <= hi + 1e-12),
                    p.zone.phi[0])
    x0, x1 = zone["x"]
    mx, mp = MARGIN * max(x1 - x0, 1e-9 * a), MARGIN * max(phi1 - phi0, 1e-9)
    zx, zp = p.zone.x, interval
    if classes is not None:  # the strip round a row of points on the zone's edge reaches past it
        zx = (max(zx[0] - mx, sh.x_min), min(zx[1] + mx, sh.x_max))
        full_round = sh.full and interval[1] - interval[0] >= sh.beta - sh.alpha - 1e-9
        zp = zp if full_round else (interval[0] - mp, interval[1] + mp)
        if not sh.full:
            zp = (max(zp[0], sh.alpha), min(zp[1], sh.beta))
    bx = (max(x0 - mx, zx[0]), min(x1 + mx, zx[1]))
    bp = (max(phi0 - mp, zp[0]), min(phi1 + mp, zp[1]))
    nx, nphi = _sample_counts(space, bx, bp, classes is not None)
    xs, ps = np.linspace(*bx, nx), np.linspace(*bp, nphi)
    X, P = np.meshgrid(xs, ps)
    if classes is not None:  # off the body its mirrored idle points close the zone
        f = class_field(*classes, X, a * P, 2.0 * np.pi * a if sh.full else None)
        # a sample equidistant from a touching and an idle point (common on a mirror-symmetric mesh) is not on
        # the line: at an exact 0 the marching squares' choice follows the grid's direction, not the mirror
        f -= 1e-6 * min(xs[1] - xs[0], a * (ps[1] - ps[0]))
    else:
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
    lines = [_without_repeats(np.asarray(ln, float)) for ln in contourpy.contour_generator(xs, a * ps, f).lines(0.0)]
    return [line for line in lines if len(line) >= 2]


def _without_repeats(line: np.ndarray) -> np.ndarray:
    """The polyline without consecutive repeated points (a contour through a sample point repeats it), which
    would give segments of zero length: no normal, and NaN in the arc-length derivatives."""
    step = np.linalg.norm(np.diff(line, axis=0), axis=1)
    scale = max(float(np.ptp(line, axis=0).max()), 1e-300)
    return line[np.concatenate([[True], step > 1e-12 * scale])]


def _sample_counts(space: ShellSpace, bx: tuple[float, float], bp: tuple[float, float],
                   fixed: bool = False) -> tuple[int, int]:
    """PER_ELEMENT samples per element along x and φ in the box (median element extents there), within SAMPLES:
    the P5 gap is smooth inside an element, so the sampled level line follows the mesh's resolution. For a fixed
    punch's distance field (``fixed``), per smallest element (FIXED_SAMPLES)."""
    m = space.mesh
    a = m.shell.radius
    corners = m.p[:, m.t]  # (2, 3, nelements)
    c = corners.mean(axis=1)
    inside = (c[0] >= bx[0]) & (c[0] <= bx[1]) & (c[1] >= a * bp[0]) & (c[1] <= a * bp[1])
    if not inside.any():
        return SAMPLES[0], SAMPLES[0]
    ext = np.ptp(corners[:, :, inside], axis=1)
    counts = []
    size, most = (lambda e: np.percentile(e, 5.0), FIXED_SAMPLES) if fixed else (np.median, SAMPLES[1])
    for width, h in ((bx[1] - bx[0], size(ext[0])), (a * (bp[1] - bp[0]), size(ext[1]))):
        n = math.ceil(PER_ELEMENT * width / h) + 1 if h > 0 else SAMPLES[0]
        counts.append(int(min(max(n, SAMPLES[0]), most)))
    return counts[0], counts[1]


def _distribute(space: ShellSpace, lines: list[np.ndarray], x: np.ndarray, phi: np.ndarray,
                force: np.ndarray, weight: np.ndarray, zone_area: float,
                on_body: Callable[[np.ndarray], np.ndarray] | None = None,
                touching: np.ndarray | None = None) -> dict:
    """The decomposition of one punch's normal force (module docstring): a line contact's ``line_load``, or the
    rim's line force and the interior (``interior.interior_split``); ``weight``: the rows' ωᵢ; ``on_body``:
    for a fixed punch, whether points (n, 2) in (x, s) face its body within its zone, and ``touching`` the rows in
    its contact (``zone_points.fill_idle_rows``), which are not idle for the interior's edges."""
    a = space.mesh.shell.radius
    total = float(force.sum())
    carrying = force > 0.0
    pts = np.stack([x[carrying], a * phi[carrying]], axis=1)
    f, w = force[carrying], weight[carrying]
    seg0 = np.concatenate([ln[:-1] for ln in lines])
    seg1 = np.concatenate([ln[1:] for ln in lines])
    seg_line = np.concatenate([np.full(len(ln) - 1, i) for i, ln in enumerate(lines)])
    seg_len = np.linalg.norm(seg1 - seg0, axis=1)
    start = np.concatenate([np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(ln, axis=0), axis=1))[:-1]])
                            for ln in lines])  # arc length at each segment's start, along its line
    line_len = np.array([float(np.linalg.norm(np.diff(ln, axis=0), axis=1).sum()) for ln in lines])
    # outline segments along the shell's own edges (x_min, x_max; φ edges of a panel) close the outline where the
    # contact continues beyond the model (a symmetry plane) or the shell ends: no rim there
    sh = space.mesh.shell
    tol = 1e-6 * max(sh.length, sh.s_max - sh.s_min)
    mid = 0.5 * (seg0 + seg1)
    closure = (np.abs(mid[:, 0] - sh.x_min) <= tol) | (np.abs(mid[:, 0] - sh.x_max) <= tol)
    if not sh.full:
        closure |= (np.abs(mid[:, 1] - sh.s_min) <= tol) | (np.abs(mid[:, 1] - sh.s_max) <= tol)
    # a hole round one idle row (none carrying inside) is below the mesh's resolution: no rim round it either
    every = np.stack([x, a * phi], axis=1)
    hole = np.array([unresolved_hole(ln, pts, every) for ln in lines])
    closure |= hole[seg_line]
    j, t, depth = _nearest_segment(pts, seg0, seg1)
    # a point as near to two stretches of the outline (the middle of a zone two elements wide, on a mirror-
    # symmetric mesh) belongs half to each: which one the order of the segments picked would break the mirror
    jt, tt, tied = _second_segment(pts, seg0, seg1, j, t, depth, 1e-9 * max(float(np.ptp(seg0, axis=0).max()), tol))
    if tied.any():
        twin = np.flatnonzero(tied)
        pts, f, w = np.vstack([pts, pts[twin]]), np.concatenate([f, f[twin]]), np.concatenate([w, w[twin]])
        f[twin], w[twin] = 0.5 * f[twin], 0.5 * w[twin]
        f[len(tied):], w[len(tied):] = f[twin], w[twin]
        j, t, depth = np.concatenate([j, jt[twin]]), np.concatenate([t, tt[twin]]), np.concatenate([depth, depth[twin]])
    if closure.any() and not closure.all():  # on a tie (a point on a corner) the segment that can carry a rim
        keep = np.flatnonzero(~closure)
        j2, t2, d2 = _nearest_segment(pts, seg0[keep], seg1[keep])
        better = closure[j] & (d2 <= depth + tol)
        j[better], t[better], depth[better] = keep[j2[better]], t2[better], d2[better]
    # the line's normal at each point's nearest point: the segment's, or at a vertex the mean of its two segments'
    # (a point nearest a corner has two nearest segments; this makes the choice not matter)
    v_n = [vertex_normals(ln, closes_on_itself(ln, sh)) for ln in lines]
    n_start = np.concatenate([n[:-1] for n in v_n])
    n_end = np.concatenate([n[1:] for n in v_n])
    seg_dir = (seg1 - seg0) / np.maximum(seg_len, 1e-300)[:, None]
    normal = np.stack([-seg_dir[j, 1], seg_dir[j, 0]], axis=1)
    normal = np.where((t <= 0.0)[:, None], n_start[j], np.where((t >= 1.0)[:, None], n_end[j], normal))
    tangent = np.stack([normal[:, 1], -normal[:, 0]], axis=1)
    across = width_along(space, pts, normal)
    along = width_along(space, pts, tangent)
    # a line contact: an outline that is a strip at least eight times longer than wide whose force sits on its
    # middle line (not outside it, as where the tolerance is below the gap's scatter between constraint points)
    line_parts: list[tuple[dict, list[np.ndarray]]] = []
    is_line = np.zeros(len(lines), bool)
    for i, ln in enumerate(lines):
        mine = np.flatnonzero(seg_line[j] == i)
        enclosed = enclosed_area([ln])
        if mine.size == 0 or not enclosed or hole[i]:
            continue
        thickness = 2.0 * enclosed / line_len[i]
        mean_depth = float(np.sum(f[mine] * depth[mine]) / max(f[mine].sum(), 1e-300))
        if LINE_CONTACT <= mean_depth / (0.5 * thickness) <= 1.0 / LINE_CONTACT and line_len[i] >= 16.0 * thickness:
            is_line[i] = True
            line_parts.append(_line_contact(space, pts[mine], f[mine], enclosed, float(line_len[i]),
                                            float(f[mine].sum()), on_body))
    where = start[j] + t * seg_len[j]  # arc length along the nearest level line
    # signed offset of each point from its line (the sign of the line's left normal): the rim's offset below is a
    # mean of these, so it does not depend on which way round or from where a line was traced (mirror images
    # of a problem give mirror images of the rim)
    side = np.einsum("nk,nk->n", pts - (seg0[j] + t[:, None] * (seg1 - seg0)[j]), normal)
    size = float(np.median(np.maximum(across, along)))  # the window along the line: about one element
    band, narrow = np.zeros(len(f), bool), np.zeros(len(f), bool)
    geometry = []
    for i, ln in enumerate(lines):
        closed = closes_on_itself(ln, sh)
        mine = np.flatnonzero((seg_line[j] == i) & ~closure[j])
        if mine.size == 0 or is_line[i]:
            geometry.append((ln, None, closed))
            continue
        period = line_len[i] if closed else None
        # the rim starts at the shallowest carrying point near each point along the line (within ± 2 elements);
        # the level line lies outside the contact by a distance that converges, not by a fraction of h
        big = mine[f[mine] >= 1e-3 * f[mine].max()]
        first = _window_min(where[mine], where[big], depth[big], 2.0 * size, period)
        typical = float(np.median(first[np.isfinite(first)])) if np.isfinite(first).any() else 0.0
        rim_here = first <= 2.0 * typical + 2.0 * size  # a point whose shallowest neighbour lies deep: no rim there
        width = RIM_WIDTH * across[mine]
        if on_body is not None:
            # a fixed punch's outline bounds where it carries, so on a zone only a few elements across (a saddle
            # two elements wide) the band takes at most RIM_SHARE of the depth to the zone's middle (its deepest
            # carrying point nearby): the rest is the interior's. (A moving punch's level line lies outside the
            # contact by a finite distance, with lift-off inside it: there the depth is not the contact's width.)
            deepest = -_window_min(where[mine], where[big], -depth[big], 2.0 * size, period)
            width = np.minimum(width, RIM_SHARE * np.maximum(deepest - first, 0.0))
        # (a row at the band's edge to round-off is in it: on a mirror-symmetric mesh its image is too)
        band[mine] = rim_here & (depth[mine] <= first + width + 1e-6 * across[mine])
        narrow[mine] = width < RIM_WIDTH * across[mine]
        geometry.append((ln, mine, closed))
    # the band also holds the interior pressure over its width, O(h): it vanishes under refinement
    rim_force = float(f[band].sum())
    rim_lines, samples, length, inner_area, peak, per_line, rim_keep, rim_outlines = [], [], 0.0, 0.0, 0.0, [], [], []
    for i, (ln, mine, closed) in enumerate(geometry):
        if mine is None:
            continue
        arc = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(ln, axis=0), axis=1))])
        period = line_len[i] if closed else None
        sel = mine[band[mine]] if mine is not None else np.zeros(0, int)
        # the rim: each point of the level line moved along its normal to the force-weighted mean offset of the
        # band within ± OFFSET_WINDOW elements (hat weights: the centroids scatter by a fraction of h)
        n_v = vertex_normals(ln, closed)
        num = hat_sum(arc, where[sel], f[sel] * side[sel], OFFSET_WINDOW * size, period)
        den = hat_sum(arc, where[sel], f[sel], OFFSET_WINDOW * size, period)
        has = den > 0
        if not has.any():
            continue
        offset = np.where(has, num / np.where(has, den, 1.0), 0.0)
        if not has.all():  # no band nearby: the neighbours' offset
            offset = np.interp(arc, arc[has], offset[has], period=period)
        rim = ln + offset[:, None] * n_v
        if np.allclose(ln[0], ln[-1]):
            rim[-1] = rim[0]
            if on_body is not None:  # a fixed punch's outline steps from row to row: its length would not converge
                rim = smoothed_loop(rim, arc, STEP_WINDOW * size)
        rim_seg = np.linalg.norm(np.diff(rim, axis=0), axis=1)
        rim_arc = np.concatenate([[0.0], np.cumsum(rim_seg)])
        rim_lines.append(rim)
        rim_keep.append(~closure[seg_line == i])  # the closing segments carry no line force
        rim_outlines.append(ln)
        per_line.append({"kind": "area", "length": 0.0, "force": float(f[sel].sum()), "mean_line_force": 0.0,
                         "closed": closed})
        inner_area += float(np.sum(0.5 * (np.abs(offset[1:]) + np.abs(offset[:-1])) * np.diff(arc)))
        # the line force: the band's forces smoothed along the line with a hat two element lengths wide (the vertex
        # and midpoint forces of a uniform load average out), per unit length of the rim (d rim_arc / d arc)
        half = 2.0 * float(np.median(along[sel]))
        stretch = np.gradient(rim_arc, arc, edge_order=1) if len(arc) > 2 else np.ones_like(arc)
        at_points = hat_sum(where[sel], where[sel], f[sel], half, period) / half
        at_points /= np.maximum(np.interp(where[sel], arc, stretch, period=period), 1e-12)
        peak = max(peak, float(at_points.max(initial=0.0)))
        nb = int(min(MAX_BINS, max(3, math.floor(line_len[i] / half))))
        centres = (np.arange(nb) + 0.5) * line_len[i] / nb
        density = hat_sum(centres, where[sel], f[sel], half, period) / half
        density /= np.maximum(np.interp(centres, arc, stretch, period=period), 1e-12)
        on_rim = points_at(rim, np.interp(centres, arc, rim_arc))
        samples += [{"x": float(c[0]), "phi": float(math.degrees(c[1] / a) % 360.0 if sh.full
                                                 else math.degrees(c[1] / a)),
                     "line_force": float(v), "line": len(per_line) - 1} for c, v in zip(on_rim, density)]
    # two stretches of the outline that the offset moves onto one line (the sides of a sliver of the zone along a
    # rim) are one rim: count its length once
    for entry, own in zip(per_line, _union_lengths(rim_lines, rim_outlines, rim_keep, 0.1 * float(np.median(across)))):
        entry["length"] = own
        entry["mean_line_force"] = entry["force"] / own if own > 0 else 0.0
        length += own
    loads = {"force": 0.0, "length": 0.0, "mean_line_force": 0.0, "peak_line_force": 0.0}
    for part, polyline in line_parts:  # line contacts: their whole force is a line load
        loads["force"] += part["force"]
        loads["length"] += part["length"]
        inner_area += part["area"]
        loads["peak_line_force"] = max(loads["peak_line_force"], part["peak_line_force"])
        samples += [{**q, "line": len(per_line)} for q in part["samples"]]
        rim_lines += polyline
        per_line.append({"kind": "line", "length": part["length"], "force": part["force"],
                         "mean_line_force": part["mean_line_force"], "closed": False})
    loads["mean_line_force"] = loads["force"] / loads["length"] if loads["length"] > 0 else 0.0
    interior = max(total - rim_force - loads["force"], 0.0)
    interior_area = max(zone_area - inner_area, 0.0)
    rest = ~band & ~is_line[seg_line[j]]  # the interior's carrying rows: not on the rim's band or a line load
    idle_rows = ~carrying if touching is None else ~(carrying | touching)  # (a filled row is in the contact)
    idle = np.stack([x[idle_rows], a * phi[idle_rows]], axis=1)
    # a band narrowed to a share of the zone's depth holds the interior's pressure over a width that does not
    # vanish as h does: where it holds most of the band's force, the interior is not resolved by this mesh
    unresolved = float(f[band & narrow].sum()) > RESOLVED * float(f[band].sum())
    split = interior_split(pts[rest], f[rest], w[rest], np.maximum(across, along)[rest], idle,
                           lambda p, d: width_along(space, p, d))
    out = {"kind": "line" if line_parts and not _geometry_has_force(geometry) else "area", "length": length,
           "force": rim_force, "interior_force": interior,
           "peak_line_force": peak, "mean_line_force": rim_force / length if length > 0 else 0.0,
           "lines": len(per_line), "interior_area": interior_area,
           "mean_interior_pressure": interior / interior_area if interior_area > 0 else 0.0, **split,
           "interior_resolved": split["interior_resolved"] and not unresolved,
           "line_loads": loads, "per_line": per_line, "samples": samples}
    return out, rim_lines


def _geometry_has_force(geometry: list) -> bool:
    """Whether an outline that is not a line contact holds carrying points."""
    return any(mine is not None and mine.size for _, mine, _ in geometry)


def _window_min(at: np.ndarray, where: np.ndarray, values: np.ndarray, half: float,
                period: float | None) -> np.ndarray:
    """At each arc position ``at``: the least of ``values`` at positions ``where`` within ± half (periodic)."""
    order = np.argsort(where)
    w, v = where[order], values[order]
    if period is not None:
        w, v = np.concatenate([w - period, w, w + period]), np.concatenate([v, v, v])
    lo = np.searchsorted(w, at - half, side="left")
    hi = np.searchsorted(w, at + half, side="right")
    out = np.full(len(at), np.inf)
    for k, (a, b) in enumerate(zip(lo, hi)):
        if b > a:
            out[k] = v[a:b].min()
    return out


def _line_contact(space: ShellSpace, pts: np.ndarray, f: np.ndarray, zone_area: float, perimeter: float,
                  total: float, on_body: Callable[[np.ndarray], np.ndarray] | None = None
                  ) -> tuple[dict, list[np.ndarray]]:
    """A zone that is a thin strip round the force (a plate on a pipe): the line load along its middle line,
    whose length follows from the strip's perimeter P and area A as the long side of a P, A rectangle. A fixed
    punch's strip (``on_body``) reaches half a point spacing past its end rows; where that is off the body (a
    saddle's horn ends at its faces) the line ends at the end row."""
    length = 0.5 * (0.5 * perimeter + math.sqrt(max(0.25 * perimeter ** 2 - 4.0 * zone_area, 0.0)))
    c = np.average(pts, axis=0, weights=f)
    e = np.array([1.0, 0.0])
    if len(pts) >= 2:
        cov = np.cov((pts - c).T, aweights=f)
        if np.all(np.isfinite(cov)):
            e = np.linalg.eigh(cov)[1][:, -1]  # the line's direction (principal axis of the forces)
    s = (pts - c) @ e
    a = space.mesh.shell.radius
    half = 2.0 * float(np.median(width_along(space, pts, np.tile(e, (len(pts), 1)))))  # two element lengths
    lo, hi = float(s.min()), float(s.max())
    if on_body is not None and length > hi - lo > 0.0:  # (a strip round one point keeps its length)
        over = 0.5 * (length - (hi - lo))
        past = np.stack([c + (lo - over) * e, c + (hi + over) * e])
        length -= over * float(np.count_nonzero(~on_body(past)))
    # the line from its middle, its whole length: bins of about two element lengths, at least LINE_SAMPLES
    mid = 0.5 * (lo + hi)
    ends = (mid - 0.5 * length, mid + 0.5 * length)
    nb = int(min(MAX_BINS, max(LINE_SAMPLES, round(length / half) if half > 0.0 else 0)))
    centres = ends[0] + (np.arange(nb) + 0.5) * length / nb
    if hi - lo > 0.0 and half > 0.0:  # the forces smoothed with a hat two element lengths wide
        kernel = np.clip(1.0 - np.abs(centres[:, None] - s[None, :]) / half, 0.0, None)
        # near the data's ends the kernel reaches past them: divide by its part within them
        inside = np.clip(np.minimum(centres - lo, hi - centres) / half, 0.0, 1.0)
        shape = kernel @ f / (0.5 + inside - 0.5 * inside ** 2)
    else:  # the forces at one point: uniform along the strip round it
        shape = np.ones(nb)
    # scaled so that the line load integrates to the line's force (the hat's ends reach past the line)
    density = shape * (total / length) / max(float(shape.mean()), 1e-300)
    line = c[None, :] + centres[:, None] * e[None, :]
    samples = [{"x": float(p[0]), "phi": float(math.degrees(p[1] / a)), "line_force": float(v)}
               for p, v in zip(line, density)]
    out = {"length": length, "force": total, "area": zone_area, "peak_line_force": float(density.max(initial=0.0)),
           "mean_line_force": total / length, "samples": samples}
    lo, hi = ends
    return out, [np.stack([c + lo * e, c + hi * e])]


def _to_segments(pts: np.ndarray, seg0: np.ndarray, d: np.ndarray, len2: np.ndarray
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """For each point (rows) and segment (columns): the projection parameter t ∈ [0, 1], the nearest point of
    the segment and the distance to it — one kernel, so that the nearest and the second-nearest segment's
    distances compare without round-off between two formulas."""
    tt = np.clip(np.einsum("nsk,sk->ns", pts[:, None, :] - seg0[None], d) / len2, 0.0, 1.0)
    near = seg0[None] + tt[..., None] * d[None]
    return tt, near, np.linalg.norm(pts[:, None, :] - near, axis=2)


def _nearest_segment(pts: np.ndarray, seg0: np.ndarray, seg1: np.ndarray,
                     chunk: int = 1024) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """For each point: its nearest segment, the projection parameter t ∈ [0, 1] on it and the distance."""
    d = seg1 - seg0
    len2 = np.maximum(np.einsum("sk,sk->s", d, d), 1e-300)
    j, t, dist = (np.zeros(len(pts), int), np.zeros(len(pts)), np.zeros(len(pts)))
    for lo in range(0, len(pts), chunk):
        tt, _, dd = _to_segments(pts[lo:lo + chunk], seg0, d, len2)
        jj = np.argmin(dd, axis=1)
        rows = np.arange(len(jj))
        j[lo:lo + chunk], t[lo:lo + chunk], dist[lo:lo + chunk] = jj, tt[rows, jj], dd[rows, jj]
    return j, t, dist


def _second_segment(pts: np.ndarray, seg0: np.ndarray, seg1: np.ndarray, j: np.ndarray, t: np.ndarray,
                    depth: np.ndarray, tol: float, chunk: int = 1024
                    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """For each point: the nearest segment whose nearest point differs from the one found (``j``, ``t``: not
    the neighbour sharing a corner), its parameter, and whether it is as near (to ``tol``)."""
    d = seg1 - seg0
    len2 = np.maximum(np.einsum("sk,sk->s", d, d), 1e-300)
    foot = seg0[j] + t[:, None] * d[j]
    j2, t2, tied = np.zeros(len(pts), int), np.zeros(len(pts)), np.zeros(len(pts), bool)
    for lo in range(0, len(pts), chunk):
        tt, near, dd = _to_segments(pts[lo:lo + chunk], seg0, d, len2)
        dd[np.linalg.norm(near - foot[lo:lo + chunk, None, :], axis=2) <= 1e3 * tol] = np.inf
        jj = np.argmin(dd, axis=1)
        rows = np.arange(len(jj))
        j2[lo:lo + chunk], t2[lo:lo + chunk] = jj, tt[rows, jj]
        tied[lo:lo + chunk] = dd[rows, jj] <= depth[lo:lo + chunk] + tol
    return j2, t2, tied


def _union_lengths(polylines: list[np.ndarray], outlines: list[np.ndarray], keep: list[np.ndarray],
                   delta: float) -> list[float]:
    """The length of each polyline's kept segments, where two stretches within ``delta`` of each other running
    opposite ways, from stretches of the outline within 2 delta too, count once: the two sides of a sliver of
    the zone along a rim, which the offset puts onto one line (not a rim's two arms near a sharp end)."""
    from scipy.spatial import cKDTree

    pts, ds, owner, direction, source, source_arc, periods = [], [], [], [], [], [], []
    for i, (pl, ol, kept) in enumerate(zip(polylines, outlines, keep)):
        seg = np.diff(pl, axis=0)
        lengths = np.linalg.norm(seg, axis=1)
        o_len = np.linalg.norm(np.diff(ol, axis=0), axis=1)
        # along the outline, a closing stretch (the shell's edge) parts two sides as much as the rest of it does
        o_len = np.where(kept, o_len, o_len.sum() + 1.0)
        periods.append(float(o_len.sum()) if np.allclose(ol[0], ol[-1]) else np.inf)
        o_start = np.concatenate([[0.0], np.cumsum(o_len)[:-1]])
        for k in np.flatnonzero(kept & (lengths > 0)):
            n = max(1, math.ceil(lengths[k] / (0.5 * delta)))
            u = (np.arange(n) + 0.5) / n
            pts.append(pl[k] + u[:, None] * seg[k])
            source.append(ol[k] + u[:, None] * (ol[k + 1] - ol[k]))
            source_arc.append(o_start[k] + u * o_len[k])
            ds.append(np.full(n, lengths[k] / n))
            owner.append(np.full(n, i))
            direction.append(np.tile(seg[k] / lengths[k], (n, 1)))
    out = np.zeros(len(polylines))
    if not pts:
        return [float(v) for v in out]
    P, dl, who, d = np.vstack(pts), np.concatenate(ds), np.concatenate(owner), np.vstack(direction)
    src, arc = np.vstack(source), np.concatenate(source_arc)
    pairs = cKDTree(P).query_pairs(delta, output_type="ndarray")
    paired = np.zeros(len(P), bool)
    if len(pairs):
        p, q = pairs[:, 0], pairs[:, 1]
        apart = np.linalg.norm(src[p] - src[q], axis=1)
        # the two sides of a sliver: close across, far along the outline (not a local fold of the offset line)
        along = np.abs(arc[p] - arc[q])
        along = np.minimum(along, np.asarray(periods)[who[p]] - along)  # round a closed outline, from anywhere
        sides = (apart <= 2 * delta) & ((who[p] != who[q]) | (along > 2 * apart + delta))
        opposite = (np.einsum("nk,nk->n", d[p], d[q]) < -0.5) & sides
        paired[np.maximum(p, q)[opposite]] = True
    np.add.at(out, who[~paired], dl[~paired])
    return [float(v) for v in out]
