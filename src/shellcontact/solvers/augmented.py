"""The augmented Lagrangian's outer loop for a contact QP with δ unknowns (MODEL.md §8: force-controlled punches,
a shell's rigid motions), shared by the frictionless dual (``dual.dual_core``, MPRGP inside) and the Tresca dual
(``tresca.solve_tresca_dual``, MPGP on discs inside).

The problem: min ½yᵀHy + linᵀy over a convex set (Λ ≥ 0, and |T_j| ≤ g_j with friction) subject to the
balance Dᵀy = −P, whose multiplier is δ. SMALBE's outer step (Dostál, *Optimal Quadratic Programming
Algorithms*, 2009, ch. 9): the inner QP on H + ρDDᵀ with the linear term lin + D(δ + ρP), whose gradient is the
gap (and slip) at the travels δ + ρ(Dᵀy + P); then δ ← δ + ρ(Dᵀy + P). The inner solver is a parameter
``inner(delta, rho, y) → (y, iterations, converged)``; so are the exact finish on a face (``polish``) and the
growth of ρ where the balance's error falls slowly.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

Inner = Callable[[np.ndarray, float, np.ndarray | None], tuple[np.ndarray, int, bool]]


@dataclass(frozen=True)
class RhoGrowth:
    """ρ ← ``factor`` ρ whenever an outer step divides the balance's error by less than ``gain``, up to
    ``limit`` times its first value."""

    factor: float
    gain: float
    limit: float


def augmented_lagrangian(inner: Inner, D: np.ndarray, P: np.ndarray, y: np.ndarray | None, delta: np.ndarray,
                         rho: float, tol: float, steps: int, size: Callable[[np.ndarray, np.ndarray], float],
                         budget: int, growth: RhoGrowth | None = None,
                         polish: Callable[[np.ndarray, np.ndarray], tuple[np.ndarray, np.ndarray] | None] | None
                         = None, record: Callable[[int, int, float], None] | None = None,
                         ) -> tuple[np.ndarray | None, np.ndarray, int, bool]:
    """At most ``steps`` outer steps (module docstring) from y, δ, stopping when ‖Dᵀy + P‖ / size(y, δ) ≤ tol
    (the gross size of the balance) or a ``polish`` of (y, δ) returns an exact point; ``budget`` bounds the inner
    iterations in all. ``record(step, iterations, error)`` after each step. Returns y, δ, iterations, converged."""
    rho0, last, total = rho, np.inf, 0
    for step in range(1, steps + 1):
        y, its, ok = inner(delta, rho, y)
        total += its
        if not ok:
            break
        h = D.T @ y + P
        delta = delta + rho * h
        if polish is not None and (exact := polish(y, delta)) is not None:
            return exact[0], exact[1], total, True
        error = float(np.linalg.norm(h)) / size(y, delta)
        if record is not None:
            record(step, total, error)
        if error <= tol:
            return y, delta, total, True
        if total >= budget:
            break
        if growth is not None and error > last / growth.gain and rho < growth.limit * rho0:
            rho *= growth.factor
        last = error
    return y, delta, total, False
