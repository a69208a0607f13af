"""Friction in the case file and summary.json (issue 26 item 3): frictionless results unchanged bit for bit,
bad values refused by name, and the friction entry of a Coulomb run checked against the law and the balance."""

from __future__ import annotations

from functools import cache

import numpy as np
import pytest
from test_contact_solve import sphere_dict

from shellcontact import solve
from shellcontact.errors import InputError
from shellcontact.problem.case import case_from_dict


def panel(**punch) -> dict:
    d = sphere_dict(n=8)
    d["punch"][0].update(punch)
    return d


@cache
def solved(method: str = "dual", **punch):
    return solve(case_from_dict(panel(**punch)), method=method)


@pytest.mark.parametrize("method", ["dual", "active-set", "penalty"])
@pytest.mark.parametrize("friction", [0.0, {"model": "coulomb", "coefficient": 0.0},
                                      {"model": "tresca", "bound": 0.0}])
def test_zero_friction_is_bit_identical(friction, method):
    """Issue 26 item 4, for each of the three methods: zero friction (μ = 0 or a Tresca bound of 0 Pa) is the
    frictionless case, its results equal to the last bit."""
    base = solved(method)
    r = solve(case_from_dict(panel(friction=friction)), method=method)
    assert np.array_equal(r.solution.U, base.solution.U)
    assert np.array_equal(r.contact.Lambda, base.contact.Lambda)
    a, b = r.summary(), base.summary()
    for key in ("contact", "kkt", "equilibrium", "energy", "stresses"):
        assert a[key] == b[key], key
    assert "friction" not in a["contact"][0]


@pytest.mark.parametrize("punch, where", [
    ({"friction": -0.1}, "punch.0.friction"),
    ({"friction": 11.0}, "punch.0.friction"),
    ({"friction": "steel"}, "punch.0.friction"),
    ({"friction": {"model": "tresca"}}, "punch.0.friction.bound"),
    ({"friction": {"model": "tresca", "bound": -1.0}}, "punch.0.friction.bound"),
    ({"friction": {"model": "coulomb", "bound": 1.0}}, "punch.0.friction.coefficient"),
    ({"friction": {"model": "amontons", "coefficient": 0.2}}, "punch.0.friction.model"),
    ({"slide": [0.0, 0.0, 1e-3]}, "punch.0.slide"),
    ({"slide": [1e-3, 0.0]}, "punch.0.slide"),
])
def test_bad_friction_refused_by_name(punch, where):
    with pytest.raises(InputError) as e:
        case_from_dict(panel(**punch))
    assert str(e.value).startswith(where + ":"), str(e.value)


def test_coulomb_summary_entry():
    """μ = 0.3 and a 1 mm axial slide of the paper's sphere: every touching point slips, so the friction force
    is μ × the normal force up to the cap's curvature; the shell's balance includes it (without it the balance
    would miss 84 kN of 285 kN)."""
    r = solved(friction=0.3, slide=(1e-3, 0.0, 0.0))
    s = r.summary()
    c = s["contact"][0]
    f = c["friction"]
    assert f["units"] == {"force": "N", "stick_area": "m²", "slip_area": "m²", "max_slip": "m"}
    assert f["stick_area"] == 0.0 and f["slip_area"] == pytest.approx(c["area"], rel=1e-12)
    assert 0.95 < f["force"][0] / (0.3 * c["total_normal_force"]) <= 1.0  # measured 0.984
    assert f["max_slip"] == pytest.approx(1e-3, rel=1.0)  # the slide less the shell's drag: 1.6 mm measured
    assert f["fixed_point"]["converged"] and f["fixed_point"]["iterations"] <= 30  # measured 5 (Anderson; 7 plain)
    base = solved().summary()["equilibrium"]["relative_residual"]
    # measured 4.3e-5 with friction, 4.5e-5 without (the interpolation error of the rigid motions)
    assert s["equilibrium"]["relative_residual"] < 10 * max(base, 1e-5)
    assert not [w for w in s["warnings"] if w["code"] == "friction_contraction"]


def test_large_mu_warns_that_the_fixed_point_does_not_contract():
    """μ = 5 on the same panel: the plain fixed point falls into a 2-cycle (not converged in 50 iterations);
    Anderson's mixing finds a fixed point between them, but the map G does not contract (the largest ratio
    |ΔG|/|Δg| measured 1.75; 0.45 at μ = 3): the coded warning says the static Coulomb problem may not be
    unique."""
    s = solved(friction=5.0, slide=(1e-3, 0.0, 0.0)).summary()
    fp = s["contact"][0]["friction"]["fixed_point"]
    assert fp["acceleration"] == "anderson" and fp["contraction"] > 0.9
    assert "friction_contraction" in [w["code"] for w in s["warnings"]]


def test_penalty_and_dual_agree_on_coulomb():
    """The same Coulomb case by the penalty (regularised friction, its default ε) and by the dual: the friction and
    normal forces agree to the penalty's O(ε) (measured 4e-6 relative)."""
    d = solved("dual", friction=0.3, slide=(1e-3, 0.0, 0.0)).summary()["contact"][0]
    p = solved("penalty", friction=0.3, slide=(1e-3, 0.0, 0.0)).summary()["contact"][0]
    assert p["friction"]["method"] == "tresca-penalty" and d["friction"]["method"] == "tresca-dual"
    scale = abs(d["friction"]["force"][0])
    assert np.allclose(p["friction"]["force"], d["friction"]["force"], rtol=0, atol=4e-5 * scale)
    assert p["total_normal_force"] == pytest.approx(d["total_normal_force"], rel=4e-5)


@pytest.mark.parametrize("mu, warned", [(0.3, False), (5.0, True)])
def test_newton_solution_gets_the_fixed_points_contraction_and_warning(mu, warned):
    """Where the whole-law Newton (active-set) converged no fixed point ran; the map's contraction is probed at its
    solution by two Tresca solves and compared with the dual's fixed point (Anderson's largest ratio |ΔG|/|Δg|) on
    the same case: the same warning and q within a factor 2 (measured active-set/dual 0.0807/0.0688 = 1.17 at
    μ = 0.3, 2.335/1.745 = 1.34 at μ = 5; 0.53/0.45 at μ = 3, unwarned)."""
    fps = {m: solved(m, friction=mu, slide=(1e-3, 0.0, 0.0)).summary() for m in ("active-set", "dual")}
    newton, dual = (s["contact"][0]["friction"]["fixed_point"] for s in (fps["active-set"], fps["dual"]))
    assert newton["iterations"] == 0 and newton["newton"]["converged"] and newton["newton"]["contraction_solves"] == 2
    assert dual["iterations"] > 0 and dual["acceleration"] == "anderson"
    assert 0.5 < newton["contraction"] / dual["contraction"] < 2.0
    assert (newton["contraction"] > 0.9) is warned
    for s in fps.values():
        assert ("friction_contraction" in [w["code"] for w in s["warnings"]]) is warned


def test_probed_contraction_does_not_depend_on_the_probes_size(monkeypatch):
    """The probes are small enough for G's derivative (the slip law's directions bend it: q drifts by O(size)) and
    above round-off: 1e-2 and 1e-6 of the bounds give the default 1e-4's q (μ = 5; measured 2.34999, 2.33506
    against 2.33521: 6.3e-3 and 6.2e-5 relative; at 1e-8 round-off shows, 5.6e-5 at μ = 0.3)."""
    from shellcontact.contact import friction

    def q(size: float) -> float:
        monkeypatch.setattr(friction, "PROBE_SIZE", size)
        s = solve(case_from_dict(panel(friction=5.0, slide=(1e-3, 0.0, 0.0))), method="active-set").summary()
        return s["contact"][0]["friction"]["fixed_point"]["contraction"]

    base = q(1e-4)
    assert q(1e-2) == pytest.approx(base, rel=3e-2)
    assert q(1e-6) == pytest.approx(base, rel=3e-4)


def test_one_fixed_point_iteration_then_polish_still_measures_the_contraction(monkeypatch):
    """The whole-law Newton held to 3 steps at μ = 5: the fixed point runs one iteration and its polish converges,
    which gives no ratio of the map (before: q 0, no warning); the contraction is then probed at the solution:
    warned, within a factor 2 of the dual's fixed point (measured 2.3352 against 1.745) and equal to the
    Newton-alone run's q (measured 1.2e-10 relative: the same solution)."""
    from shellcontact.analysis import friction

    monkeypatch.setattr(friction, "NEWTON_ITERATIONS", 3)
    s = solve(case_from_dict(panel(friction=5.0, slide=(1e-3, 0.0, 0.0))), method="active-set").summary()
    fp = s["contact"][0]["friction"]["fixed_point"]
    assert fp["iterations"] == 1 and fp["newton"]["polish_iterations"] and fp["newton"]["contraction_solves"] == 2
    assert "friction_contraction" in [w["code"] for w in s["warnings"]]
    dual = solved("dual", friction=5.0, slide=(1e-3, 0.0, 0.0)).summary()["contact"][0]["friction"]["fixed_point"]
    assert 0.5 < fp["contraction"] / dual["contraction"] < 2.0
    monkeypatch.setattr(friction, "NEWTON_ITERATIONS", 25)
    alone = solved("active-set", friction=5.0, slide=(1e-3, 0.0, 0.0)).summary()["contact"][0]["friction"]
    assert fp["contraction"] == pytest.approx(alone["fixed_point"]["contraction"], rel=1e-6)


def test_the_contraction_warning_reaches_stderr_once(tmp_path):
    """A run's warnings are logged once each from its summary (``result._check_summary``); the friction module
    printed its own as well, so `run` showed the contraction warning twice."""
    from pathlib import Path

    from inprocess import run_cli

    case = Path(__file__).resolve().parents[1] / "examples" / "panel_pushed_sideways.toml"
    code, err = run_cli(["run", str(case), "--set", "punch.0.friction=5", "--set", "mesh.nx=8", "--set",
                         "mesh.nphi=8", "--no-figures", "--no-report", "-q", "-o", str(tmp_path / "out")])
    assert code == 0, err
    assert err.count("the fixed point of the friction bounds on the normal forces") == 1, err
