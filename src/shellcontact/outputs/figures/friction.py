"""``friction.png``: per punch with friction, the stick and slip zones over (x, φ°) and the tangential traction on
the shell as arrows (drawn only when a punch has friction or a slide)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from ..fields import friction_vertex_fields
from .common import _finish, _map_axes, _q, _vertex_map

#: the colours of the friction states (fields.FRICTION_STATES)
STATE_STYLE = {0: ("open", "0.75", 6), 1: ("stick", "tab:blue", 16), 2: ("slip", "tab:red", 16)}
ARROW = 0.06  # the arrow of the key's traction (the longest): this share of the panel's width
#: the key's traction: this quantile of the tractions; longer ones are clipped to it (drawn in CLIPPED) so that a few
#: line forces (a saddle's horns on the vessel on saddles, 40 × 48: up to 5.8e5 Pa against the quantile's 1.3e5 Pa;
#: 0.9 still fell on them, 4 of 28 points) neither run off the panel nor shrink every other arrow to a dot
QUANTILE = 0.75
#: ... unless the longest is at most this much longer: then none is clipped (examples/band_clamp_slip.toml's rim rows,
#: 2.647e7 against up to 2.655e7 Pa, were 8 purple arrows clipped by 0.3 %)
CLIP_ABOVE = 1.5
CLIPPED = "tab:purple"
MARGIN = 0.12  # beyond the points on each side (× their extent): an arrow at the edge stays inside
KEY_BAND = 0.22  # below the points (× their extent): the arrows' key and the legend, clear of the points


def plot_friction(result, path: str | Path | None = None) -> Figure | None:
    """Stick (blue) and slip (red) vertices, open candidate vertices (grey) and the tangential traction on the shell
    (arrows, their key in Pa) of every punch with friction, one panel each; the title gives the friction force
    (N) and the stick and slip areas. None without friction."""
    fields = friction_vertex_fields(result)
    if not fields:
        return None
    sol = result.solution
    a = sol.shell.radius
    tri = _vertex_map(result)
    x, phi = tri.x, tri.y
    state, traction = fields["friction_state"], fields["friction_traction"]
    e2 = np.stack([np.zeros_like(phi), -np.sin(np.radians(phi)), np.cos(np.radians(phi))])
    t1, t2 = traction[:, 0], np.sum(traction.T * e2, axis=0)  # axial and circumferential components (Pa)
    entries = getattr(result.contact, "friction", None) or []
    op = result.contact.operator
    punches = [k for k, p in enumerate(result.case.punches) if p.drags]
    n = len(punches)
    fig = Figure(figsize=(7.6 if n == 1 else 6.2 * n, 5.0), layout="constrained")
    for j, k in enumerate(punches):
        ax = fig.add_subplot(1, n, j + 1)
        mine = np.zeros(x.size, bool)
        rows = (np.asarray(op.punch) == k) & (np.asarray(op.vertex) >= 0)
        mine[np.asarray(op.vertex)[rows]] = True
        for s, (label, colour, size) in STATE_STYLE.items():
            at = mine & (state == s)
            if at.any():
                ax.scatter(x[at], phi[at], s=size, c=colour, label=f"{label} ({int(at.sum())} vertices)",
                           edgecolors="none", zorder=2)
        moving = mine & (state > 0)
        mag = np.hypot(t1, t2)
        if moving.any() and mag[moving].max() > 0:
            _arrows(ax, result, x[moving], phi[moving], t1[moving], t2[moving], mag[moving], a)
        if mine.any():  # margins that hold the longest arrow, and a band below the points for the key and legend
            dx = max(float(np.ptp(x[mine])), 1e-12)
            dp = max(float(np.ptp(phi[mine])), 1e-9)
            ax.set_xlim(x[mine].min() - MARGIN * dx, x[mine].max() + MARGIN * dx)
            ax.set_ylim(phi[mine].min() - KEY_BAND * dp, phi[mine].max() + MARGIN * dp)
        ax.legend(loc="lower right", fontsize=8)
        title = f"punch {k}: friction on the shell"
        if k < len(entries):
            f = entries[k]
            force = ", ".join(_q(result, v, "force") for v in f["force"])
            title += (f"\nforce ({force}); stick {_q(result, f['stick_area'], 'area')}, "
                      f"slip {_q(result, f['slip_area'], 'area')}")
        ax.set_title(title, fontsize=9)
        _map_axes(ax, result)
    return _finish(fig, path)


def _arrows(ax, result, x: np.ndarray, phi: np.ndarray, t1: np.ndarray, t2: np.ndarray, mag: np.ndarray,
            a: float) -> None:
    """The traction arrows at (x, φ°) of axial and circumferential tractions t1, t2 (Pa), true to direction on the
    surface (a degree of φ is a·π/180 of arc), length ∝ |t| up to the key's traction (``QUANTILE``), clipped there."""
    deg = 180.0 / (math.pi * a)
    ref = float(np.quantile(mag, QUANTILE))
    if float(mag.max()) <= CLIP_ABOVE * ref:
        ref = float(mag.max())
    u, v = t1, t2 * deg
    length = np.minimum(mag, ref) / np.maximum(np.hypot(u, v), 1e-300)
    clipped = mag > ref * (1 + 1e-12)
    colours = np.where(clipped, CLIPPED, "k")
    q = ax.quiver(x, phi, u * length, v * length, angles="xy", zorder=3, color=colours, width=0.003,
                  scale_units="width", scale=ref / ARROW)
    label = f"tangential traction {_q(result, ref, 'pressure')}"
    if clipped.any():
        label += (f"\n{int(clipped.sum())} arrows clipped at it ({CLIPPED.split(':')[-1]}), "
                  f"up to {_q(result, float(mag.max()), 'pressure')}")
    ax.quiverkey(q, 0.06, 0.05, ref, label, labelpos="E", coordinates="axes", fontproperties={"size": 8}, color="k")
