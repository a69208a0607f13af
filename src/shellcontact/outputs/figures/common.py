"""What every figure module shares: PNG writing, colour levels, axis labels with
units, the map's coordinates and the contact outline drawn on a map. Imports no figure module, so the figure
modules import it and not each other."""

from __future__ import annotations

import io as _io
import math
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure
from matplotlib.ticker import MaxNLocator
from matplotlib.tri import Triangulation

from ...units import bracket, with_unit
from ..fields import contact_vertex_fields
from ..files import atomic_write_bytes

DPI = 110


def png_bytes(fig: Figure) -> bytes:
    buf = _io.BytesIO()
    fig.savefig(buf, format="png", dpi=DPI, bbox_inches="tight")
    return buf.getvalue()


def save_png(fig: Figure, path: str | Path) -> Path:
    """Write ``fig`` as PNG atomically."""
    atomic_write_bytes(path, png_bytes(fig))
    return Path(path)


def _finish(fig: Figure, path: str | Path | None) -> Figure:
    if path is not None:
        save_png(fig, path)
    return fig


def _fmt(v: float) -> str:
    """4 significant digits, without an exponent below 10⁶ (a title's 3725 N/m beside 26690 N/m, not 2.669e+04)."""
    return f"{float(f'{v:.4g}'):.0f}" if 1e4 <= abs(v) < 1e6 else f"{v:.4g}"


def _levels(values: np.ndarray, lo: float | None = None) -> np.ndarray | int:
    """21 colour bands from the smallest (or ``lo``) to the largest value exactly, so that the 3D views can use the
    same scale (one colour scale per quantity across the figures of a run)."""
    lo = float(np.min(values)) if lo is None else lo
    hi = float(np.max(values))
    return np.linspace(lo, hi, 22) if hi > lo else 1


def _unit(result, kind: str) -> str:
    """`` [unit]`` of a kind of quantity in the case's ``[units] system`` (units.py), for axis and colour-bar labels."""
    return bracket(kind, getattr(result.case, "units", "SI"))


def _q(result, value: float, kind: str) -> str:
    """A number (4 significant digits) with its unit, for titles."""
    return with_unit(_fmt(value), kind, getattr(result.case, "units", "SI"))


def _map_axes(ax, result) -> None:
    """Axis labels with units and few enough ticks that their labels never overlap."""
    ax.set_xlabel(f"x{_unit(result, 'length')}")
    ax.set_ylabel("φ [deg]")
    ax.xaxis.set_major_locator(MaxNLocator(6))
    lo, hi = ax.get_ylim()
    ax.yaxis.set_major_locator(_degree_locator(abs(hi - lo)))


def _degree_locator(span: float, most: int = 8):
    """Ticks on an angle axis at a round number of degrees (…, 5, 10, 15, 30, 45, 90, …), at most ``most`` intervals."""
    from matplotlib.ticker import MultipleLocator

    steps = [m * 10.0 ** e for e in range(-3, 3) for m in (1, 2, 5)] + [15.0, 30.0, 45.0, 90.0]
    return MultipleLocator(min((d for d in sorted(steps) if span / d <= most and d not in (20.0, 50.0)),
                               default=90.0))


def _vertex_map(result) -> Triangulation:
    """The mesh as a triangulation of its vertices over (x, φ in degrees): the maps' coordinates."""
    sol = result.solution
    x, s = sol.space.mesh.p
    return Triangulation(x, np.degrees(s / sol.shell.radius), sol.space.mesh.t.T)


def _contact_outline(ax, result, fields: dict[str, np.ndarray] | None = None, punch: int | None = None) -> bool:
    """The boundary of the contact region on a map over (x, φ°): the zone's rim (where the gap reaches the zone's
    tolerance, ``rim.rim_line_force``) of every punch or of ``punch``; else the outline of the active vertices."""
    rims = getattr(getattr(result, "contact", None), "rim_lines", None) or []
    lines = [ln for k, group in enumerate(rims) if punch is None or k == punch for ln in group]
    if lines:
        a = result.solution.shell.radius
        for ln in lines:
            ax.plot(ln[:, 0], np.degrees(ln[:, 1] / a), "c-", lw=1.5)
        ax.plot([], [], "c-", label="contact boundary")
        return True
    status = (fields if fields is not None and "contact_status" in fields else contact_vertex_fields(result)).get(
        "contact_status")
    if status is None or not np.any(status == 1) or not np.any(status != 1):
        return False
    inside = (np.asarray(status) == 1).astype(float)
    ax.tricontour(_vertex_map(result), inside, levels=[0.5], colors="c", linewidths=1.5)
    ax.plot([], [], "c-", label="contact boundary")
    return True


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


def _refined(result, max_points: int):
    """A uniformly refined copy of the mesh with at most ~max_points vertices (level ≤ 3)."""
    from ..results import sampling_mesh

    return sampling_mesh(result.solution.space.mesh.mesh, max_points)
