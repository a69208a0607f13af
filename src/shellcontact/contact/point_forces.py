"""Point forces of the contact measure: where a punch's carrying points shrink to the mesh scale.

For a Kirchhoff–Love shell the contact multiplier is a measure (MODEL.md §8, docs/theory.md §9): besides the
pressure inside a zone and the line forces along its boundary, a zone that shrinks to a point (a sphere touching
a panel lightly, a pinched contact) carries a point force. In the discrete solution such a force sits on a few
constraint points round one spot, whatever the mesh: a cluster of carrying points no wider than the elements
there. Dividing it by a rim length or an area gives numbers that grow without bound under refinement, so it is
reported as what it is, a force (N) at a position, and left out of the line/interior split
(``shellcontact.contact.rim``).

A cluster: the carrying points (Λᵢ > 0) joined when closer than ``JOIN`` element widths (the constraint points
of one element, vertices and edge midpoints, are within one width of each other), but never across the edge of a
thin strip of outline round a line (``strips``: a carrying point in a loop of its own at a saddle's corner, next
to its horn's strip, is not part of the horn's cluster; ``contact.line_ends`` attaches such a point force to the
line load whose end it is). A cluster is a point force when

- it lies within the elements round one vertex (the one nearest its force-weighted centroid): its extent is the
  mesh's, not the contact's (a discrete point force is a vertex's row and those of its neighbours); and
- it does not reach from one edge of the shell to the opposite one (a ring across a narrow sector); and
- it is the only cluster inside its outline (the closed level line of the gap at the zone's tolerance, or, where
  the zone has no outline, the only one at all): a rim traced by isolated points on a coarse mesh is many small
  clusters inside one outline, not many point forces.

Under refinement a point force keeps its force and position while its cluster shrinks with h; a zone that is
really an area, resolved by a finer mesh, gets a rim instead (that one mesh cannot tell: compare two levels).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

JOIN = 1.5  # carrying points closer than this many element widths are one cluster


def point_force_clusters(pts: np.ndarray, force: np.ndarray, width: np.ndarray, outlines: Sequence[np.ndarray],
                         mesh_p: np.ndarray, mesh_t: np.ndarray, box: tuple[float, float, float, float],
                         strips: Sequence[np.ndarray] = ()) -> list[np.ndarray]:
    """Indices into ``pts`` (n, 2 in x, s = aφ; all carrying, ``force`` > 0) of each cluster that is a point
    force (module docstring). ``width``: the element width at each point; ``outlines``: the zone's level lines
    (n, 2) in (x, s); ``mesh_p`` (2, nv), ``mesh_t`` (3, ne): the mesh; ``box``: the shell's (x_min, x_max,
    s_min, s_max) (s_min = s_max: a full cylinder); ``strips``: closed outlines that are thin strips round a line,
    whose edges no cluster crosses."""
    if len(pts) == 0:
        return []
    labels = _clusters(pts, width, _owner(pts, strips))
    groups = [np.flatnonzero(labels == c) for c in range(int(labels.max()) + 1)]
    small = []
    for k, g in enumerate(groups):
        centre = np.average(pts[g], axis=0, weights=force[g])
        if _in_one_star(pts[g], centre, mesh_p, mesh_t) and not _spans(pts[g], box):
            small.append(k)
    if not small:
        return []
    # which outline holds each cluster (by its first point: a point force's cluster is far smaller than it)
    owner = _owner(np.array([pts[g[0]] for g in groups]), outlines)
    count = np.bincount(owner + 1, minlength=len(outlines) + 1)  # owner −1: no closed outline holds it
    alone = [count[owner[k] + 1] == 1 if owner[k] >= 0 else len(groups) == 1 for k in small]
    return [groups[k] for k, one in zip(small, alone) if one]


def describe(shell, pts: np.ndarray, force: np.ndarray, clusters: list[np.ndarray]) -> list[dict]:
    """Each point force: its force (N, the normal force Σ Λᵢ|∇Zᵢ| of its cluster), and where it acts, the
    cluster's force-weighted centroid as ``x`` (m), ``phi`` (degrees) and ``position`` [X, Y, Z] (m, the middle
    surface's point)."""
    a = shell.radius
    out = []
    for g in clusters:
        c = np.average(pts[g], axis=0, weights=force[g])
        phi = c[1] / a
        out.append({"force": float(force[g].sum()), "x": float(c[0]), "phi": float(math.degrees(phi)),
                    "position": [float(v) for v in shell.point(c[0], phi)]})
    return sorted(out, key=lambda p: -p["force"])


def _in_one_star(pts: np.ndarray, centre: np.ndarray, mesh_p: np.ndarray, mesh_t: np.ndarray) -> bool:
    """Whether every point lies in (or on) the triangles round the mesh vertex nearest ``centre``."""
    v = int(np.argmin(np.sum((mesh_p - centre[:, None]) ** 2, axis=0)))
    star = mesh_t[:, np.any(mesh_t == v, axis=0)]  # (3, k)
    corners = mesh_p[:, star]  # (2, 3, k)
    e1, e2 = corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]  # (2, k)
    det = e1[0] * e2[1] - e1[1] * e2[0]
    d = pts.T[:, :, None] - corners[:, 0][:, None, :]  # (2, n, k)
    l1 = (d[0] * e2[1] - d[1] * e2[0]) / det
    l2 = (e1[0] * d[1] - e1[1] * d[0]) / det
    tol = 1e-9
    inside = (l1 >= -tol) & (l2 >= -tol) & (l1 + l2 <= 1.0 + tol)
    return bool(np.all(inside.any(axis=1)))


def _spans(pts: np.ndarray, box: tuple[float, float, float, float]) -> bool:
    """Whether the points reach from one edge of the shell to the opposite one: a line across a narrow model
    (the ring of an axisymmetric state on a sector with symmetry edges), not a point."""
    x0, x1, s0, s1 = box
    tol = 1e-9 * max(x1 - x0, s1 - s0, 1.0)
    across_x = pts[:, 0].min() <= x0 + tol and pts[:, 0].max() >= x1 - tol
    across_s = s1 > s0 and pts[:, 1].min() <= s0 + tol and pts[:, 1].max() >= s1 - tol
    return bool(across_x or across_s)


def _clusters(pts: np.ndarray, width: np.ndarray, owner: np.ndarray) -> np.ndarray:
    """Connected-component labels of the points joined when closer than JOIN × the larger of their widths and in
    the same strip or both in none (``owner``: ``_owner``'s index among the strips, −1 in none)."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components
    from scipy.spatial import cKDTree

    n = len(pts)
    pairs = cKDTree(pts).query_pairs(JOIN * float(width.max()), output_type="ndarray")
    if len(pairs):
        p, q = pairs[:, 0], pairs[:, 1]
        near = np.linalg.norm(pts[p] - pts[q], axis=1) <= JOIN * np.maximum(width[p], width[q])
        near &= owner[p] == owner[q]
        p, q = p[near], q[near]
    else:
        p = q = np.zeros(0, int)
    graph = coo_matrix((np.ones(len(p)), (p, q)), shape=(n, n))
    return connected_components(graph, directed=False)[1]


def _owner(points: np.ndarray, outlines: Sequence[np.ndarray]) -> np.ndarray:
    """For each point, the index of the smallest closed outline that contains it (−1: none)."""
    from matplotlib.path import Path

    owner = np.full(len(points), -1)
    best = np.full(len(points), np.inf)
    for i, ln in enumerate(outlines):
        if len(ln) < 3 or not np.allclose(ln[0], ln[-1]):
            continue
        area = abs(0.5 * float(np.sum(ln[:-1, 0] * ln[1:, 1] - ln[1:, 0] * ln[:-1, 1])))
        inside = Path(ln).contains_points(points) & (area < best)
        owner[inside], best[inside] = i, area
    return owner
