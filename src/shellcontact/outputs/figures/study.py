"""A parameter study's figures: responses against the keys (response.png), histograms of the responses
(histograms.png) and rank correlations (sensitivity.png)."""

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
