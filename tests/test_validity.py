"""Issue 23, items 3 and 4: the result says when it leaves the linear thin-shell range (validity.py), each
warning with a stable code; input in the wrong unit (radians for degrees, millimetres in an SI case) is named.

Independent references: the indentation itself (the crown follows the punch), a thick wall's t/a from its
inputs, the closed-form boundary layer of the clamped pressurised cylinder (its largest slope), the case's
own numbers read as radians."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from test_axisymmetric_pressure import ClampedPressurizedCylinder

import shellcontact as sc
from shellcontact.analysis.validity import ROTATION_LIMIT, STRETCH_RATIO_LIMIT, THICKNESS_RATIO_LIMIT, range_measures
from shellcontact.cli import main
from shellcontact.errors import InputError
from shellcontact.outputs.report import render
from shellcontact.problem.case import read_case_dict

ROOT = Path(__file__).resolve().parents[1]
PANEL = ROOT / "examples" / "paper_panel.toml"
COARSE = ["mesh.nx=16", "mesh.nphi=16"]


def _codes(result) -> list[str]:
    return [w["code"] for w in result.summary()["warnings"]]


def test_the_paper_demo_warns_of_its_large_deflection() -> None:
    """The paper's panel pressed 10 mm into its 10 mm wall: max |w| = t (the crown follows the punch, so the
    ratio is the indentation over the thickness, 1.0), beyond small deflections: warned with its code, on
    stderr, and first in the report. Measured stretch ratio 0.29 against the limit 0.09."""
    r = sc.solve(sc.load_case(PANEL, COARSE))
    m = range_measures(r.solution)
    assert m["deflection_ratio"] == pytest.approx(1.0, rel=0.01)
    assert m["stretch_ratio"] > STRETCH_RATIO_LIMIT
    assert "geometric_nonlinearity" in _codes(r)
    text = render(r.summary(), case=r.case)
    assert text.index("the deflection is large for a linear model") < text.index("<h2>Results</h2>")


def test_a_thick_wall_is_named_by_its_thickness_ratio() -> None:
    """shell.thickness = 0.3 on a = 1 (issue 23 ran it: 922 MN and 1.4e13 Pa without a word): t/a = 0.3,
    six times the thin-shell limit 1/20."""
    r = sc.solve(sc.load_case(PANEL, [*COARSE, "shell.thickness=0.3"]))
    assert range_measures(r.solution)["thickness_ratio"] == pytest.approx(0.3, rel=1e-12)
    warning = next(w for w in r.summary()["warnings"] if w["code"] == "thickness_ratio")
    assert "t/a = 0.3" in warning["message"] and "0.3 m" in warning["message"]
    # a wall at the limit is not warned about
    thin = sc.solve(sc.load_case(PANEL, [*COARSE, f"shell.thickness={THICKNESS_RATIO_LIMIT}"]))
    assert "thickness_ratio" not in _codes(thin)


def test_a_benign_case_has_no_warnings(tmp_path: Path) -> None:
    """The same panel pressed 1 mm (a tenth of its wall) with a yield stress above its stresses: nothing to say
    (stretch ratio about 0.03), no warning in the summary, on stderr or in the report."""
    case = sc.load_case(PANEL, [*COARSE, "punch.0.indentation=1e-3", "material.yield_stress=1e9"])
    r = sc.solve(case)
    assert range_measures(r.solution)["stretch_ratio"] < STRETCH_RATIO_LIMIT / 2
    assert r.summary()["warnings"] == []
    assert 'class="warnings"' not in render(r.summary(), case=r.case)


def test_the_rotation_is_the_closed_form_slope_of_the_pressure_boundary_layer() -> None:
    """A clamped pipe under internal pressure: its largest rotation is the largest |w'| of the closed-form
    boundary layer (tests/test_axisymmetric_pressure.py), 0.0755 rad at p = 1 (below 0.1 rad: no rotation warning)
    and 1.5 times that at p = 1.5 (warned, with its code)."""
    for p, warned in ((1.0, False), (1.5, True)):
        case = sc.load_case(ROOT / "examples" / "pressurized_cylinder.toml", [f"loads.normal={p}"])
        sh = case.shell
        exact = ClampedPressurizedCylinder(a=sh.radius, t=float(sh.thickness), H=sh.length / 2,
                                           E=sh.material.young, mu=sh.material.poisson, p=p)
        slope = float(np.max(np.abs(exact.w(np.linspace(-exact.H, exact.H, 20001), 1))))
        r = sc.solve(case)
        assert range_measures(r.solution)["rotation"] == pytest.approx(slope, rel=0.01)
        assert ("rotation" in _codes(r)) is warned and (slope > ROTATION_LIMIT) is warned


def test_summary_json_holds_coded_warnings_and_the_report_reads_old_ones(tmp_path: Path, capsys) -> None:
    """summary.json: each warning {"code", "message"}; stderr prints the message; a summary written before the
    codes (plain strings) still renders."""
    out = tmp_path / "out"
    assert main(["run", str(PANEL), *(a for s in COARSE for a in ("--set", s)), "-o", str(out), "--no-figures"]) == 0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["warnings"] and all(set(w) == {"code", "message"} for w in summary["warnings"])
    assert summary["warnings"][0]["message"] in capsys.readouterr().err
    old = {**summary, "warnings": ["an old plain warning"]}
    assert "<li>an old plain warning</li>" in render(old)


# -- item 4: the unit mistakes ----------------------------------------------------------------------------------
def test_angles_in_radians_name_shell_angle(tmp_path: Path, capsys) -> None:
    """angle = [1.047, 2.094] (60°, 120° in radians) with the punch above the crown: exit 2 naming shell.angle and
    the degrees meant, with or without the probe at 90° (before: exit 3 "empty admissible set", or a probe
    outside the shell)."""
    raw = read_case_dict(PANEL)
    raw["shell"]["angle"] = [1.047, 2.094]
    for probes in (raw.pop("probes"), []):
        data = {**raw, "probes": probes} if probes else raw
        with pytest.raises(InputError) as e:
            sc.case_from_dict(data)
        assert e.value.field == "shell.angle"
        assert "radians" in e.value.message and f"{math.degrees(1.047):.6g}" in e.value.message
    out = tmp_path / "out"
    assert main(["run", str(PANEL), "--set", "shell.angle=[1.047, 2.094]", "-o", str(out)]) == 2
    assert "shell.angle" in capsys.readouterr().err
    # a real narrow panel (the pipe's 2° sector) and a punch inside a small span are accepted
    sc.load_case(ROOT / "examples" / "pressurized_cylinder.toml")
    sc.load_case(PANEL, ["shell.angle=[89, 91]", "punch.0.zone.phi=[89.5, 90.5]"])


def test_a_radius_in_millimetres_in_an_si_case_gets_the_unit_hint(capsys) -> None:
    """radius = 1000 beside thickness 0.01 m and E = 2.1e11 Pa: the failure (the punch at 3.5 m never reaches a
    1000 m shell) ends with the unit hint; solved anyway (punch moved out), the hint is a coded warning."""
    with pytest.raises(InputError) as e:
        sc.solve(sc.load_case(PANEL, [*COARSE, "shell.radius=1000"]))
    assert e.value.field == "punch.0.direction"
    assert "shell.radius = 1000 m is 1e+05 x shell.thickness" in str(e.value) and "in m (1)" in str(e.value)
    r = sc.solve(sc.load_case(PANEL, [*COARSE, "shell.radius=1000", "punch.0.center=[0, 0, 1003.5]"]))
    assert "unit_scale" in _codes(r)
    # the paper's own lengths: no hint
    assert "unit_scale" not in _codes(sc.solve(sc.load_case(PANEL, [*COARSE, "punch.0.indentation=1e-3"])))


def test_steel_examples_give_a_yield_stress_and_the_band_clamp_no_wrong_advice() -> None:
    """Every example of steel (E = 2.1e11 Pa) but the paper's own panel sets material.yield_stress; the band
    clamp, a body that ends at the band's edges, no longer warns "widen punch.0.zone" (its sleeve was infinite
    and cut by a zone, so the pipe overlapped its imaginary continuation): its one warning is the yield (3.0 x
    S235 at the band edges)."""
    for path in sorted((ROOT / "examples").glob("*.toml")):
        raw = read_case_dict(path)
        if raw["shell"].get("young") == 2.1e11 and path.name != "paper_panel.toml":
            assert raw.get("material", {}).get("yield_stress"), path.name
    r = sc.solve(sc.load_case(ROOT / "examples" / "band_clamp.toml", ["mesh.nx=60", "mesh.nphi=12"]))
    assert _codes(r) == ["yield_stress"]
