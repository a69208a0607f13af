"""A shell held by contact alone: its free rigid motions in the contact QP (semi-coercive contact).

The supports may leave rigid motions of the shell free (``supports.free_motions``: the kernel R of the
reduced stiffness, found from the supports, not numerically) when punches can hold it. The reduction
then fixes one tangential dof per free motion (``supports.gauge_dofs``), which makes the reduced
stiffness regular, and each free motion is one of three kinds (docs/solvers.md, "Shells held by
contact alone"):

* **restrained** — some constraint row where a punch first touches the undeformed shell sees it
  (B R c ≠ 0 there: ``first_contact_rows``): its amplitude α is an unknown of the QP exactly like the
  travel of a force-controlled punch, a column B R of D with the load Rᵀ F in P; its KKT row is the
  rigid mode's equilibrium Rᵀ(F + BᵀΛ) = 0;
* **unrestrained but not excited** (B R c = 0, Rᵀ F c = 0): the gauge alone fixes it, and the
  displacement's least-squares component along it is removed from the result;
* **unrestrained and excited** — refused, naming the motion and the support that would remove it.

A load that moves the shell away from every punch that could hold it (a direction y of the rigid
motions and force-controlled travels with D y ≥ 0 and Pᵀ y > 0: the energy falls without bound) is
refused as well, naming the motion.

The elastic part U_e of the displacement is what the solver finds in the reduced space; the rigid part
(Σ α R c) is added afterwards. The interpolated rigid motions are not exactly stress-free in V_h (their
energy falls like h⁴), so strains and energy are those of the elastic part alone (results.ShellSolution
``rigid``), and the gauge dofs carry forces of the size of that interpolation error (none when they lie
on planes of symmetry of a symmetric solution).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .contact import ContactOperator
from .errors import InputError
from .spaces import ShellSpace
from .supports import Reduction, _echelon, describe_motion, remedy, rigid_modes

#: a free motion carries no load when |Rᵀ F| is below this fraction of its gross size Σ |f_d r_d| (round-off,
#: or on an unsymmetric mesh the interpolation error of the motion, which is not exactly rigid in V_h)
EXCITATION_TOL = 1e-6


@dataclass(frozen=True)
class Floating:
    """The free rigid motions of a contact problem, split into restrained and gauged ones."""

    modes: np.ndarray  # (ndofs, 6) the interpolated rigid motions (supports.rigid_modes)
    restrained: np.ndarray  # (kr, 6) basis of the restrained motions: the unknowns α
    gauged: np.ndarray  # (ku, 6) basis of the motions no punch restrains and no load excites
    radius: float
    D: np.ndarray  # (m, kr) B R: the gap's change per unit α
    P: np.ndarray  # (kr,) Rᵀ F: the load's work per unit α

    @property
    def names(self) -> list[str]:
        return [describe_motion(c, self.radius) for c in self.restrained]

    def rigid_part(self, alpha: np.ndarray) -> np.ndarray:
        """The full-space displacement Σ α_j R c_j of the restrained motions."""
        return self.modes @ (self.restrained.T @ np.asarray(alpha, float))

    def gauge(self, space: ShellSpace, U: np.ndarray) -> np.ndarray:
        """The coefficients (6,) of the gauged motions' component of U: least squares over the vertex
        displacements u, v, w (zero without gauged motions)."""
        if self.gauged.size == 0:
            return np.zeros(6)
        rows = _vertex_dofs(space)
        R = self.modes[rows] @ self.gauged.T
        c, *_ = np.linalg.lstsq(R, U[rows], rcond=None)
        return self.gauged.T @ c

    def summary(self, coefficients: np.ndarray) -> dict:
        """The rigid motion of the shell as a translation and a rotation (radians) about the origin."""
        c = np.asarray(coefficients, float)
        return {"translation": [float(v) for v in c[:3]], "rotation": [float(v) / self.radius for v in c[3:]],
                "restrained": self.names,
                "gauged": [describe_motion(g, self.radius) for g in self.gauged]}


def _vertex_dofs(space: ShellSpace) -> np.ndarray:
    v = np.arange(space.mesh.nvertices)
    return np.concatenate([space.u_dofs(v), space.v_dofs(v), space.w_vertex_dofs(v, ("w",))])


def analyse(space: ShellSpace, reduction: Reduction, op: ContactOperator, F: np.ndarray) -> Floating:
    """Classify the free motions of ``reduction`` against the contact rows of ``op`` and the load F;
    refuse those that nothing can hold (InputError naming every such motion)."""
    sh = space.mesh.shell
    modes = rigid_modes(space) if reduction.modes is None else reduction.modes
    free = reduction.motions
    BR = op.B[first_contact_rows(op, sh.radius)] @ (modes @ free.T)  # (rows, k)
    _, sv, vt = np.linalg.svd(BR, full_matrices=True) if BR.shape[0] else (None, np.zeros(0), np.eye(len(free)))
    rank = int(np.sum(sv > 1e-8 * max(float(sv[0]) if sv.size else 0.0, 1.0)))
    restrained = _echelon(vt[:rank] @ free) if rank else np.zeros((0, 6))
    unrestrained = _echelon(vt[rank:] @ free) if rank < len(free) else np.zeros((0, 6))
    excited = []
    for c in unrestrained:
        r = modes @ c
        work, gross = float(r @ F), float(np.abs(r) @ np.abs(F))
        if abs(work) > EXCITATION_TOL * gross:
            excited.append((c, work))
    if excited:
        what = "; ".join(f"{describe_motion(c, sh.radius)} (the loads do work {w:.4g} on it; remove it with "
                         f"{remedy(c)})" for c, w in excited)
        raise InputError("supports", f"the loads move the shell along a rigid motion that neither the supports nor "
                         f"any punch restrain: {what}")
    R = modes @ restrained.T
    floating = Floating(modes=modes, restrained=restrained, gauged=unrestrained, radius=sh.radius,
                        D=np.asarray(op.B @ R).reshape(op.m, -1), P=R.T @ F)
    check_held(floating, op)
    return floating


def first_contact_rows(op: ContactOperator, radius: float) -> np.ndarray:
    """The rows where each punch first touches the undeformed shell: its deepest rows, G ≤ min G + 1e-8 a
    (touching, overlapping by a prescribed indentation, or nearest when it starts apart). A motion
    restrained only at rows farther away (the tilted normals beside a line contact, or the rest of the band
    an indented punch overlaps) is not held: the linearised gaps there would allow a small amount of it
    either way, and the solution would not be unique (the rotation of a ring about its axis between
    frictionless plates)."""
    rows = []
    for k in range(len(op.punches)):
        r = op.rows(k)
        if r.size:
            g = op.G[r]
            rows.append(r[g <= float(g.min()) + 1e-8 * radius])
    return np.concatenate(rows) if rows else np.zeros(0, dtype=int)


def check_held(floating: Floating, op: ContactOperator) -> None:
    """Refuse a load that moves the shell away from every punch that could hold it: a direction y of the
    restrained motions (and force-controlled travels) along which no gap closes (D y ≥ 0) while the loads
    do positive work (Pᵀ y > 0), so the energy falls without bound. Found by a small LP (HiGHS)."""
    from scipy.optimize import linprog

    kf = 0 if op.D is None else op.D.shape[1]
    D = floating.D if op.D is None else np.hstack([op.D, floating.D])
    P = np.concatenate([op.forces, floating.P]) if kf else floating.P
    if D.shape[1] == 0:
        return
    scale = max(float(np.linalg.norm(P)), 1e-300)
    res = linprog(-P / scale, A_ub=-D, b_ub=np.zeros(D.shape[0]), bounds=[(-1.0, 1.0)] * D.shape[1],
                  method="highs")
    if res.status != 0 or -res.fun <= 1e-9 * np.sqrt(D.shape[1]):
        return
    y = np.where(np.abs(res.x) > 1e-9, res.x, 0.0)
    parts = []
    if np.any(y[kf:]):
        parts.append(describe_motion(floating.restrained.T @ y[kf:], floating.radius))
    parts += [f"punch.{op.force_punches[j]} {'advancing' if y[j] > 0 else 'moving back'}" for j in range(kf) if y[j]]
    raise InputError("loads", f"the load moves the shell away from the punches along {' and '.join(parts)}: "
                     "nothing holds it (reverse the load, or add a punch or support on the other side)")
