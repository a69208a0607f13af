"""Colour maps over (x, φ): the deflection w (deflection.png) and the von Mises stress (von_mises.png)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from matplotlib.figure import Figure
from matplotlib.ticker import MaxNLocator
from matplotlib.tri import Triangulation

from ..fields import vertex_fields
from .common import _contact_outline, _finish, _fmt, _levels, _map_axes, _q, _refined, _unit, evaluation_grid


def _probes(ax, result) -> None:
    pr = getattr(result.case, "probes", [])
    if pr:
        pts = np.array(pr, float)
        ax.plot(pts[:, 0], np.degrees(pts[:, 1]), "k+", ms=9, mew=1.5, label="probes")


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
