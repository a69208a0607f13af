"""Linearly elastic shell materials: isotropic and orthotropic plane stress (MODEL.md §3).

Material axis 1 runs along the cylinder axis x, axis 2 along the circumference. A material
gives the plane-stress matrix Q on (ε11, ε22, γ12), with which (constant through the thickness)

    N = t Q (ε11, ε22, γ12),   M = (t³/12) Q (κ11, κ22, 2κ12),
    energy density ½ t εᵀQε + ½ (t³/12) κᵀQκ,   κ = (κ11, κ22, 2κ12).

The finite elements work with the strain vector (ε11, ε22, γ12, κ11, κ22, κ12) of model.strains,
so the bending energy matrix is T Q T with T = diag(1, 1, 2). Each energy matrix is handed to the
assembly as a scalar function of the thickness times a constant 3 × 3 pattern
(``membrane_scale(t) · membrane_pattern``): one scalar per quadrature point, and for Isotropic
exactly the arithmetic of B and D that the package has always used (bit-identical results).
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from ..errors import InputError


def _finite(name: str, value: float) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise InputError(name, f"must be a finite number, got {value!r}")
    return float(value)


def _positive(name: str, value: float) -> float:
    if _finite(name, value) <= 0:
        raise InputError(name, f"must be > 0, got {value}")
    return float(value)


#: the range of E·t and E·t³ (each modulus E, thickness t over the shell) in which the arithmetic means
#: something. Stiffness entries, forces and energies are these times powers of the lengths, and the
#: 2-norms and energies of the solvers square them: squares of numbers beyond 1e±154 leave the double
#: range (1e±308). 1e±100 keeps a margin of 1e±54 for the geometry (h⁻⁴ of a fine mesh, radius, …)
#: and covers every consistent unit system (steel: E·t = 2e9 N/m, E·t³ = 2e5 N·m in SI, 2e3 N/mm and
#: 2e5 N·mm in mm).
STIFFNESS_RANGE = (1e-100, 1e100)
#: an orthotropic Q whose constants differ by more than this factor (or with 1 − ν12ν21 below it) is refused:
#: the shell's stiffness matrix already has a condition number of 1e8–1e10 (h⁻⁴, (a/t)²), and this would leave
#: fewer than 2 of double precision's 16 digits (real composites: E1/E2 ≤ 50, G12/E1 ≥ 0.01)
Q_CONDITION_MIN = 1e-6


def check_stiffness_range(material: Material, t_min: float, t_max: float) -> None:
    """Refuse a modulus whose membrane (E·t) or bending (E·t³) stiffness leaves ``STIFFNESS_RANGE``
    for a thickness in [t_min, t_max]; the error names the modulus (``material.<name>``)."""
    lo, hi = (math.log10(v) for v in STIFFNESS_RANGE)
    for name, modulus in material.moduli().items():
        logs = [math.log10(modulus) + k * math.log10(t) for k in (1, 3) for t in (t_min, t_max)]
        if not all(lo <= v <= hi for v in logs):
            raise InputError(
                f"material.{name}",
                f"{modulus:.6g} with the thickness {t_min:.6g}–{t_max:.6g} gives stiffnesses E·t and E·t³ "
                f"between 1e{min(logs):.0f} and 1e{max(logs):.0f}; they must lie in [{STIFFNESS_RANGE[0]:g}, "
                f"{STIFFNESS_RANGE[1]:g}] (their squares must stay inside floating point; choose other units)",
            )


def _times(matrix: np.ndarray, t) -> np.ndarray:
    """matrix (3, 3) times t (scalar or array): shape (3, 3) + shape(t)."""
    t = np.asarray(t, dtype=float)
    return matrix.reshape((3, 3) + (1,) * t.ndim) * t


class Material(ABC):
    """A plane-stress material of a shell (MODEL.md §3); subclasses are frozen dataclasses whose
    fields are the case-file keys of their ``[material]`` model."""

    model: ClassVar[str]

    @property
    @abstractmethod
    def plane_stress(self) -> np.ndarray:
        """Q (3 × 3) on (ε11, ε22, γ12): (σ11, σ22, σ12) = Q (ε11, ε22, γ12)."""

    def moduli(self) -> dict[str, float]:
        """The elastic moduli by their case-file key (checked by ``check_stiffness_range``)."""
        return {k: float(getattr(self, k)) for k in self.modulus_keys}

    modulus_keys: ClassVar[tuple[str, ...]]

    @property
    @abstractmethod
    def hoop_modulus(self) -> float:
        """σ22/ε22 under hoop stress alone (σ11 = σ12 = 0); times t/a² the ring membrane stiffness."""

    @abstractmethod
    def membrane_scale(self, t):
        """The scalar factor S_m(t) of the membrane energy matrix S_m(t) · membrane_pattern."""

    @property
    @abstractmethod
    def membrane_pattern(self) -> np.ndarray:
        """The constant 3 × 3 factor of the membrane energy matrix on (ε11, ε22, γ12)."""

    @abstractmethod
    def bending_scale(self, t):
        """The scalar factor S_b(t) of the bending energy matrix S_b(t) · bending_pattern."""

    @property
    @abstractmethod
    def bending_pattern(self) -> np.ndarray:
        """The constant 3 × 3 factor of the bending energy matrix on (κ11, κ22, κ12) (twist entry × 4)."""

    def membrane_stiffness(self, t) -> np.ndarray:
        """C_m = t Q, shape (3, 3) + shape(t): N = C_m (ε11, ε22, γ12)."""
        return _times(self.plane_stress, t)

    def bending_stiffness(self, t) -> np.ndarray:
        """C_b = (t³/12) Q, shape (3, 3) + shape(t): M = C_b (κ11, κ22, 2κ12)."""
        return _times(self.plane_stress, np.asarray(t, dtype=float) ** 3 / 12.0)


@dataclass(frozen=True)
class Isotropic(Material):
    """Young's modulus E > 0 and Poisson's ratio −1 < μ < 1/2.

    B = E t/(1 − μ²), D = E t³/(12(1 − μ²)); membrane energy B [[1, μ, 0], [μ, 1, 0], [0, 0, (1−μ)/2]],
    bending energy D [[1, μ, 0], [μ, 1, 0], [0, 0, 2(1−μ)]] on (κ11, κ22, κ12) since 2 M12 κ12 = 2 D (1−μ) κ12².
    """

    young: float
    poisson: float
    model: ClassVar[str] = "isotropic"
    modulus_keys: ClassVar[tuple[str, ...]] = ("young",)

    def __post_init__(self) -> None:
        _positive("material.young", self.young)
        mu = self.poisson
        if isinstance(mu, bool) or not isinstance(mu, (int, float)) or not (-1.0 < mu < 0.5):
            raise InputError("material.poisson", f"must lie in (-1, 0.5), got {mu!r}")

    @property
    def plane_stress(self) -> np.ndarray:
        return self.young / (1.0 - self.poisson**2) * self.membrane_pattern

    @property
    def hoop_modulus(self) -> float:
        return float(self.young)

    def membrane_scale(self, t):
        """B = E t / (1 − μ²)."""
        return self.young * t / (1.0 - self.poisson**2)

    def bending_scale(self, t):
        """D = E t³ / (12 (1 − μ²))."""
        return self.young * t**3 / (12.0 * (1.0 - self.poisson**2))

    @property
    def membrane_pattern(self) -> np.ndarray:
        mu = self.poisson
        return np.array([[1.0, mu, 0.0], [mu, 1.0, 0.0], [0.0, 0.0, 0.5 * (1.0 - mu)]])

    @property
    def bending_pattern(self) -> np.ndarray:
        mu = self.poisson
        return np.array([[1.0, mu, 0.0], [mu, 1.0, 0.0], [0.0, 0.0, 2.0 * (1.0 - mu)]])


@dataclass(frozen=True)
class Orthotropic(Material):
    """Moduli E1 (axial), E2 (circumferential), in-plane shear modulus G12 and Poisson's ratio ν12.

    ν21 = ν12 E2/E1; positive definite iff E1, E2, G12 > 0 and ν12 ν21 < 1. With Δ = 1 − ν12 ν21:
    Q11 = E1/Δ, Q22 = E2/Δ, Q12 = ν12 E2/Δ, Q66 = G12 (MODEL.md §3). Orthotropic(E, E, E/(2(1+μ)), μ)
    is Isotropic(E, μ).
    """

    e1: float
    e2: float
    g12: float
    nu12: float
    model: ClassVar[str] = "orthotropic"
    modulus_keys: ClassVar[tuple[str, ...]] = ("e1", "e2", "g12")

    def __post_init__(self) -> None:
        e1 = _positive("material.e1", self.e1)
        e2 = _positive("material.e2", self.e2)
        _positive("material.g12", self.g12)
        nu = _finite("material.nu12", self.nu12)
        if not nu * nu * e2 / e1 < 1.0:
            raise InputError(
                "material.nu12",
                f"must satisfy nu12 * nu21 = nu12^2 e2/e1 < 1 (positive definiteness), i.e. "
                f"|nu12| < sqrt(e1/e2) = {math.sqrt(e1 / e2):.6g}, got {nu!r}",
            )

        # nearly singular Q: its smallest eigenvalue over its largest is lost to round-off in the stiffness
        # (failing as a factorisation of "insufficient supports"): name the constant that makes it so
        delta = 1.0 - nu * nu * e2 / e1
        if delta < Q_CONDITION_MIN:
            limit = math.sqrt((1 - Q_CONDITION_MIN) * e1 / e2)
            raise InputError("material.nu12", f"{nu!r} gives 1 - nu12 nu21 = {delta:.3g}, below {Q_CONDITION_MIN:g}: "
                             "the stiffness (proportional to 1/(1 - nu12 nu21)) is nearly singular and its digits are "
                             f"lost in the factorisation; |nu12| must stay below {limit:.6g}")
        for key, ratio in (("e2", e2 / e1), ("g12", self.g12 / max(e1, e2))):
            if not Q_CONDITION_MIN <= ratio <= 1.0 / Q_CONDITION_MIN:
                raise InputError(f"material.{key}", f"{getattr(self, key):.6g} is {ratio:.3g} x the largest modulus "
                                 f"({max(e1, e2):.6g}): outside [{Q_CONDITION_MIN:g}, {1 / Q_CONDITION_MIN:g}], the "
                                 "stiffness is nearly singular and its digits are lost in the factorisation")

    @property
    def nu21(self) -> float:
        return self.nu12 * self.e2 / self.e1

    @property
    def plane_stress(self) -> np.ndarray:
        delta = 1.0 - self.nu12 * self.nu21
        q11, q22, q12 = self.e1 / delta, self.e2 / delta, self.nu12 * self.e2 / delta
        return np.array([[q11, q12, 0.0], [q12, q22, 0.0], [0.0, 0.0, float(self.g12)]])

    @property
    def hoop_modulus(self) -> float:
        return float(self.e2)

    def membrane_scale(self, t):
        """t: the membrane energy matrix is t Q."""
        return t

    def bending_scale(self, t):
        """t³/12: the bending energy matrix on (κ11, κ22, κ12) is (t³/12) T Q T."""
        return t**3 / 12.0

    @property
    def membrane_pattern(self) -> np.ndarray:
        return self.plane_stress

    @property
    def bending_pattern(self) -> np.ndarray:
        T = np.array([1.0, 1.0, 2.0])
        return T[:, None] * self.plane_stress * T[None, :]


MATERIALS: dict[str, type[Material]] = {cls.model: cls for cls in (Isotropic, Orthotropic)}  # [material] model
