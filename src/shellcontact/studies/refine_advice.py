"""What to refine for a headline whose estimated error is above the warning level (``accuracy`` warning).

The estimate compares uniform refinements, so it says how large an error is, not which mesh key removes it.
What it can say is where the error comes from (the headline's place: a contact zone, a stress maximum's or a
probe's point) and what the mesh is like there. From those, per headline, one advice:

* a stress maximum under a point load: no mesh helps. A Kirchhoff shell's bending stress under a point force
  grows like log(1/h) (MODEL.md §2: the Green's function's curvatures are logarithmic), so it is read away
  from the load (a probe);
* a place within ``NEAR`` local element sizes of a clamped edge: grade toward that edge (``mesh.grading``,
  the edge's coordinate as a focus): the boundary layer of width ~ sqrt(R t) lives there;
* a contact zone or any other place: the direction with ``ANISOTROPY`` × fewer elements across the zone, or
  at a point ``ANISOTROPY`` × larger elements, than the other (``mesh.nx`` or ``mesh.nphi``); a grading focus
  there (a zone's edges, where its rim's line force sits) when the mesh grades toward nothing there; and
  always uniform refinement (``mesh.refine``, 4× the unknowns) as the sure way.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np

from ..units import with_unit

NEAR = 2.0  # a place this many local element sizes from an edge or a point load is "at" it
ANISOTROPY = 2.0  # elements across a place: one direction this many times fewer is the one to refine


def _local_sizes(mesh, x0: float, x1: float, s0: float, s1: float) -> tuple[float, float]:
    """Median element extents (along x, along s) of the triangles whose centroids lie in the box, or of the
    triangle nearest to its centre when none does."""
    p, t = mesh.p, mesh.t
    cx, cs = p[0, t].mean(axis=0), p[1, t].mean(axis=0)
    hx = p[0, t].max(axis=0) - p[0, t].min(axis=0)
    hs = p[1, t].max(axis=0) - p[1, t].min(axis=0)
    inside = (cx >= x0) & (cx <= x1) & (cs >= s0) & (cs <= s1)
    if not inside.any():
        inside = np.zeros_like(inside)
        inside[np.argmin((cx - 0.5 * (x0 + x1)) ** 2 + (cs - 0.5 * (s0 + s1)) ** 2)] = True
    return float(np.median(hx[inside])), float(np.median(hs[inside]))


def _get(data: Any, *keys: str) -> Any:
    """``data[k0][k1]...`` with list indices given as strings, or None."""
    for k in keys:
        if isinstance(data, Mapping):
            data = data.get(k)
        elif isinstance(data, list) and k.isdigit() and int(k) < len(data):
            data = data[int(k)]
        else:
            return None
    return data


def _length(x: float, summary: Mapping[str, Any]) -> str:
    """``x`` with the length unit of the summary's unit system."""
    return with_unit(f"{x:.4g}", "length", summary.get("unit_system", "SI"))


def _place(summary: Mapping[str, Any], path: str) -> tuple[str, tuple[float, float, float, float] | None]:
    """(the place in words, its box (x0, x1, φ0, φ1 in degrees) or None) of headline ``path``."""
    parts = path.split(".")
    if parts[0] == "contact":
        zone = _get(summary, "contact", parts[1], "zone") or {}
        x, phi = zone.get("x"), zone.get("phi")
        if isinstance(x, list) and isinstance(phi, list) and len(x) == 2 and len(phi) == 2:
            return (f"punch {parts[1]}'s contact zone, x {x[0]:.4g} to {_length(x[1], summary)}, phi {phi[0]:.4g} to "
                    f"{phi[1]:.4g} deg", (x[0], x[1], phi[0], phi[1]))
        return f"punch {parts[1]}'s contact zone", None
    at = None
    if parts[0] == "stresses":
        at = _get(summary, "stresses", parts[1], "at")
    elif parts[0] == "probes":
        at = _get(summary, "probes", parts[1])
    if isinstance(at, Mapping) and isinstance(at.get("x"), (int, float)) and isinstance(at.get("phi"), (int, float)):
        x, phi = float(at["x"]), float(at["phi"])
        return f"at x = {_length(x, summary)}, phi = {phi:.4g} deg", (x, x, phi, phi)
    return "", None


def _clamped_edge(case, x0: float, x1: float, s0: float, s1: float, hx: float, hs: float) -> str | None:
    """The grading that focuses on a clamped edge within ``NEAR`` element sizes of the box, or None."""
    sh, sup, spec = case.shell, case.supports, case.mesh
    edges = (("x_min", "x", "nx", sh.x_min, x0 - sh.x_min <= NEAR * hx, spec.grading_x, sh.x_min),
             ("x_max", "x", "nx", sh.x_max, sh.x_max - x1 <= NEAR * hx, spec.grading_x, sh.x_max),
             ("phi_min", "phi", "nphi", math.degrees(sh.alpha), s0 - sh.s_min <= NEAR * hs, spec.grading_phi, sh.alpha),
             ("phi_max", "phi", "nphi", math.degrees(sh.beta), sh.s_max - s1 <= NEAR * hs, spec.grading_phi, sh.beta))
    for edge, coord, count, shown, near, foci, value in edges:
        if getattr(sup, edge) != "clamped" or not near or (coord == "phi" and sh.full):
            continue
        if spec.grading_ratio > 1.0 and any(abs(g - value) <= 1e-9 * max(1.0, abs(value)) for g in foci):
            return (f"mesh.{count} or a larger mesh.grading ratio (the boundary layer at the clamped edge {edge}, "
                    f"already a grading focus, needs more elements)")
        return f"mesh.grading {coord} = [{shown:.4g}] (the boundary layer at the clamped edge {edge})"
    return None


def _point_load(case, x0: float, x1: float, s0: float, s1: float, hx: float, hs: float) -> bool:
    a = case.shell.radius
    return any(x0 - NEAR * hx <= p.x <= x1 + NEAR * hx and s0 - NEAR * hs <= a * p.phi <= s1 + NEAR * hs
               for p in case.loads.points)


def _graded_there(spec, x0: float, x1: float, s0: float, s1: float, hx: float, hs: float, radius: float) -> bool:
    """The mesh already grades toward the box (a focus within ``NEAR`` element sizes of it, in x and in φ)."""
    if spec.grading_ratio <= 1.0:
        return False
    near_x = not spec.grading_x or any(x0 - NEAR * hx <= g <= x1 + NEAR * hx for g in spec.grading_x)
    near_s = not spec.grading_phi or any(s0 - NEAR * hs <= radius * g <= s1 + NEAR * hs for g in spec.grading_phi)
    return near_x and near_s


def advice(result, summary: Mapping[str, Any], path: str) -> str:
    """' (where): refine: what' for headline ``path`` of ``result`` (its ``summary``), as the warning says it."""
    case = result.case
    place, box = _place(summary, path)
    uniform = f"mesh.refine = {case.mesh.refine + 1} (uniform, 4x the unknowns)"
    if box is None or case.mesh.file:
        return (f" ({place})" if place else "") + f": refine {uniform}"
    a = case.shell.radius
    x0, x1, s0, s1 = box[0], box[1], a * math.radians(box[2]), a * math.radians(box[3])
    mesh = result.solution.space.mesh
    hx, hs = _local_sizes(mesh, x0, x1, s0, s1)
    if path.startswith("stresses.") and _point_load(case, x0, x1, s0, s1, hx, hs):
        return (f" ({place}, under a point load): no mesh makes it converge, a Kirchhoff shell's bending stress "
                "under a point force grows like log(1/h): read the stress away from the load (a probe)")
    clamped = _clamped_edge(case, x0, x1, s0, s1, hx, hs)
    if x1 > x0 and s1 > s0:  # a zone: the direction with fewer elements across it
        fewer_x, fewer_s = (x1 - x0) / hx, (s1 - s0) / hs
        counted = f"{fewer_x:.3g} elements across it along x, {fewer_s:.3g} along phi"
    else:  # a point: the direction with the larger elements
        fewer_x, fewer_s = hs, hx
        counted = f"elements {hx:.3g} m along x by {hs:.3g} m along s there"
    keys = [clamped] if clamped else []
    if clamped and clamped.startswith("mesh.n"):  # it names the count already
        pass
    elif fewer_x * ANISOTROPY <= fewer_s:
        keys.append(f"mesh.nx ({counted})")
    elif fewer_s * ANISOTROPY <= fewer_x:
        keys.append(f"mesh.nphi ({counted})")
    if not clamped and not _graded_there(case.mesh, x0, x1, s0, s1, hx, hs, a):
        foci = (f"x = [{x0:.4g}, {x1:.4g}], phi = [{box[2]:.4g}, {box[3]:.4g}] (its edges)" if x1 > x0 else
                f"x = [{x0:.4g}], phi = [{box[2]:.4g}] (a focus there)")
        keys.append(f"mesh.grading {foci}")
    keys.append(uniform)
    return f" ({place}): refine " + ", or ".join(keys)
