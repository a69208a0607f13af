"""The closed-form ring of this shell model: a long pipe squeezed by two opposite line loads, as a test oracle.

numpy only; it shares no code with ``shellcontact``.

Problem. A long circular pipe (mid-surface radius a, wall t, Young's modulus E, Poisson ratio μ) whose
state does not depend on x — plane strain: the ends keep the section plane, u = 0 — is loaded by two
diametrically opposite line loads P (force per unit length of generator) pressing **inward** along the
generators θ = 0 and θ = π, with θ = φ − φ_load the angle from the first load line.

Model. MODEL.md §2–3 with u = 0 and ∂/∂x = 0 (w positive outward, ' = d/dθ):

    ε22 = (v' + w)/a,   κ22 = −(w'' + w)/a²,   ε11 = γ12 = κ11 = κ12 = 0,
    N22 = B ε22,  M22 = D κ22,   B = E t/(1 − μ²),  D = E t³/(12(1 − μ²)),

energy per unit length of pipe  Π = ∫₀^{2π} ½ (B ε22² + D κ22²) a dθ + P (w(0) + w(π)). Its Euler–Lagrange
equations are (κ22 does not involve v in this model, so the hoop force is constant)

    N22' = 0,                 N22 − (M22'' + M22)/a + P Σ_k δ(θ − kπ) = 0,

with v periodic (∫ v' dθ = 0, i.e. N22 = B w̄/a, w̄ the mean of w).

Solution (Fourier series in cos nθ, n even, summed in closed form; w is even and π-periodic). With
ψ = θ − π/2 for θ ∈ [0, π] (extended π-periodically):

    w(θ)   = P a³/(π D) − P a³/(π (B a² + D)) − (P a³/(4D)) (cos ψ + ψ sin ψ)
    v(θ)   = (P a³/D) [ 1/2 − θ/π + (2 sin ψ − ψ cos ψ)/4 ]
    N22    = −(P/π) B a²/(B a² + D)                                   (constant: uniform contraction)
    M22(θ) = P a [ sin θ/2 − 1/π + D/(π (B a² + D)) ]
    δ(P)   = −2 w(0) = (π/4 − 2/π) P a³/D + 2 P a³/(π (B a² + D))     (shortening of the loaded diameter)

The series (``Ring.w_series``, ``Ring.v_series``): w = w₀ + Σ_{n=2,4,..} w_n cos nθ, v = −Σ w_n/n sin nθ with
w₀ = −P a³/(π (B a² + D)) and w_n = −2 P a³/(π D (n² − 1)²); Σ_{n even ≥ 2} (n² − 1)⁻² = π²/16 − 1/2.

Thin-ring limit. The first term of δ is the classical ring formula δ = (π/4 − 2/π) P R³/(EI) with
EI = D = E t³/(12(1 − μ²)) per unit length (``classical_diametral_change``); the second is the membrane
(extensional) contribution of this model, a relative correction 2D/(π (B a² + D)(π/4 − 2/π)) ≈ 0.357 t²/a².
(In this model the hoop force is the constant −P/π; Navier's extensible ring has −(P/2)|sin θ| instead, but
the difference enters δ only at this same order t²/a².)

API (any consistent units; SI: m, N, Pa):

    ring = Ring(radius, thickness, young, poisson)   # a, t, E, μ
    ring.B, ring.D                                   # membrane [force/length], bending [force·length] stiffness
    ring.w(theta, P), ring.v(theta, P)               # displacements [length]; theta [rad] from a load line
    ring.hoop_force(P)                               # N22 [force/length]
    ring.moment(theta, P)                            # M22 [force·length/length]
    ring.diametral_change(P)                         # δ [length], > 0 for P > 0 (inward loads)
    ring.bending_part(P), ring.membrane_part(P)      # the two terms of δ
    ring.lateral_change(P)                           # increase of the perpendicular diameter [length]
    ring.stiffness()                                 # P/δ [force/length per length]
    ring.w_series(theta, P, terms), ring.v_series(theta, P, terms)
    classical_diametral_change(P, radius, EI)        # (π/4 − 2/π) P R³/EI
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

#: Σ_{n = 2, 4, ...} 1/(n² − 1)² = π²/16 − 1/2
SERIES_SUM = math.pi**2 / 16 - 0.5


def classical_diametral_change(P: float, radius: float, EI: float) -> float:
    """The thin inextensible ring: δ = (π/4 − 2/π) P R³/EI (P per unit length, EI per unit length)."""
    return (math.pi / 4 - 2 / math.pi) * P * radius**3 / EI


@dataclass(frozen=True)
class Ring:
    """A long pipe in plane strain under two inward line loads P at θ = 0 and θ = π (see the module docstring)."""

    radius: float  # a, mid-surface radius
    thickness: float  # t
    young: float  # E
    poisson: float  # μ

    @property
    def B(self) -> float:
        return self.young * self.thickness / (1 - self.poisson**2)

    @property
    def D(self) -> float:
        return self.young * self.thickness**3 / (12 * (1 - self.poisson**2))

    @property
    def _BD(self) -> float:
        """B a² + D."""
        return self.B * self.radius**2 + self.D

    @staticmethod
    def _reduced(theta) -> tuple[np.ndarray, np.ndarray]:
        """θ reduced to [0, π) (everything is π-periodic) and ψ = θ − π/2."""
        th = np.mod(np.asarray(theta, dtype=float), math.pi)
        return th, th - math.pi / 2

    # -- closed forms -----------------------------------------------------------------------------
    def w(self, theta, P: float) -> np.ndarray:
        """Normal displacement, positive outward."""
        a3, D = self.radius**3, self.D
        _, psi = self._reduced(theta)
        return P * a3 / (math.pi * D) - P * a3 / (math.pi * self._BD) - P * a3 / (4 * D) * (
            np.cos(psi) + psi * np.sin(psi))

    def v(self, theta, P: float) -> np.ndarray:
        """Circumferential displacement along e2 (increasing θ)."""
        th, psi = self._reduced(theta)
        return P * self.radius**3 / self.D * (0.5 - th / math.pi + (2 * np.sin(psi) - psi * np.cos(psi)) / 4)

    def hoop_force(self, P: float) -> float:
        """N22 = B ε22, constant around the ring (compressive for P > 0)."""
        return -P / math.pi * self.B * self.radius**2 / self._BD

    def moment(self, theta, P: float) -> np.ndarray:
        """M22 = D κ22 = −D (w'' + w)/a² (MODEL.md §3 sign: negative under the loads for P > 0)."""
        th, _ = self._reduced(theta)
        return P * self.radius * (np.sin(th) / 2 - 1 / math.pi + self.D / (math.pi * self._BD))

    def bending_part(self, P: float) -> float:
        return (math.pi / 4 - 2 / math.pi) * P * self.radius**3 / self.D

    def membrane_part(self, P: float) -> float:
        return 2 * P * self.radius**3 / (math.pi * self._BD)

    def diametral_change(self, P: float) -> float:
        """δ = −2 w(0): the shortening of the diameter between the load lines."""
        return self.bending_part(P) + self.membrane_part(P)

    def lateral_change(self, P: float) -> float:
        """2 w(π/2): the lengthening of the diameter perpendicular to the loads."""
        return (2 / math.pi - 0.5) * P * self.radius**3 / self.D - 2 * P * self.radius**3 / (math.pi * self._BD)

    def stiffness(self) -> float:
        """P/δ."""
        return 1.0 / self.diametral_change(1.0)

    # -- the Fourier series the closed forms sum (an independent check) ---------------------------
    def _coefficients(self, P: float, terms: int) -> tuple[float, np.ndarray, np.ndarray]:
        n = 2 * np.arange(1, terms + 1)
        w0 = -P * self.radius**3 / (math.pi * self._BD)
        wn = -2 * P * self.radius**3 / (math.pi * self.D * (n**2 - 1.0) ** 2)
        return w0, n, wn

    def w_series(self, theta, P: float, terms: int = 2000) -> np.ndarray:
        w0, n, wn = self._coefficients(P, terms)
        th = np.asarray(theta, dtype=float)
        return w0 + np.cos(np.multiply.outer(th, n)) @ wn

    def v_series(self, theta, P: float, terms: int = 2000) -> np.ndarray:
        _, n, wn = self._coefficients(P, terms)
        th = np.asarray(theta, dtype=float)
        return -np.sin(np.multiply.outer(th, n)) @ (wn / n)
