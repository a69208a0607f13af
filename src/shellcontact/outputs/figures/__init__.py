"""Figures (matplotlib, no display needed), one module per kind of figure.

Every ``plot_*`` function takes a ``Result`` (or study rows), returns a ``matplotlib.figure.Figure`` (or
``None`` when the data it needs is absent, e.g. no contact) and, given ``path``, also writes a PNG
atomically. Figures are built without pyplot, so they work headless and never touch the user's backend.
Maps are drawn over (x, φ in degrees).

Modules: ``maps`` (deflection, von Mises), ``deformed`` (3D), ``sections``, ``contact`` (pressure and rim
line force, pressure profiles), ``friction`` (stick and slip zones, traction), ``run`` (all figures of a run),
``sweeps``, ``convergence``, ``study``;
``common`` holds what they share. The names below are imported on first use: matplotlib is imported only
when a figure is drawn.
"""

from __future__ import annotations

from ...lazy import lazy_attributes

_LAZY = {
    "DPI": "common", "png_bytes": "common", "save_png": "common", "evaluation_grid": "common",
    "exaggeration": "common", "plot_deflection": "maps", "plot_von_mises": "maps", "plot_deformed": "deformed",
    "plot_sections": "sections", "plot_pressure": "contact", "pressure_lines": "contact",
    "plot_pressure_profiles": "contact", "plot_friction": "friction", "run_figures": "run", "plot_sweep": "sweeps",
    "plot_force_indentation": "sweeps", "plot_convergence": "convergence", "plot_response": "study",
    "plot_histograms": "study", "plot_sensitivity": "study",
}
__all__ = sorted(_LAZY)

__getattr__, __dir__ = lazy_attributes(__name__, _LAZY, globals(), __all__)
