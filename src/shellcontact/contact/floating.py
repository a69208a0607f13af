"""A shell held by contact alone: its free rigid motions in the contact QP (semi-coercive contact).

The supports may leave rigid motions of the shell free (``supports.free_motions``: the kernel R of the
reduced stiffness, found from the supports, not numerically) when punches can hold it. The reduction
then fixes one tangential dof per free motion (``supports.gauge_dofs``), which makes the reduced
stiffness regular, and each free motion is one of four kinds (docs/solvers.md, "Shells held by
contact alone"):

* **restrained** — some constraint row where a punch first touches the undeformed shell sees it
  (B R c ≠ 0 there: ``first_contact_rows``): its amplitude α is an unknown of the QP exactly like the
  travel of a force-controlled punch, a column B R of D with the load Rᵀ F in P; its KKT row is the
  rigid mode's equilibrium Rᵀ(F + BᵀΛ) = 0;
* **balanced** — not seen at first contact, not excited (Rᵀ F c = 0), but seen by rows farther away (the
  tilted normals beside a line contact see the rotation of a ring about its axis: the linearised gap (4.8)
  is not invariant to it). It is a column of D as well, with no load (its Rᵀ F is below the excitation
  tolerance), so the contact forces do no work on it (its equilibrium row DᵀΛ = 0); the amount of it the
  rows allow (an interval) is not an answer of the problem, so after the solve it is set
  to no rigid component in the displacement (``settle``) as far as the gaps allow;
* **gauged** — seen by no row and not excited: the gauge alone fixes it (no gap depends on it), and the
  displacement's component along it is removed from the result;
* **held by friction** — seen by no row at first contact but by the tangential rows of a punch with friction
  (a vessel on concentric saddles: its axial sliding and its rotation about the axis). Friction restrains it:
  it is an unknown α like a restrained motion, with its load Rᵀ F, and its slips change by C R α
  (``friction_columns``); the gauge must not fix it, or the gauge's dof would carry the friction force's
  imbalance. Where the friction cannot hold its load (everything slides), there is no solution: the
  friction solve refuses it (``analysis.friction``), naming the motion, the punches and the force;
* **unrestrained and excited** — refused, naming the motion and the support that would remove it.

A load that moves the shell away from every punch that could hold it (a direction y of the rigid
motions and force-controlled travels with D y ≥ 0 and Pᵀ y > 0: the energy falls without bound) is
refused as well, naming the motion.

The elastic part U_e of the displacement is what the solver finds in the reduced space; the rigid part
(Σ α R c) is added afterwards. The interpolated rigid motions are not exactly stress-free in V_h (their
energy falls like h⁴), so strains and energy are those of the elastic part alone (results.ShellSolution
``rigid``), and the gauge dofs carry forces of the size of that interpolation error (none when they lie
on planes of symmetry of a symmetric solution). The rigid motion reported (``fit``) is the one that best
fits the whole displacement: least squares over the middle surface, ∫ |U − r|² dA by the vertices' areas.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from ..errors import InputError
from ..shell.spaces import ShellSpace
from ..shell.supports import Reduction, _echelon, describe_motion, remedy, right_singular, rigid_modes
from .friction import tangent_basis
from .operator import ContactOperator

#: a free motion carries no load when |Rᵀ F| is below this fraction of its gross size Σ |f_d r_d| (round-off,
#: or on an unsymmetric mesh the interpolation error of the motion, which is not exactly rigid in V_h)
EXCITATION_TOL = 1e-6
#: a row sees a motion when the exact motion's gap change |∇Z·r c| (``exact_gap_change``, not B R: the interpolated
#: motions' error at edge-midpoint rows reaches 3e-7) exceeds this fraction of the largest of the free motions'
#: (each displaces the shell by about 1): exact zeros (a plate's normal across a translation along it) stay zero
SEEN_TOL = 1e-8
#: a row carries a force when its Λ exceeds this fraction of the largest (below: round-off, e.g. the row an
#: exact method adds to the face to tell the columns of D apart, touching with Λ ≈ 1e-12 Λ_max); the default
#: of ``Floating.settle``, which analysis gives the solver's accuracy
CARRYING_TOL = 1e-10


@dataclass(frozen=True)
class Floating:
    """The free rigid motions of a contact problem: restrained, balanced and gauged ones."""

    modes: np.ndarray  # (ndofs, 6) the interpolated rigid motions (supports.rigid_modes)
    restrained: np.ndarray  # (kr, 6) basis of the motions held at first contact: unknowns α
    balanced: np.ndarray  # (kb, 6) basis of the motions only rows beside first contact see: unknowns too
    gauged: np.ndarray  # (ku, 6) basis of the motions no row sees and no load excites
    radius: float
    D: np.ndarray  # (m, kr + kb) B R: the gap's change per unit α
    P: np.ndarray  # (kr + kb,) Rᵀ F: the load's work per unit α (zero on a balanced motion: its Rᵀ F is round-off)
    areas: np.ndarray  # (nvertices,) the vertices' shares of the middle surface (P1 lumped), for ``fit``
    #: the last ``by_friction`` rows of ``restrained`` are held by friction alone (no row sees them at first contact)
    by_friction: int = 0

    @property
    def columns(self) -> np.ndarray:
        """(kr + kb, 6): the motions that are unknowns of the QP, in the order of the columns of D."""
        return np.vstack([self.restrained, self.balanced])

    @property
    def free(self) -> np.ndarray:
        """(k, 6): every free motion, restrained, balanced, gauged."""
        return np.vstack([self.restrained, self.balanced, self.gauged])

    @property
    def names(self) -> list[str]:
        return [describe_motion(c, self.radius) for c in self.columns]

    def rigid_part(self, alpha: np.ndarray) -> np.ndarray:
        """The full-space displacement Σ α_j R c_j of the QP's motions."""
        return self.modes @ (self.columns.T @ np.asarray(alpha, float))

    def fit(self, space: ShellSpace, U: np.ndarray) -> np.ndarray:
        """The free motions' amounts (k,) in U, in the order of ``free``: the rigid motion r that minimises
        ∫ |U − r|² dA, with the vertices' areas as weights on u, v, w (the frame is orthonormal)."""
        rows = _vertex_dofs(space)
        wt = np.sqrt(np.tile(self.areas, 3))
        R = (self.modes[rows] @ self.free.T) * wt[:, None]
        c, *_ = np.linalg.lstsq(R, U[rows] * wt, rcond=None)
        return c

    def settle(self, space: ShellSpace, U: np.ndarray, Lam: np.ndarray, gaps: np.ndarray,
               force_tol: float = CARRYING_TOL) -> tuple[np.ndarray, np.ndarray]:
        """The change (6,) of the rigid part that leaves U no component (``fit``) along the gauged motions,
        nor along the balanced ones as far as the linearised gaps allow: a row that carries a force keeps
        its gap (D_b y = 0 there), the others stay open (g + D_b y ≥ 0); the largest step toward the target
        that does (for one balanced motion, the nearest admissible amount). A row carries a force when its
        Λ exceeds ``force_tol`` Λ_max: the solver's accuracy (its tolerance; the penalty's predicted force
        error, whose touching rows carry O(κ) forces at round-off penetrations). Also the rows it opens that
        carry no force: no longer in contact (an exact method's face may hold one to tell the columns apart)."""
        kr, kb = len(self.restrained), len(self.balanced)
        c = self.fit(space, U)
        change = -c[kr + kb:] @ self.gauged if len(self.gauged) else np.zeros(6)
        opened = np.zeros(self.D.shape[0], dtype=bool)
        if kb:
            Lam = np.asarray(Lam, float)
            carrying = Lam > force_tol * max(float(Lam.max()) if Lam.size else 0.0, 0.0)
            y = _toward(self.D[:, kr:], -c[kr:kr + kb], carrying, np.asarray(gaps, float))
            change = change + y @ self.balanced
            opened = ~carrying & (self.D[:, kr:] @ y > 0.0)
        return change, opened

    def summary(self, coefficients: np.ndarray) -> dict:
        """The rigid motion ``coefficients`` (6,) as a translation and a rotation (radians) about the origin,
        and the names of the free motions by kind."""
        c = np.asarray(coefficients, float)
        return {"translation": [float(v) for v in c[:3]], "rotation": [float(v) / self.radius for v in c[3:]],
                "restrained": [describe_motion(g, self.radius) for g in self.restrained],
                "held_by_friction": [describe_motion(g, self.radius)
                                     for g in self.restrained[len(self.restrained) - self.by_friction:]],
                "balanced": [describe_motion(g, self.radius) for g in self.balanced],
                "gauged": [describe_motion(g, self.radius) for g in self.gauged]}


def _toward(Db: np.ndarray, target: np.ndarray, carrying: np.ndarray, gaps: np.ndarray) -> np.ndarray:
    """The amounts y (kb,) of the balanced motions nearest ``target`` along the segment from 0 that keeps the
    rows carrying a force where they are (D_b y = 0 there: ``target`` projected onto that null space) and
    the others open (g + D_b y ≥ 0; y = 0 is admissible, so a step s ∈ [0, 1] of it is)."""
    y = np.asarray(target, float)
    size = np.abs(Db).max(axis=1)
    seen = size > SEEN_TOL * max(float(size.max()) if size.size else 0.0, 1e-300)  # not round-off (cos 90°)
    held = Db[carrying & seen]
    if held.size:
        sv, vt = right_singular(held)
        rank = int(np.sum(sv > 1e-10 * max(float(sv[0]), 1e-300)))
        basis = vt[rank:]
        y = basis.T @ (basis @ y)
    step = Db @ y
    closing = ~carrying & (step < 0.0)
    s = 1.0
    if np.any(closing):
        s = float(np.clip(np.min(np.maximum(gaps[closing], 0.0) / -step[closing]), 0.0, 1.0))
    return s * y


def _vertex_dofs(space: ShellSpace) -> np.ndarray:
    v = np.arange(space.mesh.nvertices)
    return np.concatenate([space.u_dofs(v), space.v_dofs(v), space.w_vertex_dofs(v, ("w",))])


def vertex_areas(space: ShellSpace) -> np.ndarray:
    """Each vertex's share of the middle surface: a third of its triangles' areas (lumped P1 mass); the seam
    vertices of a periodic mesh count once on each side."""
    m = space.mesh
    area = 0.5 * np.abs(m._det())
    out = np.zeros(m.nvertices)
    for k in range(3):
        np.add.at(out, m.t[k], area / 3.0)
    return out


def analyse(space: ShellSpace, reduction: Reduction, op: ContactOperator, F: np.ndarray,
            rubbing: np.ndarray | None = None) -> Floating:
    """Classify the free motions of ``reduction`` against the contact rows of ``op`` and the load F;
    refuse those that nothing can hold (InputError naming every such motion). ``rubbing`` (bool, m): the rows
    of punches with friction, whose tangential rows hold the motions they see (module docstring)."""
    sh = space.mesh.shell
    modes = rigid_modes(space) if reduction.modes is None else reduction.modes
    free = reduction.motions
    # which rows see which motion, from the exact rigid motions (``exact_gap_change``): the interpolated ones
    # B R differ from them at edge-midpoint rows by their interpolation error (up to 3e-7 of the largest
    # entry on pipe_rollers, 8 x 8 and 16 x 16), which would make a motion no gap depends on "seen"
    exact = exact_gap_change(op, sh.radius)  # (m, 6)
    BR_all = exact @ free.T  # (m, k)
    restrained, unrestrained = _split(BR_all[first_contact_rows(op, sh.radius)], free, 1e-8)
    by_friction = 0
    if rubbing is not None and np.any(rubbing) and len(unrestrained):
        tangential = exact_slip_change(op, sh.radius)[:, rubbing]  # (2, rows, 6)
        held, unrestrained = _split(tangential.reshape(-1, 6) @ unrestrained.T, unrestrained, SEEN_TOL)
        restrained, by_friction = np.vstack([restrained, held]), len(held)
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
    balanced, gauged = np.zeros((0, 6)), unrestrained
    if len(unrestrained):  # which of them rows beside first contact see (relative to the free motions' size)
        scale = max(float(np.abs(BR_all).max()) if BR_all.size else 0.0, 1.0)
        BU = (exact @ unrestrained.T) / scale
        balanced, gauged = _split(BU, unrestrained, SEEN_TOL, relative=False)
    columns = np.vstack([restrained, balanced])
    R = modes @ columns.T
    D = np.asarray(op.B @ R).reshape(op.m, -1)  # the interpolated motions: the gaps of U = U_e + R α
    # rows that do not see a motion get exact zeros, not round-off (cos 90°) nor the interpolation error: a
    # face of rows that do not see it then leaves its amount undetermined exactly (not fixed by a 1e-7 entry:
    # a rotation of 42 rad about z on pipe_rollers at 8 x 8, from which the dual method did not return)
    E = exact @ columns.T
    D[np.abs(E) <= SEEN_TOL * max(float(np.abs(E).max()) if E.size else 0.0, 1e-300)] = 0.0
    P = R[:, :len(restrained)].T @ F
    for j in range(len(restrained) - by_friction, len(restrained)):  # held by friction: unexcited below round-off
        if abs(P[j]) <= EXCITATION_TOL * float(np.abs(R[:, j]) @ np.abs(F)):
            P[j] = 0.0
    floating = Floating(modes=modes, restrained=restrained, balanced=balanced, gauged=gauged, radius=sh.radius,
                        D=D, P=np.concatenate([P, np.zeros(len(balanced))]),
                        areas=vertex_areas(space), by_friction=by_friction)
    check_held(floating, op)
    return floating


def exact_slip_change(op: ContactOperator, radius: float) -> np.ndarray:
    """(2, m, 6): the change of each row's slip τ_ik·r(M_i) per unit of the six exact rigid motions
    (``exact_gap_change``'s units), τ_ik the punch's tangent vectors there (``friction.tangent_basis``)."""
    tau = tangent_basis(np.asarray(op.grad, float), np.asarray(op.phi, float))  # (2, 3, m)
    pts = np.asarray(op.points, float)
    out = np.zeros((2, op.m, 6))
    for j in range(3):
        e = np.zeros(3)
        e[j] = 1.0
        out[:, :, j] = tau[:, j]
        out[:, :, 3 + j] = np.einsum("kim,im->km", tau, np.cross(e[:, None] / radius, pts, axis=0))
    return out


def friction_columns(floating: Floating, C: sp.spmatrix) -> np.ndarray:
    """(2m, kr + kb): the slips' change C R per unit amount of the QP's motions (C: the full tangential rows)."""
    return np.asarray(C @ (floating.modes @ floating.columns.T)).reshape(C.shape[0], -1)


def exact_gap_change(op: ContactOperator, radius: float) -> np.ndarray:
    """(m, 6): the change of each row's linearised gap ∇Z(M_i)·r(M_i) per unit of the six exact rigid motions
    (translations; rotations by 1/a about the origin, as ``supports.rigid_modes``) at the contact points M_i.
    It equals B R at vertex rows to round-off; at edge-midpoint rows B R carries the interpolation error of
    the interpolated motions as well (the Kirchhoff–Love w is not exact there)."""
    grad, pts = np.asarray(op.grad, float), np.asarray(op.points, float)
    out = np.zeros((op.m, 6))
    for j in range(3):
        e = np.zeros(3)
        e[j] = 1.0
        out[:, j] = grad[j]
        out[:, 3 + j] = np.einsum("im,im->m", grad, np.cross(e[:, None] / radius, pts, axis=0))
    return out


def _split(BR: np.ndarray, motions: np.ndarray, tol: float, relative: bool = True) -> tuple[np.ndarray, np.ndarray]:
    """(seen, unseen): echelon bases of the combinations of ``motions`` that the rows BR (rows × k) see and of
    those they do not (singular values above ``tol``, relative to the largest unless not ``relative``)."""
    k = len(motions)
    if BR.shape[0] == 0 or k == 0:
        return np.zeros((0, 6)), motions
    sv, vt = right_singular(BR)
    rank = int(np.sum(sv > tol * (max(float(sv[0]), 1.0) if relative else 1.0)))
    seen = _echelon(vt[:rank] @ motions) if rank else np.zeros((0, 6))
    unseen = _echelon(vt[rank:] @ motions) if rank < k else np.zeros((0, 6))
    return seen, unseen


def first_contact_rows(op: ContactOperator, radius: float) -> np.ndarray:
    """The rows where each punch first touches the undeformed shell: its deepest rows, G ≤ min G + 1e-8 a
    (touching, overlapping by a prescribed indentation, or nearest when it starts apart). A motion seen only
    at rows farther away (the tilted normals beside a line contact, or the rest of the band an indented
    punch overlaps) is not held: the linearised gaps there allow a small amount of it either way (the
    rotation of a ring about its axis between frictionless plates). It is balanced, not restrained: no load
    may excite it (``analyse``)."""
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
    P = np.concatenate([op.forces, floating.P]) if kf else floating.P.copy()
    kr = len(floating.restrained)
    P[kf + kr - floating.by_friction:kf + kr] = 0.0  # friction holds those up to its capacity (checked in the solve)
    if D.shape[1] == 0:
        return
    scale = max(float(np.linalg.norm(P)), 1e-300)
    res = linprog(-P / scale, A_ub=-D, b_ub=np.zeros(D.shape[0]), bounds=[(-1.0, 1.0)] * D.shape[1],
                  method="highs")
    if res.status != 0 or -res.fun <= 1e-9 * np.sqrt(D.shape[1]):
        return
    y = np.where(np.abs(res.x) > 1e-9, res.x, 0.0)
    plain = y.copy()  # the balanced motions carry no load: named only if the escape needs them
    plain[kf + len(floating.restrained):] = 0.0
    if np.all(D @ plain >= -1e-9 * np.abs(D).max()):
        y = plain
    parts = []
    if np.any(y[kf:]):
        parts.append(describe_motion(floating.columns.T @ y[kf:], floating.radius))
    parts += [f"punch.{op.force_punches[j]} {'advancing' if y[j] > 0 else 'moving back'}" for j in range(kf) if y[j]]
    raise InputError("loads", f"the load moves the shell away from the punches along {' and '.join(parts)}: "
                     "nothing holds it (reverse the load, or add a punch or support on the other side)")
