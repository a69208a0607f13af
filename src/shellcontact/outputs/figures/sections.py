"""Sections through the shell along x and φ, deformed over undeformed (sections.png)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure
from matplotlib.ticker import MaxNLocator

from .common import _finish, _fmt, _q, _unit, evaluation_grid, exaggeration


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
