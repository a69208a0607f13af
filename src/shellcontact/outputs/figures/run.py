"""All figures of one run, as PNG bytes by file name (the run directory's figures)."""

from __future__ import annotations

import numpy as np

from .common import png_bytes
from .contact import plot_pressure, plot_pressure_profiles
from .deformed import plot_deformed
from .friction import plot_friction
from .maps import plot_deflection, plot_von_mises
from .sections import plot_sections


def run_figures(
    result,
    fields: dict[str, np.ndarray] | None = None,
    profile_x: float | None = None,
    profile_phi: float | None = None,
) -> dict[str, bytes]:
    """All figures of one run as PNG bytes, by file name (contact figures only with contact, friction.png only
    with friction); ``profile_x``/``profile_phi`` (degrees) choose the pressure-profile lines (default: through
    the peak)."""
    out = {"deflection.png": plot_deflection(result), "von_mises.png": plot_von_mises(result, fields=fields),
           "deformed.png": plot_deformed(result), "sections.png": plot_sections(result)}
    for name, fig in (
        ("pressure.png", plot_pressure(result)),
        ("pressure_profiles.png", plot_pressure_profiles(result, x=profile_x, phi=profile_phi)),
        ("friction.png", plot_friction(result)),
    ):
        if fig is not None:
            out[name] = fig
    return {k: png_bytes(f) for k, f in out.items()}


