"""Cylindrical shell geometry (MODEL.md §1) and the shell's material (material.py, MODEL.md §3).

The parameter domain is Ω = [x_start, x_start + length] × [α, β]; the finite elements
live on the arc-length chart (x, s), s = a φ, where the strain operators have constant
coefficients and triangles are not distorted.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from ..errors import InputError
from ..inputs.user_functions import UserFunction, user_function
from .material import Material

ThicknessFunction = Callable[[np.ndarray, np.ndarray], np.ndarray]


def _positive(name: str, value: float) -> float:
    if not isinstance(value, (int, float)) or isinstance(value, bool) or not math.isfinite(value):
        raise InputError(name, f"must be a finite number, got {value!r}")
    if value <= 0:
        raise InputError(name, f"must be > 0, got {value}")
    return float(value)


@dataclass(frozen=True)
class Shell:
    """A circular cylindrical shell of radius ``radius`` (a) made of ``material`` (material.py).

    ``alpha``/``beta`` are in radians; ``full=True`` means β − α = 2π with the φ-edges
    identified. ``thickness`` is t = 2e, a number or a callable t(x, φ) (vectorised). The
    stiffness comes from ``material`` alone (membrane and bending, MODEL.md §3).
    """

    radius: float
    length: float
    thickness: float | ThicknessFunction
    material: Material
    alpha: float = 0.0
    beta: float = 2.0 * math.pi
    full: bool = False
    x_start: float | None = None
    _x0: float = field(init=False, repr=False)

    def __post_init__(self) -> None:
        a = _positive("shell.radius", self.radius)
        _positive("shell.length", self.length)
        if not isinstance(self.material, Material):
            raise InputError("shell.material", f"must be a material.Isotropic or Orthotropic, got {self.material!r}")
        if self.full:
            object.__setattr__(self, "beta", self.alpha + 2.0 * math.pi)
        if not (math.isfinite(self.alpha) and math.isfinite(self.beta)):
            raise InputError("shell.angle", "angles must be finite")
        if self.alpha >= self.beta:
            raise InputError(
                "shell.angle",
                f"needs alpha < beta, got [{math.degrees(self.alpha)}, {math.degrees(self.beta)}] deg",
            )
        if self.beta - self.alpha > 2.0 * math.pi + 1e-12:
            raise InputError("shell.angle", "beta - alpha must not exceed 360 degrees")
        x0 = -0.5 * self.length if self.x_start is None else float(self.x_start)
        object.__setattr__(self, "_x0", x0)
        if callable(self.thickness):
            object.__setattr__(self, "thickness", user_function(self.thickness, "shell.thickness"))
            # probe the function on a grid of Ω so that a bad t(x, φ) fails here, not in assembly
            xs, ps = np.meshgrid(np.linspace(x0, x0 + self.length, 9), np.linspace(self.alpha, self.beta, 9))
            self.t(xs, ps)
        else:
            t = _positive("shell.thickness", self.thickness)
            if t >= a:
                raise InputError("shell.thickness", f"must be < radius ({a}), got {t}")

    # -- domain -------------------------------------------------------------------------
    @property
    def x_min(self) -> float:
        return self._x0

    @property
    def x_max(self) -> float:
        return self._x0 + self.length

    @property
    def s_min(self) -> float:
        return self.radius * self.alpha

    @property
    def s_max(self) -> float:
        return self.radius * self.beta

    def phi(self, s: np.ndarray) -> np.ndarray:
        return np.asarray(s) / self.radius

    # -- thickness -----------------------------------------------------------------------------
    def t(self, x: np.ndarray, phi: np.ndarray) -> np.ndarray:
        """Thickness t = 2e at (x, φ), broadcast to the shape of x."""
        x = np.asarray(x, dtype=float)
        if isinstance(self.thickness, UserFunction):  # checked wherever it is evaluated (assembly included)
            t = self.thickness.field(x, np.asarray(phi))
            bad = (t <= 0.0) | (t >= self.radius)
            if np.any(bad):
                i = int(np.argmax(bad.ravel()))
                p = np.broadcast_to(np.asarray(phi, dtype=float), x.shape).ravel()[i]
                where = f"x = {x.ravel()[i]:.6g}, phi = {math.degrees(p):.6g} deg"
                raise InputError("shell.thickness", f"t(x, phi) must lie in (0, radius = {self.radius:g}); "
                                 f"{self.thickness.spec} gives {t.ravel()[i]:.6g} at {where}")
            return t
        return np.full(x.shape, float(self.thickness))

    # -- embedding (MODEL.md §1) -----------------------------------------------------------
    def point(self, x: np.ndarray, phi: np.ndarray, zeta: float | np.ndarray = 0.0) -> np.ndarray:
        """Φ(x, φ) + ζ n(φ), shape (3, ...)."""
        x, phi = np.broadcast_arrays(np.asarray(x, float), np.asarray(phi, float))
        r = self.radius + np.asarray(zeta, float)
        return np.stack([x, r * np.cos(phi), r * np.sin(phi)])


def frame(phi: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Local orthonormal frame (e1, e2, n) at angle φ, each of shape (3, ...)."""
    phi = np.asarray(phi, dtype=float)
    one, zero = np.ones_like(phi), np.zeros_like(phi)
    e1 = np.stack([one, zero, zero])
    e2 = np.stack([zero, -np.sin(phi), np.cos(phi)])
    n = np.stack([zero, np.cos(phi), np.sin(phi)])
    return e1, e2, n


def to_local(vec: np.ndarray, phi: np.ndarray) -> np.ndarray:
    """Global vector(s) (3, ...) → local components (f·e1, f·e2, f·n)."""
    e1, e2, n = frame(phi)
    vec = np.asarray(vec, dtype=float)
    if vec.ndim == 1:
        vec = vec.reshape((3,) + (1,) * np.ndim(phi))
    return np.stack([np.sum(vec * e, axis=0) for e in (e1, e2, n)])


def to_global(local: np.ndarray, phi: np.ndarray) -> np.ndarray:
    """Local components (u, v, w) (3, ...) → global vector (3, ...)."""
    e1, e2, n = frame(phi)
    return local[0] * e1 + local[1] * e2 + local[2] * n


def rigid_motion(shell: Shell, translation, rotation):
    """Exact local displacement (u, v, w) of the rigid motion c + θ × X and its derivatives.

    Returns a function (x, s) → dict of u, u_x, u_s, v, ..., w_ss (MODEL.md §2 check).
    """
    c = np.asarray(translation, dtype=float)
    th = np.asarray(rotation, dtype=float)
    a = shell.radius

    def field_(x: np.ndarray, s: np.ndarray) -> dict[str, np.ndarray]:
        phi = s / a
        sn, cs = np.sin(phi), np.cos(phi)
        # X = (x, a cos φ, a sin φ); D = c + θ × X
        dx = c[0] + th[1] * a * sn - th[2] * a * cs
        dy = c[1] + th[2] * x - th[0] * a * sn
        dz = c[2] + th[0] * a * cs - th[1] * x
        # derivatives of D in x and φ
        dy_x, dz_x = th[2] + 0 * x, -th[1] + 0 * x
        dx_p, dy_p, dz_p = th[1] * a * cs + th[2] * a * sn, -th[0] * a * cs, -th[0] * a * sn
        dy_pp, dz_pp = th[0] * a * sn, -th[0] * a * cs
        u = dx
        v = -sn * dy + cs * dz
        w = cs * dy + sn * dz
        # φ-derivatives via product rule: e2' = -n, n' = e2
        v_p = -sn * dy_p + cs * dz_p - w
        w_p = cs * dy_p + sn * dz_p + v
        w_pp = cs * dy_pp + sn * dz_pp + (-sn * dy_p + cs * dz_p) + v_p
        w_x = cs * dy_x + sn * dz_x
        v_x = -sn * dy_x + cs * dz_x
        w_xp = -sn * dy_x + cs * dz_x
        zero = 0.0 * x
        return {
            "u": u,
            "u_x": zero,
            "u_s": dx_p / a,
            "v": v,
            "v_x": v_x,
            "v_s": v_p / a,
            "w": w,
            "w_x": w_x,
            "w_s": w_p / a,
            "w_xx": zero,
            "w_xs": w_xp / a,
            "w_ss": w_pp / a**2,
        }

    return field_
