"""Post-processing of a discrete solution U: fields, resultants, strains and stresses through the
thickness, energy, reactions.

Surfaces: ``bottom`` (inner, ζ = −t/2), ``middle`` (ζ = 0), ``top`` (outer, ζ = +t/2). At distance ζ
from the middle surface (MODEL.md §3, Kirchhoff–Love, the model's own strains of §2)

    ε(ζ) = (ε11, ε22, γ12) + ζ (κ11, κ22, 2κ12),    σ(ζ) = Q ε(ζ)   (plane stress, Q of the material),

von Mises σ_v = √(σ11² − σ11σ22 + σ22² + 3σ12²), principal stresses σ_{1,2} = (σ11 + σ22)/2 ±
√(((σ11 − σ22)/2)² + σ12²) and the angle θ of σ_1 from the axis x toward the circumference,
tan 2θ = 2σ12/(σ11 − σ22). Components are in the shell's local frame (e1 = axial, e2 = circumferential).
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from ..shell.geometry import Shell, rigid_motion, to_global
from ..shell.model import RESULTANTS, resultants, strains
from ..shell.spaces import QUANTITIES, ShellSpace

#: the surfaces where strains and stresses are reported: ζ as a fraction of the thickness t
SURFACES = {"bottom": -0.5, "middle": 0.0, "top": 0.5}


@dataclass(frozen=True)
class SurfaceState:
    """Strain (ε11, ε22, γ12) and stress (σ11, σ22, σ12) at points of one surface, shapes (3, n)."""

    strain: np.ndarray
    stress: np.ndarray

    @property
    def von_mises(self) -> np.ndarray:
        s11, s22, s12 = self.stress
        return np.sqrt(np.maximum(s11**2 - s11 * s22 + s22**2 + 3.0 * s12**2, 0.0))

    @property
    def principal(self) -> np.ndarray:
        """(σ_1, σ_2), σ_1 ≥ σ_2, shape (2, n)."""
        s11, s22, s12 = self.stress
        mean, radius = 0.5 * (s11 + s22), np.hypot(0.5 * (s11 - s22), s12)
        return np.stack([mean + radius, mean - radius])

    @property
    def principal_angle(self) -> np.ndarray:
        """Angle of σ_1 from the axis x toward the circumferential direction, degrees in (−90, 90]."""
        s11, s22, s12 = self.stress
        return np.degrees(0.5 * np.arctan2(2.0 * s12, s11 - s22))


@dataclass
class ShellSolution:
    """A displacement field U ∈ V_h with the operators that produced it."""

    space: ShellSpace
    U: np.ndarray
    A: sp.csr_matrix  # full (unreduced) stiffness
    F: np.ndarray  # full load vector
    extra_forces: np.ndarray | None = None  # e.g. contact forces Bᵀ Λ in the balance A U = F + ...
    #: the rigid part of U of a shell held by contact alone (floating.py): strains, energy and reactions are
    #: those of the elastic part U − rigid (an interpolated rigid motion is not exactly stress-free in V_h)
    rigid: np.ndarray | None = None

    @property
    def elastic(self) -> np.ndarray:
        return self.U if self.rigid is None else self.U - self.rigid

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
        """Strains of the elastic part (``values``: ``evaluate(x, phi)`` of U, already computed)."""
        d = values if values is not None else self.evaluate(x, phi)
        if self.rigid is not None:
            ops = self.space.point_operators(x, self.shell.radius * np.asarray(phi, float), tuple(d))
            d = {k: v - ops[k] @ self.rigid for k, v in d.items()}
        return strains(d, self.shell.radius)

    def resultants(self, x, phi, values: dict | None = None) -> dict[str, np.ndarray]:
        """Stress resultants N11, N22, N12 (force/length) and M11, M22, M12 (moment/length).
        ``values``: ``evaluate(x, phi)`` already computed at these points."""
        x, phi = np.atleast_1d(np.asarray(x, float)), np.atleast_1d(np.asarray(phi, float))
        r = resultants(self.shell, self.strains(x, phi, values), self.shell.t(x, phi))
        return dict(zip(RESULTANTS, r))

    def surface(self, x, phi, surface: str, values: dict | None = None) -> SurfaceState:
        """Strains, stresses, von Mises and principal stresses on ``surface`` (bottom, middle, top) at (x, φ)."""
        x, phi = np.atleast_1d(np.asarray(x, float)), np.atleast_1d(np.asarray(phi, float))
        e = self.strains(x, phi, values)
        zeta = SURFACES[surface] * self.shell.t(x, phi)
        strain = e[:3] + zeta * np.stack([e[3], e[4], 2.0 * e[5]])
        return SurfaceState(strain, np.einsum("ij,j...->i...", self.shell.material.plane_stress, strain))

    # -- global quantities ----------------------------------------------------------------------
    @property
    def energy(self) -> float:
        """Strain energy ½ a(U, U) (of the elastic part)."""
        return 0.5 * float(self.elastic @ self._AU)

    @functools.cached_property
    def _AU(self) -> np.ndarray:
        """A U of the elastic part, shared by the energy and the reactions (one product with A: 20 ms at 216k dofs)."""
        AU = self.A @ self.elastic
        AU.setflags(write=False)
        return AU

    @property
    def max_abs_w(self) -> float:
        """Largest |w| over the mesh vertices."""
        return float(np.max(np.abs(self.U[self.space.w_slice][: 6 * self.space.nv : 6])))

    def reactions(self) -> np.ndarray:
        """Generalised support reactions R = A U − F − (other forces); zero at free dofs (computed once: the
        summary reads them three times; read only)."""
        return self._reactions

    @functools.cached_property
    def _reactions(self) -> np.ndarray:
        R = self._AU - self.F
        if self.extra_forces is not None:
            R -= self.extra_forces
        R.setflags(write=False)
        return R

    @functools.cached_property
    def rigid_modes(self) -> np.ndarray:
        """(6, ndofs): the interpolated rigid translations along x, y, z and rotations about x, y, z (origin)."""
        e = np.eye(3)
        modes = [rigid_motion(self.shell, e[k], np.zeros(3)) for k in range(3)]
        modes += [rigid_motion(self.shell, np.zeros(3), e[k]) for k in range(3)]
        return self.space.memoized(("rigid_modes",), lambda: np.array([self.space.interpolate(m) for m in modes]))

    def resultant(self, forces: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Global force and moment about the origin of generalised nodal forces: their work on the rigid
        translations and rotations (force_k = f · I_h(e_k), moment_k = f · I_h(e_k × X))."""
        w = self.rigid_modes @ np.asarray(forces, float)
        return w[:3], w[3:]

    def reaction_resultant(self) -> np.ndarray:
        """Global force that the supports exert on the shell: R · I_h(e_k) for k = x, y, z."""
        return self.resultant(self.reactions())[0]

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
        """Displacement, and strain and stress on each surface, at (x, φ) (local frame: 1 = x, 2 = circumference)."""
        d = self.evaluate([x], [phi])
        out = {
            "x": float(x),
            "phi": float(np.degrees(phi)),
            "u": float(d["u"][0]),
            "v": float(d["v"][0]),
            "w": float(d["w"][0]),
            "displacement": [float(c) for c in self.displacement([x], [phi], values=d)[:, 0]],
            "stress": {},
            "strain": {},
        }
        for name in SURFACES:
            st = self.surface([x], [phi], name, d)
            s11, s22, s12 = (float(c) for c in st.stress[:, 0])
            e11, e22, g12 = (float(c) for c in st.strain[:, 0])
            out["stress"][name] = {"s11": s11, "s22": s22, "s12": s12, "von_mises": float(st.von_mises[0])}
            out["strain"][name] = {"e11": e11, "e22": e22, "g12": g12}
        return out

    @functools.cached_property
    def sampled(self) -> tuple[np.ndarray, np.ndarray, dict[str, np.ndarray]]:
        """x, φ and the fields at the vertices of ``sampling_mesh``: evaluated once for the stress maxima and the
        von Mises map."""
        x, s = sampling_mesh(self.space.mesh.mesh).p
        phi = s / self.shell.radius
        return x, phi, self.evaluate(x, phi)

    def stress_extremes(self, yield_stress: float | None = None) -> dict[str, dict]:
        """Per surface, over the vertices of ``sampling_mesh`` (the mesh refined uniformly, as von_mises.png
        draws it: the stresses vary inside an element, and their peak is rarely at a vertex): the largest von
        Mises stress and where (x, φ in degrees), the largest and smallest principal stress, and the
        utilisation σ_v / yield_stress if given."""
        x, phi, d = self.sampled
        out = {}
        for name in SURFACES:
            st = self.surface(x, phi, name, d)
            vm, (p1, p2) = st.von_mises, st.principal
            k = int(np.argmax(vm))
            out[name] = {
                "von_mises_max": float(vm[k]),
                "at": {"x": float(x[k]), "phi": float(np.degrees(phi[k]))},
                "max_principal": float(np.max(p1)),
                "min_principal": float(np.min(p2)),
            }
            if yield_stress is not None:
                out[name]["utilisation_max"] = float(vm[k] / yield_stress)
        return out


#: stress maxima (``ShellSolution.stress_extremes``) and the von Mises map sample the fields on a uniformly
#: refined copy of the mesh with at most about this many vertices
SAMPLING_POINTS = 30000


def sampling_mesh(mesh, max_points: int = SAMPLING_POINTS):
    """A uniformly refined copy of a MeshTri with at most ~max_points vertices (level ≤ 3; the mesh itself
    when it already has more)."""
    level = 0
    while level < 3 and mesh.p.shape[1] * 4 ** (level + 1) <= max_points:
        level += 1
    return mesh.refined(level) if level else mesh
