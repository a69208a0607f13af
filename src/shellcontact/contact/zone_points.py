"""The contact zone of a fixed punch classified at its constraint points (``contact.contact_zone``).

A punch that neither moves nor is pushed (a saddle, a cradle) has no travel to scale a gap tolerance by. The
linearised gap at points between the constraint points is then an interpolation: on
``examples/vessel_saddles.toml`` (80 x 96) it ranges from −0.46 µm (penetration between the points) to 76 µm
with no gap in its distribution, so a tolerance at any level (1e-9 to 1e-4 m) gives a different zone
(0.18 to 0.63 m²). At the constraint points themselves the classes separate by ten orders: a point that
carries force has a gap of round-off (≤ 1e-16 m), while points that carry nothing hover from 10 nm up
(80 x 96: a tolerance of 7.6e-9, 7.6e-8, 7.6e-7 m on the points would give 0.4446, 0.4469, 0.4587 m²). So a
point of the middle surface belongs to the zone when its nearest constraint point of that punch carries
force (Λ > 0) or has a gap at round-off, at most ``ROUND_OFF_GAP`` × the largest motion toward the punch
(stated as the zone's ``gap_tolerance``): contact is carrying force. The zone's boundary is then exact to
within half the points' spacing, which converges with h.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

#: a constraint point's gap at round-off, relative to the largest motion toward its punch (active points: 1e-12)
ROUND_OFF_GAP = 1e-9


def nearest_point_class(x: np.ndarray, s: np.ndarray, point_x: np.ndarray, point_s: np.ndarray,
                        point_touching: np.ndarray, period: float | None = None) -> np.ndarray:
    """Per (x, s): the class ``point_touching`` of the nearest of the points (``point_x``, ``point_s``); on a
    closed cylinder (``period`` = 2π a) the points are repeated one period on either side along s."""
    px, ps, cls = (np.asarray(point_x, float), np.asarray(point_s, float), np.asarray(point_touching, bool))
    if px.size == 0:
        return np.zeros(np.shape(x), dtype=bool)
    if period:
        px, ps, cls = np.tile(px, 3), np.concatenate([ps - period, ps, ps + period]), np.tile(cls, 3)
    _, nearest = cKDTree(np.column_stack([px, ps])).query(np.column_stack([np.ravel(x), np.ravel(s)]))
    return cls[nearest].reshape(np.shape(x))



#: an idle row is filled when two touching rows on opposite sides of it are at most this many element widths
#: apart (along their direction): one or two idle rows between them, at most one element of gap
FILL_GAP = 1.5
#: two directions are opposite when their cosine is at most this
OPPOSITE = -0.9


def fill_idle_rows(space, x: np.ndarray, s: np.ndarray, touching: np.ndarray, period: float | None) -> np.ndarray:
    """``touching`` at constraint rows (x, s = aφ) with every idle row that lies between two touching rows on
    opposite sides, at most ``FILL_GAP`` element widths apart along their direction, counted as touching: a
    morphological closing by about one element. A gap of one or two idle rows between carrying ones (a row of
    edge midpoints, or a vertex and a midpoint, that carry nothing between rows that do, at a coarse contact
    set's corners and columns) is below the mesh's resolution; left idle, it cut the zone's outline into loops
    round the corners, split lines and fake lines. A row with touching rows on one side only (the set's edge)
    is kept idle, so the set does not grow past its edge; a gap wider than an element is resolved and kept.
    ``space``: the ShellSpace (element widths, ``width_along``); ``period``: 2π a on a closed cylinder."""
    from scipy.spatial import cKDTree

    touching = np.asarray(touching, bool)
    out = touching.copy()
    idle, on = np.flatnonzero(~touching), np.flatnonzero(touching)
    if idle.size == 0 or on.size < 2:
        return out
    pts = np.column_stack([x, s])
    tp = pts[on]
    if period:
        tp = np.vstack([tp + [0.0, -period], tp, tp + [0.0, period]])
    q = pts[idle]
    wide = np.maximum(width_along(space, q, np.tile([1.0, 0.0], (len(q), 1))),
                      width_along(space, q, np.tile([0.0, 1.0], (len(q), 1))))
    near = cKDTree(tp).query_ball_point(q, FILL_GAP * wide * (1.0 + 1e-9))
    centre = np.repeat(np.arange(len(q)), [len(n) for n in near])
    if centre.size == 0:
        return out
    d = tp[np.concatenate(near).astype(int)] - q[centre]
    dist = np.linalg.norm(d, axis=1)
    u = d / np.maximum(dist, 1e-300)[:, None]
    reach = dist / np.maximum(width_along(space, q[centre], u), 1e-300)  # in element widths along u
    order = np.argsort(centre, kind="stable")
    starts = np.flatnonzero(np.diff(np.concatenate([[-1], centre[order]])))
    for c, uu, rr in zip(centre[order][starts], np.split(u[order], starts[1:]), np.split(reach[order], starts[1:])):
        opposite = (uu @ uu.T <= OPPOSITE) & (rr[:, None] + rr[None, :] <= FILL_GAP * (1.0 + 1e-9))
        out[idle[c]] = bool(opposite.any())
    return out


def width_along(space, pts: np.ndarray, direction: np.ndarray) -> np.ndarray:
    """The width (in x, s) of the elements at each point, measured along ``direction`` (unit, (n, 2)): the mesh's
    resolution in that direction, also on the long thin elements of a mesh graded in one direction. A point on a
    vertex or an edge touches several elements: the largest width of those in the four diagonal directions from
    it, so that mirror images of a point (on a mirror-symmetric mesh) get the same width."""
    m = space.mesh
    sh = m.shell
    eps = 1e-7 * sh.radius
    widths = np.zeros(len(pts))
    for dx, ds in ((1, 1), (1, -1), (-1, 1), (-1, -1)):
        x = np.clip(pts[:, 0] + dx * eps, sh.x_min, sh.x_max)
        s = np.clip(pts[:, 1] + ds * eps, sh.s_min, sh.s_max)
        corners = m.p[:, m.t[:, space.locate(x, s)]]  # (2, 3, n)
        widths = np.maximum(widths, np.ptp(np.einsum("kcn,nk->cn", corners, direction), axis=0))
    return widths
