"""Plane geometry of the contact zone's outline lines (n, 2) in (x, s = aφ), for ``contact.rim``."""

from __future__ import annotations

import numpy as np


def unresolved_hole(line: np.ndarray, carrying: np.ndarray, rows: np.ndarray) -> bool:
    """Whether a closed outline line is a hole round at most one row, none of them carrying: (n, 2) points."""
    from matplotlib.path import Path as PolygonPath

    if len(line) < 4 or not np.allclose(line[0], line[-1]):
        return False
    polygon = PolygonPath(line)
    return not polygon.contains_points(carrying).any() and int(polygon.contains_points(rows).sum()) <= 1


def points_at(line: np.ndarray, arc: np.ndarray) -> np.ndarray:
    """Points of a polyline at the given arc lengths."""
    cum = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(line, axis=0), axis=1))])
    return np.stack([np.interp(arc, cum, line[:, 0]), np.interp(arc, cum, line[:, 1])], axis=1)


def closes_on_itself(line: np.ndarray, shell) -> bool:
    """Whether a polyline closes on itself, also across the seam φ = 0/360° of a full cylinder (a line round it)."""
    if np.allclose(line[0], line[-1]):
        return True
    tol = 1e-9 * shell.radius
    return bool(shell.full and abs(line[0, 0] - line[-1, 0]) <= tol
                and abs(abs(line[0, 1] - line[-1, 1]) - 2.0 * np.pi * shell.radius) <= tol)


def vertex_normals(line: np.ndarray, closed: bool) -> np.ndarray:
    """Unit left normals at a polyline's points: the mean of the two segments' at each inner point (the same
    whichever way round the line is traced), of the one segment at an open line's ends."""
    d = np.diff(line, axis=0)
    d = d / np.maximum(np.linalg.norm(d, axis=1), 1e-300)[:, None]
    seg_n = np.stack([-d[:, 1], d[:, 0]], axis=1)
    before = np.vstack([seg_n[-1:] if closed else seg_n[:1], seg_n])
    after = np.vstack([seg_n, seg_n[:1] if closed else seg_n[-1:]])
    n = before + after
    return n / np.maximum(np.linalg.norm(n, axis=1), 1e-300)[:, None]


def enclosed_area(lines: list[np.ndarray]) -> float | None:
    """The area inside closed level lines (shoelace, signed so that holes subtract); None if one is open."""
    total = 0.0
    for ln in lines:
        if not np.allclose(ln[0], ln[-1]):
            return None
        total += 0.5 * float(np.sum(ln[:-1, 0] * ln[1:, 1] - ln[1:, 0] * ln[:-1, 1]))
    return abs(total)


def perimeter_of(line: np.ndarray) -> float:
    return float(np.linalg.norm(np.diff(line, axis=0), axis=1).sum())


def hat_sum(at: np.ndarray, where: np.ndarray, values: np.ndarray, half: float,
             period: float | None, chunk: int = 512) -> np.ndarray:
    """Σ values · max(0, 1 − |at − where| / half) at each ``at`` (distances periodic with ``period``)."""
    out = np.zeros(len(at))
    for lo in range(0, len(at), chunk):
        d = np.abs(at[lo:lo + chunk, None] - where[None, :])
        if period is not None:
            d = np.minimum(d, period - d)
        out[lo:lo + chunk] = np.clip(1.0 - d / half, 0.0, None) @ values
    return out


def smoothed_loop(loop: np.ndarray, arc: np.ndarray, half: float) -> np.ndarray:
    """A closed polyline (first point = last) with each point moved to the mean of the line within ± half along
    it (hat weights by arc length): a staircase from row to row (a fixed punch's outline, the boundary of its
    constraint points' Voronoi cells) has a length that stays |dx| + |ds| under refinement where the curve it
    steps along is slanted; smoothed over a few steps it tends to the curve's."""
    period = float(arc[-1])
    if period <= 0.0 or half <= 0.0:
        return loop
    at, pts = arc[:-1], loop[:-1]
    ds = 0.5 * (np.diff(arc) + np.roll(np.diff(arc), 1))  # each point's share of the length
    den = hat_sum(at, at, ds, half, period)
    out = np.stack([hat_sum(at, at, ds * pts[:, c], half, period) for c in (0, 1)], axis=1) / den[:, None]
    return np.vstack([out, out[:1]])
