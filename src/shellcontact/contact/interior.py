"""The interior of a contact zone: the pressure where the shell carries, and the line forces where that ends.

The zone (``contact.contact_zone``) is where the gap is below a tolerance; the contact set, where the shell
actually carries, can be smaller inside it. A sleeve shrunk onto a cylinder carries a uniform pressure on a band
that ends at x_t with a ring force, then lifts off by less than the tolerance up to its edge, which carries
another ring (tests/oracles/axisym.py, ``sleeve_free_boundary``). For a Kirchhoff shell the measure inside the
rim is then a pressure on the contact set's interior and line forces along its edges, and a mean over the
zone's interior area (``mean_interior_pressure``) mixes the two with the area that lifts off. So, of the carrying
rows inside the rim (not on the rim's band, a line load or a point force):

- ``edge``: those within ``EDGE`` element widths of a row that carries nothing (Λᵢ = 0): where the contact set
  ends inside the zone, which carries a line force (the sleeve's ring at x_t); their force is
  ``interior_edge_force``. A faint contact that the mesh does not resolve (scattered carrying rows) is all edge.
- the others: the contact set's interior; ``interior_pressure`` = Σ Λᵢ|∇Zᵢ| / Σ ωᵢ over them (a mean over the
  area that carries, ``carrying_area`` = Σ ωᵢ: the weights of the vertex and edge-midpoint rows differ, so a
  uniform pressure gives nodal Λᵢ/ωᵢ alternating by ±7 %, and their ratio of sums is the pressure) and
  ``peak_interior_pressure`` the largest of Σ f / Σ ω over a disc of two element widths round each of them.

The edge band holds the pressure over a width of O(h), which vanishes under refinement (as the rim's band does).
``interior_resolved`` is False when the edges hold more than half of the carrying rows' area (``RESOLVED``): the
carrying rows inside are scattered, a faint contact the mesh does not resolve (the paper's panel: the shell
grazes the sphere inside the rim, lifting off by 2.5e-7, 7e-8, 8e-9 m at refine 0, 1, 2 between rows that
carry), and ``interior_pressure`` then depends on the mesh; it is reported, with that flag, not as a headline.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

EDGE = 1.5  # a carrying row within this many element widths of a row carrying nothing is on the set's edge
RESOLVED = 0.5  # the contact set inside is resolved when at least this share of its rows' area is not on its edges
PEAK_WINDOW = 2.0  # the peak pressure: means over discs of this many element widths


def interior_split(pts: np.ndarray, force: np.ndarray, weight: np.ndarray, width: np.ndarray,
                   idle: np.ndarray, width_along: Callable[[np.ndarray, np.ndarray], np.ndarray]) -> dict:
    """``pts`` (n, 2) in (x, s = aφ), ``force`` (N), ``weight`` ωᵢ (m²) and ``width`` (m, the elements' largest
    there) of the interior's carrying rows; ``idle`` (k, 2): the rows that carry nothing; ``width_along(pts,
    unit directions)``: the elements' widths at points along directions (the edge is measured toward the
    nearest idle row: on elements long in one direction, across their short side). Returns
    ``interior_pressure`` (Pa), ``peak_interior_pressure`` (Pa), ``carrying_area`` (m²) and
    ``interior_edge_force`` (N) (module docstring)."""
    from scipy.spatial import cKDTree

    out = {"interior_pressure": 0.0, "peak_interior_pressure": 0.0, "carrying_area": 0.0,
           "interior_edge_force": 0.0, "interior_resolved": True}
    if len(pts) == 0:
        return out
    edge = np.zeros(len(pts), bool)
    if len(idle):
        near, k = cKDTree(idle).query(pts)
        toward = (idle[k] - pts) / np.maximum(near, 1e-300)[:, None]
        edge = near <= EDGE * width_along(pts, toward)
    out["interior_edge_force"] = float(force[edge].sum())
    deep = ~edge
    area = float(weight[deep].sum())
    out["interior_resolved"] = bool(area >= RESOLVED * float(weight.sum()))
    if not area > 0.0:
        return out
    p, f, w, h = pts[deep], force[deep], weight[deep], width[deep]
    out["carrying_area"] = area
    out["interior_pressure"] = float(f.sum()) / area
    sums = [(float(f[nb].sum()), float(w[nb].sum())) for nb in cKDTree(p).query_ball_point(p, PEAK_WINDOW * h)]
    out["peak_interior_pressure"] = max((a / b for a, b in sums if b > 0.0), default=0.0)
    return out
