"""The deformed shell in 3D, displacements exaggerated (deformed.png)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
from matplotlib.figure import Figure
from matplotlib.ticker import MaxNLocator
from matplotlib.tri import Triangulation

from ..fields import contact_vertex_fields
from .common import _finish, _refined, _unit, evaluation_grid, exaggeration


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
