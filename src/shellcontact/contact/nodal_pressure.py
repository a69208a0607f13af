"""The nodal contact pressure at the mesh vertices: uniform on a uniform load, converging where it is a function.

A row's Λᵢ/ωᵢ is not a pressure: the rows' forces Λᵢ are what the discrete equilibrium Kᵀ… = Bᵀ Λ makes of the
contact traction on the Argyris deflection space, while the weights ωᵢ (operator.py) are P1 area shares. On a
uniform pressure they differ row by row with the mesh's pattern (the sleeve at 80 × 2 elements: vertex rows
2.13 or 3.79, edge-midpoint rows 3.79 or 5.06 where the pressure is 4.1496), and so did the figures.

What matches the rows' forces is the deflection's own basis. The Argyris function N_v of vertex v's value dof is
1 at v, ½ at the midpoints of v's edges (the quintic Hermite H₀(½) along the edge) and 0 at every other row point,
so the force of the contact on that dof is F_v = Σᵢ fᵢ N_v(aᵢ) = the rows at v plus half of each midpoint row on
v's edges (fᵢ = Λᵢ |∇Zᵢ|, the force along the punch's normal). A pressure p puts ∫ p N_v dΩ on the same dof, so

    p_v = F_v / L_v,      L_v = ∫_{Ω_c,h} N_v dΩ       (the load of a unit pressure on the zone's triangles),

per punch (summed where zones overlap). It is exact where the pressure is uniform (the sleeve's band: 4.14955
against the 1D oracle's 4.14955 at every vertex; the rows' Λ/ω: 2.13 to 5.06) and, being the dof's own
pressure, converges where the pressure is smooth. Where a line force sits (a zone's rim) or a point force, F_v
holds a force per length or a force and p_v grows like 1/h or 1/h²: mesh-dependent by nature, shown as such.
"""

from __future__ import annotations

import numpy as np

from ..shell.argyris import dof_transformation, edge_normals, reference_derivatives
from ..shell.model import element_chunks
from ..shell.spaces import ShellSpace
from .operator import ContactOperator, _zone_elements

QUADRATURE = 6  # the Argyris functions are quintic on an affine triangle: a rule of degree 6 integrates them


def unit_pressure_loads(space: ShellSpace, op: ContactOperator) -> np.ndarray:
    """L (npunch, nv): per punch, ∫ N_v over its zone's triangles Ω_c,h (N_v the Argyris function of vertex v's
    value dof), the load of a unit pressure on that dof; a full cylinder's φ = β copies added to their twins."""
    m = space.mesh
    tri = m.mesh
    X, W = space.quadrature(QUADRATURE)
    reference = reference_derivatives(X)[(0, 0)] @ W  # ∫ of the 21 reference functions on the unit triangle
    normals = edge_normals(tri.p, tri.t, tri.t2f, tri.boundary_facets())
    value_dofs = space.w_vertex_dofs(np.arange(m.nvertices), ("w",))
    out = np.zeros((len(op.punches), m.nvertices))
    for k, punch in enumerate(op.punches):
        load = np.zeros(space.ndofs)
        els = _zone_elements(space, punch)
        for chunk in element_chunks(els.size):
            e = els[chunk]
            verts = tri.p[:, tri.t[:, e]].transpose(2, 1, 0)  # (n, 3, 2)
            d1, d2 = verts[:, 1] - verts[:, 0], verts[:, 2] - verts[:, 0]
            det = np.abs(d1[:, 0] * d2[:, 1] - d1[:, 1] * d2[:, 0])
            local = det[:, None] * np.einsum("nji,j->ni", dof_transformation(verts, normals[e]), reference)
            np.add.at(load, space.element_dofs[12:33, e].T.ravel(), local.ravel())
        out[k] = load[value_dofs]
    if op.twins is not None:
        slave, master = op.twins
        out[:, master] += out[:, slave]
        out[:, slave] = 0.0
    return out


def on_vertices(op: ContactOperator, values: np.ndarray) -> np.ndarray:
    """Row values (m, …) as loads on the vertices' value dofs, (npunch, nv, …): Σᵢ valuesᵢ N_v(aᵢ) per punch, a
    vertex row's at its vertex, half of an edge-midpoint row's at each end of its edge (on a full cylinder on the
    φ = α twins, where the vertex rows are)."""
    values = np.asarray(values, float)
    out = np.zeros((len(op.punches), int(op.nvertices), *values.shape[1:]))
    at_vertex = op.vertex >= 0
    np.add.at(out, (op.punch[at_vertex], op.vertex[at_vertex]), values[at_vertex])
    mid = np.nonzero(~at_vertex)[0]
    if mid.size:
        for end in op.ends[:, mid]:
            np.add.at(out, (op.punch[mid], end), 0.5 * values[mid])
    if op.twins is not None:  # an edge next to the seam ends on a φ = β copy: its share goes to the twin
        slave, master = op.twins
        out[:, master] += out[:, slave]
        out[:, slave] = 0.0
    return out


def dof_forces(op: ContactOperator, Lam: np.ndarray) -> np.ndarray:
    """F (npunch, nv): per punch, Σᵢ Λᵢ|∇Zᵢ| N_v(aᵢ), the contact force on each vertex's value dof."""
    return on_vertices(op, np.asarray(Lam, float) * np.linalg.norm(op.grad, axis=0))


def nodal_pressure(space: ShellSpace, op: ContactOperator, Lam: np.ndarray,
                   loads: np.ndarray | None = None) -> np.ndarray:
    """(npunch, nv): each punch's p_v = F_v / L_v (module docstring; 0 where L_v ≤ 0: off the punch's zone),
    with a full cylinder's φ = β copies given their twins' values. ``loads``: ``unit_pressure_loads``, if known."""
    L = unit_pressure_loads(space, op) if loads is None else loads
    F = dof_forces(op, Lam)
    p = np.where(L > 0.0, F / np.where(L > 0.0, L, 1.0), 0.0)
    if op.twins is not None:
        slave, master = op.twins
        p[:, slave] = p[:, master]
    return p
