"""The total force of a case's applied loads in closed form, computed from the case file alone (not from the
assembled load vector F): constant surface loads and pressures integrated over the mid-surface x ∈ [x_min,
x_max], φ ∈ [α, β] of radius a (n = (0, cos φ, sin φ)), constant line loads over their line, point loads summed;
and the prescribed forces of force-controlled punches (force along the punch's direction).

A check of the equilibrium that does not go through the stiffness or the load assembly: the reactions
R = A U − F − BᵀΛ balance these totals only if F, B and the solution are right."""

from __future__ import annotations

import math

import numpy as np


def _constant(value, what: str) -> np.ndarray:
    if callable(value):
        raise ValueError(f"{what} is a function: no closed-form total")
    return np.asarray(value, float)


def applied_force(case) -> np.ndarray:
    """Σ of the case's loads as a global force (3,)."""
    sh, loads = case.shell, case.loads
    a, L, dphi = sh.radius, sh.x_max - sh.x_min, sh.beta - sh.alpha
    cos_int = math.sin(sh.beta) - math.sin(sh.alpha)  # ∫ cos φ dφ over [α, β]
    sin_int = math.cos(sh.alpha) - math.cos(sh.beta)  # ∫ sin φ dφ
    n_int = np.array([0.0, cos_int, sin_int])  # ∫ n dφ
    total = _constant(loads.surface, "loads.surface") * a * dphi * L
    total = total + float(_constant(loads.normal, "loads.normal")) * a * L * n_int
    for i, line in enumerate(loads.lines):
        f = _constant(line.force, f"loads.line.{i}.force")
        p = float(_constant(line.normal, f"loads.line.{i}.normal"))
        if line.x is not None:  # along the ring x = const: arc length a (β − α)
            total = total + f * a * dphi + p * a * n_int
        else:  # along the generator φ = const: length L
            total = total + f * L + p * L * np.array([0.0, math.cos(line.phi), math.sin(line.phi)])
    for point in loads.points:
        total = total + np.asarray(point.force, float)
    return total


def prescribed_punch_force(case) -> np.ndarray:
    """The force the force-controlled punches exert on the shell, Σ P d (the case file's force and direction);
    zero for punches placed by indentation or fixed."""
    total = np.zeros(3)
    for p in case.punches:
        if p.mode == "force":
            total += p.force * np.asarray(p.direction, float) / np.linalg.norm(p.direction)
    return total
