"""Friction against the independent 1D oracle (issue 26 item 4): a tube clamped at both ends (x ∈ [0, 1] m,
a = 1 m, t = 20 mm, E = 2e5 Pa, ν = 0.3) squeezed by a rigid sleeve with 1 mm interference over x ∈ [0.2, 0.8] on its
outer face, then pulled 10 µm along the axis with Coulomb friction μ = 0.1. The shell contacts the sleeve in
rings at the sleeve's edges and a band in its middle; friction sticks at some nodes and slips at others (in both
directions: the friction force is a fraction of μN). The 2D model on a 1° panel with symmetry supports on its
φ edges is the axisymmetric state; its forces × 360 are compared with ``oracles.sleeve_friction`` (BVLS on the
1D dual, sharing no code with the package): the same discrete problem at the same x-nodes, and a fine 1D
reference (nx = 160, the oracle's fixed point to 1e-7: its dual loses accuracy like h⁻⁴ beyond that)."""

from __future__ import annotations

import math
from functools import cache

import numpy as np
import pytest
from oracles.axisym import Shell1D
from oracles.sleeve_friction import solve_sleeve_friction

import shellcontact
from shellcontact.errors import InputError
from shellcontact.problem.case import case_from_dict

A, T, E, NU = 1.0, 0.02, 2.0e5, 0.3
RS = A + T / 2 - 1e-3
ZONE = (0.2, 0.8)
MU, SLIDE = 0.1, 1e-5
ANGLE = 1.0
SCALE = 360.0 / ANGLE
SHELL = Shell1D(A, T, E, NU, 0.0, 1.0)


def _case(nx: int) -> dict:
    return {
        "shell": {"radius": A, "length": 1.0, "x_start": 0.0, "angle": [0.0, ANGLE], "thickness": T, "young": E,
                  "poisson": NU},
        "supports": {"x_min": "clamped", "x_max": "clamped", "phi_min": "symmetry", "phi_max": "symmetry"},
        "mesh": {"nx": nx, "nphi": 2},
        "punch": [{"shape": "cylinder", "inverted": True, "center": [0.0, 0.0, 0.0], "axis": [1.0, 0.0, 0.0],
                   "radius": RS, "side": "outer", "zone": {"x": list(ZONE)}, "friction": MU,
                   "slide": [SLIDE, 0.0, 0.0]}],
        "solver": {"method": "dual", "contact_points": "vertices"},
    }


@cache
def shell2d(nx: int) -> dict:
    """The normal force, the axial friction force (N, whole circumference) and the slip length (m)."""
    r = shellcontact.solve(case_from_dict(_case(nx)))
    c = r.summary()["contact"][0]
    f = c["friction"]
    assert f["fixed_point"]["converged"]
    return {"N": c["total_normal_force"] * SCALE, "F": f["force"][0] * SCALE,
            "slip_length": f["slip_area"] * SCALE / (2 * math.pi * A)}


@cache
def oracle(nx: int, tol: float = 1e-9):
    return solve_sleeve_friction(SHELL, np.linspace(0.0, 1.0, nx + 1), RS, ZONE, SLIDE, mu=MU, tol=tol)


def test_sleeve_friction_matches_1d_oracle():
    ref = oracle(160, 1e-7)
    rows = []
    for nx in (20, 40):
        s2, s1 = shell2d(nx), oracle(nx)
        rows.append((nx, s2, s1))
        # the same discrete problem up to the 2D discretisation: normal forces to 2.4e-6 and 7.4e-7 measured
        assert s2["N"] == pytest.approx(s1.normal_force, rel=3e-5)
        # friction forces to 1.4 % and 0.5 % (the total is a difference of slips in both directions, 4× smaller
        # than μN: small changes of the stick/slip split show amplified)
        assert s2["F"] == pytest.approx(s1.friction_force, rel=0.05)
        # the law: |F| ≤ μ N, and the slip lengths agree to a node or two (the 1D trapezoids cut to the zone against
        # the 2D rows' weights: measured 0.375 against 0.375 m, 0.396 against 0.3875 m)
        assert abs(s2["F"]) <= MU * s2["N"]
        assert abs(s2["slip_length"] - s1.slip_length) <= 2 / nx
    e = [abs(s2["N"] / ref.normal_force - 1) for _, s2, _ in rows]
    order = math.log2(e[0] / e[1])
    print(f"\n normal force against the 1D reference (nx = 160, N = {ref.normal_force:.8f} N): errors {e}, order"
          f" {order:.2f}; friction force {[s2['F'] for _, s2, _ in rows]} N against {ref.friction_force:.6f} N")
    assert order >= 2.0  # measured 2.66 (nx 20 → 40); 2.2 from 40 to 80
    assert e[1] <= 1e-4  # measured 4.2e-5
    for _, s2, _ in rows:  # measured 2.2 % and 3.8 % off the reference (the oscillation of the split)
        assert s2["F"] == pytest.approx(ref.friction_force, rel=0.15)


def test_sleeve_friction_at_the_slide_where_mpgp_stalled():
    """nx = 20 at slide 9.2534 µm: the disc QP's face step stalled here in any BLAS thread setting (a singular face
    Hessian, solvers/disc_qp.py) and ``solve_pushed`` retried at a slide 1e-6 away; solved directly now, against the
    oracle at the same slide."""
    slide = 9.2534e-6
    d = _case(20)
    d["punch"][0]["slide"] = [slide, 0.0, 0.0]
    c = shellcontact.solve(case_from_dict(d)).summary()["contact"][0]
    s1 = solve_sleeve_friction(SHELL, np.linspace(0.0, 1.0, 21), RS, ZONE, slide, mu=MU, tol=1e-9)
    assert c["total_normal_force"] * SCALE == pytest.approx(s1.normal_force, rel=3e-5)  # measured 3.3e-6
    assert c["friction"]["force"][0] * SCALE == pytest.approx(s1.friction_force, rel=0.08)  # measured 2.1 %

def test_oracle_full_slip_is_mu_times_normal_force():
    """The oracle itself: a slide far past the stick range makes every node in contact slip one way, so the friction
    force is μ × the normal force (an identity of the law, independent of the discretisation)."""
    s = solve_sleeve_friction(SHELL, np.linspace(0.0, 1.0, 41), RS, ZONE, 1e-3, mu=MU)
    assert s.friction_force == pytest.approx(MU * s.normal_force, rel=1e-9)
    assert np.all(s.state[s.lam > 0] == 2)


@pytest.mark.parametrize("steps, path, before, measured", [
    (2, "proportional", (SLIDE / 2,), 1.9e-3),
    (1, "indent-then-slide", (0.0,), 2.2e-3),
])
def test_load_path_matches_1d_oracle(steps, path, before, measured):
    """``[solver] steps``/``path``: the slip carried from step to step, against the oracle's own path (the sleeve is
    in place from the first step; the slide in two halves, or all of it after a step without slide). Coulomb is
    path dependent: the friction force is 0.535 N in one step, 1.19 N in two halves, 1.89 N after a squeeze-only step
    (the squeeze's own slip no longer counts against the slide); the 2D and 1D paths agree to 0.2 %."""
    d = _case(40)
    d["solver"].update(steps=steps, path=path)
    r = shellcontact.solve(case_from_dict(d))
    f = r.summary()["contact"][0]["friction"]
    o = solve_sleeve_friction(SHELL, np.linspace(0.0, 1.0, 41), RS, ZONE, SLIDE, mu=MU, path=before)
    assert f["force"][0] * SCALE == pytest.approx(o.friction_force, rel=5 * measured)
    assert len(f["steps"]) == len(before) + 1 and all(s["converged"] for s in f["steps"])
    assert f["units"]["steps"] == {"force": "N", "normal_force": "N"}
    assert f["steps"][-1]["force"] == f["force"]
    one_shot = shell2d(40)["F"]
    assert abs(f["force"][0] * SCALE - one_shot) > 0.5 * one_shot  # the path matters here (×2.2 and ×3.5)


@pytest.mark.parametrize("solver, where", [
    ({"steps": 0}, "solver.steps"),
    ({"steps": 2.5}, "solver.steps"),
    ({"path": "cyclic"}, "solver.path"),
])
def test_bad_load_path_refused_by_name(solver, where):
    d = _case(20)
    d["solver"].update(solver)
    with pytest.raises(InputError) as e:
        case_from_dict(d)
    assert str(e.value).startswith(where + ":"), str(e.value)


def test_load_path_without_friction_refused():
    d = _case(20)
    d["punch"][0].update(friction=0.0, slide=None)
    del d["punch"][0]["slide"]
    d["solver"]["steps"] = 3
    with pytest.raises(InputError, match="^solver.steps: .*only with friction"):
        case_from_dict(d)


@pytest.mark.parametrize("bound, measured", [(0.5, 2.7e-4), (2.0, 3.5e-4)])
def test_tresca_sleeve_matches_1d_oracle(bound, measured):
    """Tresca (a bound g in Pa on the points in contact, ω_i g per row; the 1D nodes' trapezoids cut to the zone are
    the 2D rows' weights summed over φ, × 360): the same sleeve, nx = 40. Part sticks, part slips; the friction
    force agrees to 2.7e-4 and 3.5e-4, the normal force to 2e-6, the slip length to a node."""
    d = _case(40)
    d["punch"][0]["friction"] = {"model": "tresca", "bound": bound}
    c = shellcontact.solve(case_from_dict(d)).summary()["contact"][0]
    f = c["friction"]
    o = solve_sleeve_friction(SHELL, np.linspace(0.0, 1.0, 41), RS, ZONE, SLIDE, tresca=bound)
    assert f["stick_area"] > 0 and f["slip_area"] > 0 and f["fixed_point"]["converged"]
    assert c["total_normal_force"] * SCALE == pytest.approx(o.normal_force, rel=2e-5)
    assert f["force"][0] * SCALE == pytest.approx(o.friction_force, rel=10 * measured)
    assert abs(f["slip_area"] * SCALE / (2 * math.pi * A) - o.slip_length) <= 1.01 / 40
