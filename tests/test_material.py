r"""The shell materials (material.py, MODEL.md §3), checked against independent mathematics.

* Q against the compliance matrix S = Q⁻¹ written from the engineering constants
  (ε11 = σ11/E1 − ν21 σ22/E2, ε22 = σ22/E2 − ν12 σ11/E1, γ12 = σ12/G12, with ν21/E2 = ν12/E1);
  the model's energy matrix and resultants against ½ t εᵀQε + ½ (t³/12) κᵀQκ, κ = (κ11, κ22, 2κ12);
* fields of constant strain (axial stretch, uniform radial expansion, torsion), which the elements
  represent exactly: Uᵀ A U equals the energy integral in closed form;
* the isotropic limit Orthotropic(E, E, E/(2(1+μ)), μ) = Isotropic(E, μ), and the isotropic energy
  factors are the package's historical B, D arithmetic (which keeps results bit-identical);
* the clamped pressurised cylinder (axisymmetric) against the closed form of THIS model with the
  orthotropic law, derived below; the FE error must equal its discretisation error;
* invalid materials and case files raise InputError naming the key.

The manufactured-solution rates with an orthotropic material are in test_elements.py
(test_manufactured_solution_rates, test_argyris_bending_alone_converges_at_h4_in_h2).

Axisymmetric equations (MODEL.md §2 with v = 0 and ∂/∂φ = 0, w outward, internal pressure p; d = t³/12):

    ε11 = u',  ε22 = w/a,  κ11 = −w'',  κ22 = −w/a²  (γ12 = κ12 = 0, so G12 does not enter),
    N11 = t(Q11 u' + Q12 w/a),  N22 = t(Q12 u' + Q22 w/a),
    M11 = −d(Q11 w'' + Q12 w/a²),  M22 = −d(Q12 w'' + Q22 w/a²).

Stationarity of ½ a(U, U) − ∫ p w gives, exactly as for the isotropic shell, N11' = 0 (N11 ≡ N) and
−M11'' + N22/a − M22/a² = p. With B1 = t Q11, D1 = d Q11, ν = Q12/Q11 (= ν21): u' = N/B1 − ν w/a,
N22 = ν N + t (Q22 − Q12²/Q11) w/a = ν N + E2 t w/a, and

    D1 w'''' + (2 ν D1/a²) w'' + c w = p − ν N/a,     c = E2 t/a² + d Q22/a⁴,

the isotropic equation of test_axisymmetric_pressure.py with (B, D, μ, E t) → (B1, D1, ν, E2 t). Clamped
ends: w = w' = 0 and u = 0 at x = ±H, so N = B1 ν mean(w)/a; roots r = ±λ ± iω of
r⁴ + (2ν/a²) r² + c/D1 = 0 with λ² + ω² = √(c/D1), λ² − ω² = −ν/a² (complex when c/D1 > ν²/a⁴).
"""

from __future__ import annotations

import copy
import math
import re
import tomllib
from dataclasses import dataclass, replace

import numpy as np
import pytest
from test_axisymmetric_pressure import ClampedPressurizedCylinder

import shellcontact as sc
from shellcontact.analysis.pipeline import default_penalty
from shellcontact.errors import InputError
from shellcontact.problem.case import MATERIAL, read_case_dict
from shellcontact.shell import model
from shellcontact.shell.geometry import Shell
from shellcontact.shell.material import Isotropic, Orthotropic
from shellcontact.shell.mesh import structured
from shellcontact.shell.spaces import QUANTITIES, ShellSpace

# a hoop-wound pipe (stiffer around the circumference) and an axially stiff one
HOOP_WOUND = Orthotropic(e1=1.0e4, e2=2.5e4, g12=0.4e4, nu12=0.12)
AXIAL = Orthotropic(e1=3.0e4, e2=1.2e4, g12=0.5e4, nu12=0.35)
MATERIALS = {"isotropic": Isotropic(2.0e4, 0.3), "hoop-wound": HOOP_WOUND, "axial": AXIAL}


def compliance(mat) -> np.ndarray:
    """S = Q⁻¹ from the engineering constants."""
    if isinstance(mat, Isotropic):
        E, mu = mat.young, mat.poisson
        return np.array([[1 / E, -mu / E, 0], [-mu / E, 1 / E, 0], [0, 0, 2 * (1 + mu) / E]])
    return np.array(
        [[1 / mat.e1, -mat.nu12 / mat.e1, 0], [-mat.nu12 / mat.e1, 1 / mat.e2, 0], [0, 0, 1 / mat.g12]]
    )


def panel(material, thickness=0.05) -> Shell:
    return Shell(radius=1.3, length=2.0, thickness=thickness, material=material, alpha=0.2, beta=1.0)


# ---------------------------------------------------------------------------------------------
# 1. the material matrices
# ---------------------------------------------------------------------------------------------
@pytest.mark.parametrize("name", sorted(MATERIALS))
def test_plane_stress_matrix_inverts_the_compliance(name):
    mat = MATERIALS[name]
    Q = mat.plane_stress
    np.testing.assert_allclose(Q, Q.T, rtol=0, atol=0)
    np.testing.assert_allclose(Q @ compliance(mat), np.eye(3), atol=1e-14)
    assert np.all(np.linalg.eigvalsh(Q) > 0)
    # hoop modulus: σ22/ε22 under σ22 alone
    assert math.isclose(mat.hoop_modulus, 1.0 / compliance(mat)[1, 1], rel_tol=1e-14)
    t = np.array([0.01, 0.2])
    np.testing.assert_allclose(mat.membrane_stiffness(t), Q[:, :, None] * t, rtol=1e-15)
    np.testing.assert_allclose(mat.bending_stiffness(t), Q[:, :, None] * t**3 / 12, rtol=1e-15)


@pytest.mark.parametrize("name", sorted(MATERIALS))
def test_energy_matrix_and_resultants_follow_model_md(name):
    """eᵀ C e = t εᵀQε + (t³/12) κᵀQκ and (N, M) = (t Q ε, (t³/12) Q κ) with κ = (κ11, κ22, 2κ12)."""
    mat = MATERIALS[name]
    Q = np.linalg.inv(compliance(mat))
    sh = panel(mat)
    rng = np.random.default_rng(7)
    e = rng.standard_normal((6, 40))
    t = rng.uniform(0.01, 0.1, 40)
    eps, kap = e[:3], e[3:] * np.array([1.0, 1.0, 2.0])[:, None]
    C = model.constitutive(sh, t)
    density = np.einsum("kn,kln,ln->n", e, C, e)
    expect = t * np.einsum("kn,kl,ln->n", eps, Q, eps) + t**3 / 12 * np.einsum("kn,kl,ln->n", kap, Q, kap)
    np.testing.assert_allclose(density, expect, rtol=1e-13)
    r = model.resultants(sh, e, t)
    np.testing.assert_allclose(r[:3], t * (Q @ eps), rtol=1e-12, atol=1e-12 * np.abs(t * (Q @ eps)).max())
    M = t**3 / 12 * (Q @ kap)
    np.testing.assert_allclose(r[3:], M, rtol=1e-12, atol=1e-12 * np.abs(M).max())


@pytest.mark.parametrize("name", sorted(MATERIALS))
def test_constant_strain_fields_have_their_exact_energy(name):
    """u = αx, v = γx, w = w0 lie in the FE space; their strains are constant:
    ε = (α, w0/a, γ), κ = (0, −w0/a², 2 · γ/(2a)), so Uᵀ A U = area · (t εᵀQε + (t³/12) κᵀQκ)."""
    mat = MATERIALS[name]
    Q = np.linalg.inv(compliance(mat))
    sh = panel(mat)
    a, t = sh.radius, sh.thickness
    area = sh.length * (sh.s_max - sh.s_min)
    space = ShellSpace(structured(sh, 3, 4))
    A = model.stiffness(space)

    def field(alpha, gamma, w0):
        def f(x, s):
            out = {k: 0.0 * x for k in QUANTITIES}
            out.update(u=alpha * x, u_x=alpha + 0 * x, v=gamma * x, v_x=gamma + 0 * x, w=w0 + 0 * x)
            return out

        eps = np.array([alpha, w0 / a, gamma])
        kap = np.array([0.0, -w0 / a**2, gamma / a])
        return space.interpolate(f), area * (t * eps @ Q @ eps + t**3 / 12 * kap @ Q @ kap)

    for alpha, gamma, w0 in ((1e-3, 0, 0), (0, 1e-3, 0), (0, 0, 1e-3), (1e-3, -2e-3, 3e-3)):
        U, exact = field(alpha, gamma, w0)
        assert math.isclose(float(U @ (A @ U)), exact, rel_tol=1e-12), (alpha, gamma, w0)


def test_default_penalty_uses_the_hoop_modulus(examples_dir):
    raw = read_case_dict(examples_dir / "pressurized_cylinder.toml")
    del raw["shell"]["young"], raw["shell"]["poisson"]
    raw["material"] = {"model": "orthotropic", "e1": 1.0e4, "e2": 2.5e4, "g12": 0.4e4, "nu12": 0.12}
    case = sc.case_from_dict(raw)
    sh = case.shell
    assert math.isclose(default_penalty(case), 1e-6 * sh.radius**2 / (2.5e4 * sh.thickness), rel_tol=1e-15)


# ---------------------------------------------------------------------------------------------
# 2. the isotropic limit
# ---------------------------------------------------------------------------------------------
def _as_orthotropic(mat: Isotropic) -> Orthotropic:
    E, mu = mat.young, mat.poisson
    return Orthotropic(E, E, E / (2 * (1 + mu)), mu)


@pytest.mark.parametrize("thickness", ["constant", "variable"])
@pytest.mark.parametrize("mu", [0.3, 0.0, -0.4])
def test_isotropic_limit_gives_the_same_stiffness(thickness, mu):
    iso = Isotropic(2.5, mu)
    orth = _as_orthotropic(iso)
    np.testing.assert_allclose(orth.plane_stress, iso.plane_stress, rtol=1e-15, atol=1e-15 * iso.young)
    th = 0.02 if thickness == "constant" else (lambda x, phi: 0.02 * (1 + 0.3 * np.sin(2 * x) * np.cos(3 * phi)))
    space = ShellSpace(structured(panel(iso, th), 5, 4, "crossed"))
    Ai = model.stiffness(space)
    Ao = model.stiffness(ShellSpace(structured(panel(orth, th), 5, 4, "crossed")))
    assert np.array_equal(Ai.indices, Ao.indices) and np.array_equal(Ai.indptr, Ao.indptr)
    rel = np.abs(Ao.data - Ai.data).max() / np.abs(Ai.data).max()
    print(f"\nmu = {mu}, {thickness} thickness: max |A_orth - A_iso| / max |A_iso| = {rel:.1e}")
    assert rel <= 1e-14


def _historical_constitutive(E: float, mu: float, t: np.ndarray) -> np.ndarray:
    """model.constitutive before material.py, verbatim (with B, D from E, μ): the bit-identity reference."""
    B, D = E * t / (1.0 - mu**2), E * t**3 / (12.0 * (1.0 - mu**2))
    C = np.zeros((6, 6) + np.shape(t))
    for off, S, shear in ((0, B, 0.5 * (1 - mu)), (3, D, 2.0 * (1 - mu))):
        C[off, off] = C[off + 1, off + 1] = S
        C[off, off + 1] = C[off + 1, off] = mu * S
        C[off + 2, off + 2] = shear * S
    return C


@pytest.mark.parametrize("E,mu", [(2.1e11, 0.3), (4.32e8, 0.0), (1.0, -0.2), (3, 0.49)])
def test_isotropic_arithmetic_is_the_historical_one(E, mu):
    """The assembly multiplies membrane_scale(t) by membrane_pattern (likewise bending): for Isotropic these
    are, to the last bit, the B, D and the [[1, μ, 0], [μ, 1, 0], [0, 0, (1−μ)/2 | 2(1−μ)]] of the code
    before material.py, so isotropic results are unchanged bit for bit."""
    mat = Isotropic(E, mu)
    t = np.random.default_rng(1).uniform(0.001, 0.3, (4, 7))
    assert np.array_equal(mat.membrane_scale(t), E * t / (1.0 - mu**2))
    assert np.array_equal(mat.bending_scale(t), E * t**3 / (12.0 * (1.0 - mu**2)))
    for pattern, shear in ((mat.membrane_pattern, 0.5 * (1.0 - mu)), (mat.bending_pattern, 2.0 * (1.0 - mu))):
        assert np.array_equal(pattern, np.array([[1.0, mu, 0.0], [mu, 1.0, 0.0], [0.0, 0.0, shear]]))
    assert np.array_equal(model.constitutive(panel(mat), t), _historical_constitutive(E, mu, t))
    assert mat.hoop_modulus == E


# ---------------------------------------------------------------------------------------------
# 3. the clamped pressurised cylinder, orthotropic
# ---------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class OrthotropicClampedCylinder:
    """Closed-form axisymmetric solution for x ∈ [−H, H], clamped ends (module docstring)."""

    a: float
    t: float
    H: float
    material: Orthotropic | Isotropic
    p: float

    def __post_init__(self) -> None:
        a, t, H = self.a, self.t, self.H
        Q = self.material.plane_stress
        d = t**3 / 12
        B1, D1, nu = t * Q[0, 0], d * Q[0, 0], Q[0, 1] / Q[0, 0]
        c = self.material.hoop_modulus * t / a**2 + d * Q[1, 1] / a**4
        k = c / D1
        assert k > nu**2 / a**4  # complex roots
        lam = math.sqrt((math.sqrt(k) - nu / a**2) / 2)
        om = math.sqrt((math.sqrt(k) + nu / a**2) / 2)
        r = complex(lam, om)
        assert abs(r**4 + 2 * nu / a**2 * r**2 + k) < 1e-10 * k
        f, f1, intg = np.cosh(r * H), r * np.sinh(r * H), np.sinh(r * H) / r
        g = B1 * nu / a  # N = g mean(w)
        M = np.array(
            [
                [f.real, f.imag, -nu / (a * c)],
                [f1.real, f1.imag, 0.0],
                [-g * intg.real / H, -g * intg.imag / H, 1.0 + g * nu / (a * c)],
            ]
        )
        C1, C2, N = np.linalg.solve(M, np.array([-self.p / c, 0.0, g * self.p / c]))
        for name, val in dict(B1=B1, D1=D1, nu=nu, c=c, r=r, C1=C1, C2=C2, N=N).items():
            object.__setattr__(self, name, val)

    def w(self, x, d: int = 0) -> np.ndarray:
        x = np.asarray(x, float)
        z = self.r**d * (np.cosh(self.r * x) if d % 2 == 0 else np.sinh(self.r * x))
        out = self.C1 * z.real + self.C2 * z.imag
        return out + (self.p - self.nu * self.N / self.a) / self.c if d == 0 else out

    def u(self, x) -> np.ndarray:
        """u = N (x + H)/B1 − (ν/a) ∫_{−H}^{x} w."""
        x = np.asarray(x, float)
        r, H = self.r, self.H
        prim = (np.sinh(r * x) - np.sinh(-r * H)) / r
        wp = (self.p - self.nu * self.N / self.a) / self.c
        integral = self.C1 * prim.real + self.C2 * prim.imag + wp * (x + H)
        return self.N * (x + H) / self.B1 - self.nu / self.a * integral

    def M11(self, x) -> np.ndarray:
        return -self.D1 * (self.w(x, 2) + self.nu * self.w(x) / self.a**2)


@pytest.mark.parametrize("mat", [HOOP_WOUND, AXIAL], ids=["hoop-wound", "axial"])
def test_orthotropic_closed_form_satisfies_its_equations(mat):
    """w solves D1 w'''' + 2νD1 w''/a² + c w = p − νN/a; w = w' = u = 0 at ±H; N11 = t(Q11 u' + Q12 w/a) = N."""
    ex = OrthotropicClampedCylinder(a=10.0, t=0.1, H=10.0, material=mat, p=1.0)
    Q, t, a = mat.plane_stress, ex.t, ex.a
    x = np.linspace(-ex.H, ex.H, 41)
    z4 = ex.r**4 * np.cosh(ex.r * x)
    w4 = ex.C1 * z4.real + ex.C2 * z4.imag
    # the equation written with Q and E2 directly: d Q11 w'''' + 2 d Q12 w''/a² + (E2 t/a² + d Q22/a⁴) w
    d = t**3 / 12
    lhs = d * Q[0, 0] * w4 + 2 * d * Q[0, 1] / a**2 * ex.w(x, 2) + (mat.e2 * t / a**2 + d * Q[1, 1] / a**4) * ex.w(x)
    assert np.abs(lhs - (ex.p - Q[0, 1] / Q[0, 0] * ex.N / a)).max() < 1e-10 * ex.p
    for end in (-ex.H, ex.H):
        assert abs(ex.w(end)) < 1e-12 * ex.w(0.0) and abs(ex.w(end, 1)) < 1e-10 * ex.w(0.0) / t
        assert abs(ex.u(end)) < 1e-12 * ex.w(0.0)
    h = 1e-5
    xs = np.array([-7.0, -0.5, 3.0, 9.9])
    du = (ex.u(xs + h) - ex.u(xs - h)) / (2 * h)
    assert np.allclose(t * (Q[0, 0] * du + Q[0, 1] * ex.w(xs) / a), ex.N, rtol=1e-7)
    # far from the ends: u' = 0 (the ends are fixed), so N22 = t Q22 w/a = p a, w = p a²/(t Q22) (1 + O(t²/a²))
    assert abs(ex.w(0.0) - ex.p * a**2 / (t * Q[1, 1])) < 0.01 * ex.w(0.0)


def test_orthotropic_closed_form_reduces_to_the_isotropic_one():
    for E, mu in ((1.0e4, 0.3), (2.1e11, 0.0), (5.0, -0.3)):
        iso = ClampedPressurizedCylinder(a=10.0, t=0.1, H=10.0, E=E, mu=mu, p=1.0)
        for mat in (Isotropic(E, mu), _as_orthotropic(Isotropic(E, mu))):
            ex = OrthotropicClampedCylinder(a=10.0, t=0.1, H=10.0, material=mat, p=1.0)
            x = np.linspace(-10.0, 10.0, 21)
            np.testing.assert_allclose(ex.w(x), iso.w(x), rtol=1e-11, atol=1e-11 * abs(iso.w(0.0)))
            np.testing.assert_allclose(ex.u(x), iso.u(x), rtol=1e-9, atol=1e-11 * abs(iso.u(5.0)))
            assert math.isclose(ex.M11(10.0), iso.M11(10.0), rel_tol=1e-10)


@pytest.mark.parametrize("mat", [HOOP_WOUND, AXIAL], ids=["hoop-wound", "axial"])
def test_orthotropic_pressurized_cylinder_converges_to_the_closed_form(mat, examples_dir):
    """examples/pressurized_cylinder.toml with a [material] table, meshes nx = 10, 20, 40, 80 (graded).

    The error of level k against the closed form must equal its discretisation error, estimated by the
    difference to level k + 1 (to within 25 %, which holds when the error drops ≥ 5× per level): a wrong
    closed form (or a wrong material law in the FE) would leave an offset that does not shrink.
    """
    raw = read_case_dict(examples_dir / "pressurized_cylinder.toml")
    del raw["shell"]["young"], raw["shell"]["poisson"]
    raw["material"] = {"model": "orthotropic", "e1": mat.e1, "e2": mat.e2, "g12": mat.g12, "nu12": mat.nu12}
    base = sc.case_from_dict(raw)
    sh = base.shell
    assert sh.material == mat
    ex = OrthotropicClampedCylinder(a=sh.radius, t=sh.thickness, H=sh.length / 2, material=mat,
                                    p=float(base.loads.normal))
    H, phi = ex.H, 0.5 * (sh.alpha + sh.beta)
    xs = np.linspace(-H, H, 201)
    exact = {"w": ex.w(xs), "u": ex.u(xs), "N11": np.full(xs.size, ex.N), "M11 at the ends": ex.M11(np.array([-H, H]))}
    values = []
    for nx in (10, 20, 40, 80):
        r = copy.deepcopy(raw)
        r["mesh"]["nx"] = nx
        sol = sc.solve(sc.case_from_dict(r)).solution
        d = sol.evaluate(xs, np.full(xs.size, phi), ("u", "w"))
        R = sol.resultants(xs, np.full(xs.size, phi))
        values.append({"w": d["w"], "u": d["u"], "N11": R["N11"], "M11 at the ends": R["M11"][[0, -1]]})

    def dist(f, g):  # max over x, relative to the largest exact value
        return np.array([np.abs(f[k] - g[k]).max() / np.abs(exact[k]).max() for k in exact])

    err = np.array([dist(v, exact) for v in values])
    est = np.array([dist(values[k], values[k + 1]) for k in range(len(values) - 1)])
    print(f"\n{'nx':>4s} " + "".join(f"{n:>24s}" for n in exact) + "   (relative error | error/estimate)")
    for k, nx in enumerate((10, 20, 40, 80)):
        ratio = err[k] / est[k] if k < len(est) else [math.nan] * len(exact)
        print(f"{nx:4d} " + "".join(f"{e:14.2e} | {q:6.3f} " for e, q in zip(err[k], ratio)))
    assert np.all(err[1:] < err[:-1])
    np.testing.assert_array_less(np.abs(err[:-1] / est - 1.0), 0.25)
    assert err[-1, 0] < 1e-6


# ---------------------------------------------------------------------------------------------
# 4. bad input
# ---------------------------------------------------------------------------------------------
@pytest.mark.parametrize(
    "make,field,fragment",
    [
        (lambda: Isotropic(0.0, 0.3), "material.young", "> 0"),
        (lambda: Isotropic(float("nan"), 0.3), "material.young", "finite"),
        (lambda: Isotropic("steel", 0.3), "material.young", "finite number"),
        (lambda: Isotropic(1.0, 0.5), "material.poisson", "(-1, 0.5)"),
        (lambda: Isotropic(1.0, -1.0), "material.poisson", "(-1, 0.5)"),
        (lambda: Isotropic(1.0, True), "material.poisson", "(-1, 0.5)"),
        (lambda: Orthotropic(0.0, 1.0, 1.0, 0.3), "material.e1", "> 0"),
        (lambda: Orthotropic(1.0, -1.0, 1.0, 0.3), "material.e2", "> 0"),
        (lambda: Orthotropic(1.0, 1.0, 0.0, 0.3), "material.g12", "> 0"),
        (lambda: Orthotropic(1.0, 4.0, 1.0, 0.5), "material.nu12", "nu12 * nu21"),
        (lambda: Orthotropic(4.0, 1.0, 1.0, -2.0), "material.nu12", "sqrt(e1/e2) = 2"),
        (lambda: Orthotropic(1.0, 1.0, 1.0, float("inf")), "material.nu12", "finite"),
    ],
)
def test_invalid_materials_name_the_key(make, field, fragment):
    with pytest.raises(InputError) as exc:
        make()
    assert exc.value.field == field and fragment in exc.value.message, exc.value


def test_orthotropic_limits_of_positive_definiteness_are_accepted():
    """ν12 ν21 < 1 allows ν12 > 1/2 (and > 1) when E1 > E2: Q stays positive definite."""
    for mat in (Orthotropic(4.0, 1.0, 1.0, 1.9), Orthotropic(1.0, 1.0, 1.0, -0.99)):
        assert np.all(np.linalg.eigvalsh(mat.plane_stress) > 0)


def test_shell_needs_a_material():
    with pytest.raises(InputError) as exc:
        Shell(radius=1.0, length=1.0, thickness=0.1, material=2.1e11)
    assert exc.value.field == "shell.material"


BASE = {"shell": {"radius": 1.0, "length": 2.0, "angle": [0.0, 30.0], "thickness": 0.1}}


def with_material(table=None, **shell_keys) -> dict:
    data = copy.deepcopy(BASE)
    data["shell"].update(shell_keys)
    if table is not None:
        data["material"] = table
    return data


def test_material_table_and_shell_keys_give_the_same_shell():
    legacy = sc.case_from_dict(with_material(young=2.0e4, poisson=0.3)).shell
    table = sc.case_from_dict(with_material({"model": "isotropic", "young": 2.0e4, "poisson": 0.3})).shell
    implicit = sc.case_from_dict(with_material({"young": 2.0e4, "poisson": 0.3})).shell  # model defaults
    assert legacy == table == implicit and legacy.material == Isotropic(2.0e4, 0.3)
    orth = sc.case_from_dict(with_material({"model": "orthotropic", "e1": 3, "e2": 1, "g12": 0.5, "nu12": 0.4}))
    assert orth.shell.material == Orthotropic(3.0, 1.0, 0.5, 0.4)
    assert replace(orth.shell, material=legacy.material) == legacy


ORTHO = {"model": "orthotropic", "e1": 3.0, "e2": 1.0, "g12": 0.5, "nu12": 0.4}


@pytest.mark.parametrize(
    "data,field,fragments",
    [
        (with_material({"young": 1.0, "poisson": 0.3}, young=1.0), "material", ["given twice", "shell.young"]),
        (with_material(ORTHO, poisson=0.3), "material", ["given twice", "shell.poisson", "[material]"]),
        (with_material(3.0), "material", ["must be a table"]),
        (with_material({**ORTHO, "model": "anisotropic"}), "material.model", ['"isotropic"', '"orthotropic"']),
        (with_material({**ORTHO, "model": 1}), "material.model", ["must be one of"]),
        (with_material({**ORTHO, "young": 1.0}), "material.young", ["not a key of model = 'orthotropic'", "e1"]),
        (with_material({"young": 1.0, "poisson": 0.3, "g12": 1.0}), "material.g12", ["model = 'isotropic'"]),
        (with_material({**ORTHO, "e22": 1.0}), "material.e22", ["did you mean 'e2'"]),
        (with_material({k: v for k, v in ORTHO.items() if k != "g12"}), "material.g12", ["is required"]),
        (with_material({**ORTHO, "e2": "glass"}), "material.e2", ["must be a number", "str"]),
        (with_material({**ORTHO, "e2": -1.0}), "material.e2", ["> 0"]),
        (with_material({**ORTHO, "nu12": 2.0}), "material.nu12", ["nu12 * nu21 = nu12^2 e2/e1 < 1"]),
        (with_material({"model": "isotropic", "young": 1.0, "poisson": 0.6}), "material.poisson", ["(-1, 0.5)"]),
        (with_material(young=1.0, poisson=0.6), "shell.poisson", ["(-1, 0.5)"]),
        (with_material(young=0.0, poisson=0.3), "shell.young", ["> 0"]),
        (with_material(poisson=0.3), "shell.young", ["is required"]),
    ],
)
def test_bad_material_in_a_case_file_names_the_key(data, field, fragments):
    with pytest.raises(InputError) as exc:
        sc.case_from_dict(data)
    assert exc.value.field == field, exc.value
    for f in fragments:
        assert f in exc.value.message, (f, exc.value.message)


def test_case_file_reference_documents_the_material_table(examples_dir):
    """docs/case-file.md, section [material]: every key, both models, and its example parses."""
    text = (examples_dir.parent / "docs" / "case-file.md").read_text()
    section = text[text.index("## [material]") :]
    section = section[: section.index("\n## ")]
    assert not [k for k in MATERIAL.names() if f"`{k}`" not in section]
    assert '`"isotropic"`' in section and '`"orthotropic"`' in section
    (example,) = re.findall(r"```toml\n(.*?)```", section, re.S)
    mat = sc.case_from_dict(tomllib.loads(example)).shell.material
    assert isinstance(mat, Orthotropic) and mat.e2 > mat.e1
