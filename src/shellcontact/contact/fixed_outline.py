"""A fixed punch's outline for the rim (``contact.rim``): the boundary of where it carries force.

A punch that neither moves nor is pushed (a saddle, a cradle) has no travel to scale a gap tolerance by, and its
zone is where its constraint points carry force or have a gap at round-off (``zone_points.py``). The gap's level
line at that round-off tolerance is noise (on examples/vessel_saddles.toml 58 and 55 loops for the two mirror
saddles, with a spurious 8 kN point force on one), and the 0/1 class contoured at ½ follows the sampling grid. So
the outline is the zero set of a continuous field: the distance to the nearest touching point minus that to the
nearest idle one, whose zero set is the boundary of ``zone_points.nearest_point_class`` and as mirror-symmetric as
the points. Past the zone's edges (the end of a finite body, such as a saddle's horn) there are no points: there
each point's neighbours are mirrored through it as idle points, so that a row of touching points along the edge
is a strip with the row in its middle, as a row inside is.
"""

from __future__ import annotations

import numpy as np

from ..shell.spaces import ShellSpace
from .operator import ContactOperator, facing_body
from .punches import Punch


def fixed_punch_points(space: ShellSpace, p: Punch, operator: ContactOperator, rows: np.ndarray,
                       touching: np.ndarray | None) -> tuple[np.ndarray, np.ndarray] | None:
    """A fixed punch's constraint points (n, 2) in (x, s) and whether each touches (None for a moving punch),
    with idle points mirrored across the candidate zone's edges: each point's neighbours reflected through it
    where that falls outside the zone or off the body, but on the shell (past a symmetry plane or the shell's
    end the contact goes on). A row of touching points along the zone's edge (a saddle's horn) is then a strip
    with the row in its middle, as a row inside is, and not cut off at the row."""
    if touching is None:
        return None
    from scipy.spatial import cKDTree

    sh = space.mesh.shell
    pts = np.stack([operator.x[rows], sh.radius * operator.phi[rows]], axis=1)
    tree = cKDTree(pts)
    _, near = tree.query(pts, k=min(9, len(pts)))
    mirrored = (2.0 * pts[:, None, :] - pts[near]).reshape(-1, 2)
    reach = np.linalg.norm(pts[near] - pts[:, None, :], axis=2).ravel()
    x, s = mirrored[:, 0], mirrored[:, 1]
    new = tree.query(mirrored)[0] > 0.5 * reach  # not (to round-off) one of the points themselves
    on_shell = (x >= sh.x_min) & (x <= sh.x_max)
    if not sh.full:
        on_shell &= (s >= sh.s_min) & (s <= sh.s_max)
    outside = new & on_shell & ~in_zone_facing_body(space, p, x, s)
    return np.vstack([pts, mirrored[outside]]), np.concatenate([touching, np.zeros(int(outside.sum()), bool)])


def in_zone_facing_body(space: ShellSpace, p: Punch, x: np.ndarray, s: np.ndarray) -> np.ndarray:
    """Whether points (x, s = aφ) lie in the punch's candidate zone, facing its body."""
    sh = space.mesh.shell
    phi = np.mod(s / sh.radius, 2.0 * np.pi) if sh.full else s / sh.radius
    return p.zone.contains(x, phi) & facing_body(space, p, x, s)


def class_field(pts: np.ndarray, touching: np.ndarray, X: np.ndarray, S: np.ndarray, period: float | None
                ) -> np.ndarray:
    """The distance to the nearest touching point minus that to the nearest idle one (negative inside the
    contact): continuous, its zero set the boundary of ``zone_points.nearest_point_class``, and as symmetric as
    the points are (a 0/1 class contoured at ½ follows the sampling grid instead)."""
    from scipy.spatial import cKDTree

    q = np.column_stack([X.ravel(), S.ravel()])
    far = 1e3 * float(np.ptp(q, axis=0).max() + np.ptp(pts, axis=0).max() + 1.0)
    dist = []
    for group in (pts[touching], pts[~touching]):
        if period:
            group = np.vstack([group + [0.0, -period], group, group + [0.0, period]])
        dist.append(cKDTree(group).query(q)[0] if len(group) else np.full(len(q), far))
    return (dist[0] - dist[1]).reshape(X.shape)
