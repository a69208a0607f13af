"""The run directory: summary.json, fields.vtu (meshio), results.npz, PNG figures, report.html.

One subprocess run of the Scordelis–Lo roof on 4 × 4 cells is checked file by file. The contact
outputs (arrays, pressure figures, report tables) are checked in-process by attaching a contact
object with prescribed per-vertex arrays to a solved Result: this tests the plumbing from
``result.contact`` to the files, not the contact mechanics.
"""

from __future__ import annotations

import base64
import html
import json
import os
import re
import subprocess
import sys
from pathlib import Path
from types import SimpleNamespace

import meshio
import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]
CASE = ROOT / "examples" / "scordelis_lo.toml"
SETS = ["mesh.nx=4", "mesh.nphi=4"]
ENV = {**os.environ, "OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1"}
PNG = b"\x89PNG\r\n\x1a\n"
VERTEX_ARRAYS = {"x", "phi_deg", "u", "v", "w", "displacement", "deformed", "N11", "N22", "N12", "M11", "M22", "M12"}


@pytest.fixture(scope="module")
def run_dir(tmp_path_factory) -> Path:
    cwd = tmp_path_factory.mktemp("run")
    args = [sys.executable, "-m", "shellcontact.cli", "run", str(CASE), "-o", "out"]
    for s in SETS:
        args += ["--set", s]
    r = subprocess.run(args, cwd=cwd, env=ENV, capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    return cwd / "out"


@pytest.fixture(scope="module")
def summary(run_dir: Path) -> dict:
    return json.loads((run_dir / "summary.json").read_text())


def test_run_directory_files(run_dir: Path) -> None:
    names = {p.name for p in run_dir.iterdir()}
    assert names == {"summary.json", "fields.vtu", "results.npz", "deflection.png", "von_mises.png", "deformed.png",
                     "sections.png", "report.html"}


def test_vtu_fields(run_dir: Path, summary: dict) -> None:
    m = meshio.read(run_dir / "fields.vtu")
    assert VERTEX_ARRAYS <= set(m.point_data)
    nv = summary["vertices"]
    assert m.points.shape == (nv, 3)
    tri = m.cells_dict["triangle"]
    assert tri.shape == (summary["elements"], 3)
    # points are the reference middle surface: on the cylinder of radius 25 around the x-axis
    assert np.allclose(np.hypot(m.points[:, 1], m.points[:, 2]), 25.0, rtol=1e-12)
    d = m.point_data
    assert d["displacement"].shape == (nv, 3) and d["deformed"].shape == (nv, 3)
    assert np.allclose(d["deformed"], m.points + d["displacement"], rtol=0, atol=1e-12)
    assert np.max(np.abs(d["w"])) == pytest.approx(summary["max_abs_w"], rel=1e-12)
    # the probe at (x, phi) = (0, 50 deg) is a vertex: its arrays match summary.json
    p = summary["probes"][0]
    i = int(np.argmin(np.hypot(d["x"] - p["x"], d["phi_deg"] - p["phi"])))
    assert (d["u"][i], d["v"][i], d["w"][i]) == pytest.approx((p["u"], p["v"], p["w"]), rel=1e-10, abs=1e-14)
    assert d["displacement"][i] == pytest.approx(p["displacement"], rel=1e-10, abs=1e-14)
    # the local-to-global rotation: radial component of the displacement is w
    phi = np.radians(d["phi_deg"])
    radial = d["displacement"][:, 1] * np.cos(phi) + d["displacement"][:, 2] * np.sin(phi)
    assert np.allclose(radial, d["w"], rtol=0, atol=1e-12 * np.max(np.abs(d["w"])))
    assert not any(k.startswith("contact") or k == "gap" for k in d)  # no contact, no contact arrays


def test_npz(run_dir: Path, summary: dict) -> None:
    z = np.load(run_dir / "results.npz")
    assert z["U"].shape == (summary["dofs"],)
    assert z["p"].shape == (2, summary["vertices"]) and z["t"].shape == (3, summary["elements"])
    assert float(z["radius"]) == 25.0
    assert np.max(np.abs(z["w"])) == pytest.approx(summary["max_abs_w"], rel=1e-12)


def test_pngs(run_dir: Path) -> None:
    for name in ("deflection.png", "deformed.png"):
        data = (run_dir / name).read_bytes()
        assert data.startswith(PNG) and len(data) > 5000, name


def test_report_contains_summary_numbers(run_dir: Path, summary: dict) -> None:
    text = (run_dir / "report.html").read_text()
    assert text.startswith("<!DOCTYPE html>") and text.rstrip().endswith("</html>")
    numbers = [
        summary["energy"],
        summary["max_abs_w"],
        summary["timings"]["total"],
        *(summary["probes"][0][k] for k in ("u", "v", "w")),
    ]
    for v in numbers:
        assert f">{v:.6g}<" in text, v  # in a table cell
    assert f">{summary['dofs']}<" in text
    # the verbatim summary.json is embedded
    pre = re.search(r"<pre>(.*?)</pre>", text, re.S)
    assert pre and json.loads(html.unescape(pre.group(1))) == summary
    # self-contained: figures are embedded, nothing is loaded from elsewhere
    imgs = re.findall(r'src="data:image/png;base64,([^"]+)"', text)
    assert len(imgs) == 4 and all(base64.b64decode(b).startswith(PNG) for b in imgs)
    assert "http://" not in text and "https://" not in text
    # inputs with the --set overrides marked
    assert "mesh.nx</span> (--set)" in text and "shell.radius" in text


# -- contact plumbing (prescribed arrays on a solved result) ------------------------------------------------
@pytest.fixture(scope="module")
def contact_result():
    from shellcontact import load_case, solve

    result = solve(load_case(CASE, SETS))
    x, s = result.solution.space.mesh.p
    phi = np.degrees(s / 25.0)
    cand = np.nonzero((x <= 12.5) & (phi >= 70.0))[0]  # candidate vertices
    r2 = (x[cand] / 12.5) ** 2 + ((phi[cand] - 90.0) / 20.0) ** 2
    pressure = np.maximum(0.0, 1.0 - r2) * 1e3
    active = pressure > 0
    contact = SimpleNamespace(
        vertices=cand,
        active=active,
        pressure=pressure,
        Lambda=pressure * 2.0,
        gap=lambda: np.where(active, 0.0, r2 - 1.0),  # a method, as on ContactSolution
    )
    result.contact = contact
    return result, cand, pressure


def test_contact_arrays_in_vtu_and_npz(tmp_path: Path, contact_result) -> None:
    from shellcontact.outputs.writers import write_npz, write_vtu

    result, cand, pressure = contact_result
    nv = result.solution.space.mesh.nvertices
    write_vtu(result, tmp_path / "f.vtu")
    d = meshio.read(tmp_path / "f.vtu").point_data
    status = np.full(nv, -1)
    status[cand] = pressure > 0
    assert np.array_equal(d["contact_status"], status)
    full = np.zeros(nv)
    full[cand] = pressure
    assert np.array_equal(d["contact_pressure"], full)
    assert np.isnan(d["gap"]).sum() == nv - cand.size  # gap unknown off the candidate set: NaN, not 0
    assert np.array_equal(d["contact_force"][cand], 2.0 * pressure)
    write_npz(result, tmp_path / "r.npz")
    z = np.load(tmp_path / "r.npz")
    assert np.array_equal(z["contact_pressure"], full) and np.array_equal(z["contact_vertices"], cand)


def test_contact_figures_and_report(tmp_path: Path, contact_result) -> None:
    from shellcontact.outputs.run import write_outputs

    result, _, _ = contact_result
    stub, result.contact = result.contact, None
    try:
        summary = result.summary()  # the shell part; contact entries are prescribed below
    finally:
        result.contact = stub
    summary["contact"] = [
        {
            "active_vertices": 7,
            "area": 12.3456789,
            "force": [0.0, 0.0, -4.5],
            "force_magnitude": 4.5,
            "total_normal_force": 4.75,
            "peak_pressure": 987.654321,
            "punch_travel": None,
        }
    ]
    summary["kkt"] = {
        "stationarity": 1.234e-13,
        "penetration": 0.0,
        "dual_feasibility": 0.0,
        "complementarity": 5.5e-15,
        "duality_gap": 2.2e-16,
    }
    written = write_outputs(result, tmp_path / "out", summary)
    for name in ("pressure.png", "pressure_profiles.png", "deformed.png"):
        assert name in written and written[name].read_bytes().startswith(PNG)
    text = (tmp_path / "out" / "report.html").read_text()
    for v in (12.3456789, 987.654321, 1.234e-13, 5.5e-15):
        assert f">{v:.6g}<" in text
    assert "KKT residuals" in text and "Contact" in text
    assert json.loads((tmp_path / "out" / "summary.json").read_text())["contact"][0]["area"] == 12.3456789


def test_pressure_lines_pass_through_peak(contact_result) -> None:
    from shellcontact.outputs.figures.contact import pressure_lines

    result, cand, pressure = contact_result
    lines = pressure_lines(result)
    assert lines is not None and len(lines) == 2
    peak = float(np.max(pressure))
    for _, (_, p) in lines.items():
        assert float(np.max(p)) == peak
    # chosen lines snap to the nearest mesh line: x = 5 → the vertex line x = 6.25 (4 cells on [0, 25])
    chosen = pressure_lines(result, x=5.0, phi=80.0)
    assert list(chosen) == ["x = 6.25", "φ = 80°"]
    coords, _ = chosen["x = 6.25"]
    assert np.all(coords >= 70.0)  # only the candidate zone (phi >= 70 deg)


def test_contact_vertex_arrays_gather_operator_rows() -> None:
    """Row values of a real contact operator (paper's panel) gathered on the mesh vertices keep
    their sums: Σ contact_force = Σ Λ, Σ contact_force_vector = the punch resultant Σ Λ_i ∇Z_i."""
    from shellcontact import load_case
    from shellcontact.analysis.discretization import case_mesh
    from shellcontact.contact.nodal_pressure import on_vertices
    from shellcontact.contact.operator import contact_operator
    from shellcontact.contact.punches import place_punches
    from shellcontact.outputs.fields import contact_vertex_arrays
    from shellcontact.shell.spaces import ShellSpace

    case = load_case(ROOT / "examples" / "paper_panel.toml", ["mesh.nx=6", "mesh.nphi=6", "mesh.grading={ratio=1.0}"])
    punches = place_punches(case.punches, case.shell)
    space = ShellSpace(case_mesh(case, punches))
    op = contact_operator(space, punches)
    rng = np.random.default_rng(1)
    Lam = np.where(rng.random(op.m) < 0.3, rng.random(op.m), 0.0)
    gap = rng.random(op.m)
    f = contact_vertex_arrays(op, Lam, lambda v: on_vertices(op, v), Lam > 0, gap)
    nv = space.mesh.nvertices
    assert all(f[k].shape[0] == nv for k in f)
    rows = op.vertex >= 0
    assert f["contact_force"].sum() == pytest.approx(Lam[rows].sum(), rel=1e-12)
    assert f["contact_force_vector"].sum(axis=0) == pytest.approx(op.resultant(np.where(rows, Lam, 0))[0], rel=1e-12)
    assert np.array_equal(np.sort(np.nonzero(f["contact_status"] >= 0)[0]), np.unique(op.vertex[rows]))
    assert np.array_equal(np.sort(np.nonzero(f["contact_status"] == 1)[0]), np.unique(op.vertex[rows & (Lam > 0)]))
    assert np.array_equal(np.isnan(f["gap"]), f["contact_status"] < 0)
    assert np.allclose(f["contact_pressure"], op.vertex_pressure(Lam))


def test_contact_vertex_forces_keep_the_seam_rows_on_a_full_cylinder() -> None:
    """On a full cylinder the band clamp's zone crosses the seam φ = α ≡ β. The per-vertex contact forces of the
    φ = α vertices (the φ = β copies repeat them) sum to every row's Λ and to the resultant Σ Λ_i ∇Z_i,
    edge-midpoint rows whose edge ends on a φ = β copy included (their half used to be overwritten by the twin's
    value: 3.3 % of the clamp force lost at 40 × 8, 253 379 of 262 117 N)."""
    from shellcontact import load_case, solve
    from shellcontact.outputs.fields import contact_vertex_fields

    case = load_case(ROOT / "examples" / "band_clamp.toml", ["mesh.nx=40", "mesh.nphi=8"])
    result = solve(case)
    c = result.contact
    f = contact_vertex_fields(result)
    keep = np.ones(result.solution.space.mesh.nvertices, bool)
    keep[c.operator.twins[0]] = False  # the φ = β copies
    assert (c.operator.vertex < 0).any() and c.Lambda[c.operator.vertex < 0].sum() > 0  # midpoint rows carry
    assert f["contact_force"][keep].sum() == pytest.approx(c.Lambda.sum(), rel=1e-12)
    resultant = (c.operator.grad * c.Lambda).sum(axis=1)
    scale = np.abs(c.operator.grad * c.Lambda).sum()
    assert np.abs(f["contact_force_vector"][keep].sum(axis=0) - resultant).max() <= 1e-12 * scale
    assert np.array_equal(f["contact_force"][c.operator.twins[0]], f["contact_force"][c.operator.twins[1]])


# -- a real contact run (the paper's panel, coarse) ---------------------------------------------------------
@pytest.fixture(scope="module")
def contact_run(tmp_path_factory) -> Path:
    cwd = tmp_path_factory.mktemp("contact")
    args = [sys.executable, "-m", "shellcontact.cli", "run", str(ROOT / "examples" / "paper_panel.toml"), "-o", "out"]
    args += ["--set", "mesh.nx=6", "--set", "mesh.nphi=6"]
    r = subprocess.run(args, cwd=cwd, env=ENV, capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    return cwd / "out"


def test_contact_run_outputs(contact_run: Path) -> None:
    s = json.loads((contact_run / "summary.json").read_text())
    c = s["contact"][0]
    for key in ("active_vertices", "area", "force", "force_magnitude", "total_normal_force", "peak_pressure"):
        assert key in c
    assert set(s["kkt"]) == {"stationarity", "penetration", "dual_feasibility", "complementarity", "duality_gap"}
    m = meshio.read(contact_run / "fields.vtu")
    d = m.point_data
    assert {"contact_status", "contact_pressure", "contact_force", "contact_force_vector", "gap"} <= set(d)
    assert int(np.sum(d["contact_status"] == 1)) == c["active_vertices"]
    assert float(np.max(d["contact_pressure"])) == pytest.approx(c["peak_pressure"], rel=1e-12)
    # Σ nodal force vectors = the punch's force on the shell
    assert d["contact_force_vector"].sum(axis=0) == pytest.approx(
        c["force"], rel=1e-10, abs=1e-8 * c["force_magnitude"]
    )
    assert np.all(np.isnan(d["gap"]) == (d["contact_status"] < 0))
    z = np.load(contact_run / "results.npz")
    assert np.array_equal(z["contact_status"], d["contact_status"])
    for name in ("pressure.png", "pressure_profiles.png"):
        assert (contact_run / name).read_bytes().startswith(PNG)
    text = (contact_run / "report.html").read_text()
    for v in (c["area"], c["force_magnitude"], c["peak_pressure"], *s["kkt"].values()):
        assert f">{v:.6g}<" in text, v
    assert len(re.findall(r'src="data:image/png;base64,', text)) == 6


def test_report_opens_with_the_case_and_a_headline_table_with_units(contact_run: Path) -> None:
    """The case in one paragraph (from the case file), then the headline results with their units."""
    s = json.loads((contact_run / "summary.json").read_text())
    text = (contact_run / "report.html").read_text()
    case = text[text.index("<h2>The case</h2>"):text.index("<h2>Results</h2>")]
    for words in ("cylindrical panel of radius 1 m", "φ from 60° to 120°", "thickness 0.01 m", "E = 2.1e+11 Pa",
                  "x_min, x_max, φ_min, φ_max clamped", "a sphere of radius 2 m", "pressed 0.01 m past first contact",
                  f"{s['elements']} triangles", "active-set method", "Units: N, m, Pa"):
        assert words in case, words
    start = text.index("<h2>Results</h2>")  # the warnings come first, before the case (issue 23)
    assert text.index("<h2>Warnings</h2>") < text.index("<h2>The case</h2>") < start
    head = text[start:text.index("<h2>", start + 1)]
    c = s["contact"][0]
    rows = {m.group(1): (m.group(2), m.group(3)) for m in re.finditer(
        r'<tr><td>([^<]+)</td><td class="num">([^<]+)</td><td class="unit">([^<]*)</td>', head)}
    assert rows["total normal force"] == (f"{c['total_normal_force']:.6g}", "N")
    assert rows["contact zone area"] == (f"{c['zone']['area']:.6g}", "m²")
    assert rows["peak nodal pressure (mesh-dependent)"] == (f"{c['peak_pressure']:.6g}", "Pa")
    if c["rim"]["kind"] == "point":  # at 6 x 6 the sphere's zone lies within the elements round one vertex
        assert rows["point force"] == (f"{c['rim']['point_forces'][0]['force']:.6g}", "N")
    else:
        assert rows["rim line force (mean)"] == (f"{c['rim']['mean_line_force']:.6g}", "N/m")
    assert rows["max deflection |w|"] == (f"{s['max_abs_w']:.6g}", "m")
    assert rows["max von Mises stress"] == (f"{max(v['von_mises_max'] for v in s['stresses'].values()):.6g}", "Pa")
    assert rows["equilibrium residual"][0] == f"{s['equilibrium']['relative_residual']:.6g}"
