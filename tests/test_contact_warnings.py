"""The two contact warnings made to fire (docs/outputs.md, docs/solvers.md): contact beyond a punch's candidate
zone, and penetration between the constraint points with ``solver.contact_points = "vertices"``. Each reaches
stderr, summary.json ``warnings`` and the warnings box at the top of report.html, and the penetration it reports
is checked against the exact geometry of the deformed shell and the rigid punch (a sphere; a coaxial bore),
not against the linearised gap that produced it. A control run of the same case without the defect is silent."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
from inprocess import run_cli

import shellcontact as sc
from shellcontact.demo import demo_case_path

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
PANEL = ["--set", "mesh.nx=8", "--set", "mesh.nphi=8", "--set", "punch.0.indentation=0.03"]
NARROW = ["--set", "punch.0.zone={x=[-0.05,0.05],phi=[88.0,92.0]}"]  # the contact reaches |x| ≈ 0.1 m
# the band clamp with a finite body (extent = the band), so nothing is reported outside its zone
BAND = ["--set", "mesh.nx=60", "--set", "mesh.nphi=12", "--set", "punch.0.extent={x=[-0.015,0.015]}"]
SPHERE_RADIUS, BORE = 2.0, 0.1008  # the demo's sphere, the band's bore (m)


def _outer_points(sol, x: np.ndarray, phi: np.ndarray) -> np.ndarray:
    """Deformed outer surface (the contact side) at (x, φ): Φ + ζ n + the Kirchhoff displacement, ζ = t/2."""
    zeta = 0.5 * float(sol.shell.thickness)
    return sol.shell.point(x, phi, zeta) + sol.displacement(x, phi, zeta)


def _run(tmp_path: Path, name: str, case: Path, *sets: str) -> tuple[str, dict, str, sc.Result]:
    code, stderr = run_cli(["run", str(case), *sets, "--no-figures", "-o", str(tmp_path / name)])
    assert code == 0, stderr
    summary = json.loads((tmp_path / name / "summary.json").read_text())
    report = (tmp_path / name / "report.html").read_text()
    start = report.find('class="warnings"')
    box = report[start:report.index("<h2>Details</h2>")] if start >= 0 else ""
    overrides = [s for s in sets if s != "--set"]
    return stderr, summary, box, sc.solve(sc.load_case(case, overrides))


def test_contact_beyond_the_candidate_zone_is_warned(tmp_path: Path) -> None:
    """The demo panel pressed 30 mm with a zone far narrower than its contact: warned by name, with the
    penetration at the vertices outside the zone, 7.0775e-3 m (measured), equal to the exact-geometry overlap of
    the deformed outer surface with the sphere, 2 − |X − c| = 7.0774e-3 m, to 1e-4 (measured 1.1e-5: the gap is
    linearised). With the case's own zone (x ± 0.2 m, φ 78–102°) the outside vertices keep 7.6 mm clear."""
    stderr, s, box, res = _run(tmp_path, "narrow", demo_case_path(), *PANEL, *NARROW)
    pen = s["contact"][0]["penetration_outside_zone"]
    message = f"punch.0: the shell penetrates the punch by {pen:.3e} m outside its candidate zone; widen punch.0.zone"
    # the case also leaves the linear model's range (30 mm into a 10 mm wall: geometric_nonlinearity), so the
    # contact warning is picked by its code
    assert [w["message"] for w in s["warnings"] if w["code"] == "contact_outside_zone"] == [message]
    assert stderr.count(message) == 1
    assert message in box
    sol, punch = res.solution, res.contact.operator.punches[0]
    x, phi = sol.space.mesh.p[0], sol.space.mesh.p[1] / sol.shell.radius
    overlap = SPHERE_RADIUS - np.linalg.norm(_outer_points(sol, x, phi) - punch.center[:, None], axis=0)
    outside = ~punch.zone.contains(x, phi, tol=1e-12)
    assert pen > 1e-3  # the zone is far too narrow: millimetres, not round-off
    assert abs(pen - overlap[outside].max()) <= 1e-4 * pen
    # the control: the case's own zone; nothing penetrates outside it
    stderr, s, box, res = _run(tmp_path, "wide", demo_case_path(), *PANEL)
    assert not {"contact_outside_zone", "contact_between_points"} & {w["code"] for w in s["warnings"]}
    assert "candidate zone" not in stderr and "candidate zone" not in box
    assert s["contact"][0]["penetration_outside_zone"] == 0.0


def test_penetration_between_vertex_constraints_is_warned(tmp_path: Path) -> None:
    """The band clamp (0.2 mm interference) constrained at the vertices only, 12 around the ring: the pipe
    bulges into the band between them by 2.0757e-4 m (measured; 104 % of the interference, beyond the 1 %
    threshold), the overlap of the deformed outer surface's edge midpoints with the bore (radius − 0.1008 m)
    to 1e-6 (measured: round-off), while the constrained vertices touch (1e-17 m). With the edge midpoints
    constrained too (the default) no warning, and no midpoint penetrates more than 1e-9 of the interference."""
    stderr, s, box, res = _run(tmp_path, "vertices", EXAMPLES / "band_clamp.toml", *BAND,
                               "--set", 'solver.contact_points="vertices"')
    pen = s["contact"][0]["penetration_between_points"]
    message = f"punch.0: the shell penetrates the punch by {pen:.3e} m between the constraint points"
    between = [w["message"] for w in s["warnings"] if w["code"] == "contact_between_points"]
    assert len(between) == 1 and between[0].startswith(message)  # (beside the steel band's yield_stress warning)
    assert "set solver.contact_points = 'vertices+midpoints' or refine" in between[0]
    assert stderr.count(message) == 1 and message in box

    def overlaps(sol) -> tuple[np.ndarray, np.ndarray]:  # (edge midpoints, vertices) in the band
        m = sol.space.mesh
        f = m.mesh.facets
        mid = 0.5 * (m.p[:, f[0]] + m.p[:, f[1]])
        out = []
        for x, s_ in (mid, m.p):
            band = np.abs(x) <= 0.015 + 1e-12
            X = _outer_points(sol, x[band], s_[band] / sol.shell.radius)
            out.append(np.hypot(X[1], X[2]) - BORE)
        return out[0], out[1]

    mid, vertices = overlaps(res.solution)
    assert pen > 0.5 * 2e-4  # most of the interference
    assert abs(pen - mid.max()) <= 1e-6 * pen
    assert vertices.max() <= 1e-9 * pen
    # the control: the default contact points
    stderr, s, box, res = _run(tmp_path, "midpoints", EXAMPLES / "band_clamp.toml", *BAND)
    assert not {"contact_outside_zone", "contact_between_points"} & {w["code"] for w in s["warnings"]}
    assert "between the constraint points" not in stderr and "between the constraint points" not in box
    assert s["contact"][0]["penetration_between_points"] == 0.0
    assert overlaps(res.solution)[0].max() <= 1e-9 * 2e-4
