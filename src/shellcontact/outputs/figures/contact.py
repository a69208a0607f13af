"""The contact figures of a run: pressure.png and pressure_profiles.png (split from plots, which draws the rest).

For a Kirchhoff shell the contact force is a measure (docs/theory.md §9): line forces along the zone's rim (or a
line load), a pressure inside, point forces where a zone is a point. The figures draw what converges as what it
is — the line force as a line along the rim, coloured by its value in N/m (``contact.<k>.rim.samples``), with the
rim's mean or the line load in the title, the same numbers as summary.json, and each point force as a marker
labelled with its force — and show the nodal pressure (contact/nodal_pressure.py: uniform on a uniform load,
converging where the pressure is a function), which at a line or point force grows like 1/h: labelled so.
Several punches: one panel each, each with its own colour scales.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
from matplotlib.collections import LineCollection
from matplotlib.figure import Figure
from matplotlib.ticker import MaxNLocator

from ...units import with_unit
from ..fields import contact_vertex_fields
from .common import _contact_outline, _finish, _fmt, _levels, _map_axes, _q, _unit, _vertex_map


def _contact_box(fields: dict[str, np.ndarray], x: np.ndarray, phi: np.ndarray, hx: float, hphi: float):
    """The candidate zone, narrowed to the contact region (padded by its size or 4 cells) when smaller."""
    status = fields.get("contact_status")
    cand = status >= 0 if status is not None else np.ones(x.size, bool)
    if not np.any(cand):
        cand = np.ones(x.size, bool)
    xr, pr = [float(x[cand].min()), float(x[cand].max())], [float(phi[cand].min()), float(phi[cand].max())]
    act = status == 1 if status is not None else np.zeros(x.size, bool)
    if np.any(act):
        for r, c, h in ((xr, x[act], hx), (pr, phi[act], hphi)):
            pad = max(float(np.ptp(c)), 4.0 * h)
            r[0], r[1] = max(r[0], float(c.min()) - pad), min(r[1], float(c.max()) + pad)
    px, pp = 0.03 * (xr[1] - xr[0] or 1.0), 0.03 * (pr[1] - pr[0] or 1.0)
    return (xr[0] - px, xr[1] + px), (pr[0] - pp, pr[1] + pp)


def _punch_status(result, nv: int) -> list[np.ndarray] | None:
    """Per punch, the vertex status of its own rows (1 active, 0 candidate, −1 not its candidate), or None."""
    c = getattr(result, "contact", None)
    op = getattr(c, "operator", None)
    if op is None or getattr(c, "active", None) is None or len(op.punches) < 2:
        return None
    out = []
    for k in range(len(op.punches)):
        rows = op.rows(k)
        rows = rows[op.vertex[rows] >= 0]
        status = np.full(nv, -1)
        status[op.vertex[rows]] = 0
        status[op.vertex[rows][np.asarray(c.active, bool)[rows]]] = 1
        if op.twins is not None:
            slave, master = op.twins
            status[slave] = status[master]
        out.append(status)
    return out


def _rims(result) -> list[dict | None]:
    """Per punch, the summary's ``rim`` entry (None where a punch has none)."""
    c = getattr(result, "contact", None)
    try:
        return list(getattr(c, "rim", None) or [])
    except Exception:  # a contact object without the decomposition
        return []


def _peak_pressures(result) -> list[float]:
    """Per punch, the summary's ``peak_pressure`` (the largest of its nodal pressure), so that the title says what
    the report's table says; [] without the nodal pressure."""
    pressure = getattr(getattr(result, "contact", None), "nodal_pressure", None)
    return [] if pressure is None else [float(p.max(initial=0.0)) for p in pressure]


def _rim_headline(result, rim: dict | None) -> str:
    """The converging number of a punch's contact force, as summary.json has it."""
    if not rim:
        return ""
    points = rim.get("point_forces") or []
    if rim.get("kind") == "point":
        return ", ".join(f"point force {_q(result, pf['force'], 'force')}" for pf in points[:3])
    loads = rim.get("line_loads") or {}
    parts = [f"rim line force (mean) {_q(result, rim['mean_line_force'], 'force/length')}"] if rim.get("force") else []
    if loads.get("force"):  # the line loads apart from the area rim (rim.py), their end forces included
        ends = " with end forces" if loads.get("end_force") else ""
        parts.append(f"line load {_q(result, loads['mean_line_force'], 'force/length')}{ends}")
    return ", ".join(parts)


def _draw_line_force(ax, fig, result, rim: dict | None, lines: list[np.ndarray]) -> bool:
    """The rim's polylines coloured by the line force (N/m) of the nearest of their own samples (polyline i is
    ``per_line`` i), with its own colour bar."""
    if not rim or not rim.get("samples") or not lines:
        return False
    a = result.solution.shell.radius
    samples = rim["samples"]
    owner = np.array([s.get("line", -1) for s in samples])
    segments, values = [], []
    for i, ln in enumerate(lines):
        own = [s for s, k in zip(samples, owner) if k == i] or samples  # the line's own samples (polyline i)
        sx = np.array([s["x"] for s in own])
        ss = np.radians([s["phi"] for s in own]) * a
        q = np.array([s["line_force"] for s in own])
        ln = _densified(ln, 4 * len(own))  # a straight line load is 2 points: one segment, one colour otherwise
        pts = np.stack([ln[:, 0], np.degrees(ln[:, 1] / a)], axis=1)
        mid = 0.5 * (ln[1:] + ln[:-1])
        ds = np.abs(mid[:, 1, None] - ss[None])
        if result.solution.shell.full:  # samples' φ lie in [0, 360°): the short way round the seam
            ds = np.minimum(ds, 2.0 * math.pi * a - ds)
        nearest = np.argmin((mid[:, 0, None] - sx[None]) ** 2 + ds ** 2, axis=1)
        segments += [pts[i:i + 2] for i in range(len(pts) - 1)]
        values += list(q[nearest])
    lc = LineCollection(segments, cmap="viridis", linewidths=3.5)
    lc.set_array(np.asarray(values))
    lc.set_clim(0.0, max(float(np.max(values)), 1e-300))
    ax.add_collection(lc)
    fig.colorbar(lc, ax=ax, label=f"line force{_unit(result, 'force/length')}", ticks=MaxNLocator(6), pad=0.02)
    ax.plot([], [], "-", color=lc.cmap(0.6), lw=3.5, label="contact boundary")  # as on the other maps
    _legend(ax)
    return True


def _densified(line: np.ndarray, n: int) -> np.ndarray:
    """The polyline (k, 2) with points added along its segments so that it has at least ``n`` segments of about
    equal length (its own points kept)."""
    step = np.linalg.norm(np.diff(line, axis=0), axis=1)
    if len(line) - 1 >= n or not step.sum() > 0.0:
        return line
    parts = [np.linspace(line[i], line[i + 1], max(1, math.ceil(n * d / step.sum())) + 1)[:-1]
             for i, d in enumerate(step)]
    return np.vstack([*parts, line[-1:]])


def _draw_point_forces(ax, result, rim: dict | None) -> None:
    """Each point force (``rim.point_forces``) as a marker labelled with its force, and each line load's end
    forces (``per_line.end_forces``: a corner force of a saddle's horn) as a marker at the line's end."""
    points = (rim or {}).get("point_forces") or []
    ends = [q for line in (rim or {}).get("per_line") or [] for q in line.get("end_forces") or []]
    samples = (rim or {}).get("samples") or []
    # labels toward the zone's middle: an end force sits at the zone's corner, on the edge of the zoomed map
    centre = (np.mean([q["x"] for q in samples]), np.mean([q["phi"] for q in samples])) if samples else None
    for marks, style, colour, name in ((points, "*", "darkred", "point force"),
                                       (ends, "D", "darkorange", "line load's end force")):
        for j, pf in enumerate(marks):
            ax.plot(pf["x"], pf["phi"], marker=style, ls="", color=colour, ms=13 if style == "*" else 8, mec="k",
                    mew=0.6, clip_on=False, label=name if j == 0 else None)  # an end force sits on the map's edge
            sx, sy = ((1.0, 1.0) if centre is None else
                      (1.0 if centre[0] >= pf["x"] else -1.0, 1.0 if centre[1] >= pf["phi"] else -1.0))
            ax.annotate(_q(result, pf["force"], "force"), (pf["x"], pf["phi"]), xytext=(8 * sx, 8 * sy),
                        textcoords="offset points", fontsize=8, color=colour,
                        ha="left" if sx > 0 else "right", va="bottom" if sy > 0 else "top",
                        bbox={"boxstyle": "round,pad=0.2", "fc": "white", "ec": colour, "alpha": 0.85})
    if points or ends:
        _legend(ax)


def _legend(ax) -> None:
    """The legend below the axes, where it covers nothing (over the map it hid a saddle's horn)."""
    ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.14), ncol=3, fontsize=8, frameon=False)


def plot_pressure(result, path: str | Path | None = None) -> Figure | None:
    """The contact force per punch (None without contact): the line force along the rim (or the line load) as a
    coloured line, over the nodal pressure of the candidate zone (mesh-dependent at the rim); one panel per punch,
    each zoomed to its own zone with its own colour scales."""
    fields = contact_vertex_fields(result)
    p = fields.get("contact_pressure")
    if p is None:
        return None
    sol = result.solution
    tri = _vertex_map(result)
    x, phi = tri.x, tri.y
    p = np.asarray(p, float)
    per_punch = _punch_status(result, x.size)
    statuses = per_punch or [fields.get("contact_status")]
    rims = _rims(result)
    rim_lines = getattr(getattr(result, "contact", None), "rim_lines", None) or []
    n = len(statuses)
    fig = Figure(figsize=(7.6 if n == 1 else 6.2 * n, 4.8), layout="constrained")
    h = sol.space.mesh.h() / math.sqrt(2.0)
    for k, status in enumerate(statuses):
        ax = fig.add_subplot(1, n, k + 1)
        own = {**fields, "contact_status": status} if status is not None else fields
        mine = p[np.asarray(status) >= 0] if per_punch else p
        rim = rims[k] if k < len(rims) else None
        if not (rim and rim.get("kind") == "line"):  # a line contact has no pressure: its line load is the line
            cs = ax.tricontourf(tri, p, levels=_levels(mine if mine.size else p, 0.0), cmap="Greys")
            fig.colorbar(cs, ax=ax, label=f"nodal pressure (∝ 1/h at the rim){_unit(result, 'pressure')}",
                         ticks=MaxNLocator(6), pad=0.02)
        lines = rim_lines[k] if k < len(rim_lines) else []
        if not _draw_line_force(ax, fig, result, rim, lines) and _contact_outline(ax, result, own):
            if not (rim and rim.get("kind") == "point"):  # a point force's vertices: its marker below
                act = np.asarray(status) == 1
                ax.plot(x[act], phi[act], "c.", ms=3, label="active vertices")
            _legend(ax)
        _draw_point_forces(ax, result, rim)
        xr, pr = _contact_box(own, x, phi, h, math.degrees(h / sol.shell.radius))
        ax.set_xlim(*xr)
        ax.set_ylim(*pr)
        peaks = _peak_pressures(result)
        peak = peaks[k] if k < len(peaks) else (float(mine.max()) if mine.size else 0.0)
        who = f"punch {k}: " if per_punch else ""
        headline = _rim_headline(result, rim) or "contact pressure at the vertices"
        ax.set_title(f"{who}{headline}\npeak nodal pressure {_q(result, peak, 'pressure')} (∝ 1/h at a line force)",
                     fontsize=9)
        _map_axes(ax, result)
    return _finish(fig, path)


def pressure_lines(
    result, x: float | None = None, phi: float | None = None
) -> dict[str, tuple[np.ndarray, np.ndarray]] | None:
    """Nodal pressures along the mesh line x = x* (against φ°) and the line φ = φ* (against x),
    within the candidate zone. x* and φ* (degrees) default to the peak-pressure vertex; given
    values are moved to the nearest mesh line (pressures live at vertices)."""
    fields = contact_vertex_fields(result)
    p = fields.get("contact_pressure")
    if p is None or not np.any(np.asarray(p) > 0):
        return None
    p = np.asarray(p, float)
    sol = result.solution
    xv, s = sol.space.mesh.p
    phv = np.degrees(s / sol.shell.radius)
    i = int(np.argmax(p))
    x0 = xv[i] if x is None else xv[np.argmin(np.abs(xv - x))]
    p0 = phv[i] if phi is None else phv[np.argmin(np.abs(phv - phi))]
    tol_x = 1e-9 * max(sol.shell.length, 1.0)
    tol_p = 1e-9 * max(float(np.ptp(phv)), 1.0)
    status = fields.get("contact_status")
    zone = np.asarray(status) >= 0 if status is not None else np.ones(xv.size, bool)  # the candidate zone
    on_x = np.nonzero((np.abs(xv - x0) <= tol_x) & zone)[0]
    on_p = np.nonzero((np.abs(phv - p0) <= tol_p) & zone)[0]
    on_x, on_p = on_x[np.argsort(phv[on_x])], on_p[np.argsort(xv[on_p])]
    return {
        f"x = {_fmt(x0)}": (phv[on_x], p[on_x]),
        f"φ = {_fmt(p0)}°": (xv[on_p], p[on_p]),
    }


def _broken(c: np.ndarray, p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The profile with NaN where nothing touches between two points (both zero) or across a jump between
    candidate zones (a spacing above 3× the median): no line is drawn across a gap."""
    if len(c) < 2:
        return c, p
    step = np.diff(c)
    cut = ((p[:-1] <= 0.0) & (p[1:] <= 0.0)) | (step > 3.0 * max(float(np.median(step)), 1e-300))
    k = np.flatnonzero(cut) + 1
    return np.insert(c.astype(float), k, np.nan), np.insert(p.astype(float), k, np.nan)


def rim_line_profiles(rim: dict, radius: float, period: float | None) -> list[tuple[np.ndarray, np.ndarray]]:
    """Per boundary line of a punch's rim (the samples' ``line``): the arc length along it from its first
    sample and the line force there, closed back to the first sample where the line closes (``per_line``
    ``closed``, also round a full cylinder across its seam: ``period`` = 2π a)."""
    per_line = rim.get("per_line") or []
    groups: dict[int, list[dict]] = {}
    for q in rim["samples"]:
        groups.setdefault(int(q.get("line", 0)), []).append(q)
    out = []
    for i, samples in sorted(groups.items()):
        pts = np.array([[q["x"], radius * math.radians(q["phi"])] for q in samples])
        step = np.diff(pts, axis=0)
        closed = i < len(per_line) and per_line[i].get("closed") and len(samples) > 2
        if closed:
            step = np.vstack([step, pts[:1] - pts[-1:]])
        if period:  # a step across the seam is the short way round
            step[:, 1] = (step[:, 1] + 0.5 * period) % period - 0.5 * period
        arc = np.concatenate([[0.0], np.cumsum(np.linalg.norm(step, axis=1))])
        q = np.array([s["line_force"] for s in samples])
        if not closed and i < len(per_line) and per_line[i].get("kind") == "line":  # bin centres on the line
            arc = arc + 0.5 * max(per_line[i]["length"] - arc[-1], 0.0)
        out.append((arc, np.append(q, q[0]) if closed else q))
    return out


def plot_pressure_profiles(
    result, path: str | Path | None = None, x: float | None = None, phi: float | None = None
) -> Figure | None:
    """The line force along each punch's rim (or its line load) against the arc length, then the nodal pressure
    (mesh-dependent) along the mesh lines x = x* and φ = φ* (degrees; default through the peak), broken where
    nothing touches; None without contact pressure."""
    lines = pressure_lines(result, x, phi)
    if lines is None:
        return None
    rims = [(k, r) for k, r in enumerate(_rims(result)) if r and r.get("samples")]
    if rims and all(r.get("kind") == "line" for _, r in rims):
        lines = {}  # line contacts only: a line load has no pressure (its nodal value is a force per h)
    n = len(lines) + (1 if rims else 0)
    fig = Figure(figsize=(5.0 * n, 4), layout="constrained")
    if rims:
        ax = fig.add_subplot(1, n, 1)
        a = result.solution.shell.radius
        period = 2.0 * math.pi * a if result.solution.shell.full else None
        for k, rim in rims:
            colour = None
            for arc, q in rim_line_profiles(rim, a, period):
                line = ax.plot(arc, q, "-" if len(q) > 1 else "o", color=colour,  # one sample: a line load's mean
                               label=None if colour else f"punch {k}: {_rim_headline(result, rim)}")[0]
                colour = line.get_color()
            ax.axhline(rim["mean_line_force"], color=colour, ls="--", lw=0.8)
        ax.set_xlabel(f"along each rim or line{_unit(result, 'length')}")
        ax.set_ylabel(f"line force{_unit(result, 'force/length')}")
        ax.set_ylim(0.0, 1.15 * max(max(s["line_force"] for s in r["samples"]) for _, r in rims))
        ax.set_title("line force along the rim or line (dashed: its mean)", fontsize=10)
        ax.legend(fontsize=7)
        ax.grid(True, alpha=0.3)
    for k, (label, (c, p)) in enumerate(lines.items()):
        ax = fig.add_subplot(1, n, n - len(lines) + k + 1)
        ax.plot(*_broken(c, p), "o-", ms=3)
        ax.set_ylim(bottom=0.0)  # from zero: a rim's alternation (its triangles' pattern) read against its size
        ax.set_xlabel("φ [deg]" if label.startswith("x") else f"x{_unit(result, 'length')}")
        ax.set_ylabel(f"nodal pressure (∝ 1/h at a rim){_unit(result, 'pressure')}")
        ax.xaxis.set_major_locator(MaxNLocator(6))
        where = with_unit(label, 'length', result.case.units) if label.startswith('x') else label
        rim_note = "\non a rim: a line force per element width" if _along_a_rim(result, label) else ""
        ax.set_title(f"along {where}{rim_note}", fontsize=10)
        ax.grid(True, alpha=0.3)
    return _finish(fig, path)


def _along_a_rim(result, label: str) -> bool:
    """Whether the profile's mesh line (``pressure_lines``' label "x = …" or "φ = …°") runs along a rim: the
    samples of one of a punch's rim lines lie within half an element of it (four in five of them; a line across
    the profile has its samples spread, at most the one where it crosses near). There the nodal pressure
    is a line force over the area the line's vertices share with the zone, which alternates with the triangles'
    pattern."""
    xv, s = result.solution.space.mesh.p
    a = result.solution.shell.radius
    along_x = label.startswith("x")
    value = float(label.split("=")[1].strip().rstrip("°"))
    coords = xv if along_x else np.degrees(s / a)
    others = np.abs(coords - value)
    tol = 0.5 * float(others[others > 1e-9 * max(float(np.ptp(coords)), 1e-300)].min(initial=np.inf))
    for rim in _rims(result):
        samples = (rim or {}).get("samples") or []
        line = np.array([q.get("line", 0) for q in samples])
        near = np.abs(np.array([q["x"] if along_x else q["phi"] for q in samples]) - value) <= tol
        if any(np.mean(near[line == i]) >= 0.8 for i in np.unique(line)):
            return True
    return False
