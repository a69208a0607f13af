"""The rim's line force (summary ``contact.rim``, shellcontact.rim): converges on three meshes.

The paper's panel (a sphere on a clamped panel): a Kirchhoff shell carries the load in a line force along the
rim of the contact zone. The rim is the level line of the gap at the zone's tolerance, so its length and the
mean line force (rim force / length) converge with the displacement field, unlike the active-vertex outline
(0.89/0.88/1.21 m on three meshes in an earlier prototype). Checked: the length converges and agrees with the
perimeter of the ellipse with the zone's extents (Ramanujan's formula: the contact patch of a sphere on a
cylinder is close to an ellipse), the rim carries the whole force (the interior lifts off), rim + interior
force is the total normal force, and on a band round a full pipe the rim lines run round the circumference
(the seam does not cut them).
"""

from __future__ import annotations

import math
from pathlib import Path

import pytest

import shellcontact
from shellcontact.case import load_case

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


@pytest.fixture(scope="module")
def panel_rims():
    out = []
    for n in (16, 32, 64):
        res = shellcontact.solve(load_case(EXAMPLES / "paper_panel.toml", [f"mesh.nx={n}", f"mesh.nphi={n}"]))
        entry = res.summary()["contact"][0]
        out.append((n, entry, res.case.shell.radius))
    return out


def test_rim_converges_on_three_meshes(panel_rims):
    lengths = [e["rim"]["length"] for _, e, _ in panel_rims]
    means = [e["rim"]["mean_line_force"] for _, e, _ in panel_rims]
    print("\n mesh  rim length [m]  mean line force [N/m]  rim force / total")
    for (n, e, _), length, mean in zip(panel_rims, lengths, means):
        print(f" {n:4d}  {length:.5f}        {mean:.6g}              {e['rim']['force'] / e['total_normal_force']:.4f}")
    # the differences between levels shrink, and the two finer meshes agree to 1 %
    assert abs(lengths[2] - lengths[1]) < abs(lengths[1] - lengths[0])
    assert abs(lengths[2] / lengths[1] - 1) <= 0.01
    assert abs(means[2] / means[1] - 1) <= 0.01
    for _, e, a in panel_rims[1:]:
        rim = e["rim"]
        # the interior of the zone lifts off: the rim carries (nearly) all of the force
        assert rim["force"] >= 0.99 * e["total_normal_force"]
        assert rim["peak_line_force"] >= rim["mean_line_force"] > 0
        # the patch is close to an ellipse with the zone's semi-axes (in x and in s = aφ)
        A = 0.5 * (e["zone"]["x"][1] - e["zone"]["x"][0])
        B = 0.5 * a * math.radians(e["zone"]["phi"][1] - e["zone"]["phi"][0])
        ellipse = math.pi * (3 * (A + B) - math.sqrt((3 * A + B) * (A + 3 * B)))
        assert rim["length"] == pytest.approx(ellipse, rel=0.02)
        for s in rim["samples"]:  # sampled on the rim: at the edge of the zone's extent, never beyond it
            assert e["zone"]["x"][0] - 1e-3 <= s["x"] <= e["zone"]["x"][1] + 1e-3
            assert e["zone"]["phi"][0] - 0.1 <= s["phi"] <= e["zone"]["phi"][1] + 0.1
    for _, e, _ in panel_rims:
        rim = e["rim"]
        assert rim["force"] + rim["interior_force"] == pytest.approx(e["total_normal_force"], rel=1e-12)
        assert rim["mean_line_force"] == pytest.approx(rim["force"] / rim["length"], rel=1e-12)
        assert rim["lines"] == 1 and rim["samples"]


def test_band_rim_runs_round_the_pipe():
    """A band round a full pipe: each rim line is a whole circle (length 2πa), however the seam cuts it."""
    res = shellcontact.solve(load_case(EXAMPLES / "band_clamp.toml"))
    e = res.summary()["contact"][0]
    rim, a = e["rim"], res.case.shell.radius
    circles = rim["length"] / (2 * math.pi * a)
    print(f"\n band clamp: rim {rim['length']:.6f} m = {circles:.5f} circles, {rim['lines']} lines")
    assert circles == pytest.approx(round(circles), abs=1e-3) and round(circles) >= 2
    assert rim["force"] + rim["interior_force"] == pytest.approx(e["total_normal_force"], rel=1e-12)
