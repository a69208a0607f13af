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
