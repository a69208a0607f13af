"""Figures (matplotlib, no display needed): deflection map, deformed 3D shell, contact pressure.

Every ``plot_*`` function takes a ``Result`` (or study rows), returns a
``matplotlib.figure.Figure`` (or ``None`` when the data it needs is absent, e.g. no contact) and,
given ``path``, also writes a PNG atomically. Figures are built without pyplot, so they work
headless and never touch the user's backend. Maps are drawn over (x, φ in degrees).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.figure import Figure
from matplotlib.ticker import MaxNLocator
from matplotlib.tri import Triangulation

from ..fields import contact_vertex_fields, vertex_fields
from .common import (  # noqa: F401 — save_png, png_bytes, DPI public here too
    DPI,
    _contact_outline,
    _finish,
    _fmt,
    _levels,
    _map_axes,
    _q,
    _unit,
    _vertex_map,
    png_bytes,
    save_png,
)
from ...units import bracket


# -- helpers ------------------------------------------------------------------------------------------
def evaluation_grid(result, quantity: str = "w", max_points: int = 30000) -> tuple[Triangulation, np.ndarray]:
    """``quantity`` on the vertices of a uniformly refined copy of the mesh (at most ~max_points),
    evaluated with the finite-element basis (not linear interpolation), over (x, φ°)."""
    sol = result.solution
    r = _refined(result, max_points)
    x, s = r.p
    vals = sol.evaluate(x, s / sol.shell.radius, (quantity,))[quantity]
    return Triangulation(x, np.degrees(s / sol.shell.radius), r.t.T), vals


def exaggeration(result, fraction: float = 0.1) -> float:
    """A round factor that makes the largest displacement ``fraction`` of min(radius, length)."""
    sol = result.solution
    x, s = sol.space.mesh.p
    dmax = float(np.max(np.linalg.norm(sol.displacement(x, s / sol.shell.radius), axis=0)))
    if not np.isfinite(dmax) or dmax <= 0:
        return 1.0
    raw = fraction * min(sol.shell.radius, sol.shell.length) / dmax
    e = 10.0 ** math.floor(math.log10(raw))
    return max(m * e for m in (1, 2, 5, 10) if m * e <= raw * (1 + 1e-12)) if raw >= 1 else 1.0


def _probes(ax, result) -> None:
    pr = getattr(result.case, "probes", [])
    if pr:
        pts = np.array(pr, float)
        ax.plot(pts[:, 0], np.degrees(pts[:, 1]), "k+", ms=9, mew=1.5, label="probes")


















# -- run figures -----------------------------------------------------------------------------------------
def plot_deflection(result, path: str | Path | None = None) -> Figure:
    """Map of the deflection w (outward positive) over (x, φ°), with the probes and the contact boundary."""
    tri, w = evaluation_grid(result, "w")
    fig = Figure(figsize=(6.4, 4.6))
    ax = fig.add_subplot()
    levels = _levels(w)
    cs = ax.tricontourf(tri, w, levels=levels, cmap="viridis")
    fig.colorbar(cs, ax=ax, label=f"w, outward positive{_unit(result, 'length')}", ticks=MaxNLocator(8))
    _probes(ax, result)
    if _contact_outline(ax, result) or getattr(result.case, "probes", None):
        ax.legend(loc="upper right", fontsize=8)
    i = int(np.argmax(np.abs(w)))
    ax.set_title(f"deflection w: max |w| = {_q(result, abs(w[i]), 'length')} at x = {_q(result, tri.x[i], 'length')}, "
                 f"φ = {_fmt(tri.y[i])}°", fontsize=10)
    _map_axes(ax, result)
    return _finish(fig, path)


def plot_von_mises(result, path: str | Path | None = None, fields: dict[str, np.ndarray] | None = None) -> Figure:
    """Map of the von Mises stress on the worse surface (the one with the largest value) over (x, φ°), its
    maximum marked, the contact boundary and, with ``[material] yield_stress``, the yield contour."""
    from ..results import SAMPLING_POINTS

    fields = vertex_fields(result) if fields is None else fields
    extremes = result.stresses  # the maximum over the same refined copy as the map: one value (summary.json)
    surface = max(("bottom", "middle", "top"), key=lambda k: extremes[k]["von_mises_max"])
    vm = np.asarray(fields[f"von_mises_{surface}"], float)
    # the map from the finite-element fields on a refined copy of the mesh (vertex values alone draw blocks)
    sol = result.solution
    fine = _refined(result, SAMPLING_POINTS)
    xf, phf, values = sol.sampled  # the fields at fine's vertices, evaluated once (also for summary's maxima)
    vm_fine = sol.surface(xf, phf, surface, values=values).von_mises
    tri_fine = Triangulation(xf, np.degrees(phf), fine.t.T)
    fig = Figure(figsize=(6.4, 4.6))
    ax = fig.add_subplot()
    cs = ax.tricontourf(tri_fine, vm_fine, levels=_levels(np.concatenate([vm_fine, vm])), cmap="plasma")
    fig.colorbar(cs, ax=ax, label=f"von Mises stress, {surface} surface{_unit(result, 'pressure')}",
                 ticks=MaxNLocator(8))
    top, at = extremes[surface]["von_mises_max"], extremes[surface]["at"]
    ax.plot(at["x"], at["phi"], "wx", ms=9, mew=2, label="maximum")
    fy = getattr(result.case, "yield_stress", None)
    if fy is not None and vm.min() < fy < vm.max():
        ax.tricontour(tri_fine, vm_fine, levels=[fy], colors="w", linestyles="--", linewidths=1.2)
        ax.plot([], [], "w--", label="yield stress")
    _contact_outline(ax, result, fields)
    legend = ax.legend(loc="upper right", fontsize=8, facecolor="0.5", framealpha=0.6)
    for text in legend.get_texts():
        text.set_color("w")
    util = f", utilisation {_fmt(top / fy)}" if fy else ""
    ax.set_title(f"von Mises stress ({surface} surface): max {_q(result, top, 'pressure')}{util}\n"
                 f"at x = {_q(result, at['x'], 'length')}, φ = {_fmt(at['phi'])}°", fontsize=10)
    _map_axes(ax, result)
    return _finish(fig, path)


def _surface(ax, pts: np.ndarray, t: np.ndarray, values: np.ndarray, cmap: str, label: str, fig: Figure,
             length: str = "", limits: tuple[float, float] | None = None, blank_zero: bool = False) -> None:
    from matplotlib import cm, colors
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection

    face = values[t].mean(axis=1)
    lo, hi = (float(np.min(face)), float(np.max(face))) if limits is None else limits
    norm = colors.Normalize(lo, hi if hi > lo else lo + 1.0)
    mapper = cm.ScalarMappable(norm=norm, cmap=cmap)
    rgba = mapper.to_rgba(face)
    if blank_zero:  # off contact: light grey, so that the shell stays visible around the coloured patch
        rgba[face <= 0.0] = (0.85, 0.85, 0.85, 1.0)
    poly = Poly3DCollection(pts[t], facecolors=rgba, edgecolors=rgba, linewidths=0.3)  # edges hide seams
    ax.add_collection3d(poly)
    lo3, hi3 = pts.min(axis=0), pts.max(axis=0)
    span = np.maximum(hi3 - lo3, 0.05 * float(np.max(hi3 - lo3)))  # true proportions, no flat axis
    ctr = 0.5 * (lo3 + hi3)
    for k, setter in enumerate((ax.set_xlim, ax.set_ylim, ax.set_zlim)):
        setter(ctr[k] - 0.5 * span[k], ctr[k] + 0.5 * span[k])
    ax.set_box_aspect(tuple(span / span.max()))
    for axis, k in ((ax.xaxis, 0), (ax.yaxis, 1), (ax.zaxis, 2)):
        axis.set_major_locator(MaxNLocator(max(2, int(4 * span[k] / span.max()))))
    ax.tick_params(labelsize=8, pad=1)
    for setter, name, k in ((ax.set_xlabel, "X", 0), (ax.set_ylabel, "Y", 1), (ax.set_zlabel, "Z", 2)):
        setter(f"{name}{length}", labelpad=4 + 10 * span[k] / span.max())  # clear of the tick labels
    fig.colorbar(mapper, ax=ax, shrink=0.6, pad=0.22, label=label)  # clear of the Z label


def _refined(result, max_points: int):
    """A uniformly refined copy of the mesh with at most ~max_points vertices (level ≤ 3)."""
    from ..results import sampling_mesh

    return sampling_mesh(result.solution.space.mesh.mesh, max_points)


def plot_deformed(result, path: str | Path | None = None, scale: float | None = None) -> Figure:
    """3D view of the deformed middle surface coloured by w (and by contact pressure when present);
    displacements are multiplied by ``scale`` (default: ``exaggeration(result)``), shown in the title.
    The surface is drawn on a refined copy of the mesh with the finite-element fields (so coarse
    meshes still look curved); the dashed lines are the undeformed edges."""
    sol = result.solution
    sh = sol.shell
    scale = exaggeration(result) if scale is None else float(scale)
    r = _refined(result, 6000)
    x, s = r.p
    phi = s / sh.radius
    pts = (sh.point(x, phi) + scale * sol.displacement(x, phi)).T
    t = r.t.T
    w = sol.evaluate(x, phi, ("w",))["w"]
    _, w_map = evaluation_grid(result, "w")  # the colour scale of deflection.png: one scale per quantity
    panels = [("w", w, "viridis", f"w{_unit(result, 'length')}", (float(w_map.min()), float(w_map.max())))]
    pressure = contact_vertex_fields(result).get("contact_pressure")
    # a contact patch on under a tenth of the vertices is a speck on the 3D view: pressure.png shows it
    if pressure is not None and np.mean(np.asarray(pressure) > 0.0) >= 0.1:
        from matplotlib.tri import LinearTriInterpolator

        mx, ms = sol.space.mesh.p
        interp = LinearTriInterpolator(Triangulation(mx, ms, sol.space.mesh.t.T), np.asarray(pressure, float))
        panels.append(("contact pressure", np.ma.filled(interp(x, s), 0.0), "inferno",
                       f"contact pressure{_unit(result, 'pressure')}", (0.0, float(np.max(pressure)))))
    n = 60
    lines = [
        (np.full(n, sh.x_min), np.linspace(sh.alpha, sh.beta, n)),
        (np.full(n, sh.x_max), np.linspace(sh.alpha, sh.beta, n)),
        (np.linspace(sh.x_min, sh.x_max, n), np.full(n, sh.alpha)),
        (np.linspace(sh.x_min, sh.x_max, n), np.full(n, sh.beta)),
    ]
    fig = Figure(figsize=(6.0 * len(panels), 5.2))
    for k, (label, vals, cmap, bar, limits) in enumerate(panels):
        ax = fig.add_subplot(1, len(panels), k + 1, projection="3d")
        _surface(ax, pts, t, np.asarray(vals, float), cmap, bar, fig, _unit(result, "length"), limits,
                 blank_zero=label == "contact pressure")
        for lx, lp in lines:  # the undeformed boundary, for reference
            ax.plot(*sh.point(lx, lp), color="0.4", lw=0.8, ls="--")
        ax.view_init(elev=25, azim=-60)
        ax.set_title(f"deformed shell coloured by {label}\ndisplacements × {scale:g}")
    return _finish(fig, path)


def plot_sections(result, path: str | Path | None = None, scale: float | None = None) -> Figure:
    """Two sections through the point of largest |w| (under the punch, with contact): the ring at that x,
    undeformed and deformed (displacements × ``scale``, default ``exaggeration(result)``: the ovalisation),
    and w along the generator at that φ (true size)."""
    sol = result.solution
    sh = sol.shell
    scale = exaggeration(result) if scale is None else float(scale)
    tri, w = evaluation_grid(result, "w")
    i = int(np.argmax(np.abs(w)))
    x0, phi0 = float(tri.x[i]), math.radians(float(tri.y[i]))
    L = _unit(result, "length")
    fig = Figure(figsize=(11.0, 4.6), layout="constrained")
    ring, gen = fig.add_subplot(1, 2, 1), fig.add_subplot(1, 2, 2)
    phi = np.linspace(sh.alpha, sh.beta, 361)
    xs = np.full(phi.size, x0)
    ref = sh.point(xs, phi)
    cur = ref + scale * sol.displacement(xs, phi)
    ring.plot(ref[1], ref[2], color="0.5", ls="--", lw=1.0, label="undeformed")
    ring.plot(cur[1], cur[2], color="C0", lw=1.8, label=f"deformed, displacements × {scale:g}")
    ring.plot(*cur[1:, np.argmin(np.abs(phi - phi0))], "k+", ms=10, mew=1.5, label=f"φ = {_fmt(math.degrees(phi0))}°")
    ring.set_aspect("equal", adjustable="datalim")
    ring.set_xlabel(f"y{L}")
    ring.set_ylabel(f"z{L}")
    ring.set_title(f"ring section at x = {_q(result, x0, 'length')}", fontsize=10)
    ring.legend(loc="best", fontsize=8)
    ring.grid(True, alpha=0.3)
    x = np.linspace(sh.x_min, sh.x_max, 401)
    wx = sol.evaluate(x, np.full(x.size, phi0), ("w",))["w"]
    gen.plot(x, wx, color="C0", lw=1.8)
    gen.axhline(0.0, color="0.5", lw=0.8, ls="--")
    gen.set_xlabel(f"x{L}")
    gen.set_ylabel(f"w, outward positive{L}")
    gen.set_title(f"w along the generator φ = {_fmt(math.degrees(phi0))}° (true size)", fontsize=10)
    gen.xaxis.set_major_locator(MaxNLocator(6))
    gen.grid(True, alpha=0.3)
    for ax in (ring, gen):
        ax.xaxis.set_major_locator(MaxNLocator(6))
    return _finish(fig, path)


def plot_pressure(result, path: str | Path | None = None) -> Figure | None:
    """pressure.png (``contact_figures.plot_pressure``): the line force along each rim over the nodal pressure."""
    from .contact import plot_pressure as plot

    return plot(result, path)


def pressure_lines(result, x: float | None = None, phi: float | None = None):
    """The nodal pressures along two mesh lines (``contact_figures.pressure_lines``)."""
    from .contact import pressure_lines as lines

    return lines(result, x, phi)


def plot_pressure_profiles(
    result, path: str | Path | None = None, x: float | None = None, phi: float | None = None
) -> Figure | None:
    """pressure_profiles.png (``contact_figures.plot_pressure_profiles``)."""
    from .contact import plot_pressure_profiles as plot

    return plot(result, path, x, phi)


def run_figures(
    result,
    fields: dict[str, np.ndarray] | None = None,
    profile_x: float | None = None,
    profile_phi: float | None = None,
) -> dict[str, bytes]:
    """All figures of one run as PNG bytes, by file name (contact figures only with contact);
    ``profile_x``/``profile_phi`` (degrees) choose the pressure-profile lines (default: through the peak)."""
    out = {"deflection.png": plot_deflection(result), "von_mises.png": plot_von_mises(result, fields=fields),
           "deformed.png": plot_deformed(result), "sections.png": plot_sections(result)}
    for name, fig in (
        ("pressure.png", plot_pressure(result)),
        ("pressure_profiles.png", plot_pressure_profiles(result, x=profile_x, phi=profile_phi)),
    ):
        if fig is not None:
            out[name] = fig
    return {k: png_bytes(f) for k, f in out.items()}


# -- study figures -------------------------------------------------------------------------------------
SWEEP_PANELS = (
    ("force", "contact force |F|", "force"),
    ("zone_area", "contact zone area", "area"),
    ("line_force", "line force (rim mean or line load)", "force/length"),
    ("energy", "strain energy", "energy"),
    ("max_abs_w", "max |w|", "length"),
)


def _param_label(param: str, system: str, kind: str | None) -> str:
    """The swept key with its unit (``kind``: its kind of quantity, ``case.key_kind``)."""
    return param + (bracket(kind, system) if kind else "")


def plot_sweep(rows: Sequence[dict[str, Any]], param: str, path: str | Path | None = None,
               system: str = "SI", param_kind: str | None = None) -> Figure:
    """Each converging result column (force, zone area, line force, energy, max|w|; per punch) against the parameter;
    ``system``: the case's ``[units] system``, ``param_kind``: the swept key's kind of quantity (axis labels)."""
    xs = np.array([r[param] for r in rows], float)
    panels = []
    for key, label, kind in SWEEP_PANELS:
        cols = [c for c in rows[0] if c == key or c.startswith(key + "_")] if rows else []
        cols = [c for c in cols if not (key == "force" and c.startswith("force_"))] or cols
        cols = [c for c in cols if all(isinstance(r.get(c), (int, float)) for r in rows)]
        if cols:
            panels.append((label + bracket(kind, system), cols))
    n = len(panels)
    ncol = min(n, 3)
    nrow = math.ceil(n / ncol)
    fig = Figure(figsize=(4.4 * ncol, 3.5 * nrow), layout="constrained")
    for k, (label, cols) in enumerate(panels):
        ax = fig.add_subplot(nrow, ncol, k + 1)
        for c in cols:
            ax.plot(xs, [r[c] for r in rows], "o-", ms=4, label=c)
        if len(cols) > 1:
            ax.legend(fontsize=8)
        ax.set_xlabel(_param_label(param, system, param_kind))
        ax.set_ylabel(label)
        ax.xaxis.set_major_locator(MaxNLocator(5))
        ax.grid(True, alpha=0.3)
    fig.suptitle(f"sweep over {param}")
    return _finish(fig, path)


def plot_force_indentation(rows: Sequence[dict[str, Any]], param: str, path: str | Path | None = None,
                           system: str = "SI", param_kind: str | None = None) -> Figure | None:
    """Contact force against the swept parameter (None when the rows have no force column)."""
    cols = [c for c in (rows[0] if rows else {}) if c == "force" or (c.startswith("force_") and c[6:].isdigit())]
    if not cols:
        return None
    fig = Figure(figsize=(6, 4.5))
    ax = fig.add_subplot()
    xs = np.array([r[param] for r in rows], float)
    for c in cols:
        ax.plot(xs, [r[c] for r in rows], "o-", label=c)
    ax.set_xlabel(_param_label(param, system, param_kind))
    ax.set_ylabel(f"contact force |F| on the shell{bracket('force', system)}")
    ax.xaxis.set_major_locator(MaxNLocator(6))
    ax.set_title("force–indentation" if "indentation" in param else f"force against {param}")
    ax.grid(True, alpha=0.3)
    if len(cols) > 1:
        ax.legend()
    return _finish(fig, path)


def plot_convergence(rows: Sequence[dict[str, Any]], path: str | Path | None = None, system: str = "SI") -> Figure:
    """Log–log errors against the finest level versus h (levels except the finest)."""
    fig = Figure(figsize=(6, 4.5))
    ax = fig.add_subplot()
    rows = [r for r in rows if r.get("h") is not None]
    cols = [c for c in (rows[0] if rows else {}) if c.startswith("error_")]
    for c in cols:
        pts = [(r["h"], r[c]) for r in rows if isinstance(r.get(c), float) and r[c] > 0]
        if pts:
            h, e = np.array(pts).T
            ax.loglog(h, e, "o-", label=c.removeprefix("error_"))
    ref = [r for r in rows if cols and isinstance(r.get(cols[0]), float) and r[cols[0]] > 0]
    if len(ref) >= 2:
        h = np.array([r["h"] for r in ref])
        for order, style in ((2, ":"), (4, "--")):
            ax.loglog(h, ref[0][cols[0]] * (h / h[0]) ** order, "k" + style, lw=0.8, label=f"O(h{'²⁴'[order // 4]})")
    ax.set_xlabel(f"h, the largest edge in (x, s){bracket('length', system)}")
    ax.set_ylabel("relative error against the finest level")
    ax.set_title("convergence under nested refinement")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    return _finish(fig, path)


def _column_label(column: str, system: str, kinds: dict[str, str | None]) -> str:
    kind = kinds.get(column)
    return column + (bracket(kind, system) if kind else "")


def plot_response(rows: Sequence[dict[str, Any]], keys: Sequence[str], responses: Sequence[str],
                  system: str = "SI", kinds: dict[str, str | None] | None = None,
                  path: str | Path | None = None) -> Figure:
    """Every response against every varied key, one panel each, at most 4 panels to a row (a 9 × 2 column of
    panels was unreadable); ``kinds``: each column's kind of quantity (axis units in ``system``)."""
    kinds = kinds or {}
    pairs = [(c, k) for c in responses for k in keys]
    ncol = min(len(pairs), 4)
    nrow = math.ceil(len(pairs) / ncol)
    fig = Figure(figsize=(3.6 * ncol + 0.4, 2.8 * nrow + 0.6), layout="constrained")
    for n, (c, k) in enumerate(pairs):
        ax = fig.add_subplot(nrow, ncol, n + 1)
        ax.plot([r[k] for r in rows], [r[c] for r in rows], "o", ms=3, alpha=0.7)
        ax.set_xlabel(_column_label(k, system, kinds), fontsize=8)
        ax.set_ylabel(_column_label(c, system, kinds), fontsize=8)
        ax.tick_params(labelsize=7)
        ax.xaxis.set_major_locator(MaxNLocator(4))
        ax.grid(True, alpha=0.3)
    fig.suptitle("responses against the study's keys")
    return _finish(fig, path)


def plot_histograms(rows: Sequence[dict[str, Any]], responses: Sequence[str], system: str = "SI",
                    kinds: dict[str, str | None] | None = None, path: str | Path | None = None) -> Figure:
    """A histogram of each response over the points of a random study."""
    kinds = kinds or {}
    n = len(responses)
    ncol = min(n, 3)
    nrow = math.ceil(n / ncol)
    fig = Figure(figsize=(3.8 * ncol, 2.9 * nrow), layout="constrained")
    bins = max(5, min(40, int(math.sqrt(len(rows))) + 1))
    for k, c in enumerate(responses):
        ax = fig.add_subplot(nrow, ncol, k + 1)
        ax.hist([r[c] for r in rows], bins=bins, color="tab:blue", alpha=0.8)
        ax.set_xlabel(_column_label(c, system, kinds), fontsize=8)
        ax.set_ylabel("points", fontsize=8)
        ax.tick_params(labelsize=7)
        ax.xaxis.set_major_locator(MaxNLocator(4))
    fig.suptitle(f"distribution of the responses over {len(rows)} points")
    return _finish(fig, path)


def plot_sensitivity(correlations: dict[str, dict[str, float | None]], keys: Sequence[str],
                     path: str | Path | None = None) -> Figure:
    """Spearman rank correlation of each response (rows) with each key (columns), from −1 to 1."""
    responses = list(correlations)
    m = np.array([[np.nan if correlations[c].get(k) is None else correlations[c][k] for k in keys]
                  for c in responses], float)
    fig = Figure(figsize=(1.6 * len(keys) + 3.2, 0.45 * len(responses) + 1.6), layout="constrained")
    ax = fig.add_subplot()
    im = ax.imshow(m, cmap="RdBu_r", vmin=-1, vmax=1, aspect="auto")
    ax.set_xticks(range(len(keys)), keys, rotation=20, ha="right", fontsize=8)
    ax.set_yticks(range(len(responses)), responses, fontsize=8)
    for i in range(len(responses)):
        for j in range(len(keys)):
            if np.isfinite(m[i, j]):
                ax.text(j, i, f"{m[i, j]:.2f}", ha="center", va="center", fontsize=8,
                        color="white" if abs(m[i, j]) > 0.6 else "black")
    fig.colorbar(im, ax=ax, label="Spearman rank correlation")
    ax.set_title("sensitivity of each response to each key")
    return _finish(fig, path)
