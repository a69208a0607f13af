"""The linear Kirchhoff–Love cylindrical shell: strains, resultants, stiffness (MODEL.md §2–3).

In the chart (x, s), s = a φ (so ∂/∂φ = a ∂/∂s and dΩ = a dx dφ = dx ds), the strain
measures of MODEL.md §2 (w positive outward) read

    ε11 = u_x            κ11 = −w_xx
    ε22 = v_s + w/a      κ22 = −(w_ss + w/a²)
    γ12 = u_s + v_x      κ12 = −w_xs + (v_x − u_s)/(2a)

and the strain energy density is ½ eᵀ C e with the material's energy matrices (material.py,
MODEL.md §3): the shell's ``material`` is the only source of stiffness.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from .argyris import affine_maps, dof_transformation, edge_normals, reference_derivatives
from .geometry import Shell
from .spaces import ShellSpace

STRAINS = ("eps11", "eps22", "gam12", "kap11", "kap22", "kap12")
RESULTANTS = ("N11", "N22", "N12", "M11", "M22", "M12")


def strains(d: dict[str, np.ndarray], a: float) -> np.ndarray:
    """Strain vector (ε11, ε22, γ12, κ11, κ22, κ12) from the field derivatives (MODEL.md §2)."""
    return np.stack(
        [
            d["u_x"],
            d["v_s"] + d["w"] / a,
            d["u_s"] + d["v_x"],
            -d["w_xx"],
            -(d["w_ss"] + d["w"] / a**2),
            -d["w_xs"] + (d["v_x"] - d["u_s"]) / (2.0 * a),
        ]
    )


def constitutive(shell: Shell, t: np.ndarray) -> np.ndarray:
    """Energy matrix C (6, 6, ...) with energy density ½ eᵀ C e (MODEL.md §3), from the shell's material.

    Membrane block: membrane_scale(t) · membrane_pattern on (ε11, ε22, γ12) = t Q;
    bending block: bending_scale(t) · bending_pattern on (κ11, κ22, κ12) = (t³/12) T Q T, T = diag(1, 1, 2)
    (isotropic: B [[1, μ, 0], [μ, 1, 0], [0, 0, (1−μ)/2]] and D [[1, μ, 0], [μ, 1, 0], [0, 0, 2(1−μ)]]).
    """
    mat = shell.material
    C = np.zeros((6, 6) + np.shape(t))
    for off, S, pattern in ((0, mat.membrane_scale(t), mat.membrane_pattern),
                            (3, mat.bending_scale(t), mat.bending_pattern)):
        C[off : off + 3, off : off + 3] = pattern.reshape((3, 3) + (1,) * np.ndim(S)) * S
    return C


def resultants(shell: Shell, e: np.ndarray, t: np.ndarray) -> np.ndarray:
    """(N11, N22, N12, M11, M22, M12) from strains e (6, ...): N = t Q (ε11, ε22, γ12),
    M = (t³/12) Q (κ11, κ22, 2κ12) (MODEL.md §3)."""
    C = constitutive(shell, t)
    r = np.einsum("ij...,j...->i...", C, e)
    r[5] *= 0.5  # the energy matrix carries 2 M12 κ12
    return r


def element_chunks(nel: int, size: int = 4096):
    for start in range(0, nel, size):
        yield np.arange(start, min(start + size, nel))


# -- fast assembly: reference element plus a per-element transformation ----------------------------
#
# On the reference triangle the basis functions are fixed: the P2 basis, and the Argyris basis
# ψ̂ for *reference* dofs. On an element with affine map F, the P2 basis is the reference one
# composed with F⁻¹, and the Argyris basis is φ = (V⁻¹)ᵀ ψ̂ ∘ F⁻¹ with V⁻¹ sparse and explicit
# (argyris.dof_transformation). Every strain is a combination, with coefficients c(e) built from
# K = J⁻¹ and 1/a, of eight reference derivatives ρ: û_x̂, û_ŷ, v̂_x̂, v̂_ŷ, ŵ, ŵ_x̂x̂, ŵ_x̂ŷ, ŵ_ŷŷ.
# So the element matrix in the reference basis is
#
#     M_e[α, β] = Σ_ρρ' W_ρρ'(e) H_ρρ'[α, β],   W = |det J| cᵀ C c,   H_ρρ' = Σ_q w_q R_ρψ̂_α R_ρ'ψ̂_β,
#
# with tables H computed once from the quadrature rule, and K_e = Tᵀ M_e T, T = diag(I, I, V⁻¹).
# With a variable thickness W depends on the quadrature point and the sum over q stays in the
# contraction. The arithmetic is that of point-wise quadrature (same rule), so the result
# agrees with it to rounding; no per-element basis tables, monomials or inverses.

_TABLES: dict = {}


def _reference_tables(order: int, X: np.ndarray, W: np.ndarray):
    """Pair tables (pp, pw, ww) for the quadrature rule, per point (nq·16, size) and summed (16, size)."""
    if order in _TABLES:
        return _TABLES[order]
    from skfem import ElementTriP2

    nq = W.size
    gp = np.stack([ElementTriP2().lbasis(X, i)[1] for i in range(6)], axis=1)  # (2, 6, nq)
    P = np.zeros((4, 12, nq))
    P[0, :6], P[1, :6], P[2, 6:], P[3, 6:] = gp[0], gp[1], gp[0], gp[1]
    d = reference_derivatives(X)
    Wt = np.stack([d[(0, 0)], d[(2, 0)], d[(1, 1)], d[(0, 2)]])  # (4, 21, nq)
    out = []
    for A, B in ((P, P), (P, Wt), (Wt, Wt)):
        Hq = np.einsum("rAq,sBq->qrsAB", A, B) * W[:, None, None, None, None]
        Hq = Hq.reshape(nq * 16, -1)
        out.append((np.ascontiguousarray(Hq), Hq.reshape(nq, 16, -1).sum(axis=0)))
    _TABLES[order] = out
    return out


def _strain_coefficients(K: np.ndarray, a: float) -> np.ndarray:
    """c (n, 6 strains, 8 reference derivatives) with strain_k = Σ_ρ c_kρ R_ρ (MODEL.md §2 in (x, s))."""
    n = K.shape[0]
    c = np.zeros((n, 6, 8))
    k00, k01, k10, k11 = K[:, 0, 0], K[:, 0, 1], K[:, 1, 0], K[:, 1, 1]  # K[a, i] = ∂x̂_a/∂x_i
    c[:, 0, 0], c[:, 0, 1] = k00, k10  # ε11 = u_x
    c[:, 1, 2], c[:, 1, 3], c[:, 1, 4] = k01, k11, 1.0 / a  # ε22 = v_s + w/a
    c[:, 2, 0], c[:, 2, 1], c[:, 2, 2], c[:, 2, 3] = k01, k11, k00, k10  # γ12 = u_s + v_x
    c[:, 3, 5], c[:, 3, 6], c[:, 3, 7] = -k00 * k00, -2.0 * k00 * k10, -k10 * k10  # κ11 = −w_xx
    c[:, 4, 5], c[:, 4, 6], c[:, 4, 7] = -k01 * k01, -2.0 * k01 * k11, -k11 * k11  # κ22 = −w_ss − w/a²
    c[:, 4, 4] = -1.0 / a**2
    c[:, 5, 5], c[:, 5, 6], c[:, 5, 7] = -k00 * k01, -(k00 * k11 + k10 * k01), -k10 * k11  # κ12 = −w_xs
    c[:, 5, 2], c[:, 5, 3] = 0.5 * k00 / a, 0.5 * k10 / a  # … + (v_x − u_s)/(2a)
    c[:, 5, 0], c[:, 5, 1] = -0.5 * k01 / a, -0.5 * k11 / a
    return c


def element_matrices(
    space: ShellSpace, e: np.ndarray, order: int = 10, parts=("membrane", "bending"), normals: np.ndarray | None = None
) -> np.ndarray:
    """Element stiffness matrices (n, 33, 33) of a(U, V) (MODEL.md §3) in the local dof order of element_dofs."""
    shell = space.mesh.shell
    mat = shell.material
    X, W = space.quadrature(order)
    (Hpp_q, Hpp), (Hpw_q, Hpw), (Hww_q, Hww) = _reference_tables(order, X, W)
    m = space.mesh.mesh
    if normals is None:
        normals = edge_normals(m.p, m.t, m.t2f, m.boundary_facets())[e]
    verts = m.p[:, m.t[:, e]].transpose(2, 1, 0)  # (n, 3, 2)
    _, K, det = affine_maps(verts)
    n = e.size
    c = _strain_coefficients(K, shell.radius)
    cm = mat.membrane_pattern * ("membrane" in parts)
    cb = mat.bending_pattern * ("bending" in parts)
    adet = np.abs(det)[:, None, None]
    cmem, cben = c[:, :3], c[:, 3:]
    Wm = (cmem.transpose(0, 2, 1) @ (cm @ cmem)) * adet  # (n, 8, 8)
    Wb = (cben.transpose(0, 2, 1) @ (cb @ cben)) * adet
    if callable(shell.thickness):
        x, s, _ = space.reference_to_physical(e, X)
        t = shell.t(x, s / shell.radius)
        Wq = (mat.membrane_scale(t)[:, :, None, None] * Wm[:, None] + mat.bending_scale(t)[:, :, None, None]
              * Wb[:, None])  # (n, nq, 8, 8)
        Mpp = Wq[:, :, :4, :4].reshape(n, -1) @ Hpp_q
        Mpw = Wq[:, :, :4, 4:].reshape(n, -1) @ Hpw_q
        Mww = Wq[:, :, 4:, 4:].reshape(n, -1) @ Hww_q
    else:
        thick = float(shell.thickness)
        Wc = mat.membrane_scale(thick) * Wm + mat.bending_scale(thick) * Wb
        Mpp = Wc[:, :4, :4].reshape(n, 16) @ Hpp
        Mpw = Wc[:, :4, 4:].reshape(n, 16) @ Hpw
        Mww = Wc[:, 4:, 4:].reshape(n, 16) @ Hww
    Vi = dof_transformation(verts, normals)
    Ke = np.empty((n, 33, 33))
    Ke[:, :12, :12] = Mpp.reshape(n, 12, 12)
    Kpw = Mpw.reshape(n, 12, 21) @ Vi
    Ke[:, :12, 12:] = Kpw
    Ke[:, 12:, :12] = Kpw.transpose(0, 2, 1)
    Ke[:, 12:, 12:] = Vi.transpose(0, 2, 1) @ (Mww.reshape(n, 21, 21) @ Vi)
    return Ke


# -- the sparsity pattern, built once per space from the entity graph -----------------------------


class StiffnessPattern:
    """CSR structure of the stiffness matrix and the map element entry → CSR data position.

    Entities are vertices (0..nv−1) and facets (nv..nv+nf−1). Every dof belongs to one entity
    (u, v: one dof per entity; w: six per vertex, one per facet) and, with the dof numbering of
    ShellSpace, the sorted columns of a dof row depend only on its entity: for each field, the
    dofs of the adjacent entities in entity order. So the pattern and the position of every
    element entry follow from the (small) entity adjacency graph without sorting the
    33² × nel element entries.
    """

    def __init__(self, space: ShellSpace) -> None:
        m = space.mesh.mesh
        nv, nf = space.nv, space.nf
        nE, n2 = nv + nf, space.n_p2
        ent = np.vstack([m.t, nv + m.t2f]).astype(np.int64)  # (6, nel)
        nel = ent.shape[1]
        I = np.broadcast_to(ent[:, None, :], (6, 6, nel)).ravel()
        J = np.broadcast_to(ent[None, :, :], (6, 6, nel)).ravel()
        graph = sp.csr_matrix((np.ones(I.size, dtype=np.int8), (I, J)), shape=(nE, nE))
        graph.sum_duplicates()
        graph.sort_indices()
        ep, ej = graph.indptr.astype(np.int64), graph.indices.astype(np.int64)
        nnzE = ej.size
        row_of = np.repeat(np.arange(nE), np.diff(ep))
        deg = np.diff(ep)
        nw = np.where(ej < nv, 6, 1)
        cs = np.cumsum(nw) - nw
        wcum = cs - cs[ep[:-1]][row_of]
        wsum = np.add.reduceat(nw, ep[:-1]) if nnzE else np.zeros(nE, np.int64)
        L = 2 * deg + wsum  # row length of every dof row of entity E
        rpos = np.arange(nnzE) - ep[:-1][row_of]
        off = np.stack([rpos, deg[row_of] + rpos, 2 * deg[row_of] + wcum], axis=1)  # (nnzE, 3 fields)
        # the column pattern of each entity, concatenated in entity order
        patstart = np.concatenate([[0], np.cumsum(L)])
        pat = np.empty(patstart[-1], dtype=np.int32)
        base = patstart[:-1][row_of]
        pat[base + off[:, 0]] = ej
        pat[base + off[:, 1]] = n2 + ej
        isv = ej < nv
        wb = base[isv] + off[isv, 2]
        for k in range(6):
            pat[wb + k] = 2 * n2 + 6 * ej[isv] + k
        pat[base[~isv] + off[~isv, 2]] = 2 * n2 + 6 * nv + (ej[~isv] - nv)
        # rows: u (entity order), v (entity order), w (6 per vertex, then one per facet)
        ent_of_row = np.concatenate([np.arange(nE), np.arange(nE), np.repeat(np.arange(nv), 6), np.arange(nv, nE)])
        rowlen = L[ent_of_row]
        indptr = np.zeros(ent_of_row.size + 1, dtype=np.int64)
        np.cumsum(rowlen, out=indptr[1:])
        nnz = int(indptr[-1])
        idx_type = np.int32 if nnz < 2**31 - 1 else np.int64
        # u rows, v rows and w facet rows are the entity patterns in order; w vertex rows repeat
        # each vertex's pattern six times (one gather)
        nvpat = int(patstart[nv])
        rl = L[:nv].repeat(6)
        start = np.repeat(patstart[:nv], 6) - np.concatenate([[0], np.cumsum(rl)[:-1]])
        shift = np.repeat(start.astype(idx_type), rl)
        shift += np.arange(shift.size, dtype=idx_type)
        pat = pat.astype(idx_type, copy=False)
        self.indices = np.concatenate([pat, pat, pat[shift], pat[nvpat:]])
        del shift
        self.indptr = indptr.astype(idx_type)
        self.shape = (space.ndofs, space.ndofs)
        self.nnz = nnz
        # element map: pos[e, a, b] = indptr[dof_a] + (column offset of b in the row pattern of ent_a)
        gkeys = row_of * nE + ej
        kE = np.searchsorted(gkeys, I * nE + J).reshape(6, 6, nel).transpose(2, 0, 1)  # (nel, A, B)
        self._kE = np.ascontiguousarray(kE)
        self._ent = ent
        self._dofs = space.element_dofs
        self._itype = idx_type
        self._indptr_t = indptr.astype(idx_type)
        self._rpos, self._offw = rpos.astype(idx_type), off[:, 2].astype(idx_type)
        self._deg = deg.astype(idx_type)

    def positions(self, e: np.ndarray) -> np.ndarray:
        """CSR data positions (n, 33, 33) of the element entries of elements ``e``."""
        kE = self._kE[e]  # (n, 6, 6) entity-pair entries
        n = e.size
        ou = self._rpos[kE]  # (n, A, B): position of entity B in the u-part of A's rows
        ow = self._offw[kE]  # start of B's w-dofs in A's rows
        dg = self._deg[self._ent[:, e].T]  # (n, A)
        col = np.empty((n, 6, 33), dtype=self._itype)  # column offset of local dof b in the rows of entity A
        col[:, :, 0:6] = ou
        col[:, :, 6:12] = ou + dg[:, :, None]
        col[:, :, 12:30] = (ow[:, :, 0:3, None] + np.arange(6)).reshape(n, 6, 18)
        col[:, :, 30:33] = ow[:, :, 3:6]
        pos = np.take(col, _ENT_OF_LOCAL, axis=1)  # (n, 33, 33), C-contiguous
        pos += self._indptr_t[self._dofs[:, e]].T[:, :, None]
        return pos


_ENT_OF_LOCAL = np.array([0, 1, 2, 3, 4, 5] * 2 + [v for v in range(3) for _ in range(6)] + [3, 4, 5])


def stiffness_pattern(space: ShellSpace) -> StiffnessPattern:
    """The (cached) sparsity pattern of ``space``'s stiffness matrix."""
    pat = space.__dict__.get("_stiffness_pattern")
    if pat is None:
        pat = StiffnessPattern(space)
        space.__dict__["_stiffness_pattern"] = pat
    return pat


def stiffness(space: ShellSpace, order: int = 10, parts: tuple[str, ...] = ("membrane", "bending")) -> sp.csr_matrix:
    """Global stiffness matrix A of a(U, V) (MODEL.md §3), vectorised over elements.

    ``parts`` may drop the membrane or bending energy (used to verify each element alone).
    Element matrices come from element_matrices (reference tables and a per-element transformation); they are
    added into a CSR structure built once per space (stiffness_pattern).
    """
    pat = stiffness_pattern(space)
    m = space.mesh.mesh
    normals = edge_normals(m.p, m.t, m.t2f, m.boundary_facets())
    data = np.zeros(pat.nnz)
    for e in element_chunks(space.mesh.nelements, 8192):
        Ke = element_matrices(space, e, order, parts, normals[e])
        np.add.at(data, pat.positions(e).ravel(), Ke.ravel())
    # copies: callers may modify the matrix structure in place (e.g. eliminate_zeros)
    A = sp.csr_matrix((data, pat.indices.copy(), pat.indptr.copy()), shape=pat.shape)
    A.has_sorted_indices = True
    A.has_canonical_format = True
    return A


def field_derivatives(space: ShellSpace, U: np.ndarray, elements: np.ndarray, X: np.ndarray,
                      quantities: tuple[str, ...] | None = None) -> dict[str, np.ndarray]:
    """The QUANTITIES (or those named in ``quantities``) of the discrete field U at reference points X in
    ``elements``."""
    basis = space.element_basis(elements, X)
    coeff = U[space.element_dofs[:, elements]]  # (33, n)
    # only the rows of the field a quantity belongs to are nonzero (``ShellSpace.element_basis``)
    rows = {"u": slice(0, 6), "v": slice(6, 12), "w": slice(12, 33)}
    return {k: np.einsum("bnq,bn->nq", basis[k][rows[k[0]]], coeff[rows[k[0]]])
            for k in (quantities or basis)}


def energy_norm_sq(space: ShellSpace, fields_error, order: int = 10) -> float:
    """a(E, E) for an error field given as a callable (elements, X) → derivative dict."""
    shell = space.mesh.shell
    X, W = space.quadrature(order)
    total = 0.0
    for e in element_chunks(space.mesh.nelements):
        d = fields_error(e, X)
        x, s, detJ = space.reference_to_physical(e, X)
        eps = strains(d, shell.radius)
        C = constitutive(shell, shell.t(x, s / shell.radius))
        total += float(np.einsum("knq,klnq,lnq,nq->", eps, C, eps, W[None, :] * detJ[:, None]))
    return total
