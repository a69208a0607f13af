"""``[units] system``: labels only, never a conversion; summary.json's ``units`` map covers every numeric key.

The independent check: the same cylinder written in N, m, Pa and in N, mm, MPa gives the same numbers
scaled by the unit factors (lengths × 1e3, stresses × 1e-6, energy × 1e3), so no constant inside the
package carries a hidden unit.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from shellcontact import units
from shellcontact.analysis.pipeline import solve
from shellcontact.errors import InputError
from shellcontact.problem.case import case_from_dict, load_case, read_case_dict

ROOT = Path(__file__).resolve().parents[1]
CYLINDER = ROOT / "examples" / "pressurized_cylinder.toml"
ENV = {**os.environ, "OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1"}


def test_system_parsed_with_default_and_refused_by_name() -> None:
    data = read_case_dict(CYLINDER)
    assert case_from_dict(data).units == "SI"
    assert case_from_dict({**data, "units": {"system": "mm"}}).units == "mm"
    with pytest.raises(InputError) as exc:
        case_from_dict({**data, "units": {"system": "inch"}})
    assert exc.value.field == "units.system" and "SI" in exc.value.message and "none" in exc.value.message
    with pytest.raises(InputError) as exc:
        case_from_dict({**data, "units": {"sytem": "mm"}})
    assert exc.value.field == "units.sytem" and "system" in exc.value.message


def test_labels_per_system() -> None:
    assert units.bracket("pressure", "SI") == " [Pa]" and units.bracket("pressure", "mm") == " [MPa]"
    assert units.with_unit("2", "length", "mm") == "2 mm"
    assert units.bracket("length", "none") == "" and units.with_unit("2", "length", "none") == "2"
    assert units.bracket("strain", "SI") == "" and units.label("angle", "none") == "deg"
    for system in units.SYSTEMS.values():
        assert set(system) == set(units.KINDS)


def _mm(data: dict) -> dict:
    """The case file of ``data`` (N, m, Pa) rewritten in N, mm, MPa."""
    sh, loads = dict(data["shell"]), dict(data["loads"])
    for k in ("radius", "length", "thickness"):
        sh[k] *= 1e3
    sh["young"] *= 1e-6
    loads["normal"] *= 1e-6
    grading = data["mesh"]["grading"]
    mesh = {**data["mesh"], "grading": {**grading, "x": [x * 1e3 for x in grading["x"]]}}
    probes = [{**p, "x": p["x"] * 1e3} for p in data["probes"]]
    return {**data, "shell": sh, "loads": loads, "mesh": mesh, "probes": probes, "units": {"system": "mm"}}


def test_same_case_in_mm_gives_the_scaled_numbers_and_labels() -> None:
    data = read_case_dict(CYLINDER)
    si = solve(case_from_dict(data)).summary()
    mm = solve(case_from_dict(_mm(data))).summary()
    assert mm["max_abs_w"] == pytest.approx(1e3 * si["max_abs_w"], rel=1e-9)
    assert mm["energy"] == pytest.approx(1e3 * si["energy"], rel=1e-9)  # J = N·m → N·mm
    for a, b in zip(si["probes"], mm["probes"]):
        assert b["w"] == pytest.approx(1e3 * a["w"], rel=1e-9)
        assert b["stress"]["middle"]["s22"] == pytest.approx(1e-6 * a["stress"]["middle"]["s22"], rel=1e-9)
    for surface in ("bottom", "middle", "top"):
        assert mm["stresses"][surface]["von_mises_max"] == pytest.approx(
            1e-6 * si["stresses"][surface]["von_mises_max"], rel=1e-9)
    assert (si["unit_system"], mm["unit_system"]) == ("SI", "mm")
    assert si["units"]["max_abs_w"] == "m" and mm["units"]["max_abs_w"] == "mm"
    assert si["units"]["stresses.top.von_mises_max"] == "Pa" and mm["units"]["stresses.top.von_mises_max"] == "MPa"
    assert mm["units"]["energy"] == "N·mm" and mm["units"]["probes.phi"] == "deg"
    assert mm["units"]["reactions.x_min.moment"] == "N·mm" and mm["units"]["timings.total"] == "s"
    assert "dofs" not in mm["units"] and "probes.strain.top.e11" in mm["units"]


def test_every_numeric_summary_key_is_classified() -> None:
    """A new summary key must be given its kind in units.SUMMARY_KINDS (or the map would silently lack it)."""
    for case in (load_case(ROOT / "examples" / "paper_panel.toml", ["mesh.nx=8", "mesh.nphi=8"]),
                 load_case(ROOT / "examples" / "band_clamp.toml", ["mesh.nx=8", "mesh.nphi=12"]),
                 load_case(CYLINDER, ['units.system="none"'])):
        s = solve(case).summary()
        for path in units.numeric_paths(s):
            if not path.startswith("units."):
                kind = units.kind_of(path)  # KeyError names an unclassified key
                assert (path in s["units"]) == (kind is not None), path
        if case.units == "none":
            assert s["units"]["max_abs_w"] == "length" and s["units"]["stresses.top.von_mises_max"] == "force/length²"
        else:
            assert s["units"]["contact.zone.area"] == "m²" and s["units"]["contact.peak_pressure"] == "Pa"
            assert s["units"]["contact.zone.phi"] == "deg" and s["units"]["kkt.penetration"] == "m"


def test_console_figures_carry_the_case_units(tmp_path: Path) -> None:
    def run(system: str) -> str:
        r = subprocess.run([sys.executable, "-m", "shellcontact.cli", "run", str(CYLINDER), "-o", system,
                            "--no-figures", "--no-report", "--set", f'units.system="{system}"'],
                           cwd=tmp_path, env=ENV, capture_output=True, text=True, timeout=300)
        assert r.returncode == 0, r.stderr
        return r.stdout

    mm, none = run("mm"), run("none")
    assert "energy 0" in mm and " N·mm " in mm
    line = next(s for s in mm.splitlines() if s.startswith("dofs"))
    assert line.endswith(" mm") and "N·mm" in line
    assert "max von Mises" in mm and " MPa (" in mm and "forces [N]" in mm
    assert " mm " not in none and " MPa" not in none and " m " not in none
    assert json.loads((tmp_path / "none" / "summary.json").read_text())["unit_system"] == "none"
