"""Punch shapes (MODEL.md §5): signed distances, gradients, inversion, placement, zones, input errors."""

from __future__ import annotations

import math
import sys
import textwrap

import numpy as np
import pytest

from shellcontact.analysis.discretization import case_mesh
from shellcontact.contact.punches import (
    Cylinder,
    Ellipsoid,
    Plane,
    Sphere,
    Torus,
    contact_surface,
    fitted_lines,
    focus_lines,
    parse_punches,
    place_punches,
    punch_from_dict,
)
from shellcontact.errors import InputError
from shellcontact.inputs.user_functions import CodeConsent, code_consent
from shellcontact.problem.case import case_from_dict
from shellcontact.shell.geometry import Shell
from shellcontact.shell.material import Isotropic

RNG = np.random.default_rng(7)


def panel() -> Shell:
    return Shell(
        radius=1.0, length=2.0, thickness=0.02,
        material=Isotropic(1e3, 0.3),
        alpha=math.radians(45), beta=math.radians(135),
    )


def pipe() -> Shell:
    return Shell(radius=1.0, length=2.0, thickness=0.02, material=Isotropic(1e3, 0.3), full=True)


def unit(v):
    v = np.asarray(v, float)
    return v / np.linalg.norm(v)


SHAPES = {
    "sphere": Sphere(np.array([0.1, -0.2, 0.3]), 0.7),
    "cylinder": Cylinder(np.array([0.1, -0.2, 0.3]), unit([1.0, 2.0, -0.5]), 0.4),
    "plane": Plane(np.array([0.1, -0.2, 0.3]), unit([0.3, -1.0, 2.0])),
    "torus": Torus(np.array([0.1, -0.2, 0.3]), unit([0.2, 1.0, 0.1]), 1.1, 0.3),
}


def surface_samples(name: str, n: int = 400) -> np.ndarray:
    """Dense points of the shape's surface (independent parametrisations)."""
    s = SHAPES[name]
    if name == "sphere":
        th, ph = np.meshgrid(np.linspace(0, math.pi, n), np.linspace(0, 2 * math.pi, 2 * n))
        d = np.stack([np.sin(th) * np.cos(ph), np.sin(th) * np.sin(ph), np.cos(th)]).reshape(3, -1)
        return s.center[:, None] + s.radius * d
    a = s.axis if name != "plane" else s.normal
    p = np.cross(a, [1.0, 0.0, 0.0])
    p /= np.linalg.norm(p)
    q = np.cross(a, p)
    if name == "cylinder":
        h, ph = np.meshgrid(np.linspace(-4, 4, 4 * n), np.linspace(0, 2 * math.pi, n))
        h, ph = h.ravel(), ph.ravel()
        return s.center[:, None] + h * a[:, None] + s.radius * (np.cos(ph) * p[:, None] + np.sin(ph) * q[:, None])
    if name == "plane":
        u, v = np.meshgrid(np.linspace(-4, 4, 2 * n), np.linspace(-4, 4, 2 * n))
        return s.center[:, None] + u.ravel() * p[:, None] + v.ravel() * q[:, None]
    th, ph = np.meshgrid(np.linspace(0, 2 * math.pi, n), np.linspace(0, 2 * math.pi, 2 * n))
    th, ph = th.ravel(), ph.ravel()
    radial = np.cos(ph) * p[:, None] + np.sin(ph) * q[:, None]
    return (
        s.center[:, None]
        + (s.major_radius + s.minor_radius * np.cos(th)) * radial
        + s.minor_radius * np.sin(th) * a[:, None]
    )


def fd_gradient(f, X, h=1e-6):
    g = np.empty_like(X)
    for k in range(3):
        e = np.zeros((3, 1))
        e[k] = h
        g[k] = (f(X + e)[0] - f(X - e)[0]) / (2 * h)
    return g


@pytest.mark.parametrize("name", list(SHAPES))
def test_closed_form_shapes_are_signed_distances(name):
    shape = SHAPES[name]
    X = shape.center[:, None] + RNG.uniform(-1.5, 1.5, size=(3, 40))
    Z, g = shape(X)
    assert np.allclose(np.linalg.norm(g, axis=0), 1.0, atol=1e-12)
    assert np.allclose(g, fd_gradient(shape, X), atol=1e-7)
    S = surface_samples(name)
    assert np.max(np.abs(shape(S)[0])) < 1e-12
    # |Z| is the distance to the surface: compare with the nearest dense surface sample
    dist = np.array([np.min(np.linalg.norm(S - X[:, [i]], axis=0)) for i in range(X.shape[1])])
    assert np.all(np.abs(np.abs(Z) - dist) < 2e-2)
    # points along the gradient: Z changes by the step (signed distance away from the medial axis)
    near = X[:, np.abs(Z) < 0.1]
    Zn, gn = shape(near)
    assert np.allclose(shape(near + 0.01 * gn)[0], Zn + 0.01, atol=1e-12)


def test_known_points():
    sph = SHAPES["sphere"]
    assert sph(sph.center[:, None])[0][0] == pytest.approx(-0.7)
    assert sph(sph.center[:, None] + np.array([[0.0], [1.0], [0.0]]))[0][0] == pytest.approx(0.3)
    tor = SHAPES["torus"]
    p = np.cross(tor.axis, [1.0, 0.0, 0.0])
    p /= np.linalg.norm(p)
    X = tor.center[:, None] + np.c_[(1.1 + 0.3 + 0.25) * p, 1.1 * p + 0.1 * tor.axis, tor.center * 0 - 0 * p]
    Z = tor(X)[0]
    assert Z[0] == pytest.approx(0.25) and Z[1] == pytest.approx(-0.2)
    assert Z[2] == pytest.approx(1.1 - 0.3)  # the centre of the ring is outside the tube
    cyl = SHAPES["cylinder"]
    assert cyl((cyl.center + 3.0 * cyl.axis)[:, None])[0][0] == pytest.approx(-0.4)
    pl = SHAPES["plane"]
    assert pl((pl.center - 0.5 * pl.normal)[:, None])[0][0] == pytest.approx(-0.5)


def test_ellipsoid_first_order_distance():
    axes = np.linalg.qr(RNG.normal(size=(3, 3)))[0].T
    ell = Ellipsoid(np.array([0.2, 0.1, -0.3]), np.array([0.9, 0.5, 0.3]), axes)
    th, ph = RNG.uniform(0, math.pi, 30), RNG.uniform(0, 2 * math.pi, 30)
    loc = ell.radii[:, None] * np.stack([np.sin(th) * np.cos(ph), np.sin(th) * np.sin(ph), np.cos(th)])
    S = ell.center[:, None] + axes.T @ loc
    Z, g = ell(S)
    assert np.max(np.abs(Z)) < 1e-12  # the zero set is exactly the ellipsoid
    assert np.allclose(np.linalg.norm(g, axis=0), 1.0, atol=1e-12)  # unit normal on the surface
    n_exact = axes.T @ (loc / ell.radii[:, None] ** 2)
    assert np.allclose(g, n_exact / np.linalg.norm(n_exact, axis=0), atol=1e-12)
    X = ell.center[:, None] + RNG.uniform(-1.2, 1.2, size=(3, 40))
    assert np.allclose(ell(X)[1], fd_gradient(ell, X), atol=1e-6)
    # first-order signed distance: Z(S + h n) = h + O(h²)
    for h in (1e-2, -1e-2):
        err1 = np.max(np.abs(ell(S + h * g)[0] - h))
        err2 = np.max(np.abs(ell(S + 0.5 * h * g)[0] - 0.5 * h))
        assert err2 < 0.3 * err1 + 1e-14
    assert np.all(ell(ell.center[:, None] + 0.5 * (S - ell.center[:, None]))[0] < 0)
    assert np.all(ell(ell.center[:, None] + 1.5 * (S - ell.center[:, None]))[0] > 0)


def test_inverted_flips_sign():
    sh = pipe()
    raw = {"shape": "cylinder", "center": [0, 0, 0], "axis": [1, 0, 0], "radius": 1.0 + 0.01 - 0.002}
    plain = punch_from_dict(raw, sh)
    inv = punch_from_dict({**raw, "inverted": True}, sh)
    X = RNG.uniform(-2, 2, size=(3, 20))
    (Z1, g1), (Z2, g2) = plain.Z(X), inv.Z(X)
    assert np.allclose(Z1, -Z2) and np.allclose(g1, -g2)
    sleeve = inv  # a sleeve with interference 0.002
    assert plain.overlap == 0.0 and plain.min_gap == pytest.approx(0.002, abs=1e-12)
    assert sleeve.overlap == pytest.approx(0.002, abs=1e-12)
    assert sleeve.zone.x == (sh.x_min, sh.x_max)


def fine_min(punch, sh, n=801):
    """Independent check: min Z over a dense grid of the contact surface in the zone."""
    best = math.inf
    for p0, p1 in punch.zone.phi:
        x, p = np.meshgrid(np.linspace(*punch.zone.x, n), np.linspace(p0, p1, n), indexing="ij")
        best = min(best, float(punch.Z(contact_surface(sh, x.ravel(), p.ravel(), punch.side_sign))[0].min()))
    return best


@pytest.mark.parametrize(
    "raw",
    [
        {"shape": "sphere", "center": [0.13, 0.05, 1.6], "radius": 0.3},
        {"shape": "plane", "center": [0.0, 0.0, 1.3], "normal": [0, 0, -1]},
        {"shape": "cylinder", "center": [0.2, 0.0, 1.6], "axis": [0, 1, 0], "radius": 0.25},
        {"shape": "ellipsoid", "center": [0.0, 0.1, 1.7], "radii": [0.4, 0.3, 0.2]},
    ],
)
def test_indentation_places_punch(raw):
    sh = panel()
    d = 0.004
    touching = punch_from_dict({**raw, "indentation": 0.0}, sh)
    assert abs(touching.min_gap) < 1e-10
    assert abs(fine_min(touching, sh)) < 1e-5
    p = punch_from_dict({**raw, "indentation": d}, sh)
    # the contact normal at first contact is radial and so is the default direction: min Z = −d
    # (exactly for signed distances; to O(d²) for the ellipsoid's first-order distance)
    tol = 1e-9 if raw["shape"] != "ellipsoid" else 10 * d**2
    assert p.min_gap == pytest.approx(-d, abs=tol)
    assert fine_min(p, sh) == pytest.approx(-d, abs=1e-5)
    assert p.overlap == pytest.approx(-p.min_gap, abs=1e-15)
    assert np.allclose(p.offset, (touching.touch_travel + d) * p.direction)


def test_oblique_direction_and_force_control():
    sh = panel()
    raw = {"shape": "sphere", "center": [0.3, 0.2, 1.5], "radius": 0.3, "direction": [-0.3, 0.1, -1.0]}
    p = punch_from_dict({**raw, "force": 5.0}, sh)
    assert p.mode == "force" and p.force == 5.0
    assert abs(p.min_gap) < 1e-10 and abs(fine_min(p, sh)) < 1e-5
    assert np.allclose(p.direction, unit([-0.3, 0.1, -1.0]))
    # a punch starting in overlap backs off to the touching position
    q = punch_from_dict({**raw, "center": [0.3, 0.2, 1.2], "indentation": 0.0}, sh)
    assert q.touch_travel < 0 and abs(q.min_gap) < 1e-10


def test_inner_side_and_ring_on_pipe():
    sh = pipe()
    inner = punch_from_dict(
        {"shape": "sphere", "center": [0.0, 0.0, 0.5], "radius": 0.3, "side": "inner", "indentation": 0.003}, sh
    )
    assert np.allclose(inner.direction, [0, 0, 1])
    assert inner.min_gap == pytest.approx(-0.003, abs=1e-9)
    assert inner.first_contact[1] == pytest.approx(math.pi / 2, abs=1e-6)
    ring = punch_from_dict(
        {
            "shape": "torus",
            "center": [0.25, 0, 0],
            "axis": [1, 0, 0],
            "major_radius": 1.01 + 0.1 - 0.001,
            "minor_radius": 0.1,
        },
        sh,
    )
    assert ring.overlap == pytest.approx(0.001, abs=1e-12)
    assert ring.first_contact[0] == pytest.approx(0.25, abs=1e-9)
    assert ring.zone.phi == ((sh.alpha, sh.beta),)
    assert ring.zone.x[0] < 0.25 < ring.zone.x[1]


def test_zones_given_wrapped_and_automatic():
    sh = pipe()
    p = punch_from_dict(
        {
            "shape": "sphere",
            "center": [0.0, 1.5, 0.0],
            "radius": 0.3,
            "indentation": 0.002,
            "zone": {"x": [-0.5, 0.5], "phi": [-30, 30]},
        },
        sh,
    )
    assert np.allclose(p.zone.phi, ((0.0, math.radians(30)), (math.radians(330), 2 * math.pi)), rtol=0, atol=1e-14)
    assert p.zone.area(sh.radius) == pytest.approx(1.0 * math.radians(60))
    auto = punch_from_dict({"shape": "sphere", "center": [0.0, 1.5, 0.0], "radius": 0.3, "indentation": 0.002}, sh)
    assert auto.zone.automatic and len(auto.zone.phi) == 2  # crosses the seam φ = 0
    assert auto.zone.contains(np.array([0.0]), np.array([0.0]))[0]
    # every point with Z below the threshold lies in the automatic zone
    x, ph = np.meshgrid(np.linspace(-1, 1, 301), np.linspace(0, 2 * math.pi, 721), indexing="ij")
    Z = auto.Z(contact_surface(sh, x.ravel(), ph.ravel(), 1.0))[0]
    inside = Z < auto.zone.gap
    assert np.all(auto.zone.contains(x.ravel()[inside], ph.ravel()[inside]))
    assert not np.all(auto.zone.contains(x.ravel(), ph.ravel()))  # and it is finite
    g = punch_from_dict(
        {"shape": "sphere", "center": [0.0, 1.5, 0.0], "radius": 0.3, "indentation": 0.002, "zone": {"gap": 0.001}}, sh
    )
    assert g.zone.area(1.0) < auto.zone.area(1.0)


def test_fitted_lines_put_nodes_on_contact_lines():
    data = {
        "shell": {"radius": 1.0, "length": 2.0, "thickness": 0.02, "young": 1e3, "poisson": 0.3, "angle": [45, 135]},
        "mesh": {"nx": 6, "nphi": 6},
        "punch": [
            {"shape": "sphere", "center": [0.137, 0.21, 1.5], "radius": 0.3, "indentation": 0.002},
            {"shape": "cylinder", "center": [-0.61, 0.0, 1.5], "axis": [0, 1, 0], "radius": 0.2, "indentation": 0.001},
        ],
    }
    case = case_from_dict(data)
    punches = place_punches(case.punches, case.shell)
    xs, phis = fitted_lines(punches, case.shell)
    mesh = case_mesh(case, punches)
    px, pphi = mesh.p[0], mesh.p[1] / case.shell.radius
    fx, fp = focus_lines(punches)
    assert fx[1] == pytest.approx(-0.61, abs=1e-9)  # the line under the transverse bar
    for v in [*xs, *fx]:
        assert np.min(np.abs(px - v)) < 1e-12
    for v in [*phis, *fp]:
        assert np.min(np.abs(pphi - v)) < 1e-12
    sx, sp = punches[0].first_contact
    assert np.any((np.abs(px - sx) < 1e-12) & (np.abs(pphi - sp) < 1e-12))  # a node at the point contact


def test_custom_shape(tmp_path, monkeypatch):
    (tmp_path / "my_punch.py").write_text(
        textwrap.dedent(
            """
            import numpy as np
            def ball(X):
                d = X - np.array([[0.0], [0.0], [1.4]])
                r = np.linalg.norm(d, axis=0)
                return r - 0.4, d / r
            NOT_CALLABLE = 3
            def bad_shape(X):
                return np.zeros(3), np.zeros(3)
            """
        )
    )
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.delitem(sys.modules, "my_punch", raising=False)
    consent = code_consent(CodeConsent(modules=("my_punch",)))
    consent.__enter__()
    sh = panel()
    p = punch_from_dict(
        {"shape": "custom", "function": "my_punch:ball", "direction": [0, 0, -1], "indentation": 0.002}, sh
    )
    ref = punch_from_dict({"shape": "sphere", "center": [0, 0, 1.4], "radius": 0.4, "indentation": 0.002}, sh)
    assert p.min_gap == pytest.approx(-0.002, abs=1e-9)
    assert np.allclose(p.offset, ref.offset)
    with pytest.raises(InputError) as e:
        punch_from_dict({"shape": "custom", "function": "my_punch:NOT_CALLABLE"}, sh)
    assert e.value.field == "punch.0.function"
    with pytest.raises(InputError) as e:
        punch_from_dict({"shape": "custom", "function": "my_punch:bad_shape"}, sh)
    assert e.value.field == "punch.0.function"
    with pytest.raises(InputError) as e:
        punch_from_dict({"shape": "custom", "function": "my_punch:ball", "indentation": 0.001}, sh)
    assert e.value.field == "punch.0.direction"
    consent.__exit__(None, None, None)


SPHERE = {"shape": "sphere", "center": [0.0, 0.0, 1.5], "radius": 0.3}


@pytest.mark.parametrize(
    "raw, field",
    [
        ({"shape": "cone"}, "punch.0.shape"),
        ({}, "punch.0.shape"),
        ({**SPHERE, "radiu": 1.0}, "punch.0.radiu"),
        ({**SPHERE, "radius": -1.0}, "punch.0.radius"),
        ({**SPHERE, "center": [0, 1]}, "punch.0.center"),
        ({"shape": "cylinder", "center": [0, 0, 1.3], "axis": [0, 0, 0], "radius": 0.2}, "punch.0.axis"),
        ({"shape": "plane", "center": [0, 0, 1.3], "normal": [0, 0, 0]}, "punch.0.normal"),
        (
            {"shape": "torus", "center": [0, 0, 0], "axis": [1, 0, 0], "major_radius": 0.1, "minor_radius": 0.2},
            "punch.0.minor_radius",
        ),
        ({"shape": "ellipsoid", "center": [0, 0, 1.3], "radii": [1, 0, 1]}, "punch.0.radii"),
        (
            {
                "shape": "ellipsoid",
                "center": [0, 0, 1.3],
                "radii": [1, 1, 1],
                "axes": [[1, 0, 0], [1, 1, 0], [0, 0, 1]],
            },
            "punch.0.axes",
        ),
        ({**SPHERE, "indentation": 0.01, "force": 1.0}, "punch.0.force"),
        ({**SPHERE, "indentation": -0.01}, "punch.0.indentation"),
        ({**SPHERE, "force": 0.0}, "punch.0.force"),
        ({**SPHERE, "side": "top"}, "punch.0.side"),
        ({**SPHERE, "inverted": "yes"}, "punch.0.inverted"),
        ({**SPHERE, "direction": [0, 0, -1]}, "punch.0.direction"),  # direction without indentation/force
        ({**SPHERE, "indentation": 0.01, "direction": [0, 0, 1]}, "punch.0.direction"),  # never touches
        ({**SPHERE, "center": [0.0, 0.0, 5.0]}, "punch.0"),  # fixed, nowhere near the shell
        ({**SPHERE, "indentation": 0.5}, "punch.0.indentation"),  # overlap beyond a linear shell
        ({**SPHERE, "center": [0, 0, 1.25]}, "punch.0"),  # interference 0.06 > 10 thicknesses... of 0.02? no: 3 t
        ({**SPHERE, "indentation": 0.01, "zone": {"x": [0.5, 1.5]}}, "punch.0.zone.x"),  # zone outside Ω
        ({**SPHERE, "indentation": 0.01, "zone": {"x": [0.5, 0.2]}}, "punch.0.zone.x"),  # empty zone
        ({**SPHERE, "indentation": 0.01, "zone": {"phi": [10, 40]}}, "punch.0.zone.phi"),
        ({**SPHERE, "indentation": 0.01, "zone": {"y": [0, 1]}}, "punch.0.zone.y"),
        ({**SPHERE, "indentation": 0.01, "zone": {"x": [-0.9, -0.6]}}, "punch.0.direction"),  # zone far from the punch
    ],
)
def test_bad_input_names_the_key(raw, field):
    sh = Shell(
        radius=1.0, length=2.0, thickness=0.002,
        material=Isotropic(1e3, 0.3),
        alpha=math.radians(45), beta=math.radians(135),
    )
    with pytest.raises(InputError) as e:
        place_punches(parse_punches([raw]), sh)
    assert e.value.field == field, str(e.value)


def test_punch_on_axis_needs_direction():
    with pytest.raises(InputError) as e:
        punch_from_dict(
            {
                "shape": "torus",
                "center": [0, 0, 0],
                "axis": [1, 0, 0],
                "major_radius": 1.2,
                "minor_radius": 0.1,
                "force": 1.0,
            },
            pipe(),
        )
    assert e.value.field == "punch.0.direction"


def test_symmetric_configuration_gives_symmetric_zone_and_lines():
    data = {
        "shell": {"radius": 1.0, "length": 2.0, "thickness": 0.02, "young": 1e3, "poisson": 0.3, "angle": [60, 120]},
        "mesh": {"nx": 20, "nphi": 7, "grading": {"ratio": 3.0}},
        "punch": [{"shape": "sphere", "center": [0.0, 0.0, 1.5], "radius": 0.3, "indentation": 0.005}],
    }
    case = case_from_dict(data)
    (p,) = place_punches(case.punches, case.shell)
    assert p.first_contact[0] == 0.0 and p.first_contact[1] == pytest.approx(math.pi / 2, abs=1e-15)
    assert p.zone.x[0] == pytest.approx(-p.zone.x[1], abs=1e-14)
    ((p0, p1),) = p.zone.phi
    assert p0 + p1 == pytest.approx(math.pi, abs=1e-14)
    mesh = case_mesh(case, [p])
    x, s = np.sort(np.unique(mesh.p[0])), np.sort(np.unique(mesh.p[1]))
    assert np.allclose(x, -x[::-1], atol=1e-13) and np.allclose(s - math.pi / 2, (math.pi / 2 - s)[::-1], atol=1e-13)
    assert np.min(np.diff(x)) < 0.5 * np.max(np.diff(x))  # graded toward the contact point


def test_ring_and_roller_lines():
    sh = pipe()
    ring = punch_from_dict(
        {"shape": "torus", "center": [0.3, 0, 0], "axis": [1, 0, 0], "major_radius": 1.109, "minor_radius": 0.1}, sh
    )
    assert ring.varies_x and not ring.varies_phi
    xs, ps = fitted_lines([ring], sh)
    assert ps == [] and any(abs(v - 0.3) < 1e-12 for v in xs)  # no line at an arbitrary angle
    roller = punch_from_dict(
        {"shape": "cylinder", "center": [0, 0, 1.3], "axis": [1, 0, 0], "radius": 0.2, "indentation": 0.001}, sh
    )
    assert not roller.varies_x and roller.varies_phi
    xs, ps = fitted_lines([roller], sh)
    assert xs == [] and ps[1] == pytest.approx(math.pi / 2, abs=1e-12)
    sleeve = punch_from_dict(
        {"shape": "cylinder", "center": [0, 0, 0], "axis": [1, 0, 0], "radius": 1.009, "inverted": True}, sh
    )
    assert not sleeve.varies_x and not sleeve.varies_phi and fitted_lines([sleeve], sh) == ([], [])
