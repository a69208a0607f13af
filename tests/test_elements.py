"""The elements and the discrete model, checked against independent mathematics.

* rigid-body motions of MODEL.md §2 (exact: zero strain energy; interpolated: energy → 0 at
  the interpolation rate), coercivity with clamped edges (MODEL.md §9, (6.5)), the supports'
  rigid-motion check;
* the vectorised Argyris and P2 bases against scikit-fem's reference elements;
* a manufactured solution under nested refinement (MODEL.md §7, Theorem 5): observed rates.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest
from skfem import CellBasis, ElementTriArgyris, ElementTriP2

from shellcontact.errors import InputError
from shellcontact.linalg import factorize
from shellcontact.shell import model
from shellcontact.shell.geometry import Shell, rigid_motion, to_local
from shellcontact.shell.material import Isotropic, Orthotropic
from shellcontact.shell.mesh import structured
from shellcontact.shell.model import element_chunks, field_derivatives
from shellcontact.shell.spaces import QUANTITIES, ShellSpace
from shellcontact.shell.supports import RIGID_MOTIONS, Reduction, Supports

PANEL = Shell(
    radius=2.0,
    length=3.0,
    thickness=0.1,
    material=Isotropic(1.0, 0.3),
    alpha=math.radians(-40.0),
    beta=math.radians(70.0),
    x_start=-1.0,
)


def _rigid(k: int, shell: Shell):
    """The k-th unit rigid motion: translations e_k, rotations e_k / a (displacements of order 1)."""
    c, th = np.zeros(3), np.zeros(3)
    if k < 3:
        c[k] = 1.0
    else:
        th[k - 3] = 1.0 / shell.radius
    return c, th


def _exact_callable(space: ShellSpace, fields):
    """(elements, X) → derivative dict of an exact field at the physical quadrature points."""

    def f(e, X):
        x, s, _ = space.reference_to_physical(e, X)
        return fields(x, s)

    return f


# ---------------------------------------------------------------------------------------------
# 1. rigid motions
# ---------------------------------------------------------------------------------------------
def test_rigid_motion_fields_match_the_3d_motion():
    """geometry.rigid_motion equals to_local(c + θ × X), its derivatives equal finite differences."""
    sh = PANEL
    rng = np.random.default_rng(0)
    x = rng.uniform(sh.x_min, sh.x_max, 50)
    s = rng.uniform(sh.s_min, sh.s_max, 50)
    h = 1e-4

    def local(k, x, s):
        c, th = _rigid(k, sh)
        X = sh.point(x, s / sh.radius)
        D = c[:, None] + np.cross(th, X.T).T
        return to_local(D, s / sh.radius)

    for k in range(6):
        f = rigid_motion(sh, *_rigid(k, sh))
        d = f(x, s)
        ref = local(k, x, s)
        for i, name in enumerate("uvw"):
            assert np.allclose(d[name], ref[i], atol=1e-13), (RIGID_MOTIONS[k], name)
            dx = (local(k, x + h, s)[i] - local(k, x - h, s)[i]) / (2 * h)
            ds = (local(k, x, s + h)[i] - local(k, x, s - h)[i]) / (2 * h)
            assert np.allclose(d[name + "_x"], dx, atol=1e-7), (RIGID_MOTIONS[k], name + "_x")
            assert np.allclose(d[name + "_s"], ds, atol=1e-7), (RIGID_MOTIONS[k], name + "_s")
        wxx = (local(k, x + h, s)[2] - 2 * ref[2] + local(k, x - h, s)[2]) / h**2
        wss = (local(k, x, s + h)[2] - 2 * ref[2] + local(k, x, s - h)[2]) / h**2
        wxs = (
            local(k, x + h, s + h)[2]
            - local(k, x + h, s - h)[2]
            - local(k, x - h, s + h)[2]
            + local(k, x - h, s - h)[2]
        ) / (4 * h**2)
        for name, fd in (("w_xx", wxx), ("w_ss", wss), ("w_xs", wxs)):
            assert np.allclose(d[name], fd, atol=1e-5), (RIGID_MOTIONS[k], name)
        # the strains of MODEL.md §2, fed with these finite differences only, vanish
        fd = {"w_xx": wxx, "w_ss": wss, "w_xs": wxs}
        for i, name in enumerate("uvw"):
            fd[name] = ref[i]
            fd[name + "_x"] = (local(k, x + h, s)[i] - local(k, x - h, s)[i]) / (2 * h)
            fd[name + "_s"] = (local(k, x, s + h)[i] - local(k, x, s - h)[i]) / (2 * h)
        assert np.abs(model.strains(fd, sh.radius)).max() < 1e-6, RIGID_MOTIONS[k]


def test_exact_rigid_motions_have_zero_strain_energy():
    """a(R, R) / a(Q, Q) ≤ 1e-12 for the six rigid motions R and a non-rigid Q of the same size."""
    sh = PANEL
    space = ShellSpace(structured(sh, 4, 4))
    xi = lambda x: (x - sh.x_min) / sh.length  # noqa: E731
    L, S = sh.length, sh.s_max - sh.s_min

    def bump(x, s):  # w = sin(πξ) sin(πη), an inextensional-free, non-rigid field of size 1
        e = (s - sh.s_min) / S
        a, b = np.pi * xi(x), np.pi * e
        z = 0 * x
        out = {k: z for k in QUANTITIES}
        out.update(
            w=np.sin(a) * np.sin(b),
            w_x=np.pi / L * np.cos(a) * np.sin(b),
            w_s=np.pi / S * np.sin(a) * np.cos(b),
            w_xx=-((np.pi / L) ** 2) * np.sin(a) * np.sin(b),
            w_xs=np.pi**2 / (L * S) * np.cos(a) * np.cos(b),
            w_ss=-((np.pi / S) ** 2) * np.sin(a) * np.sin(b),
        )
        return out

    ref = model.energy_norm_sq(space, _exact_callable(space, bump))
    assert ref > 0
    print("\nrigid motion                 a(R,R)/a(Q,Q)")
    for k in range(6):
        e = model.energy_norm_sq(space, _exact_callable(space, rigid_motion(sh, *_rigid(k, sh))))
        print(f"{RIGID_MOTIONS[k]:26s} {e / ref:10.2e}")
        assert e <= 1e-12 * ref, RIGID_MOTIONS[k]


def test_interpolated_rigid_motions_energy_tends_to_zero(rates):
    """Energy of I_h(R) → 0 like h⁴ (P2 interpolation error O(h²) in H¹); exact for two of them."""
    sh = PANEL
    base = structured(sh, 2, 2)
    hs, energies = [], []
    for level in range(4):
        m = base.refined(level)
        space = ShellSpace(m)
        A = model.stiffness(space)
        absA = abs(A)
        row = []
        for k in range(6):
            r = space.interpolate(rigid_motion(sh, *_rigid(k, sh)))
            e = float(r @ (A @ r))
            if k in (0, 3):  # u = const, v = const lie in the P2 space: zero up to round-off in rᵀ A r
                assert abs(e) <= 1e-13 * float(abs(r) @ (absA @ abs(r))), RIGID_MOTIONS[k]
            row.append(max(e, 0.0))
        hs.append(m.h())
        energies.append(row)
    E = np.array(energies)
    print("\nh        " + " ".join(f"{n[:14]:>14s}" for n in RIGID_MOTIONS))
    for h, row in zip(hs, E):
        print(f"{h:.4f} " + " ".join(f"{v:14.3e}" for v in row))
    for k in range(6):
        if k in (0, 3):
            continue
        r = rates(hs, np.sqrt(E[:, k]))
        print(f"{RIGID_MOTIONS[k]}: energy-norm rates {np.round(r, 3)}")
        assert r[-1] > 1.9, (RIGID_MOTIONS[k], r)


def test_clamped_stiffness_is_symmetric_positive_definite():
    sh = PANEL
    space = ShellSpace(structured(sh, 3, 2))
    A = model.stiffness(space)
    red = Reduction.build(space, Supports())
    Ar = red.reduce_matrix(A).toarray()
    assert np.abs(Ar - Ar.T).max() <= 1e-13 * np.abs(Ar).max()
    d = 1.0 / np.sqrt(np.diag(Ar))
    As = Ar * d[:, None] * d[None, :]
    np.linalg.cholesky(As)  # raises LinAlgError if not positive definite
    lam = np.linalg.eigvalsh(As)
    print(f"\nclamped {As.shape[0]} unknowns: scaled eigenvalues in [{lam[0]:.3e}, {lam[-1]:.3e}]")
    assert lam[0] > 0.0
    # the free panel, by contrast, has the rigid motions u = const, v = const as exact null vectors
    Af = A.toarray()
    for k in (0, 3):
        r = space.interpolate(rigid_motion(sh, *_rigid(k, sh)))
        assert np.linalg.norm(Af @ r) <= 1e-12 * np.abs(Af).max() * np.linalg.norm(r)


@pytest.mark.parametrize(
    ("supports", "expect"),
    [
        (Supports("free", "free", "free", "free"), "no edge is supported"),
        (Supports("simply_supported", "simply_supported", "free", "free"), "translation along x"),
        (Supports("free", "free", "simply_supported", "simply_supported"), "rotation about x"),
    ],
)
def test_supports_that_leave_a_rigid_motion_free_are_rejected(supports, expect):
    space = ShellSpace(structured(PANEL, 3, 3))
    with pytest.raises(InputError, match=expect) as exc:
        Reduction.build(space, supports)
    assert exc.value.field == "supports"
    print(f"\n{supports}: {exc.value}")


def test_diaphragm_roof_with_a_symmetry_plane_is_accepted():
    """Diaphragms at both ends leave only the axial translation free (rejected above); the
    quarter Scordelis–Lo model with u = 0 on its mid-length symmetry plane is accepted."""
    sh = Shell(
        radius=25.0,
        length=25.0,
        thickness=0.25,
        material=Isotropic(4.32e8, 0.0),
        alpha=math.radians(50.0),
        beta=math.radians(90.0),
        x_start=0.0,
    )
    space = ShellSpace(structured(sh, 3, 3))
    Reduction.build(space, Supports("symmetry", "simply_supported", "free", "symmetry"))


# ---------------------------------------------------------------------------------------------
# 2. the bases against scikit-fem
# ---------------------------------------------------------------------------------------------
def test_argyris_and_p2_bases_equal_scikit_fem():
    sh = Shell(
        radius=1.0, length=1.0, thickness=0.01,
        material=Isotropic(1.0, 0.3),
        alpha=0.0, beta=math.radians(40.0), x_start=0.0,
    )
    m = structured(sh, 2, 2)
    space = ShellSpace(m)
    nel = m.nelements
    # Argyris (w): element dofs and values/gradients/Hessians at quadrature points
    ba = CellBasis(m.mesh, ElementTriArgyris(), intorder=8)
    ours = space.element_basis(np.arange(nel), ba.X)
    w0 = 2 * space.n_p2
    assert np.array_equal(space.element_dofs[12:] - w0, ba.element_dofs)
    worst = {}
    for i in range(21):
        ref = ba.basis[i][0]
        pairs = {
            "w": (ours["w"][12 + i], ref.value),
            "w_x": (ours["w_x"][12 + i], ref.grad[0]),
            "w_s": (ours["w_s"][12 + i], ref.grad[1]),
            "w_xx": (ours["w_xx"][12 + i], ref.hess[0, 0]),
            "w_xs": (ours["w_xs"][12 + i], ref.hess[0, 1]),
            "w_ss": (ours["w_ss"][12 + i], ref.hess[1, 1]),
        }
        for k, (a, b) in pairs.items():
            err = np.abs(a - b).max() / max(np.abs(b).max(), 1e-300)
            worst[k] = max(worst.get(k, 0.0), err)
    # P2 (u and v)
    bp = CellBasis(m.mesh, ElementTriP2(), intorder=8)
    assert np.array_equal(space.element_dofs[:6], bp.element_dofs)
    assert np.array_equal(space.element_dofs[6:12] - space.n_p2, bp.element_dofs)
    for i in range(6):
        ref = bp.basis[i][0]
        for k, (a, b) in {
            "u": (ours["u"][i], ref.value),
            "u_x": (ours["u_x"][i], ref.grad[0]),
            "u_s": (ours["u_s"][i], ref.grad[1]),
            "v": (ours["v"][6 + i], ref.value),
            "v_s": (ours["v_s"][6 + i], ref.grad[1]),
        }.items():
            worst[k] = max(worst.get(k, 0.0), np.abs(a - b).max() / np.abs(b).max())
    print("\nmax relative difference to scikit-fem: " + ", ".join(f"{k} {v:.1e}" for k, v in worst.items()))
    for k, v in worst.items():
        assert v < 1e-10, k


# ---------------------------------------------------------------------------------------------
# 3. manufactured solution under nested refinement
# ---------------------------------------------------------------------------------------------
MS_SHELL = Shell(
    radius=1.5, length=2.0, thickness=0.1, material=Isotropic(1.0, 0.3), alpha=0.0, beta=math.radians(60.0), x_start=0.0
)
# the same rates for an orthotropic law (material.py), here a strongly hoop-stiff one
MS_MATERIALS = {"isotropic": Isotropic(1.0, 0.3), "orthotropic": Orthotropic(e1=1.0, e2=3.0, g12=0.2, nu12=0.1)}


def _f1(kind: str, z: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A 1D function on [0, 1] and its first two derivatives."""
    p = np.pi
    if kind == "s1":  # sin(πz): vanishes at 0, 1
        return np.sin(p * z), p * np.cos(p * z), -(p**2) * np.sin(p * z)
    if kind == "s2":  # sin(2πz) (1 + z): vanishes at 0, 1
        g, g1, g2 = np.sin(2 * p * z), 2 * p * np.cos(2 * p * z), -4 * p**2 * np.sin(2 * p * z)
        return g * (1 + z), g1 * (1 + z) + g, g2 * (1 + z) + 2 * g1
    if kind == "q":  # sin²(πz) e^z: value and slope vanish at 0, 1
        g, g1, g2 = np.sin(p * z) ** 2, p * np.sin(2 * p * z), 2 * p**2 * np.cos(2 * p * z)
        e = np.exp(z)
        return g * e, (g1 + g) * e, (g2 + 2 * g1 + g) * e
    raise ValueError(kind)


def manufactured(sh: Shell, with_membrane: bool = True):
    """U = (u, v, w) with u = v = 0, w = ∇w = 0 on ∂Ω (the clamped conditions (2.3))."""
    L, S = sh.length, sh.s_max - sh.s_min
    spec = {"u": (0.5, "s1", "s2"), "v": (0.4, "s2", "s1"), "w": (0.3, "q", "q")}

    def fields(x, s):
        xi, eta = (x - sh.x_min) / L, (s - sh.s_min) / S
        out = {}
        for name, (amp, fx, fs) in spec.items():
            if name != "w" and not with_membrane:
                amp = 0.0
            f, g = _f1(fx, xi), _f1(fs, eta)
            out[name] = amp * f[0] * g[0]
            out[name + "_x"] = amp * f[1] * g[0] / L
            out[name + "_s"] = amp * f[0] * g[1] / S
            if name == "w":
                out["w_xx"] = amp * f[2] * g[0] / L**2
                out["w_xs"] = amp * f[1] * g[1] / (L * S)
                out["w_ss"] = amp * f[0] * g[2] / S**2
        return out

    return fields


def _weak_load(space: ShellSpace, exact, parts=("membrane", "bending")) -> np.ndarray:
    """F_i = a(U_exact, φ_i) by quadrature with the exact derivatives (equivalently the strong operator)."""
    sh = space.mesh.shell
    X, W = space.quadrature(12)
    mask = np.array([1.0 * ("membrane" in parts)] * 3 + [1.0 * ("bending" in parts)] * 3)
    F = np.zeros(space.ndofs)
    for e in element_chunks(space.mesh.nelements):
        x, s, detJ = space.reference_to_physical(e, X)
        eb = model.strains(space.element_basis(e, X), sh.radius) * mask[:, None, None, None]
        ee = model.strains(exact(x, s), sh.radius) * mask[:, None, None]
        C = model.constitutive(sh, sh.t(x, s / sh.radius))
        fe = np.einsum("kbnq,klnq,lnq,nq->bn", eb, C, ee, W[None, :] * detJ[:, None], optimize=True)
        np.add.at(F, space.element_dofs[:, e], fe)
    return F


def _errors(space: ShellSpace, U: np.ndarray, exact) -> tuple[dict[str, float], dict[str, float]]:
    """∫ (quantity_h − quantity)² and ∫ quantity² for every QUANTITY."""
    X, W = space.quadrature(12)
    err, ref = dict.fromkeys(QUANTITIES, 0.0), dict.fromkeys(QUANTITIES, 0.0)
    for e in element_chunks(space.mesh.nelements):
        x, s, detJ = space.reference_to_physical(e, X)
        dh, de = field_derivatives(space, U, e, X), exact(x, s)
        wq = W[None, :] * detJ[:, None]
        for k in QUANTITIES:
            err[k] += float(np.sum((dh[k] - de[k]) ** 2 * wq))
            ref[k] += float(np.sum(de[k] ** 2 * wq))
    return err, ref


def _norm(d: dict[str, float], field: str, order: int) -> float:
    keys = {0: [""], 1: ["", "_x", "_s"], 2: ["", "_x", "_s", "_xx", "_xs", "_ss"]}[order]
    extra = ["_xs"] if order == 2 else []  # the mixed derivative appears twice in |D²w|²
    return math.sqrt(sum(d[field + k] for k in keys + extra))


@pytest.mark.parametrize("material", sorted(MS_MATERIALS))
def test_manufactured_solution_rates(rates, material):
    """Clamped panel, U smooth: u, v in H¹ and the energy norm converge like h², as P2 allows.

    The load is a(U, φ_i) with the exact derivatives, so U_h is the a-projection of U and the
    energy error is the best approximation error, dominated by the P2 fields (O(h²)).
    """
    sh = replace(MS_SHELL, material=MS_MATERIALS[material])
    exact = manufactured(sh)
    base = structured(sh, 2, 2)
    rows = []
    for level in range(1, 5):
        m = base.refined(level)
        space = ShellSpace(m)
        A = model.stiffness(space)
        F = _weak_load(space, exact)
        red = Reduction.build(space, Supports())
        U = red.expand(factorize(red.reduce_matrix(A)).solve(red.reduce_vector(F)))
        err, ref = _errors(space, U, exact)

        def diff(e, X, space=space, U=U):
            dh = field_derivatives(space, U, e, X)
            x, s, _ = space.reference_to_physical(e, X)
            de = exact(x, s)
            return {k: dh[k] - de[k] for k in QUANTITIES}

        en = math.sqrt(model.energy_norm_sq(space, diff) / model.energy_norm_sq(space, _exact_callable(space, exact)))
        rows.append(
            (
                m.h(),
                space.ndofs,
                _norm(err, "u", 1) / _norm(ref, "u", 1),
                _norm(err, "v", 1) / _norm(ref, "v", 1),
                _norm(err, "w", 2) / _norm(ref, "w", 2),
                en,
            )
        )
    R = np.array(rows)
    print("\n   h       dofs   |u-uh|_1   rate  |v-vh|_1   rate  |w-wh|_2   rate   energy    rate")
    for i, r in enumerate(R):
        rr = [rates(R[i - 1 : i + 1, 0], R[i - 1 : i + 1, 2 + j])[0] for j in range(4)] if i else None
        tail = "".join(f"{r[2 + j]:10.3e} {'' if rr is None else f'{rr[j]:5.2f}':>5s}" for j in range(4))
        print(f"{r[0]:.4f} {int(r[1]):7d} {tail}")
    for j, name in enumerate(("u in H1", "v in H1", "w in H2 (coupled)", "energy")):
        print(f"{name}: rates {np.round(rates(R[:, 0], R[:, 2 + j]), 2)}")
    for j in (0, 1, 3):  # u, v, energy norm: O(h²)
        r = rates(R[:, 0], R[:, 2 + j])
        assert r[-1] > 1.9 and r[-2] > 1.8, (j, r)
    assert R[-1, 5] < 1e-2


@pytest.mark.parametrize("material", sorted(MS_MATERIALS))
def test_argyris_bending_alone_converges_at_h4_in_h2(rates, material):
    """Bending energy only, w alone, clamped: the Argyris P5 element gives O(h⁴) in H², O(h⁵) in H¹."""
    sh = replace(MS_SHELL, material=MS_MATERIALS[material])
    exact = manufactured(sh, with_membrane=False)
    base = structured(sh, 2, 2)
    rows = []
    for level in range(0, 4):
        m = base.refined(level)
        space = ShellSpace(m)
        A = model.stiffness(space, parts=("bending",))
        F = _weak_load(space, exact, parts=("bending",))
        red = Reduction.build(space, Supports())
        cols = np.nonzero(red.free >= space.w_slice.start)[0]
        Aw = red.reduce_matrix(A)[cols][:, cols]
        Fw = red.reduce_vector(F)[cols]
        Ur = np.zeros(red.P.shape[1])
        Ur[cols] = factorize(Aw).solve(Fw)
        U = red.expand(Ur)
        err, ref = _errors(space, U, exact)
        rows.append(
            (m.h(), cols.size, _norm(err, "w", 2) / _norm(ref, "w", 2), _norm(err, "w", 1) / _norm(ref, "w", 1))
        )
    R = np.array(rows)
    r2, r1 = rates(R[:, 0], R[:, 2]), rates(R[:, 0], R[:, 3])
    print("\n   h     w-dofs   |w-wh|_2  rate   |w-wh|_1  rate")
    for i, r in enumerate(R):
        print(
            f"{r[0]:.4f} {int(r[1]):7d} {r[2]:10.3e} {r2[i - 1] if i else float('nan'):5.2f} "
            f"{r[3]:10.3e} {r1[i - 1] if i else float('nan'):5.2f}"
        )
    assert r2[-1] > 3.8 and r2[-2] > 3.6, r2
    assert r1[-1] > 4.7, r1


def test_prolongation_into_a_nested_space_evaluates_the_coarse_field_once():
    """The nested start's prolongation (``interpolate`` of a coarse solution): P2 is nested, so u and v are
    reproduced at any point; Argyris P5 is not (the fine space asks for C² at the new vertices), but the
    interpolant takes w, ∇w, ∇²w at the fine vertices from the coarse field, which is C¹ there, so w and ∇w at the
    fine vertices are the coarse field's. The coarse field is evaluated once, at every P2 node of the fine mesh:
    before, also at its vertices and its midpoints again (twice the cost: 4.0 → 2.0 CPU s at 281k dofs)."""
    from shellcontact.outputs.results import ShellSolution

    coarse = ShellSpace(structured(PANEL, 3, 2))
    fine = ShellSpace(structured(PANEL, 3, 2).refined(1))
    U = np.random.default_rng(4).standard_normal(coarse.ndofs)
    sol = ShellSolution(space=coarse, U=U, A=None, F=None)
    calls = []

    def fields(x, s):
        calls.append(x.size)
        return sol.evaluate(x, s / PANEL.radius)

    Uf = fine.interpolate(fields)
    assert len(calls) == 1
    fine_sol = ShellSolution(space=fine, U=Uf, A=None, F=None)
    rng = np.random.default_rng(5)
    x, phi = rng.uniform(PANEL.x_min, PANEL.x_max, 50), rng.uniform(PANEL.alpha, PANEL.beta, 50)
    p = fine.mesh.p
    checks = [(x, phi, ("u", "u_x", "u_s", "v", "v_x", "v_s")), (p[0], p[1] / PANEL.radius, ("w", "w_x", "w_s"))]
    for xs, ps, quantities in checks:
        got, want = fine_sol.evaluate(xs, ps), sol.evaluate(xs, ps)
        for q in quantities:
            assert np.abs(got[q] - want[q]).max() <= 1e-9 * np.abs(want[q]).max(), q  # measured: round-off
