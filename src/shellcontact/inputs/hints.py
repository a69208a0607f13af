"""Hints for input mistakes that the case parser recognises before anything is built (the case imports this;
it imports nothing of the package): ``shell.angle`` given in radians."""

from __future__ import annotations

import math
from collections.abc import Iterable

TWO_PI = 6.2832  # 2π rounded up: an angle span up to 2π "degrees" may be radians


def angle_unit_error(alpha_deg: float, beta_deg: float, points: Iterable[tuple[str, tuple[float, ...]]]) -> str:
    """The message for ``shell.angle`` given in radians: a span of at most 2π "degrees" with a point (``(name,
    (x, y, z))``: a punch centre, a probe) outside it whose direction does lie between the same numbers read as
    radians (``[1.047, 2.094]`` for [60, 120] deg with the punch above the crown). "" when nothing suggests it."""
    if not (-TWO_PI <= alpha_deg < beta_deg <= TWO_PI):
        return ""
    lo, hi = math.degrees(alpha_deg), math.degrees(beta_deg)
    for name, c in points:
        if len(c) != 3 or math.hypot(c[1], c[2]) == 0.0:
            continue
        at = math.degrees(math.atan2(c[2], c[1]))
        inside = [a for a in (at, at + 360.0, at - 360.0) if lo <= a <= hi]
        if inside and not alpha_deg - 1.0 <= inside[0] <= beta_deg + 1.0:
            return (f"[{alpha_deg:g}, {beta_deg:g}] deg spans {beta_deg - alpha_deg:.3g} deg while {name} "
                    f"is at phi = {inside[0]:.4g} deg: these look like radians; shell.angle is in degrees, "
                    f"write [{lo:.6g}, {hi:.6g}]")
    return ""
