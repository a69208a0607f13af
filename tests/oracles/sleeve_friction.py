"""An independent 1D oracle for friction (issue 26): an axisymmetric cylinder squeezed by a rigid sleeve that is
then pulled along the axis, with Coulomb (or Tresca) friction on the contact face.

Shares no code with ``shellcontact``: the shell is the 1D model of ``oracles.axisym`` (its ``assemble``: radial
w(x) a beam on an elastic foundation, axial u(x) a bar, coupled through ν by N11 = B(u' + ν w/a)), the contact
rows are written here from the kinematics of MODEL.md §5 restricted to the axisymmetric state, and the QP is
solved by SciPy's bounded-variable least squares (an exact active-set method), not by the package's MPGP.

At every mesh node x_i of the sleeve's zone (M_i = (x_i, a + ζ), ζ = +t/2 on the outer face):

    normal    Π_i = Z(M_i) + Z_x (u − ζ w')_i + Z_ρ w_i ≥ 0        (the sleeve: Z = R − ρ, Z_x = 0, Z_ρ = −1)
    tangent   σ_i = (u − ζ w')_i − s                                 (slip of the face relative to the sleeve)

with nodal forces per unit circumferential length of the mid-surface: Λ_i ≥ 0 (normal) and T_i (axial, on the
shell). The law: |T_i| ≤ g_i; σ_i = 0 where |T_i| < g_i (stick); σ_i T_i ≤ 0 where |T_i| = g_i (slip against
the force). Tresca: g_i given; Coulomb: g_i = μ Λ_i |∇Z_i| by the fixed point g ← μ Λ(g) on Tresca problems.

Each Tresca problem is the dual  min ½ yᵀ S y + yᵀ(Ĝ + B̂ A⁻¹ F)  over Λ ≥ 0, −g ≤ T ≤ g, y = (Λ, T),
B̂ = [B; C], Ĝ = (G; −s), S = B̂ A⁻¹ B̂ᵀ (dense, A⁻¹ by the refined extended-precision LU of ``axisym``),
written as the bounded least-squares problem min ½‖Rᵀy + R⁻¹b‖² with S = R Rᵀ, solved by BVLS.
Totals on the whole circumference are 2πa × the sums per unit length.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import scipy.linalg as sla
import scipy.optimize as sopt
import scipy.sparse as sp

from .axisym import Shell1D, _Refined, assemble


@dataclass
class FrictionSleeve1D:
    """The solution: nodes x of the zone, Λ and T (per unit circumferential length), slip σ, bounds g."""

    shell: Shell1D
    x: np.ndarray
    weights: np.ndarray  # the zone's nodes' trapezoidal lengths cut to the zone (m): the 1D measure of a node
    lam: np.ndarray
    T: np.ndarray
    slip: np.ndarray
    g: np.ndarray
    iterations: int

    @property
    def state(self) -> np.ndarray:
        """0 open, 1 stick, 2 slip (|T_i| = g_i within 1e-6 of g_i) per node."""
        closed = (self.lam > 0) & (self.g > 0)
        return np.where(closed, np.where(np.abs(self.T) >= (1 - 1e-6) * self.g, 2, 1), 0)

    def total(self, per_length: np.ndarray) -> float:
        return 2.0 * math.pi * self.shell.radius * float(np.sum(per_length))

    @property
    def normal_force(self) -> float:
        """The normal force on the whole circumference (N): 2πa Σ Λ_i (|∇Z| = 1 for the sleeve)."""
        return self.total(self.lam)

    @property
    def friction_force(self) -> float:
        """The axial friction force on the shell, whole circumference (N)."""
        return self.total(self.T)

    @property
    def slip_length(self) -> float:
        """Σ of the trapezoidal lengths of the slipping nodes (m)."""
        return float(self.weights[self.state == 2].sum())


def solve_sleeve_friction(shell: Shell1D, nodes: np.ndarray, radius: float, zone: tuple[float, float], slide: float,
                          mu: float = 0.0, tresca: float | None = None, bc0: str = "clamped", bc1: str = "clamped",
                          pw: int = 5, pu: int = 2, tol: float = 1e-11, max_iterations: int = 100,
                          path: tuple[float, ...] = ()) -> FrictionSleeve1D:
    """A sleeve of inner ``radius`` over ``zone`` on the outer face, pulled by ``slide`` (m) along the axis, with
    Coulomb's ``mu`` or the Tresca bound ``tresca`` (force per unit area, times the node's trapezoidal length on
    the nodes in contact). ``path``: the slides (m) of the steps before the last (the sleeve in place from the
first): each step's law acts on the slip since the last step (slip σ_prev carried: the slide offset of a step
is s_k + σ_prev). Raises RuntimeError if a fixed point does not converge to ``tol`` (relative)."""
    nodes = np.asarray(nodes, float)
    asm = assemble(shell, nodes, bc0, bc1, pw=pw, pu=pu)
    free = np.setdiff1d(np.arange(asm.ndof), asm.fixed)
    lu = _Refined(asm.A[free][:, free])
    zeta = shell.thickness / 2
    idx = np.flatnonzero((nodes >= zone[0] - 1e-12) & (nodes <= zone[1] + 1e-12))
    m = len(idx)
    x = nodes[idx]
    wdof = asm.nn + 2 * idx
    r = np.repeat(np.arange(m), 3)
    cols = np.stack([idx, wdof + 1, wdof], -1).ravel()
    B = sp.csr_matrix((np.tile([0.0, 0.0, -1.0], m), (r, cols)), shape=(m, asm.ndof))
    C = sp.csr_matrix((np.tile([1.0, -zeta, 0.0], m), (r, cols)), shape=(m, asm.ndof))
    G = np.full(m, radius - (shell.radius + zeta))
    Bh = sp.vstack([B, C], format="csr")[:, free]
    X = lu.solve(np.asarray(Bh.T.todense(), dtype=np.longdouble))
    S = np.asarray(Bh @ X, dtype=float)
    S = 0.5 * (S + S.T)
    b0 = np.concatenate([G, np.zeros(m)]) + np.asarray(Bh @ lu.solve(asm.F[free]), dtype=float)
    mids = np.concatenate([[nodes[0]], 0.5 * (nodes[1:] + nodes[:-1]), [nodes[-1]]])  # a node's trapezoid, cut to
    weights = np.clip(mids[idx + 1], *zone) - np.clip(mids[idx], *zone)  # the zone (half at the zone's ends)

    def tresca_solve(g: np.ndarray, offset: np.ndarray) -> np.ndarray:
        """The Tresca dual with bounds g and slide offsets; pairs with g_i = 0 have T_i = 0 and leave the QP."""
        b = b0 - np.concatenate([np.zeros(m), offset])
        keep = np.concatenate([np.ones(m, bool), g > 0])
        R = sla.cholesky(S[np.ix_(keep, keep)], lower=True)  # S = R Rᵀ on the kept variables
        rhs = -sla.solve_triangular(R, b[keep], lower=True)
        lo = np.concatenate([np.zeros(m), -g[g > 0]])
        hi = np.concatenate([np.full(m, np.inf), g[g > 0]])
        y = np.zeros(2 * m)
        y[keep] = sopt.lsq_linear(R.T, rhs, bounds=(lo, hi), method="bvls", tol=1e-15, max_iter=50 * m).x
        return y

    def bounds(lam: np.ndarray) -> np.ndarray:
        if tresca is not None:
            return np.where(lam > 0, tresca * weights, 0.0)
        return mu * np.maximum(lam, 0.0)

    def coulomb(offset: np.ndarray) -> tuple[np.ndarray, np.ndarray, int]:
        y = tresca_solve(np.zeros(m), offset)
        g = bounds(y[:m])
        iterations = 0
        while True:
            iterations += 1
            y = tresca_solve(g, offset)
            g_new = bounds(y[:m])
            change = float(np.abs(g_new - g).max())
            g = g_new
            if change <= tol * max(float(g.max()), 1e-300):
                return y, g, iterations
            if iterations == max_iterations:
                raise RuntimeError(f"sleeve friction oracle: no fixed point in {max_iterations} iterations")

    sigma = np.zeros(m)  # the slip since the start, carried from step to step
    for s in (*path, slide):
        y, g, iterations = coulomb(s + sigma)
        U = np.zeros(asm.ndof)
        U[free] = np.asarray(lu.solve(asm.F[free] + np.asarray(Bh.T @ y, dtype=np.longdouble)), dtype=float)
        sigma = C @ U - s
    lam, T = y[:m], y[m:]
    lam = np.where(lam > 1e-12 * lam.max(), lam, 0.0)
    slip = sigma
    return FrictionSleeve1D(shell, x, weights, lam, T, slip, g, iterations)
