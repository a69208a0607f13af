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
    verts: np.ndarray | None = None  # (nel, 3, 2), for evaluate_reference
    normals: np.ndarray | None = None  # (nel, 3, 2) edge normals of the edge dofs

    @classmethod
    def build(cls, p: np.ndarray, t: np.ndarray, normals: np.ndarray) -> ArgyrisBasis:
        """Coefficients by the reference-element transformation (no per-element inverse).

        The functions ψ_j = ψ̂_j ∘ F⁻¹ (ψ̂ the reference basis for reference dofs: values,
        reference gradient and Hessian at the vertices, reference normal derivative at the
        edge midpoints) span P5 on the element. The physical dofs of the ψ_j form a sparse
        matrix V: identity for values, Jᴵᵀ-blocks for gradients and Hessians, and, because
        a physical normal is a mix of reference normal and tangent, a row per edge with the
        tangential derivative of the endpoint data (Kirby 2018; Domínguez & Sayas 2008).
        V⁻¹ is written down block-wise, and the physical basis is S Â V⁻¹, where Â holds the
        reference basis in reference monomials and S re-expands reference monomials in the
        element's scaled monomials. Same result as build_vandermonde to rounding.
        """
        verts = p[:, t].transpose(2, 1, 0)  # (nel, 3, 2)
        centre = verts.mean(axis=1)
        h = np.max(np.linalg.norm(verts - np.roll(verts, 1, axis=1), axis=2), axis=1)
        coef = np.empty((t.shape[1], 21, 21))
        for start in range(0, t.shape[1], 2048):  # chunks that stay in cache
            sl = slice(start, min(start + 2048, t.shape[1]))
            coef[sl] = _transformed_coefficients(verts[sl], centre[sl], h[sl], normals[sl])
        return cls(centre=centre, h=h, coef=coef, verts=verts, normals=np.asarray(normals))

    @classmethod
    def build_vandermonde(cls, p: np.ndarray, t: np.ndarray, normals: np.ndarray) -> ArgyrisBasis:
        """Coefficients by inverting each element's 21×21 dof matrix (the direct construction)."""
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
        return cls(centre=centre, h=h, coef=coef, verts=verts, normals=np.asarray(normals))

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

    def evaluate_reference(self, elements: np.ndarray, X: np.ndarray, order: int = 2) -> dict[str, np.ndarray]:
        """Same as ``evaluate`` at the images of reference points X: (2, nq) shared or (2, n, nq).

        Uses the reference basis and the explicit transformation (no monomials per element):
        φ = V⁻ᵀ ψ̂, ∇φ = Kᵀ ∇̂φ, and the Hessian transformed by K = J⁻¹.
        """
        elements = np.asarray(elements, dtype=int)
        verts = self.verts[elements]
        Vt = dof_transformation(verts, self.normals[elements]).transpose(0, 2, 1)  # (n, 21 φ, 21 ψ̂)
        _, K, _ = affine_maps(verts)
        needed = [(0, 0)] + ([(1, 0), (0, 1)] if order >= 1 else []) + ([(2, 0), (1, 1), (0, 2)] if order >= 2 else [])
        ref = {}
        for d in needed:
            if X.ndim == 2:
                tab = (monomials(X[0], X[1], *d) @ _REF_A).T  # (21, nq)
                ref[d] = np.matmul(Vt, tab).transpose(1, 0, 2)  # (21, n, nq)
            else:
                tab = (monomials(X[0], X[1], *d) @ _REF_A).transpose(0, 2, 1)  # (n, 21, nq)
                ref[d] = np.matmul(Vt, tab).transpose(1, 0, 2)
        k = [[K[:, a, i][None, :, None] for i in range(2)] for a in range(2)]  # K[a][i] = ∂x̂_a/∂x_i
        out = {"w": ref[(0, 0)]}
        if order >= 1:
            out["w_x"] = k[0][0] * ref[(1, 0)] + k[1][0] * ref[(0, 1)]
            out["w_y"] = k[0][1] * ref[(1, 0)] + k[1][1] * ref[(0, 1)]
        if order >= 2:
            for name, (i, j) in (("w_xx", (0, 0)), ("w_xy", (0, 1)), ("w_yy", (1, 1))):
                out[name] = (k[0][i] * k[0][j] * ref[(2, 0)] + (k[0][i] * k[1][j] + k[1][i] * k[0][j]) * ref[(1, 1)]
                             + k[1][i] * k[1][j] * ref[(0, 2)])
        return out


# -- the reference element and the per-element transformation -----------------------------------

_REF_VERTS = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]])


def _reference_tables() -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Â (21 monomials × 21 reference basis functions), τ (3 edges × 21), edge normals and tangents."""
    tang = np.array([_REF_VERTS[j] - _REF_VERTS[i] for i, j in EDGE_VERTICES])
    tang /= np.linalg.norm(tang, axis=1)[:, None]
    nrm = np.stack([tang[:, 1], -tang[:, 0]], axis=1)
    V = np.empty((21, 21))
    derivs = ((0, 0), (1, 0), (0, 1), (2, 0), (1, 1), (0, 2))
    for v in range(3):
        for k, (dx, dy) in enumerate(derivs):
            V[6 * v + k] = monomials(_REF_VERTS[v, 0], _REF_VERTS[v, 1], dx, dy)
    mids = np.array([0.5 * (_REF_VERTS[i] + _REF_VERTS[j]) for i, j in EDGE_VERTICES])
    grad = [(monomials(m[0], m[1], 1, 0), monomials(m[0], m[1], 0, 1)) for m in mids]
    for k in range(3):
        V[18 + k] = nrm[k, 0] * grad[k][0] + nrm[k, 1] * grad[k][1]
    A = np.linalg.inv(V)
    tau = np.array([(tang[k, 0] * grad[k][0] + tang[k, 1] * grad[k][1]) @ A for k in range(3)])
    tau[np.abs(tau) < 1e-12 * np.abs(tau).max()] = 0.0  # exact zeros (edge dofs, far vertex)
    return A, tau, nrm, tang


_REF_A, _REF_TAU, _REF_N, _REF_T = _reference_tables()


def _shift_index(dx: int, dy: int) -> np.ndarray:
    """For each of the 21 monomials, the index of the monomial divided by ξ^dx η^dy (21 if none)."""
    lookup = {tuple(e): n for n, e in enumerate(EXPONENTS.tolist())}
    return np.array([lookup.get((px - dx, py - dy), 21) for px, py in EXPONENTS.tolist()])


_SHIFT_X, _SHIFT_Y = _shift_index(1, 0), _shift_index(0, 1)


def affine_maps(verts: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """J (n, 2, 2) with J[e, i, a] = ∂x_i/∂x̂_a, its inverse K[e, a, i] = ∂x̂_a/∂x_i, and det J."""
    d1, d2 = verts[:, 1] - verts[:, 0], verts[:, 2] - verts[:, 0]
    J = np.stack([d1, d2], axis=2)
    det = d1[:, 0] * d2[:, 1] - d1[:, 1] * d2[:, 0]
    K = np.stack([np.stack([d2[:, 1], -d2[:, 0]], 1), np.stack([-d1[:, 1], d1[:, 0]], 1)], 1) / det[:, None, None]
    return J, K, det


def dof_transformation(verts: np.ndarray, normals: np.ndarray) -> np.ndarray:
    """V⁻¹ (n, 21, 21): the physical basis is φ_i = Σ_j V⁻¹[j, i] ψ̂_j ∘ F⁻¹ (ψ̂ the reference basis).

    V[k, j] = L_k(ψ̂_j ∘ F⁻¹) for the physical dofs L_k: vertex blocks [1] ⊕ Kᵀ ⊕ (Hessian
    transform), and for each edge α_k (reference normal dof) + β_k (tangential derivative of
    the endpoint data, table τ), with g = K n = α n̂ + β t̂. Its inverse is written down.
    """
    n = verts.shape[0]
    J, K, _ = affine_maps(verts)
    # the vertex block, the same at the three vertices: [1] ⊕ Jᵀ ⊕ (Hessian transform by J)
    blk = np.zeros((n, 6, 6))
    blk[:, 0, 0] = 1.0
    blk[:, 1:3, 1:3] = J.transpose(0, 2, 1)  # blk[1 + a, 1 + i] = J[i, a]
    for r, (a_, b_) in enumerate(((0, 0), (0, 1), (1, 1))):
        blk[:, 3 + r, 3] = J[:, 0, a_] * J[:, 0, b_]
        blk[:, 3 + r, 4] = J[:, 0, a_] * J[:, 1, b_] + J[:, 1, a_] * J[:, 0, b_]
        blk[:, 3 + r, 5] = J[:, 1, a_] * J[:, 1, b_]
    Vi = np.zeros((n, 21, 21))
    for v in range(3):
        Vi[:, 6 * v : 6 * v + 6, 6 * v : 6 * v + 6] = blk
    g = np.einsum("eai,eki->eka", K, normals)  # (n, 3, 2)
    alpha = g[:, :, 0] * _REF_N[None, :, 0] + g[:, :, 1] * _REF_N[None, :, 1]
    beta = g[:, :, 0] * _REF_T[None, :, 0] + g[:, :, 1] * _REF_T[None, :, 1]
    for k, (i, j) in enumerate(EDGE_VERTICES):
        Vi[:, 18 + k, 18 + k] = 1.0 / alpha[:, k]
        ratio = (-beta[:, k] / alpha[:, k])[:, None]
        for v in (i, j):  # τ_k vanishes on the dofs of the vertex opposite edge k
            Vi[:, 18 + k, 6 * v : 6 * v + 6] = ratio * (_REF_TAU[k, 6 * v : 6 * v + 6] @ blk)
    return Vi


def reference_derivatives(X: np.ndarray) -> dict[tuple[int, int], np.ndarray]:
    """∂^dx ∂^dy of the 21 reference basis functions ψ̂_j at reference points X (2, nq): (21, nq) each."""
    out = {}
    for dx, dy in ((0, 0), (1, 0), (0, 1), (2, 0), (1, 1), (0, 2)):
        out[(dx, dy)] = (monomials(X[0], X[1], dx, dy) @ _REF_A).T
    return out


def _transformed_coefficients(verts: np.ndarray, centre: np.ndarray, h: np.ndarray, normals: np.ndarray) -> np.ndarray:
    """coef (n, 21 scaled monomials, 21 physical dofs) of ArgyrisBasis, by the reference transformation."""
    n = verts.shape[0]
    _, K, _ = affine_maps(verts)
    Vi = dof_transformation(verts, normals)
    # S: reference monomials x̂^p ŷ^q in the scaled monomials ξ = (x − c)/h
    off = centre - verts[:, 0]
    aff = []  # x̂ and ŷ as c0 + c1 ξ + c2 η
    for a_ in range(2):
        aff.append((K[:, a_, 0] * off[:, 0] + K[:, a_, 1] * off[:, 1], K[:, a_, 0] * h, K[:, a_, 1] * h))
    S = np.zeros((21, 21, n))  # S[col, row] = coefficient of scaled monomial row in reference monomial col
    S[0, 0] = 1.0
    for col, (px, py) in enumerate(EXPONENTS.tolist()):
        if col == 0:
            continue
        if px > 0:
            src, (c0, c1, c2) = _REF_INDEX[(px - 1, py)], aff[0]
        else:
            src, (c0, c1, c2) = _REF_INDEX[(px, py - 1)], aff[1]
        for row in range(_NMONO_DEG[px + py]):  # the monomials of degree ≤ px + py
            out = S[col, row]
            np.multiply(c0, S[src, row], out=out)
            if _SHIFT_X[row] < 21:
                out += c1 * S[src, _SHIFT_X[row]]
            if _SHIFT_Y[row] < 21:
                out += c2 * S[src, _SHIFT_Y[row]]
    AV = np.matmul(_REF_A, Vi)
    return np.matmul(np.ascontiguousarray(S.transpose(2, 1, 0)), AV)


_REF_INDEX = {tuple(e): n for n, e in enumerate(EXPONENTS.tolist())}
_NMONO_DEG = [(d + 1) * (d + 2) // 2 for d in range(6)]  # number of monomials of degree ≤ d
