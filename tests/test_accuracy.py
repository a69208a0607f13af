"""Issue 22 item 4: every headline number states its accuracy (``accuracy.py``, ``run --estimate``,
``run --accuracy TOL``).

The estimates are checked against independent references only — a manufactured sequence with a known limit,
closed forms (the clamped pressurised cylinder of tests/test_axisymmetric_pressure.py, the ring between two
plates of tests/oracles/ring.py) and the series values of the Scordelis–Lo roof and the pinched cylinder
(tests/test_shell_benchmarks.py): the estimate lies within a factor 3 of the true error. Measured ratios
estimate / true error are in each docstring.
"""

from __future__ import annotations

import json
import math
import re
from pathlib import Path

import pytest
from inprocess import run_cli
from oracles.ring import Ring
from test_axisymmetric_pressure import _exact
from test_shell_benchmarks import PINCHED, SCORDELIS_LO

import shellcontact as sc
from shellcontact.errors import InputError
from shellcontact.studies import accuracy

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


def _ratio(est: sc.studies.accuracy.Estimate, path: str, exact: float) -> float:
    """The estimate over the true relative error of ``path``."""
    entry = est.accuracy[path]
    true = abs(entry["value"] - exact) / abs(exact)
    print(f"{path}: value {entry['value']:.8g} exact {exact:.8g} true {true:.3e} estimate {entry['estimate']:.3e} "
          f"order {entry['order']} -> ratio {entry['estimate'] / true:.2f}")
    return entry["estimate"] / true


# -- the estimator on sequences with a known limit ---------------------------------------------------------------
@pytest.mark.parametrize("order", [1.0, 2.0, 3.7])
def test_richardson_recovers_the_error_of_a_sequence_with_a_known_limit(order):
    """q(h) = q* + C h^p on h, 2h, 4h: the observed order is p and the estimate is the exact error."""
    limit, c, h = 3.0, 0.7, 0.05
    values = [limit + c * (k * h) ** order for k in (1, 2, 4)]
    err, observed = accuracy.richardson(values)
    assert observed == pytest.approx(order, rel=1e-9)
    assert err == pytest.approx(c * h**order, rel=1e-9)


def test_richardson_without_an_observed_order_takes_the_difference():
    """Two meshes, or differences that change sign or grow: order 1 assumed, the estimate |q0 − q1|."""
    assert accuracy.richardson([1.0, 1.1]) == (pytest.approx(0.1), None)
    assert accuracy.richardson([1.0, 1.1, 1.05]) == (pytest.approx(0.1), None)  # sign change
    assert accuracy.richardson([1.0, 1.1, 1.15]) == (pytest.approx(0.1), None)  # growing differences
    assert accuracy.richardson([1.0, None]) == (None, None)
    assert accuracy.richardson([2.0, 2.0, 3.0]) == (0.0, None)


def test_headlines_are_read_by_path_and_probe_components_are_relative_to_the_probe():
    summary = {"max_abs_w": 2.0, "energy": 5.0,
               "probes": [{"u": 1e-18, "v": 0.0, "w": -2.0, "displacement": [1e-18, 0.0, -2.0]}],
               "contact": [{"force_magnitude": 10.0, "zone": {"area": 0.5}, "rim": {"mean_line_force": 4.0}},
                           {"force_magnitude": 0.0, "zone": {"area": 0.0}}],
               "stresses": {"top": {"von_mises_max": 7.0}, "bottom": {"von_mises_max": 8.0}}}
    values = accuracy.headline_values(summary)
    assert "energy" not in values
    assert values["probes.0.u"] == (1e-18, 2.0)  # relative to |displacement|, not to itself
    still = {**summary, "probes": [{"v": 1e-15, "displacement": [0.0, 1e-15, 0.0]}]}  # a point that hardly moves
    assert accuracy.headline_values(still)["probes.0.v"] == (1e-15, 2e-6)  # 1e-6 max |w|
    ring = {"contact": [{"force_magnitude": 1e-9, "total_normal_force": 5.0}]}  # a band: the resultant vanishes
    assert accuracy.headline_values(ring)["contact.0.force_magnitude"] == (1e-9, 5.0)
    assert values["probes.0.displacement.2"] == (-2.0, 2.0)
    assert values["contact.0.rim.mean_line_force"] == (4.0, 4.0)
    assert "contact.1.rim.mean_line_force" not in values
    assert values["stresses.bottom.von_mises_max"] == (8.0, 8.0)
    plates = {"contact": [{"zone": {"area": 1e-3}, "rim": {"kind": "line", "mean_line_force": 667.0}},
                          {"zone": {"area": 1e-3}, "rim": {"kind": "area", "mean_line_force": 667.0}}]}
    values = accuracy.headline_values(plates)  # a line contact's area is zero in the limit: not a headline
    assert "contact.0.zone.area" not in values and "contact.1.zone.area" in values
    assert "contact.0.rim.mean_line_force" in values
    coarse = json.loads(json.dumps(summary))
    coarse["contact"][0]["force_magnitude"] = 11.0
    del coarse["contact"][0]["rim"]
    table = accuracy.accuracy_table([summary, coarse])
    assert table["contact.0.force_magnitude"]["estimate"] == pytest.approx(0.1)
    assert table["contact.0.rim.mean_line_force"]["estimate"] is None  # missing on the coarser mesh
    assert table["max_abs_w"]["estimate"] == 0.0


# -- honest estimates: closed forms and series values --------------------------------------------------------------
def test_pressurised_cylinder_deflection_and_edge_stresses_against_the_closed_form():
    """The clamped cylinder under internal pressure (examples/pressurized_cylinder.toml). w at the probes
    on the example's mesh (nx = 40 → 20 → 10): measured ratios 0.94, 0.89 (true errors 1.2e-8, 1.0e-8). The
    von Mises maxima at the clamped edge (σ11 = N/t ± 6M/t², σ22 = μσ11 there, w = 0): at nx = 80, measured
    0.80 and 1.49 (true 8.5e-5, 2.8e-4); at nx = 40 the coarse levels are not yet asymptotic for the edge
    stresses and the estimate is conservative (2.7, 3.2)."""
    case = sc.load_case(EXAMPLES / "pressurized_cylinder.toml")
    ex = _exact(case)
    est = accuracy.estimate(case)
    for path, x in (("probes.0.w", 0.0), ("probes.1.w", 5.0)):
        assert 1 / 3 <= _ratio(est, path, ex.w(x)) <= 3
    est = accuracy.estimate(sc.load_case(EXAMPLES / "pressurized_cylinder.toml", sets=["mesh.nx=80"]))
    k = math.sqrt(1 - ex.mu + ex.mu**2)
    for surface, sign in (("top", 1), ("bottom", -1)):
        exact = abs(ex.N / ex.t + sign * 6 * ex.M11(ex.H) / ex.t**2) * k
        assert 1 / 3 <= _ratio(est, f"stresses.{surface}.von_mises_max", exact) <= 3


@pytest.mark.parametrize("n", [12, 16])
def test_scordelis_lo_against_the_series_value(n):
    """The roof's vertical displacement at mid-length of the free edge, 0.3006 (the converged Kirchhoff–Love
    value): measured ratios 2.03 at 12 × 12 (true error 3.2e-3), 1.35 at the example's 16 × 16 (9.8e-4)."""
    case = sc.load_case(EXAMPLES / "scordelis_lo.toml", sets=[f"mesh.nx={n}", f"mesh.nphi={n}"])
    est = accuracy.estimate(case)
    assert 1 / 3 <= _ratio(est, "probes.0.displacement.2", -SCORDELIS_LO) <= 3


def test_pinched_cylinder_against_the_series_value():
    """The radial displacement under the load, 1.8248e-5: at 24 × 24 measured ratio 1.34 (true error 7.2e-4).
    On the example's 16 × 16 (levels down to 4 × 4, before the asymptotic range of a point load) the
    estimate is conservative, 8.3e-3 against 1.5e-3 (and this model's limit lies about 0.13 % above the
    series value, which bounds how small a true error this reference can show)."""
    case = sc.load_case(EXAMPLES / "pinched_cylinder_eighth.toml", sets=["mesh.nx=24", "mesh.nphi=24"])
    assert 1 / 3 <= _ratio(accuracy.estimate(case), "probes.0.w", -PINCHED) <= 3
    coarse = accuracy.estimate(sc.load_case(EXAMPLES / "pinched_cylinder_eighth.toml"))
    assert _ratio(coarse, "probes.0.w", -PINCHED) >= 1 / 3  # never an underestimate


def test_ring_between_plates_travel_against_the_closed_form_ring():
    """The plates' approach (the top plate's travel under force control) against δ of the closed-form ring
    (tests/test_ring_plates.py): 64 elements around (→ 32 → 16), one along the uniform pipe, measured ratio
    1.25 (true error 4.4e-4). The prescribed force has an estimate of round-off size."""
    case = sc.load_case(EXAMPLES / "ring_stiffness.toml", sets=[
        "mesh.nx=1", "mesh.nphi=64", "punch.0.zone={phi=[67.5,112.5]}", "punch.1.zone={phi=[247.5,292.5]}"])
    raw = case.raw
    ring = Ring(raw["shell"]["radius"], raw["shell"]["thickness"], raw["shell"]["young"], raw["shell"]["poisson"])
    est = accuracy.estimate(case)
    exact = ring.diametral_change(raw["punch"][0]["force"] / raw["shell"]["length"])
    assert 1 / 3 <= _ratio(est, "contact.0.punch_travel", exact) <= 3
    assert est.accuracy["contact.0.force_magnitude"]["estimate"] < 1e-12


def test_sleeve_force_against_the_axisymmetric_free_boundary_solution():
    """The rigid sleeve on the 1° panel of tests/test_axisymmetric_contact.py against the exact free-boundary
    solution of the 1D oracle (tests/oracles/axisym.py): the total normal force at nx × nphi = 40 × 2 (→ 20 × 1
    → 10 × 1), measured ratio 1.22 (true error 2.8e-5). Where the estimate is not honest, measured: at 80 × 4
    the free boundary moves between node lines and the observed order (4.0) overstates the rate, ratio 0.30
    (true 5.1e-6); at 20 × 2 the coarsest level has two elements in the contact band, ratio 27 (conservative);
    and a direction kept at one element (nphi = 1 on every level) is not refined, so its error (the vertex
    constraint across the panel, 3.5e-5 at 80 × 1) is invisible to the estimate (ratio 0.02)."""
    from oracles.axisym import Shell1D, sleeve_free_boundary
    from test_axisymmetric_contact import ANGLE, C_S, MU, RS, SLEEVE, A, E, T, _case

    exact = sleeve_free_boundary(Shell1D(A, T, E, MU, 0.0, 1.0), RS, C_S).total_normal_force * ANGLE / 360.0
    est = accuracy.estimate(sc.case_from_dict(_case(1.0, "clamped", SLEEVE, 40, 2)))
    assert 1 / 3 <= _ratio(est, "contact.0.total_normal_force", exact) <= 3


def test_refine_to_reaches_the_tolerance_it_reports():
    """refine_to on the ring (16 elements around): it refines until the travel's estimate is below 1e-3, and
    the true error there is below the tolerance too (the headlines that do not converge — zone area, the
    middle surface's stress — stop it at --max-levels, said in ``stopped``)."""
    case = sc.load_case(EXAMPLES / "ring_stiffness.toml", sets=[
        "mesh.nx=1", "mesh.nphi=16", "punch.0.zone={phi=[67.5,112.5]}", "punch.1.zone={phi=[247.5,292.5]}"])
    raw = case.raw
    ring = Ring(raw["shell"]["radius"], raw["shell"]["thickness"], raw["shell"]["young"], raw["shell"]["poisson"])
    exact = ring.diametral_change(raw["punch"][0]["force"] / raw["shell"]["length"])
    est = accuracy.refine_to(case, 1e-3, max_levels=2)
    assert [lv["mesh"]["refine"] for lv in est.levels[:3]] == [2, 1, 0]
    travel = est.accuracy["contact.0.punch_travel"]
    assert travel["estimate"] <= 1e-3
    assert abs(travel["value"] - exact) / exact <= 1e-3
    assert not est.met and "--max-levels 2" in est.stopped
    assert any("tolerance 0.001 is not met" in w for w in est.warnings())


def test_refine_to_stops_at_the_memory_guard_with_the_results_it_reached():
    """A memory limit between the needs of mesh.refine = 0 and 1 (sizing.estimate): the case's own mesh is
    solved and estimated, the refinement stops naming the guard, and nothing beyond is built."""
    from shellcontact.problem import sizing

    case = sc.load_case(EXAMPLES / "scordelis_lo.toml", sets=["mesh.nx=8", "mesh.nphi=8"])
    finer = sc.load_case(EXAMPLES / "scordelis_lo.toml", sets=["mesh.nx=8", "mesh.nphi=8", "mesh.refine=1"])
    limit = 0.5 * (sizing.estimate(case).bytes + sizing.estimate(finer).bytes)
    est = accuracy.refine_to(case, 1e-6, max_memory=limit)
    assert [lv["mesh"] for lv in est.levels] == [{"refine": 0, "nx": n, "nphi": n} for n in (8, 4, 2)]
    assert est.stopped.startswith("the memory guard stopped the refinement: mesh.refine") and not est.met
    assert est.summary()["refinement"]["stopped"] == est.stopped


def test_a_failing_coarsest_mesh_leaves_two_meshes_and_a_failing_next_one_is_named(monkeypatch):
    from shellcontact.analysis import pipeline as analysis

    real = analysis.solve

    def solve(case, **kw):  # a coarse mesh the case cannot be solved on (e.g. too coarse for its punch)
        if case.mesh.nx <= failing:
            raise InputError("punch.0.zone", "no constraint point in the zone")
        return real(case, **kw)

    monkeypatch.setattr(analysis, "solve", solve)
    case = sc.load_case(EXAMPLES / "scordelis_lo.toml", sets=["mesh.nx=8", "mesh.nphi=8"])
    failing = 2
    est = accuracy.estimate(case)
    assert [lv["dofs"] for lv in est.levels] == [1272, 368]
    assert est.accuracy["probes.0.w"]["order"] is None and est.accuracy["probes.0.w"]["estimate"] > 0
    failing = 4
    with pytest.raises(InputError) as e:
        accuracy.estimate(case)
    assert e.value.field == "punch.0.zone" and "on the next coarser mesh" in e.value.message
    failing = 2
    real_refined = real

    def solve_fine_fails(case, **kw):  # refine_to's next level fails: the results reached stand
        if case.mesh.refine >= 1:
            raise sc.SolverError("did not converge")
        return real_refined(case, **kw)

    monkeypatch.setattr(analysis, "solve", solve_fine_fails)
    est = accuracy.refine_to(case, 1e-6)
    assert est.levels[0]["mesh"]["refine"] == 0 and est.stopped.startswith("the solve on mesh.refine = 1 failed")


# -- the command line -------------------------------------------------------------------------------------------
def test_run_estimate_writes_accuracy_and_warns(tmp_path):
    out = tmp_path / "out"
    code, err = run_cli(["run", str(EXAMPLES / "scordelis_lo.toml"), "--estimate", "-o", str(out), "--no-figures",
                         "--set", "mesh.nx=8", "--set", "mesh.nphi=8"])
    assert code == 0, err
    s = json.loads((out / "summary.json").read_text())
    entry = s["accuracy"]["probes.0.w"]
    assert entry["value"] == s["probes"][0]["w"] and entry["estimate"] > 0.01
    assert s["units"]["accuracy.probes.0.w.value"] == "m" and "accuracy.probes.0.w.estimate" not in s["units"]
    assert [lv["dofs"] for lv in s["refinement"]["levels"]] == [s["dofs"], 368, 120]
    assert any(w["code"] == "accuracy" and w["message"].startswith("accuracy: estimated discretisation error above 1 %")
               for w in s["warnings"])
    assert "estimated discretisation error above 1 %" in err
    at = s["probes"][0]
    place = f"(at x = {at['x']:.4g} {s['units']['probes.x']}, phi = {at['phi']:.4g} deg)"  # x with its unit
    assert f"probes.0.w {100 * entry['estimate']:.3g} % {place}" in err, err
    html = (out / "report.html").read_text()
    assert "<h2>Accuracy</h2>" in html and "estimated relative error" in html
    results = html.split("<h2>Results</h2>")[1].split("<h2>")[0]  # the estimate beside each headline number
    assert "<th>estimated error</th>" in results
    w = s["accuracy"]["max_abs_w"]["estimate"]
    row = re.sub(r"<[^>]+>", "|", results.split("max deflection |w|")[1].split("</tr>")[0])
    assert row.split("||")[:4] == ["", f"{s['max_abs_w']:.6g}", "m", f"{100 * w:.2g} % (above 1 %)"], row


def test_the_console_shows_each_estimate_next_to_its_number(capsys):
    from shellcontact.console import Console, print_summary

    summary = {"dofs": 10, "elements": 2, "energy": 1.0, "max_abs_w": 0.5, "unit_system": "SI",
               "probes": [{"x": 0.0, "phi": 90.0, "u": 0.0, "v": 0.0, "w": -0.5}],
               "contact": [{"force_magnitude": 3.0, "zone": {"area": 2.0}}],
               "stresses": {"top": {"von_mises_max": 7.0, "at": {"x": 0.0, "phi": 90.0}}},
               "accuracy": {"max_abs_w": {"estimate": 0.0123}, "probes.0.w": {"estimate": 0.0123},
                            "contact.0.force_magnitude": {"estimate": 0.004}, "contact.0.zone.area": {"estimate": 0.3},
                            "stresses.top.von_mises_max": {"estimate": None}}}
    print_summary(Console(), summary)
    out = capsys.readouterr().out
    for text in ("max|w| 0.5 m (±1.2 %)", "w=-0.5 m (±1.2 %)", "force 3 N (±0.4 %)", "zone area 2 m² (±30 %)",
                 "max von Mises 7 Pa (top"):
        assert text in out, (text, out)


@pytest.mark.parametrize("system, length, pressure", [("SI", "m", "Pa"), ("mm", "mm", "MPa")])
def test_the_console_accuracy_table_gives_each_value_its_unit(system, length, pressure):
    """Each line of ``run --estimate``'s table carries its quantity's unit in the case's unit system (a length
    in m or mm, a stress in Pa or MPa), as summary.json's ``units`` map does; a count would stay bare."""
    from types import SimpleNamespace

    result = SimpleNamespace(case=SimpleNamespace(units=system))
    entries = {"max_abs_w": {"value": 0.331745, "estimate": 0.0016, "order": 3.4},
               "probes.0.displacement.1": {"value": -0.158214, "estimate": 0.00078, "order": 3.4},
               "stresses.top.von_mises_max": {"value": 283372.0, "estimate": 0.002, "order": None}}
    est = accuracy.Estimate(result=result, accuracy=entries, levels=[{"dofs": 4712, "seconds": 0.86}])
    lines = accuracy.describe(est)
    assert re.search(rf"max_abs_w\s+0\.331745 {length}\s+± 0\.16 % \(observed order 3\.4\)", lines[1]), lines
    assert re.search(rf"probes\.0\.displacement\.1\s+-0\.158214 {length}\s+± 0\.078 %", lines[2]), lines
    assert re.search(rf"stresses\.top\.von_mises_max\s+283372 {pressure}\s+± 0\.2 % \(order 1 assumed\)",
                     lines[3]), lines


def test_run_accuracy_stops_at_the_level_limit_and_strict_exits_1(tmp_path):
    args = ["run", str(EXAMPLES / "scordelis_lo.toml"), "--accuracy", "1e-6", "--max-levels", "0", "--no-figures",
            "--no-report", "--set", "mesh.nx=8", "--set", "mesh.nphi=8"]
    code, err = run_cli([*args, "-o", str(tmp_path / "a")])
    assert code == 0, err
    s = json.loads((tmp_path / "a" / "summary.json").read_text())
    assert s["refinement"]["tolerance"] == 1e-6 and "--max-levels 0" in s["refinement"]["stopped"]
    assert s["accuracy"]["probes.0.w"]["met"] is False
    assert "tolerance 1e-06 is not met" in err
    code, _ = run_cli([*args, "-o", str(tmp_path / "b"), "--strict"])
    assert code == 1


@pytest.mark.parametrize(("extra", "field"), [
    (["--accuracy", "0"], "--accuracy"),
    (["--accuracy", "2"], "--accuracy"),
    (["--accuracy", "1e-3", "--estimate"], "--accuracy"),
    (["--strict"], "--strict"),
    (["--estimate", "--set", "mesh.nx=7"], "mesh.refine"),
    (["--accuracy", "1e-3", "--max-levels", "-1"], "--max-levels"),
])
def test_bad_accuracy_options_are_refused_by_name(tmp_path, extra, field):
    code, err = run_cli(["run", str(EXAMPLES / "scordelis_lo.toml"), "-o", str(tmp_path / "x"), *extra])
    assert code == 2, err
    assert err.startswith(f"error: {field}:"), err
    assert not (tmp_path / "x").exists()


def test_the_api_refuses_a_case_without_a_coarser_mesh():
    case = sc.load_case(EXAMPLES / "scordelis_lo.toml", sets=["mesh.nx=7"])
    with pytest.raises(InputError) as e:
        sc.estimate(case)
    assert e.value.field == "mesh.refine" and "mesh.nx = 7" in e.value.message
    with pytest.raises(InputError) as e:
        sc.refine_to(case, 1e-9)
    assert e.value.field == "tolerance"
