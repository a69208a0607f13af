"""Vectorised C¹ Argyris P5 triangle (MODEL.md §7, (8.2), (8.4)).

Degrees of freedom, in the order of scikit-fem's ``ElementTriArgyris``: at each vertex
w, w_x, w_y, w_xx, w_xy, w_yy, then the normal derivative at the midpoints of the edges
(v0v1), (v1v2), (v0v2). The edge normal is (d_y, −d_x)/|d| with d = p[lo] − p[hi] for
interior edges and the outward normal on the boundary (scikit-fem's rule), so global
matrices agree with scikit-fem's.

Each element's basis is built from the 21 monomials in *local scaled* coordinates
ξ = (x − c)/h (c the centroid, h the diameter), with derivative functionals scaled by
powers of h. The 21×21 dof matrices are then O(1)-conditioned whatever the element size
or distance from the origin, and all elements are inverted in one batched LAPACK call.
scikit-fem instead inverts a Vandermonde matrix of global monomials per element in
Python loops, which is slow and loses digits far from the origin.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

EXPONENTS = np.array([(i, k - i) for k in range(6) for i in range(k, -1, -1)])  # 21 × (px, py)
EDGE_VERTICES = ((0, 1), (1, 2), (0, 2))
# derivative order of each of the 21 dofs (values, first, second derivatives, normals)
DOF_ORDER = np.array([0, 1, 1, 2, 2, 2] * 3 + [1, 1, 1])


def _powers(x: np.ndarray) -> np.ndarray:
    """x**k for k = 0..5, shape (6, ...), by repeated multiplication (float pow is slow)."""
    out = np.empty((6,) + np.shape(x))
    out[0] = 1.0
    for k in range(1, 6):
        out[k] = out[k - 1] * x
    return out


def _dpow(powers: np.ndarray, p: np.ndarray, d: int) -> np.ndarray:
    """d-th derivative of x**p for the exponent array p, from a table of powers; shape (..., len(p))."""
    coef = np.ones_like(p, dtype=float)
    for k in range(d):
        coef = coef * (p - k)
    return np.moveaxis(powers[np.maximum(p - d, 0)], 0, -1) * coef


def monomials(xi: np.ndarray, eta: np.ndarray, dx: int = 0, dy: int = 0) -> np.ndarray:
    """∂^dx_ξ ∂^dy_η of the 21 monomials at points (...), result shape (..., 21)."""
    return _dpow(_powers(xi), EXPONENTS[:, 0], dx) * _dpow(_powers(eta), EXPONENTS[:, 1], dy)


def edge_normals(p: np.ndarray, t: np.ndarray, t2f: np.ndarray, boundary_facets: np.ndarray) -> np.ndarray:
    """Unit normals (nel, 3 edges, 2) that define the edge dofs (scikit-fem's convention)."""
    is_boundary = np.zeros(t2f.max() + 1, dtype=bool)
    is_boundary[boundary_facets] = True
    centroid = p[:, t].mean(axis=1)  # (2, nel)
    n = np.empty((t.shape[1], 3, 2))
    for k, (i, j) in enumerate(EDGE_VERTICES):
        vi, vj = t[i], t[j]
        lo, hi = np.minimum(vi, vj), np.maximum(vi, vj)
        d = p[:, lo] - p[:, hi]
        nk = np.array([d[1], -d[0]]) / np.linalg.norm(d, axis=0)
        mid = 0.5 * (p[:, vi] + p[:, vj])
        outward = np.sign(np.sum(nk * (mid - centroid), axis=0))
        flip = is_boundary[t2f[k]] & (outward < 0)
        nk[:, flip] *= -1.0
        n[:, k, :] = nk.T
    return n


@dataclass
class ArgyrisBasis:
    """Per-element coefficients of the 21 Argyris basis functions in scaled monomials."""

    centre: np.ndarray  # (nel, 2)
    h: np.ndarray  # (nel,)
    coef: np.ndarray  # (nel, 21 monomials, 21 basis functions), for the *physical* dofs

    @classmethod
    def build(cls, p: np.ndarray, t: np.ndarray, normals: np.ndarray) -> ArgyrisBasis:
        verts = p[:, t].transpose(2, 1, 0)  # (nel, 3, 2)
        centre = verts.mean(axis=1)
        h = np.max(np.linalg.norm(verts - np.roll(verts, 1, axis=1), axis=2), axis=1)
        loc = (verts - centre[:, None, :]) / h[:, None, None]  # (nel, 3, 2)
        nel = t.shape[1]
        V = np.empty((nel, 21, 21))
        derivs = ((0, 0), (1, 0), (0, 1), (2, 0), (1, 1), (0, 2))
        for v in range(3):
            for k, (dx, dy) in enumerate(derivs):
                V[:, 6 * v + k, :] = monomials(loc[:, v, 0], loc[:, v, 1], dx, dy)
        for k, (i, j) in enumerate(EDGE_VERTICES):
            mid = 0.5 * (loc[:, i] + loc[:, j])
            V[:, 18 + k, :] = normals[:, k, 0:1] * monomials(mid[:, 0], mid[:, 1], 1, 0) + normals[
                :, k, 1:2
            ] * monomials(mid[:, 0], mid[:, 1], 0, 1)
        coef_scaled = np.linalg.inv(V)  # basis for the h-scaled dofs
        # physical dof of order r is (scaled dof)/h^r, so its basis function is h^r × scaled one
        coef = coef_scaled * h[:, None, None] ** DOF_ORDER[None, None, :]
        return cls(centre=centre, h=h, coef=coef)

    def evaluate(self, elements: np.ndarray, x: np.ndarray, y: np.ndarray, order: int = 2) -> dict[str, np.ndarray]:
        """Basis functions and derivatives at physical points (x, y) of shape (n, nq).

        ``elements`` (n,) gives the element of each row. Returns arrays (21, n, nq) under
        keys 'w', 'w_x', 'w_y' (order ≥ 1) and 'w_xx', 'w_xy', 'w_yy' (order 2).
        """
        c, h, C = self.centre[elements], self.h[elements], self.coef[elements]
        xi = (x - c[:, 0:1]) / h[:, None]
        eta = (y - c[:, 1:2]) / h[:, None]
        out = {}
        keys = {(0, 0): "w", (1, 0): "w_x", (0, 1): "w_y", (2, 0): "w_xx", (1, 1): "w_xy", (0, 2): "w_yy"}
        for (dx, dy), name in keys.items():
            if dx + dy > order:
                continue
            m = monomials(xi, eta, dx, dy)  # (n, nq, 21)
            val = np.einsum("nqm,nmb->bnq", m, C, optimize=True)
            out[name] = val / h[None, :, None] ** (dx + dy)
        return out
