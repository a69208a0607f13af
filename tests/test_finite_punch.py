"""Punches of finite extent (issue 14, item 2): a shape cut to a body by a box and half-spaces.

* An extent that covers the whole candidate zone changes nothing: bit-identical solutions.
* A half-space is the same cut as the box face it replaces: bit-identical solutions.
* A sleeve of finite length on a pipe (an axisymmetric state, the 1° panel of
  test_axisymmetric_contact.py) touches only within its length, carries a line force at its edge (the
  rim) and agrees with the exact free-boundary solution of the independent 1D oracle
  (tests/oracles/axisym.py): total force, edge line force, converging under refinement.
* The saddle example: contact only under the saddle, its ends and horns node lines, no spurious
  penetration warning.
* Bad extents are refused by name.
"""

from __future__ import annotations

import copy
import math

import numpy as np
import pytest
from oracles.axisym import Shell1D, sleeve_free_boundary

import shellcontact
from shellcontact.contact.punches import parse_punch
from shellcontact.errors import InputError
from shellcontact.problem.case import case_from_dict, read_case_dict

A, T, E, MU = 1.0, 0.02, 2.0e5, 0.3
ANGLE = 1.0  # degrees: panel width (an exact model of the axisymmetric state)
DELTA, C = 1e-3, 0.3  # the sleeve's interference and half length
RS = A + T / 2 - DELTA
SLEEVE = {"shape": "cylinder", "inverted": True, "center": [0.0, 0.0, 0.0], "axis": [1.0, 0.0, 0.0], "radius": RS}


def _panel(punch: dict, nx: int, method: str = "active-set") -> dict:
    return {
        "shell": {"radius": A, "length": 1.0, "x_start": 0.0, "angle": [0.0, ANGLE], "thickness": T, "young": E,
                  "poisson": MU},
        "supports": {"x_min": "symmetry", "x_max": "clamped", "phi_min": "symmetry", "phi_max": "symmetry"},
        "mesh": {"nx": nx, "nphi": 2},
        "punch": [punch],
        "solver": {"method": method},
    }


def _solve(data: dict):
    res = shellcontact.solve(case_from_dict(data))
    summ = res.summary()
    assert max(summ["kkt"][k] for k in ("stationarity", "penetration", "dual_feasibility", "complementarity")) < 1e-8
    return res, summ


def _identical(r1, r2) -> None:
    assert np.array_equal(r1.solution.space.mesh.p, r2.solution.space.mesh.p)
    assert np.array_equal(r1.solution.U, r2.solution.U)
    assert np.array_equal(r1.contact.Lambda, r2.contact.Lambda)


# ---------------------------------------------------------------------------------------------------------------
# an extent covering the zone, a half-space for a box face: nothing changes
# ---------------------------------------------------------------------------------------------------------------
def test_extent_covering_the_zone_is_bit_identical():
    """An infinite sleeve cut by its zone x ∈ [0, C] and the same sleeve as a body x ∈ [−1, 0.5] ⊃ zone."""
    infinite = {**SLEEVE, "zone": {"x": [0.0, C]}}
    finite = {**infinite, "extent": {"x": [-1.0, 0.5], "y": [-2.0, 2.0]}}
    _identical(_solve(_panel(infinite, 20))[0], _solve(_panel(finite, 20))[0])


def test_extent_covering_the_shell_keeps_the_automatic_zone(examples_dir):
    """The paper's sphere (automatic zone) inside a box larger than the shell: the same zone, bit for bit."""
    data = read_case_dict(examples_dir / "paper_panel.toml")
    data["mesh"] = {**data.get("mesh", {}), "nx": 8, "nphi": 8, "refine": 0}
    data["punch"][0].pop("zone", None)
    boxed = copy.deepcopy(data)
    boxed["punch"][0]["extent"] = {"x": [-10.0, 10.0], "z": [-10.0, 10.0]}
    r1, r2 = shellcontact.solve(case_from_dict(data)), shellcontact.solve(case_from_dict(boxed))
    assert r1.contact.operator.punches[0].zone == r2.contact.operator.punches[0].zone
    _identical(r1, r2)


def test_half_spaces_cut_as_the_box_faces_they_replace():
    box = {**SLEEVE, "extent": {"x": [-C, C]}}
    planes = {**SLEEVE, "extent": {"half_spaces": [{"point": [C, 0.0, 0.0], "normal": [2.0, 0.0, 0.0]},
                                                   {"point": [-C, 0.0, 0.0], "normal": [-1.0, 0.0, 0.0]}]}}
    _identical(_solve(_panel(box, 20))[0], _solve(_panel(planes, 20))[0])


# ---------------------------------------------------------------------------------------------------------------
# a sleeve of finite length: contact only within it, a line force at its rim, the exact solution
# ---------------------------------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def sleeve_reference():
    return sleeve_free_boundary(Shell1D(A, T, E, MU, 0.0, 1.0), RS, C)


@pytest.mark.parametrize("method", ["active-set", "dual"])
def test_finite_sleeve_line_force_at_its_rim_converges(sleeve_reference, method):
    """The body x ∈ [−C, C] (the panel is x ∈ [0, 1], symmetric about x = 0) with an automatic zone. Measured
    against the 1D oracle (both methods alike): rim line force −1.5e-3, −1.7e-4, +4.1e-5 at nx = 20, 40, 80
    (asserted at 80: 2e-4); total force −1.7e-5, −3.9e-6, +4.3e-8 (asserted at 80: 3e-7)."""
    ref = sleeve_reference
    width = A * math.radians(ANGLE)  # circumferential length of the panel's mid-surface
    rows = []
    for nx in (20, 40, 80):
        res, summ = _solve(_panel({**SLEEVE, "extent": {"x": [-C, C]}}, nx, method))
        op, lam = res.contact.operator, res.contact.Lambda
        punch = op.punches[0]
        # the zone follows from the body, and its end is a node line
        assert punch.zone.x == (0.0, pytest.approx(C, abs=1e-12))
        assert np.any(np.abs(res.solution.space.mesh.p[0] - C) < 1e-12)
        # contact only where the body is: no row, hence no force, beyond its end; nothing penetrates there
        assert op.x.max() <= C + 1e-12
        assert summ["contact"][0]["penetration_outside_zone"] == 0.0
        assert not summ.get("warnings")
        rim = np.abs(op.x - C) < 1e-9
        line_force = lam[rim].sum() / width  # per unit circumferential length, as the oracle's ring force
        total = summ["contact"][0]["total_normal_force"] / width
        rows.append((nx, total, line_force))
    print(f"\n finite sleeve ({method}): exact total {ref.force_per_length:.8f}, rim line force {ref.ring_edge:.8f}")
    print("  nx   total (per unit length)  rel. error   rim line force  rel. error")
    for nx, tot, lf in rows:
        print(f" {nx:3d}   {tot:.8f}          {tot / ref.force_per_length - 1: .2e}   {lf:.8f}     "
              f"{lf / ref.ring_edge - 1: .2e}")
    # the rim carries a line force: a finite share of the total at every mesh, not a vanishing nodal share
    assert ref.ring_edge > 0.05 * ref.force_per_length
    errors = [abs(lf / ref.ring_edge - 1) for _, _, lf in rows]
    assert errors[2] < errors[1] < errors[0]
    assert errors[2] < 2e-4
    assert abs(rows[-1][1] / ref.force_per_length - 1) < 3e-7


# ---------------------------------------------------------------------------------------------------------------
# the saddle example: a finite saddle
# ---------------------------------------------------------------------------------------------------------------
def test_saddle_of_finite_length(examples_dir):
    case = shellcontact.load_case(examples_dir / "saddle_support.toml",
                                  ["mesh.nx=24", "mesh.nphi=32", "mesh.refine=0"])
    res = shellcontact.solve(case)
    summ = res.summary()
    op, lam = res.contact.operator, res.contact.Lambda
    saddle = op.punches[1]
    # the zone is the part of the shell the body faces: its length and its arc between the horns
    assert saddle.zone.x == (pytest.approx(-0.1, abs=1e-12), pytest.approx(0.1, abs=1e-12))
    (p0, p1), = saddle.zone.phi
    assert math.degrees(p0) == pytest.approx(225.0, abs=0.01) and math.degrees(p1) == pytest.approx(315.0, abs=0.01)
    p = res.solution.space.mesh.p
    for x in (-0.1, 0.1):
        assert np.any(np.abs(p[0] - x) < 1e-9), "the saddle's ends are node lines"
    rows = op.rows(1)
    assert np.all(np.abs(op.x[rows]) <= 0.1 + 1e-9)
    # the reaction concentrates at the saddle's ends: line forces at its rims carry the largest nodal forces
    ends = np.abs(np.abs(op.x[rows]) - 0.1) < 1e-9
    assert lam[rows][ends].max() > 2.0 * lam[rows][~ends].max() > 0.0
    assert summ["contact"][1]["penetration_outside_zone"] == 0.0
    assert not any("punch.1" in w["message"] for w in summ.get("warnings", []))
    assert summ["contact"][1]["force"][2] > 0.0


# ---------------------------------------------------------------------------------------------------------------
# refusals
# ---------------------------------------------------------------------------------------------------------------
@pytest.mark.parametrize(("extent", "key"), [
    ({"x": [0.1, -0.1]}, "punch.0.extent.x"),
    ({"y": [0.1, 0.1]}, "punch.0.extent.y"),
    ({"z": [float("nan"), 1.0]}, "punch.0.extent.z"),
    ({"x": [0.0, float("inf")]}, "punch.0.extent.x"),
    ({"x": [0.0, 1.0], "half_spaces": [{"point": [0.5, 0.0, 0.0], "normal": [-1.0, 0.0, 0.0]},
                                       {"point": [0.2, 0.0, 0.0], "normal": [1.0, 0.0, 0.0]}]}, "punch.0.extent"),
    ({"half_spaces": [{"point": [0.0, 0.0, 0.0], "normal": [0.0, 0.0, 0.0]}]}, "punch.0.extent.half_spaces.0.normal"),
    ({"half_spaces": [{"point": [0.0, 0.0, 0.0]}]}, "punch.0.extent.half_spaces.0.normal"),
    ({"w": [0.0, 1.0]}, "punch.0.extent.w"),
])
def test_bad_extent_is_refused_by_name(extent, key):
    with pytest.raises(InputError) as err:
        parse_punch({**SLEEVE, "extent": extent})
    assert err.value.field == key


def test_body_that_faces_no_part_of_the_shell_is_refused():
    """The sleeve cut to x ∈ [2, 3], beyond the shell x ∈ [0, 1]."""
    with pytest.raises(InputError) as err:
        shellcontact.solve(case_from_dict(_panel({**SLEEVE, "extent": {"x": [2.0, 3.0]}}, 8)))
    assert err.value.field == "punch.0.extent"


def test_body_across_the_seam_of_a_full_cylinder():
    """A roller of finite height (z ∈ [−0.03, 0.03]) at the side of a full pipe, across the seam φ = 0 ≡ 360°,
    with a zone given in x only (the whole circle): the zone keeps the arcs the body faces, the one across the
    seam as two intervals meeting there, whose edges are where the foot of the contact surface on the roller
    reaches z = ±0.03 (found here independently by root finding); only points opposite the body are rows."""
    from scipy.optimize import brentq

    roller = {"shape": "cylinder", "center": [0.0, 0.151, 0.0], "axis": [1.0, 0.0, 0.0], "radius": 0.05,
              "direction": [0.0, -1.0, 0.0], "indentation": 1e-4, "zone": {"x": [-0.3, 0.3]},
              "extent": {"x": [-0.1, 0.1], "z": [-0.03, 0.03]}}
    data = {"shell": {"radius": 0.1, "length": 1.0, "full": True, "thickness": 0.002, "young": 2.1e11,
                      "poisson": 0.3},
            "supports": {"x_min": "clamped", "x_max": "clamped"},
            "mesh": {"nx": 8, "nphi": 24}, "punch": [roller], "solver": {"method": "active-set"}}
    res, summ = _solve(data)
    op = res.contact.operator
    punch = op.punches[0]
    cy = 0.151 + punch.offset[1]  # the placed roller's axis: y = cy, z = 0
    r_out = 0.1 + 0.001  # the outer contact surface

    def foot_z(phi: float) -> float:
        y, z = r_out * math.cos(phi), r_out * math.sin(phi)
        return 0.05 * z / math.hypot(y - cy, z)

    edge = brentq(lambda p: foot_z(p) - 0.03, 0.0, 0.9, xtol=1e-15)
    near = [(a, b) for a, b in punch.zone.phi if a == 0.0 or b == pytest.approx(2 * math.pi, abs=1e-12)]
    assert len(near) == 2
    assert near[0] == (0.0, pytest.approx(edge, abs=1e-9))
    assert near[1] == (pytest.approx(2 * math.pi - edge, abs=1e-9), pytest.approx(2 * math.pi, abs=1e-12))
    mesh_phi = res.solution.space.mesh.p[1] / 0.1
    assert np.any(np.abs(mesh_phi - edge) < 1e-9) and np.any(np.abs(mesh_phi - (2 * math.pi - edge)) < 1e-9)
    assert punch.zone.x == (pytest.approx(-0.1, abs=1e-12), pytest.approx(0.1, abs=1e-12))
    assert np.all(punch.on_body(op.points, tol=1e-9))
    assert summ["contact"][0]["force"][1] < 0.0  # the roller pushes the pipe toward −y
