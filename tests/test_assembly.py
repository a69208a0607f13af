"""The fast stiffness assembly (issue 5, target 1) against two independent constructions.

* the point-wise quadrature assembly that the package used before (kept here verbatim as the
  reference: strains of all 33 basis functions at every quadrature point, K_e = Σ Sᵀ C S w);
* scikit-fem's own ElementTriArgyris / ElementTriP2 bases and a BilinearForm of the same
  operator (MODEL.md §3), on small meshes near the origin where scikit-fem's global-monomial
  Vandermonde matrices are still accurate.
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp
from scipy.spatial import Delaunay
from skfem import BilinearForm, CellBasis, ElementTriArgyris, ElementTriP2, MeshTri

from shellcontact.shell import model
from shellcontact.shell.argyris import ArgyrisBasis, edge_normals
from shellcontact.shell.geometry import Shell
from shellcontact.shell.material import Isotropic
from shellcontact.shell.mesh import ShellMesh, structured
from shellcontact.shell.spaces import ShellSpace

# -- the previous implementation, kept as the reference --------------------------------------


def reference_stiffness(space: ShellSpace, order: int = 10, parts=("membrane", "bending")) -> sp.csr_matrix:
    shell = space.mesh.shell
    a = shell.radius
    X, W = space.quadrature(order)
    rows, cols, vals = [], [], []
    mask = np.zeros(6)
    if "membrane" in parts:
        mask[:3] = 1.0
    if "bending" in parts:
        mask[3:] = 1.0
    for e in model.element_chunks(space.mesh.nelements):
        basis = space.element_basis(e, X)
        x, s, detJ = space.reference_to_physical(e, X)
        S = model.strains(basis, a) * mask[:, None, None, None]  # (6, 33, n, nq)
        C = model.constitutive(shell, shell.t(x, s / a))  # (6, 6, n, nq)
        dx = W[None, :] * detJ[:, None]
        CS = np.einsum("klnq,ljnq->kjnq", C, S, optimize=True) * dx
        n = e.size
        Ke = np.matmul(S.transpose(2, 1, 0, 3).reshape(n, 33, -1), CS.transpose(2, 0, 3, 1).reshape(n, -1, 33))
        dofs = space.element_dofs[:, e]
        rows.append(np.broadcast_to(dofs[:, None, :], (33, 33, n)).transpose(2, 0, 1).ravel())
        cols.append(np.broadcast_to(dofs[None, :, :], (33, 33, n)).transpose(2, 0, 1).ravel())
        vals.append(Ke.ravel())
    A = sp.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))), shape=(space.ndofs,) * 2)
    A.sum_duplicates()
    return A


def scaled_difference(A: sp.spmatrix, B: sp.spmatrix) -> float:
    """max |A_ij − B_ij| / sqrt(|B_ii B_jj|): relative to the natural size of each entry (Cauchy–Schwarz)."""
    d = np.sqrt(np.abs(B.diagonal()))
    D = (sp.csr_matrix(A) - sp.csr_matrix(B)).tocoo()
    if D.nnz == 0:
        return 0.0
    return float(np.max(np.abs(D.data) / (d[D.row] * d[D.col])))


# -- meshes ---------------------------------------------------------------------------------------


def variable_thickness(x, phi):
    return 0.02 * (1.0 + 0.3 * np.sin(2.0 * x) * np.cos(3.0 * phi))


def panel(thickness=0.02, x_start=None) -> Shell:
    return Shell(
        radius=1.3, length=2.0, thickness=thickness, material=Isotropic(2.5, 0.3), alpha=0.2, beta=1.0, x_start=x_start
    )


def perturbed(shell: Shell, nx: int, nphi: int, seed: int = 0) -> ShellMesh:
    """A structured mesh with the interior nodes moved at random: every element a different shape."""
    m = structured(shell, nx, nphi)
    p = m.p.copy()
    rng = np.random.default_rng(seed)
    hx, hs = shell.length / nx, (shell.s_max - shell.s_min) / nphi
    inner = (
        (p[0] > shell.x_min + 1e-9)
        & (p[0] < shell.x_max - 1e-9)
        & (p[1] > shell.s_min + 1e-9)
        & (p[1] < shell.s_max - 1e-9)
    )
    p[0, inner] += 0.2 * hx * rng.uniform(-1, 1, inner.sum())
    p[1, inner] += 0.2 * hs * rng.uniform(-1, 1, inner.sum())
    return ShellMesh(shell, MeshTri(p, m.t))


def delaunay(shell: Shell, n: int = 7, seed: int = 1) -> ShellMesh:
    """Delaunay triangulation of jittered grid points: unstructured, but shape-regular (no slivers)."""
    rng = np.random.default_rng(seed)
    xs, ss = np.linspace(shell.x_min, shell.x_max, n + 1), np.linspace(shell.s_min, shell.s_max, n)
    X, S = np.meshgrid(xs, ss, indexing="ij")
    X[1:-1, 1:-1] += 0.3 * (xs[1] - xs[0]) * rng.uniform(-1, 1, X[1:-1, 1:-1].shape)
    S[1:-1, 1:-1] += 0.3 * (ss[1] - ss[0]) * rng.uniform(-1, 1, S[1:-1, 1:-1].shape)
    pts = np.c_[X.ravel(), S.ravel()]
    tri = Delaunay(pts)
    return ShellMesh(shell, MeshTri(pts.T.copy(), tri.simplices.T.copy()))


MESHES = {
    "structured": lambda sh: structured(sh, 5, 4),
    "right": lambda sh: structured(sh, 4, 3, "right"),
    "crossed": lambda sh: structured(sh, 3, 3, "crossed"),
    "perturbed": lambda sh: perturbed(sh, 5, 4),
    "delaunay": lambda sh: delaunay(sh),
}


# -- against the point-wise quadrature reference ----------------------------------------------


@pytest.mark.parametrize("mesh_kind", sorted(MESHES))
@pytest.mark.parametrize("thickness", ["constant", "variable"])
def test_matches_pointwise_quadrature(mesh_kind, thickness):
    sh = panel(0.02 if thickness == "constant" else variable_thickness)
    space = ShellSpace(MESHES[mesh_kind](sh))
    for order in (10, 6):
        for parts in (("membrane", "bending"), ("membrane",), ("bending",)):
            A = model.stiffness(space, order, parts)
            R = reference_stiffness(space, order, parts)
            assert A.shape == R.shape and A.has_sorted_indices
            assert scaled_difference(A, R) < 1e-12, (order, parts)


def test_far_from_origin_and_small_elements():
    sh = Shell(
        radius=50.0, length=3.0, thickness=0.05,
        material=Isotropic(1e5, 0.25),
        alpha=1.0, beta=1.06, x_start=200.0,
    )
    space = ShellSpace(perturbed(sh, 6, 5, seed=3))
    assert scaled_difference(model.stiffness(space), reference_stiffness(space)) < 1e-12


def test_argyris_transformation_matches_vandermonde():
    for sh in (panel(), panel(x_start=100.0)):
        m = perturbed(sh, 6, 5).mesh
        normals = edge_normals(m.p, m.t, m.t2f, m.boundary_facets())
        fast = ArgyrisBasis.build(m.p, m.t, normals)
        direct = ArgyrisBasis.build_vandermonde(m.p, m.t, normals)
        scale = np.abs(direct.coef).max(axis=1, keepdims=True)  # per basis function
        assert np.max(np.abs(fast.coef - direct.coef) / scale) < 1e-12
        np.testing.assert_allclose(fast.centre, direct.centre)
        np.testing.assert_allclose(fast.h, direct.h)


def test_reference_evaluation_matches_monomial_evaluation():
    """ArgyrisBasis.evaluate_reference (reference basis + transformation) = evaluate (scaled monomials)."""
    space = ShellSpace(perturbed(panel(x_start=50.0), 5, 4))
    arg = space.argyris
    e = np.arange(space.mesh.nelements)
    X, _ = space.quadrature(8)
    Xe = np.random.default_rng(4).uniform(0.0, 0.5, (2, e.size, 3))  # different points in every element
    for pts in (X, Xe):
        x, s = (space.reference_to_physical(e, pts)[:2] if pts.ndim == 2 else
                _physical(space, e, pts))
        direct, ref = arg.evaluate(e, x, s), arg.evaluate_reference(e, pts)
        for k, v in direct.items():
            assert np.abs(ref[k] - v).max() <= 1e-12 * np.abs(v).max(), k


def _physical(space, e, Xe):
    p, t = space.mesh.p, space.mesh.t[:, e]
    p0, d1, d2 = p[:, t[0]], p[:, t[1]] - p[:, t[0]], p[:, t[2]] - p[:, t[0]]
    return tuple(p0[i][:, None] + d1[i][:, None] * Xe[0] + d2[i][:, None] * Xe[1] for i in range(2))


# -- against scikit-fem -----------------------------------------------------------------------


def _skfem_forms(shell: Shell):
    a, mu, E, t = shell.radius, shell.material.poisson, shell.material.young, shell.thickness
    B, D = E * t / (1 - mu**2), E * t**3 / (12 * (1 - mu**2))

    def strains(u, v, w):
        ux, us, vx, vs, H = u.grad[0], u.grad[1], v.grad[0], v.grad[1], w.hess
        return (ux, vs + w.value / a, us + vx, -H[0][0], -(H[1][1] + w.value / a**2), -H[0][1] + (vx - us) / (2 * a))

    def energy(e, f):
        return B * (e[0] * f[0] + mu * (e[0] * f[1] + e[1] * f[0]) + e[1] * f[1] + 0.5 * (1 - mu) * e[2] * f[2]) + D * (
            e[3] * f[3] + mu * (e[3] * f[4] + e[4] * f[3]) + e[4] * f[4] + 2 * (1 - mu) * e[5] * f[5]
        )

    @BilinearForm
    def full(u1, v1, w1, u2, v2, w2, _):
        return energy(strains(u1, v1, w1), strains(u2, v2, w2))

    @BilinearForm
    def w_only(w1, w2, _):
        zero = 0.0 * w1.value
        e = (zero, w1.value / a, zero, -w1.hess[0][0], -(w1.hess[1][1] + w1.value / a**2), -w1.hess[0][1])
        f = (zero, w2.value / a, zero, -w2.hess[0][0], -(w2.hess[1][1] + w2.value / a**2), -w2.hess[0][1])
        return energy(e, f)

    return full, w_only


@pytest.mark.parametrize("mesh_kind", ["structured", "perturbed"])
def test_reproduces_scikit_fem(mesh_kind):
    sh = Shell(radius=1.3, length=1.0, thickness=0.05, material=Isotropic(2.5, 0.3), alpha=0.0, beta=0.8, x_start=0.0)
    m = MESHES[mesh_kind](sh)
    space = ShellSpace(m)
    A = model.stiffness(space)
    full, w_only = _skfem_forms(sh)
    # The form has no explicit (x, s) dependence, so the mesh moved to have its centroid at the origin has the
    # same stiffness. scikit-fem inverts Vandermonde matrices of global monomials, which costs it digits far
    # from the origin (the small second-derivative dof entries); centred, it is the more exact reference.
    # Measured (AMD EPYC, relative to the largest entry), at the original place / centred: full operator
    # structured 3.2e-12 / 1.3e-13, perturbed 6.8e-11 / 2.4e-12; w block 1.4e-11 / 5.9e-13 and 1.6e-10 / 5.6e-12.
    centred = MeshTri(m.mesh.p - m.mesh.p.mean(axis=1, keepdims=True), m.mesh.t)
    cb = CellBasis(centred, ElementTriP2() * ElementTriP2() * ElementTriArgyris(), intorder=10)
    perm = np.concatenate(cb.split_indices())  # our dof k is scikit-fem's dof perm[k]
    F = full.assemble(cb)[perm][:, perm]
    assert abs(A - F).max() / abs(F).max() < 2e-11
    Wb = w_only.assemble(CellBasis(centred, ElementTriArgyris(), intorder=10))
    Aw = A[space.w_slice, space.w_slice]
    assert abs(Aw - Wb).max() / abs(Wb).max() < 5e-11


# -- the sparsity pattern ---------------------------------------------------------------------


@pytest.mark.parametrize("mesh_kind", sorted(MESHES))
def test_pattern_places_every_element_entry(mesh_kind):
    space = ShellSpace(MESHES[mesh_kind](panel()))
    pat = model.stiffness_pattern(space)
    nel = space.mesh.nelements
    rng = np.random.default_rng(5)
    Ke = rng.standard_normal((nel, 33, 33))
    dofs = space.element_dofs
    rows = np.broadcast_to(dofs.T[:, :, None], Ke.shape).ravel()
    cols = np.broadcast_to(dofs.T[:, None, :], Ke.shape).ravel()
    ref = sp.coo_matrix((Ke.ravel(), (rows, cols)), shape=pat.shape).tocsr()
    ref.sum_duplicates()
    ref.sort_indices()
    data = np.zeros(pat.nnz)
    np.add.at(data, pat.positions(np.arange(nel)).ravel(), Ke.ravel())
    np.testing.assert_array_equal(pat.indptr, ref.indptr)
    np.testing.assert_array_equal(pat.indices, ref.indices)
    np.testing.assert_allclose(data, ref.data, rtol=1e-13, atol=1e-13)


def test_stiffness_is_symmetric_and_does_not_share_the_cached_pattern():
    space = ShellSpace(perturbed(panel(), 4, 4))
    A = model.stiffness(space)
    assert abs(A - A.T).max() <= 1e-14 * abs(A).max()
    A.data[:] = 0.0
    A.eliminate_zeros()  # modifies indices/indptr in place
    B = model.stiffness(space)
    assert B.nnz == model.stiffness_pattern(space).nnz
    assert scaled_difference(B, reference_stiffness(space)) < 1e-12
