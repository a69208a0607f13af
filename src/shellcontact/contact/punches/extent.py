"""The extent of a punch of finite size: a box and half-spaces that limit its shape (MODEL.md §5).

A punch is a rigid body. Its shape (``shapes``) is an infinite or closed surface {Z = 0}; the
``extent`` keeps the part of it inside a box and on the inner side of some planes, e.g. a cradle
200 mm long (``x = [-0.1, 0.1]``) whose horns stop at a height (``z = [-0.2, -0.07]``), a plate of
finite width, a roller of finite length, a sleeve shorter than the pipe.

Coordinates are global, those of the shape keys (``center``, ``axis``) at the punch's given
position; the extent moves with the punch when it is placed (``indentation``, ``force``).

Where the body is (the rule behind ``Punch.on_body``): a point M of the shell's contact surface is
opposite the body when its foot F = M − Z ∇Z/|∇Z|² (the nearest point of the shape's surface for a
signed distance, to first order otherwise) lies in the extent. ``Extent.distance`` is
max(lo − F, F − hi, (F − p)·n) over the box faces and half-spaces: ≤ 0 in the extent, > 0 outside,
continuous (not the Euclidean distance beyond an edge of the box, but of the same sign).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from ...errors import InputError
from ...inputs.schema import Key, Table

AXES = ("x", "y", "z")

HALF_SPACE = Table("half_spaces", (
    Key("point", "vector", "a point of the bounding plane", unit="length"),
    Key("normal", "vector", "its normal, pointing **out of** the body (the body keeps (X − point)·normal ≤ 0)",
        allowed="nonzero"),
))

EXTENT = Table("extent", (
    *(Key(axis, "pair", f"the body's range [{axis}0, {axis}1] in global {axis}", unit="length", default=None,
          default_doc="unbounded", allowed=f"finite, {axis}0 < {axis}1") for axis in AXES),
    Key("half_spaces", "tables", "planes that cut the body: `[{ point = [..], normal = [..] }, ...]`",
        table=HALF_SPACE, default=()),
))


@dataclass(frozen=True)
class Extent:
    """Box [lower, upper] (±inf where unbounded) ∩ half-spaces {(X − p_k)·n_k ≤ 0}, shape coordinates."""

    lower: np.ndarray  # (3,)
    upper: np.ndarray  # (3,)
    points: np.ndarray  # (k, 3)
    normals: np.ndarray  # (k, 3), unit

    def distance(self, X: np.ndarray) -> np.ndarray:
        """max over faces of the signed distance of the points X (3, n) to each face plane: ≤ 0 inside."""
        X = np.asarray(X, float).reshape(3, -1)
        d = np.full(X.shape[1], -np.inf)
        for k in range(3):
            if math.isfinite(self.lower[k]):
                d = np.maximum(d, self.lower[k] - X[k])
            if math.isfinite(self.upper[k]):
                d = np.maximum(d, X[k] - self.upper[k])
        for p, n in zip(self.points, self.normals, strict=True):
            d = np.maximum(d, n @ (X - p[:, None]))
        return d

    def describe(self) -> str:
        parts = [f"{a} in [{self.lower[k]:.6g}, {self.upper[k]:.6g}]" for k, a in enumerate(AXES)
                 if math.isfinite(self.lower[k])]
        parts += [f"(X - {np.round(p, 9).tolist()}).{np.round(n, 9).tolist()} <= 0"
                  for p, n in zip(self.points, self.normals, strict=True)]
        return ", ".join(parts)


def parse_extent(values: dict[str, Any] | None, where: str) -> Extent | None:
    """The extent of the validated ``extent`` table (None: unbounded); errors name ``<where>.<key>``."""
    if values is None:
        return None
    lower, upper = np.full(3, -np.inf), np.full(3, np.inf)
    for k, axis in enumerate(AXES):
        pair = values[axis]
        if pair is None:
            continue
        if not pair[0] < pair[1]:
            raise InputError(f"{where}.{axis}", f"needs {axis}0 < {axis}1, got [{pair[0]:g}, {pair[1]:g}]")
        lower[k], upper[k] = pair
    points, normals = [], []
    for i, h in enumerate(values["half_spaces"]):
        n = np.asarray(h["normal"], float)
        biggest = float(np.max(np.abs(n)))
        if not biggest > 0.0:
            raise InputError(f"{where}.half_spaces.{i}.normal", f"must be a nonzero vector, got {n.tolist()}")
        n = n / biggest  # first: |n| of [1e308, 1e308, 0] overflows
        points.append(np.asarray(h["point"], float))
        normals.append(n / np.linalg.norm(n))
    if not points and not np.any(np.isfinite(lower)):
        return None
    extent = Extent(lower, upper, np.reshape(points, (-1, 3)), np.reshape(normals, (-1, 3)))
    _check_not_empty(extent, where)
    return extent


def _check_not_empty(extent: Extent, where: str) -> None:
    """Refuse an extent without interior: the largest ball inside it (an LP) must have a positive radius."""
    from scipy.optimize import linprog

    rows, rhs = [], []
    for k in range(3):
        e = np.eye(3)[k]
        if math.isfinite(extent.lower[k]):
            rows.append(-e)
            rhs.append(-extent.lower[k])
        if math.isfinite(extent.upper[k]):
            rows.append(e)
            rhs.append(extent.upper[k])
    for p, n in zip(extent.points, extent.normals, strict=True):
        rows.append(n)
        rhs.append(float(n @ p))
    A = np.array(rows)
    scale = max(1.0, float(np.max(np.abs(rhs))))
    # in units of the largest coordinate: maximise r subject to a_i·X + r ≤ b_i (|a_i| = 1), 0 ≤ r ≤ 1
    res = linprog(c=[0.0, 0.0, 0.0, -1.0], A_ub=np.hstack([A, np.ones((len(rows), 1))]), b_ub=np.array(rhs) / scale,
                  bounds=[(None, None)] * 3 + [(0.0, 1.0)], method="highs")
    if res.status != 0 or -res.fun <= 1e-12:
        raise InputError(where, f"is empty: no point lies inside {extent.describe()}")
