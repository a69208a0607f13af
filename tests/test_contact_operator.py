"""The discrete contact operator (MODEL.md §5, §7, §8): Kirchhoff kinematics, linearisation, weights."""

from __future__ import annotations

import math

import numpy as np
import pytest

from shellcontact.analysis.discretization import case_mesh
from shellcontact.contact.operator import contact_operator, penetration_outside
from shellcontact.contact.punches import place_punches
from shellcontact.errors import InputError
from shellcontact.problem.case import case_from_dict
from shellcontact.shell.geometry import frame, rigid_motion
from shellcontact.shell.spaces import ShellSpace
from shellcontact.shell.supports import Reduction

SHELL = {"radius": 1.0, "length": 2.0, "thickness": 0.05, "young": 1e3, "poisson": 0.3}


def setup(punch: list[dict], full: bool = False, n: int = 8, points: str = "vertices", fit: bool = True):
    shell = {**SHELL, "full": True} if full else {**SHELL, "angle": [45, 135]}
    case = case_from_dict({"shell": shell, "mesh": {"nx": n, "nphi": 2 * n if full else n}, "punch": punch})
    punches = place_punches(case.punches, case.shell)
    space = ShellSpace(case_mesh(case, punches if fit else ()))
    return case, punches, space, contact_operator(space, punches, points=points)


SPHERE = {"shape": "sphere", "center": [0.1, 0.2, 1.6], "radius": 0.4, "indentation": 0.003}
SPHERE_IN = {"shape": "sphere", "center": [-0.2, 0.1, 0.4], "radius": 0.3, "side": "inner", "indentation": 0.002}
BAR = {"shape": "cylinder", "center": [0.3, 0.0, 1.4], "axis": [0.2, 1.0, 0.0], "radius": 0.3, "force": 2.0}
ELL = {
    "shape": "ellipsoid",
    "center": [-0.3, 0.0, 1.5],
    "radii": [0.5, 0.3, 0.45],
    "axes": [[0.8, 0.6, 0], [-0.6, 0.8, 0], [0, 0, 1]],
    "indentation": 0.002,
}


def smooth(x, s):
    """A smooth displacement field and its (x, s) derivatives (ShellSpace.QUANTITIES)."""
    sx, cx = np.sin(x + 0.3), np.cos(x + 0.3)
    s2, c2 = np.sin(2 * s), np.cos(2 * s)
    return {
        "u": np.cos(0.7 * x) * np.sin(s),
        "u_x": -0.7 * np.sin(0.7 * x) * np.sin(s),
        "u_s": np.cos(0.7 * x) * np.cos(s),
        "v": x**2 * s / 3 + s,
        "v_x": 2 * x * s / 3,
        "v_s": x**2 / 3 + 1,
        "w": sx * c2,
        "w_x": cx * c2,
        "w_s": -2 * sx * s2,
        "w_xx": -sx * c2,
        "w_xs": -2 * cx * s2,
        "w_ss": -4 * sx * c2,
    }


def polynomial(x, s):
    """u, v quadratic and w quintic: represented exactly by P2 × P2 × Argyris."""
    return {
        "u": 0.3 + x - 0.5 * s + 0.7 * x * s + 0.2 * s**2,
        "u_x": 1 + 0.7 * s + 0 * x,
        "u_s": -0.5 + 0.7 * x + 0.4 * s,
        "v": -0.1 + 0.4 * x**2 - x * s + s,
        "v_x": 0.8 * x - s,
        "v_s": -x + 1 + 0 * s,
        "w": x**3 * s**2 - 0.5 * s**5 + x * s + 0.1,
        "w_x": 3 * x**2 * s**2 + s,
        "w_s": 2 * x**3 * s - 2.5 * s**4 + x,
        "w_xx": 6 * x * s**2,
        "w_xs": 6 * x**2 * s + 1,
        "w_ss": 2 * x**3 - 10 * s**3,
    }


def kirchhoff(op, fields):
    """U(M) of MODEL.md (4.9) at the rows, from exact fields (global vector, (3, m))."""
    a = 1.0
    f = fields(op.x, a * op.phi)
    e1, e2, n = frame(op.phi)
    z = op.zeta
    return (f["u"] - z * f["w_x"]) * e1 + (f["v"] * (1 + z / a) - z * f["w_s"]) * e2 + f["w"] * n


def Z_rows(op, X):
    out = np.empty(op.m)
    for k, p in enumerate(op.punches):
        r = op.rows(k)
        out[r] = p.Z(X[:, r])[0]
    return out


@pytest.mark.parametrize("punch", [[SPHERE], [SPHERE_IN], [BAR, ELL]])
def test_rows_are_kirchhoff_displacement(punch):
    case, punches, space, op = setup(punch)
    assert np.all(np.diff(op.B.indptr) <= 5)
    assert np.allclose(op.G, Z_rows(op, op.points), atol=0)
    U = space.interpolate(smooth)
    # vertex dofs are the exact values, so B U = ∇Z·U(M) to round-off
    assert np.allclose(op.B @ U, np.sum(op.grad * kirchhoff(op, smooth), axis=0), rtol=0, atol=1e-13)
    # contact points on the requested surface
    r = np.linalg.norm(op.points[1:], axis=0)
    t2 = 0.5 * case.shell.t(op.x, op.phi)
    for k, p in enumerate(punches):
        assert np.allclose(r[op.rows(k)], 1.0 + p.side_sign * t2[op.rows(k)])


def test_linearisation_is_second_order():
    case, punches, space, op = setup([SPHERE, ELL])
    U = space.interpolate(smooth)
    UM = kirchhoff(op, smooth)
    errs = []
    for eps in (1e-3, 5e-4, 2.5e-4):
        exact = Z_rows(op, op.points + eps * UM)
        errs.append(np.max(np.abs(exact - (op.G + eps * (op.B @ U)))))
    ratios = [errs[0] / errs[1], errs[1] / errs[2]]
    print("linearisation errors", errs, "ratios", ratios)
    assert all(3.8 < q < 4.2 for q in ratios)


@pytest.mark.parametrize("full", [False, True])
def test_rigid_motion_moves_contact_points_exactly(full):
    punch = [SPHERE, SPHERE_IN] if not full else [{**SPHERE, "center": [0.1, 1.2, 0.3]}]
    case, punches, space, op = setup(punch, full=full)
    rng = np.random.default_rng(3)
    for _ in range(3):
        c, th = rng.normal(size=3) * 1e-3, rng.normal(size=3) * 1e-3
        U = space.interpolate(rigid_motion(case.shell, c, th))
        exact = c[:, None] + np.cross(th, op.points.T).T  # displacement of M under the rigid motion
        assert np.allclose(op.B @ U, np.sum(op.grad * exact, axis=0), rtol=0, atol=1e-15)


def test_midpoint_rows_exact_for_polynomials():
    case, punches, space, op = setup([SPHERE, BAR], points="vertices+midpoints")
    assert np.any(op.vertex < 0) and np.all((op.vertex >= 0) != (op.facet >= 0))
    U = space.interpolate(polynomial)
    val = np.sum(op.grad * kirchhoff(op, polynomial), axis=0)
    assert np.allclose(op.B @ U, val, rtol=0, atol=1e-10 * np.max(np.abs(val)))
    vert = contact_operator(space, punches)
    assert op.weights.sum() == pytest.approx(vert.weights.sum(), rel=1e-13)


def test_weights_sum_to_zone_area_panel():
    case, punches, space, op = setup(
        [{**SPHERE, "zone": {"x": [-0.4, 0.55], "phi": [70, 110]}}, {**SPHERE_IN, "indentation": 0.0}]
    )
    for k, p in enumerate(punches):
        assert op.weights[op.rows(k)].sum() == pytest.approx(p.zone.area(case.shell.radius), rel=1e-12)
        assert np.all(op.weights[op.rows(k)] > 0)
        assert np.all(p.zone.contains(op.x[op.rows(k)], op.phi[op.rows(k)], tol=1e-12))


@pytest.mark.parametrize("points", ["vertices", "vertices+midpoints"])
def test_full_cylinder_seam_rows_merged(points):
    punch = [
        {**SPHERE, "center": [0.0, 1.5, 0.0], "zone": {"x": [-0.5, 0.5], "phi": [-40, 40]}},
        {"shape": "torus", "center": [0.3, 0, 0], "axis": [1, 0, 0], "major_radius": 1.124, "minor_radius": 0.1},
    ]
    case, punches, space, op = setup(punch, full=True, points=points)
    assert len(punches[0].zone.phi) == 2 and punches[1].zone.phi == ((0.0, 2 * math.pi),)
    for k, p in enumerate(punches):
        r = op.rows(k)
        assert op.weights[r].sum() == pytest.approx(p.zone.area(1.0), rel=1e-12)
        key = np.round(np.c_[op.x[r], np.mod(op.phi[r], 2 * math.pi) % (2 * math.pi - 1e-12)], 10)
        assert np.unique(key, axis=0).shape[0] == r.size  # no point constrained twice
    assert np.all(op.phi[op.vertex >= 0] < 2 * math.pi - 1e-9)  # rows use the φ = α copy
    red = Reduction.build(space, case.supports)
    Br = op.B @ red.P
    assert Br.shape == (op.m, red.P.shape[1])
    # after the reduction a rigid motion still moves the contact points exactly
    c, th = np.array([1e-3, -2e-3, 5e-4]), np.array([2e-3, 1e-3, -1e-3])
    U = space.interpolate(rigid_motion(case.shell, c, th))
    exact = np.sum(op.grad * (c[:, None] + np.cross(th, op.points.T).T), axis=0)
    vert = op.vertex >= 0
    assert np.allclose((op.B @ U)[vert], exact[vert], rtol=0, atol=1e-15)


def test_force_control_column():
    case, punches, space, op = setup([SPHERE, BAR])
    assert op.force_punches == [1] and op.forces.tolist() == [2.0]
    assert op.D.shape == (op.m, 1)
    assert np.all(op.D[op.rows(0)] == 0)
    d = punches[1].direction
    assert np.allclose(op.D[op.rows(1), 0], -(d @ op.grad[:, op.rows(1)]))
    # Π(δ) = G + D δ is the linearisation of Z of the punch translated by δ along d
    r = op.rows(1)
    errs = []
    for delta in (1e-3, 5e-4):
        exact = punches[1].body(op.points[:, r] - punches[1].offset[:, None] - delta * d[:, None])[0]
        errs.append(np.max(np.abs(exact - op.gap(np.zeros(space.ndofs), [delta])[r])))
    assert 3.5 < errs[0] / errs[1] < 4.5
    with pytest.raises(ValueError):
        op.gap(np.zeros(space.ndofs))


def test_result_helpers():
    case, punches, space, op = setup([SPHERE, SPHERE_IN])
    Lam = op.weights.copy()  # unit pressure on every zone
    assert np.allclose(op.pressure(Lam), 1.0)
    areas = [p.zone.area(1.0) for p in punches]
    assert np.allclose(op.contact_area(np.ones(op.m, bool)), areas)
    assert np.allclose(op.total_normal_force(Lam), areas)  # |∇Z| = 1
    F = op.resultant(Lam)
    assert np.allclose(F[0], (op.grad[:, op.rows(0)] * Lam[op.rows(0)]).sum(axis=1))
    assert F[0][2] < 0 and F[1][2] > 0  # outer punch pushes down, inner punch pushes up (toward +z)
    assert np.allclose(op.moment(Lam), 0.0, atol=1e-14)  # sphere: every force passes through the centre
    vp = op.vertex_pressure(Lam)
    assert vp.shape == (space.nv,) and set(np.unique(vp)) <= {0.0, 1.0, 2.0}
    s = op.summary(Lam)
    assert [e["active_vertices"] for e in s] == [op.rows(0).size, op.rows(1).size]
    assert s[0]["punch_travel"] == pytest.approx(0.003) and s[0]["peak_pressure"] == pytest.approx(1.0)
    assert s[0]["area"] == pytest.approx(areas[0]) and s[0]["force_magnitude"] == pytest.approx(np.linalg.norm(F[0]))


def test_contact_operator_errors():
    case, punches, space, op = setup([SPHERE])
    with pytest.raises(InputError) as e:
        contact_operator(space, punches, points="quadrature")
    assert e.value.field == "solver.contact_points"
    # a zone thinner than the mesh, on an unfitted mesh, contains no vertex
    with pytest.raises(InputError) as e:
        setup([{**SPHERE, "zone": {"x": [0.01, 0.02], "phi": [85, 86]}}], fit=False)
    assert e.value.field == "punch.0.zone"


def test_blocked_rows_detect_punch_on_clamped_edge():
    # the punch overlaps the shell at the clamped edge x = x_min: no admissible displacement exists
    case, punches, space, op = setup([{**SPHERE, "center": [-1.0, 0.0, 1.6]}])
    red = Reduction.build(space, case.supports)
    blocked = op.blocked_rows(red.P)
    assert blocked.size > 0 and np.allclose(op.x[blocked], case.shell.x_min)
    case, punches, space, op = setup([SPHERE])
    assert op.blocked_rows(Reduction.build(space, case.supports).P).size == 0


def test_penetration_outside_the_zone_is_reported():
    # a fixed sphere with a deep prescribed overlap (radius ≈ 0.17) but a zone of one vertex
    deep = {"shape": "sphere", "center": [0.0, 0.0, 1.6], "radius": 0.6, "zone": {"x": [-0.01, 0.01], "phi": [89, 91]}}
    case, punches, space, op = setup([deep], n=16, fit=False)
    assert op.m == 1
    pen = penetration_outside(space, punches, np.zeros(space.ndofs))
    assert pen[0] > 0
    wide = setup([{**deep, "zone": {"x": [-0.5, 0.5], "phi": [60, 120]}}], n=16)
    assert penetration_outside(wide[2], wide[1], np.zeros(wide[2].ndofs))[0] == 0.0
    # a rigid translation away from the punch (larger than the overlap) opens every gap
    U = space.interpolate(rigid_motion(case.shell, [0.0, 0.0, -0.05], [0.0, 0.0, 0.0]))
    assert penetration_outside(space, punches, U)[0] == 0.0
