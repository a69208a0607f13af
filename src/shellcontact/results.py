"""Post-processing of a discrete solution U: fields, resultants, stresses, energy, reactions."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from .geometry import Shell, rigid_motion, to_global
from .model import RESULTANTS, resultants, strains
from .spaces import QUANTITIES, ShellSpace


@dataclass
class ShellSolution:
    """A displacement field U ∈ V_h with the operators that produced it."""

    space: ShellSpace
    U: np.ndarray
    A: sp.csr_matrix  # full (unreduced) stiffness
    F: np.ndarray  # full load vector
    extra_forces: np.ndarray | None = None  # e.g. contact forces Bᵀ Λ in the balance A U = F + ...

    @property
    def shell(self) -> Shell:
        return self.space.mesh.shell

    # -- fields ----------------------------------------------------------------------------
    def evaluate(self, x, phi, quantities=QUANTITIES) -> dict[str, np.ndarray]:
        """u, v, w and their (x, s) derivatives at points (x, φ) (φ in radians)."""
        ops = self.space.point_operators(x, self.shell.radius * np.asarray(phi, float), quantities)
        return {k: op @ self.U for k, op in ops.items()}

    def displacement(self, x, phi, zeta: float = 0.0, values: dict | None = None) -> np.ndarray:
        """Global displacement (3, n) of the point Φ + ζ n (Kirchhoff kinematics, MODEL.md §5).
        ``values``: ``evaluate(x, phi)`` already computed at these points."""
        a = self.shell.radius
        d = values if values is not None else self.evaluate(x, phi, ("u", "v", "w", "w_x", "w_s"))
        local = np.stack(
            [
                d["u"] - zeta * d["w_x"],
                d["v"] * (1.0 + zeta / a) - zeta * d["w_s"],
                d["w"],
            ]
        )
        return to_global(local, np.atleast_1d(np.asarray(phi, float)))

    def strains(self, x, phi, values: dict | None = None) -> np.ndarray:
        return strains(values if values is not None else self.evaluate(x, phi), self.shell.radius)

    def resultants(self, x, phi, values: dict | None = None) -> dict[str, np.ndarray]:
        """Stress resultants N11, N22, N12 (force/length) and M11, M22, M12 (moment/length).
        ``values``: ``evaluate(x, phi)`` already computed at these points."""
        x, phi = np.atleast_1d(np.asarray(x, float)), np.atleast_1d(np.asarray(phi, float))
        r = resultants(self.shell, self.strains(x, phi, values), self.shell.t(x, phi))
        return dict(zip(RESULTANTS, r))

    def stresses(self, x, phi, zeta) -> dict[str, np.ndarray]:
        """Stresses σ11, σ22, σ12 at distance ζ from the middle surface: σ = Q (ε + ζ κ), κ = (κ11, κ22, 2κ12)
        (MODEL.md §3), written N/t + 12 ζ M/t³ with the material's resultants (Q constant through the thickness)."""
        x, phi = np.atleast_1d(np.asarray(x, float)), np.atleast_1d(np.asarray(phi, float))
        r = self.resultants(x, phi)
        t = self.shell.t(x, phi)
        return {
            f"sigma{ij}": r[f"N{ij}"] / t + 12.0 * np.asarray(zeta) * r[f"M{ij}"] / t**3 for ij in ("11", "22", "12")
        }

    # -- global quantities ----------------------------------------------------------------------
    @property
    def energy(self) -> float:
        """Strain energy ½ a(U, U)."""
        return 0.5 * float(self.U @ (self.A @ self.U))

    @property
    def max_abs_w(self) -> float:
        """Largest |w| over the mesh vertices."""
        return float(np.max(np.abs(self.U[self.space.w_slice][: 6 * self.space.nv : 6])))

    def reactions(self) -> np.ndarray:
        """Generalised support reactions R = A U − F − (other forces); zero at free dofs."""
        R = self.A @ self.U - self.F
        if self.extra_forces is not None:
            R -= self.extra_forces
        return R

    def reaction_resultant(self) -> np.ndarray:
        """Global force that the supports exert on the shell: R · I_h(e_k) for k = x, y, z."""
        R = self.reactions()
        return np.array(
            [R @ self.space.interpolate(rigid_motion(self.shell, np.eye(3)[k], np.zeros(3))) for k in range(3)]
        )

    def deformed_vertices(self, scale: float = 1.0) -> np.ndarray:
        """3D coordinates (3, nv) of the deformed middle surface at the mesh vertices."""
        p = self.space.mesh.p
        phi = p[1] / self.shell.radius
        return self.shell.point(p[0], phi) + scale * self.displacement(p[0], phi)

    def prolongate(self, space: ShellSpace) -> np.ndarray:
        """This field interpolated into another (typically finer, nested) space: a warm start."""
        a = self.shell.radius
        return space.interpolate(lambda x, s: self.evaluate(x, s / a))

    def probe(self, x: float, phi: float) -> dict:
        d = self.evaluate([x], [phi], ("u", "v", "w"))
        return {
            "x": float(x),
            "phi": float(np.degrees(phi)),
            "u": float(d["u"][0]),
            "v": float(d["v"][0]),
            "w": float(d["w"][0]),
            "displacement": [float(c) for c in self.displacement([x], [phi])[:, 0]],
        }
