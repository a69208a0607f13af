"""A line load's end forces: the point forces at the ends of a line load belong to it (``contact.rim``).

A Kirchhoff–Love shell pressed along the edge of a rigid body (a saddle's horn) carries, where that edge ends at
a corner of the body, a concentrated corner force, as a Kirchhoff plate's corner reaction 2 M_xy: physical and
finite under refinement (docs/theory.md §9). A mesh fine enough to resolve it (a saddle 8 elements across)
shows it as a carrying point in a loop of its own at the corner, a row or two apart from the rest of the horn,
which ``point_forces`` finds as a point force. The horn's force is its line load plus its two corner forces
(7 824, 8 007, 8 008 N at 2, 4, 8 elements across, docs/outputs.md): so a point force on a line load's
extension, within ``END_REACH`` element widths past its end, is that line's end force. It counts in the line's
``force`` and in ``line_loads.force``, and no longer as a point force; the line's ``length`` reaches to it, so
that the line's ``mean_line_force`` (force with its ends over the length between them) is the horn's.
"""

from __future__ import annotations

import numpy as np

from ..shell.spaces import ShellSpace
from .zone_points import width_along

END_REACH = 3.0  # element widths (along the line) past a line's end: measured 2.0 and 2.5 at a saddle's corners
ACROSS = 0.5  # element widths (across the line) from the line's extension


def attach_end_forces(space: ShellSpace, entry: dict, polylines: list[np.ndarray]) -> None:
    """Move the point forces at a line load's ends (module docstring) into that line, in ``entry`` (one punch's
    decomposition, ``rim.rim_line_force``; ``polylines`` its rim polylines, one per ``per_line`` entry): each
    line gets ``end_forces`` [{force (N), x (m), phi (degrees)}], ``line_loads`` its ``end_force`` (N, their
    sum). The total is unchanged: area rim + line loads (with their ends) + interior + point forces."""
    sh = space.mesh.shell
    a = sh.radius
    period = 2.0 * np.pi * a if sh.full else None
    entry["point_force"] = sum(q["force"] for q in entry.get("point_forces", []))
    lines = [i for i, pl in enumerate(entry["per_line"]) if pl["kind"] == "line"]
    past = {i: [0.0, 0.0] for i in lines}  # how far the line reaches past its first and its last point
    kept = []
    for i in lines:
        entry["per_line"][i]["end_forces"] = []
    for q in entry.get("point_forces", []):
        found = _line_end(space, q, [(i, polylines[i]) for i in lines], a, period)
        if found is None:
            kept.append(q)
            continue
        i, t, length = found
        line = entry["per_line"][i]
        line["end_forces"].append({"force": q["force"], "x": q["x"], "phi": q["phi"]})
        line["force"] += q["force"]
        past[i] = [max(past[i][0], -t), max(past[i][1], t - length)]
    entry["line_loads"]["end_force"] = 0.0
    if len(kept) == len(entry.get("point_forces", [])):
        return
    for i in lines:
        line = entry["per_line"][i]
        line["length"] += sum(past[i])
        line["mean_line_force"] = line["force"] / line["length"] if line["length"] > 0 else 0.0
    loads = entry["line_loads"]
    loads["force"] = sum(entry["per_line"][i]["force"] for i in lines)
    loads["length"] = sum(entry["per_line"][i]["length"] for i in lines)
    loads["mean_line_force"] = loads["force"] / loads["length"] if loads["length"] > 0 else 0.0
    loads["end_force"] = sum(q["force"] for i in lines for q in entry["per_line"][i]["end_forces"])
    entry["point_forces"] = kept
    entry["point_force"] = sum(q["force"] for q in kept)


def _line_end(space: ShellSpace, q: dict, lines: list[tuple[int, np.ndarray]], a: float,
              period: float | None) -> tuple[int, float, float] | None:
    """The line (index) whose end the point force ``q`` is at, its position along that line (m from the line's
    first point; < 0 or > the line's length) and the line's length, or None."""
    best = None
    for i, pl in lines:
        p0, p1 = pl[0], pl[-1]
        length = float(np.linalg.norm(p1 - p0))
        if length <= 0.0:
            continue
        e = (p1 - p0) / length
        d = np.array([q["x"], a * np.radians(q["phi"])]) - p0
        if period:  # the nearest image across a closed cylinder's seam
            d[1] -= period * round(d[1] / period)
        t, off = float(d @ e), abs(float(d @ np.array([-e[1], e[0]])))
        past = max(-t, t - length)
        if past < 0.0:  # beside the line, not past its end
            continue
        end = (p0 if t < 0.0 else p1)[None, :]  # the line's elements there (not those past the body's corner)
        along = float(width_along(space, end, e[None, :])[0])
        across = float(width_along(space, end, np.array([[-e[1], e[0]]]))[0])
        if past <= END_REACH * along and off <= ACROSS * across and (best is None or past < best[0]):
            best = (past, i, t, length)
    return None if best is None else best[1:]
