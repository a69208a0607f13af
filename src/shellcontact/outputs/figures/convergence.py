"""A mesh-convergence study's figure: errors against the finest level, by mesh size (convergence.png)."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.figure import Figure

from ...units import bracket
from .common import _finish


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
