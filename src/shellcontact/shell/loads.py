"""Work-consistent load vectors F with F·V = L(V) (MODEL.md §3, loads).

Surface loads are per unit area of the middle surface, line loads per unit length, point
loads are forces; global vectors are [fx, fy, fz], ``normal`` is along the outward normal
n (positive outward: internal pressure is a positive ``normal``). Any value may be a
callable of (x, φ) (vectorised, φ in radians).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from ..errors import InputError
from ..inputs.user_functions import UserFunction, user_function
from .geometry import Shell, to_local
from .model import element_chunks
from .spaces import ShellSpace

Value = float | Callable[[np.ndarray, np.ndarray], np.ndarray]
Vector = tuple[float, float, float] | Callable[[np.ndarray, np.ndarray], np.ndarray]


def _eval(value, x, phi) -> np.ndarray:
    if callable(value):
        return _checked(value, "loads").field(x, phi)
    return np.full(np.shape(x), float(value))


def _eval_vec(value, x, phi) -> np.ndarray:
    if callable(value):
        return _checked(value, "loads").vector_field(x, phi)
    return np.asarray(value, dtype=float).reshape((3,) + (1,) * np.ndim(x)) * np.ones(np.shape(x))


def _checked(value, where: str):
    """A callable load as a ``UserFunction`` for the key ``where`` (its calls then fail by that name); a
    ``UserFunction`` keeps the key it was given for."""
    if isinstance(value, UserFunction) or not callable(value):
        return value
    return user_function(value, where)


@dataclass(frozen=True)
class LineLoad:
    """Load per unit length along the mesh line x = ``x`` or φ = ``phi`` (radians)."""

    force: Vector = (0.0, 0.0, 0.0)
    normal: Value = 0.0
    x: float | None = None
    phi: float | None = None

    def __post_init__(self) -> None:
        if (self.x is None) == (self.phi is None):
            raise InputError("loads.line", "give exactly one of 'x' or 'phi'")


@dataclass(frozen=True)
class PointLoad:
    """A force [fx, fy, fz] (global) at (x, φ)."""

    x: float
    phi: float
    force: tuple[float, float, float]


@dataclass(frozen=True)
class Loads:
    normal: Value = 0.0
    surface: Vector = (0.0, 0.0, 0.0)
    lines: tuple[LineLoad, ...] = field(default_factory=tuple)
    points: tuple[PointLoad, ...] = field(default_factory=tuple)

    def __post_init__(self) -> None:
        object.__setattr__(self, "normal", _checked(self.normal, "loads.normal"))
        object.__setattr__(self, "surface", _checked(self.surface, "loads.surface"))
        lines = tuple(
            dataclasses.replace(ln, force=_checked(ln.force, f"loads.line.{i}.force"),
                                normal=_checked(ln.normal, f"loads.line.{i}.normal"))
            for i, ln in enumerate(self.lines)
        )
        object.__setattr__(self, "lines", lines)

    def check_functions(self, shell: Shell) -> None:
        """Sample every load function on a 9 × 9 grid of the shell, so a bad one fails when the case is read."""
        x, phi = np.meshgrid(np.linspace(shell.x_min, shell.x_max, 9), np.linspace(shell.alpha, shell.beta, 9))
        for value in (self.normal, *(ln.normal for ln in self.lines)):
            _eval(value, x, phi)
        for vector in (self.surface, *(ln.force for ln in self.lines)):
            _eval_vec(vector, x, phi)


def surface_load_vector(space: ShellSpace, normal: Value, surface: Vector, order: int = 10) -> np.ndarray:
    """∫ (q1 v1 + q2 v2 + q_n w) dx ds with (q1, q2, q_n) the local components of the load."""
    a = space.mesh.shell.radius
    X, W = space.quadrature(order)
    F = np.zeros(space.ndofs)
    for e in element_chunks(space.mesh.nelements):
        basis = space.element_basis(e, X)
        x, s, detJ = space.reference_to_physical(e, X)
        phi = s / a
        q = to_local(_eval_vec(surface, x, phi), phi)
        q[2] = q[2] + _eval(normal, x, phi)
        dx = W[None, :] * detJ[:, None]
        fe = sum(np.einsum("bnq,nq->bn", basis[k], q[i] * dx) for i, k in enumerate("uvw"))
        np.add.at(F, space.element_dofs[:, e], fe)
    return F


def _line_vector(space: ShellSpace, load: LineLoad, order: int = 10) -> np.ndarray:
    m, a = space.mesh, space.mesh.shell.radius
    coord, value = (0, load.x) if load.x is not None else (1, a * load.phi)
    facets = m.line_facets(coord, value)
    span = (m.shell.s_max - m.shell.s_min) if coord == 0 else m.shell.length
    f = m.mesh.facets[:, facets]
    length = np.abs(m.p[1 - coord, f[1]] - m.p[1 - coord, f[0]]).sum()
    if facets.size == 0 or abs(length - span) > 1e-8 * span:
        where = f"x = {load.x}" if coord == 0 else f"phi = {np.degrees(load.phi)} deg"
        raise InputError("loads.line", f"no mesh line at {where}: the mesh must have a node line there")
    g, gw = np.polynomial.legendre.leggauss(order)
    tq, wq = 0.5 * (g + 1.0), 0.5 * gw
    p0, p1 = m.p[:, f[0]], m.p[:, f[1]]
    pts = p0[:, :, None] + (p1 - p0)[:, :, None] * tq  # (2, nfac, nq)
    ds = np.linalg.norm(p1 - p0, axis=0)[:, None] * wq  # (nfac, nq)
    # evaluate in the element beside each facet, at points nudged inside it
    x, s = pts[0].ravel(), pts[1].ravel()
    ops = space.point_operators(x, s, ("u", "v", "w"))
    phi = s / a
    q = to_local(_eval_vec(load.force, x, phi), phi)
    q[2] = q[2] + _eval(load.normal, x, phi)
    wts = ds.ravel()
    return sum(ops[k].T @ (q[i] * wts) for i, k in enumerate("uvw"))


def point_load_vector(space: ShellSpace, x, phi, force) -> np.ndarray:
    """Σ_k f_k · U(x_k, φ_k) for global forces f_k (3, n) at points (x_k, φ_k)."""
    x, phi = np.atleast_1d(np.asarray(x, float)), np.atleast_1d(np.asarray(phi, float))
    a = space.mesh.shell.radius
    ops = space.point_operators(x, a * phi, ("u", "v", "w"))
    q = to_local(np.asarray(force, float).reshape(3, -1), phi)
    return sum(ops[k].T @ q[i] for i, k in enumerate("uvw"))


def _is_zero(value) -> bool:
    """A constant zero load (a callable is never taken for zero)."""
    return not callable(value) and not np.any(np.asarray(value, dtype=float))


def load_vector(space: ShellSpace, loads: Loads) -> np.ndarray:
    # no quadrature over the whole surface for an absent surface load (2.7 of 4.3 s at 281k dofs)
    if _is_zero(loads.normal) and _is_zero(loads.surface):
        F = np.zeros(space.ndofs)
    else:
        F = surface_load_vector(space, loads.normal, loads.surface)
    for line in loads.lines:
        F += _line_vector(space, line)
    if loads.points:
        pts = loads.points
        F += point_load_vector(space, [p.x for p in pts], [p.phi for p in pts], np.array([p.force for p in pts]).T)
    return F
