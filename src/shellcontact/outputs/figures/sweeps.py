"""A sweep's figures: its responses against the swept key (sweep.png) and the force–indentation curve
(force_indentation.png)."""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.figure import Figure
from matplotlib.ticker import MaxNLocator

from ...units import bracket
from .common import _finish

SWEEP_PANELS = (
    ("force", "contact force |F|", "force"),
    ("zone_area", "contact zone area", "area"),
    ("line_force", "rim line force (mean)", "force/length"),
    ("line_load", "line load (mean)", "force/length"),
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
