"""The contact force's decomposition (summary ``contact.rim``, shellcontact.contact.rim): converges, and equals
closed forms.

For a Kirchhoff shell the contact multiplier is a measure: a line force along the zone's boundary, a pressure
inside, point forces where a zone is a point. The paper's panel (a sphere on a clamped panel) carries nearly all
of its load in a line force round the rim while the inside lifts off; the level line of the gap at the zone's
tolerance lies about 10 mm outside that line (a distance that converges: the gap grows like the squared distance
outside the contact), so the rim is the level line moved inward onto the forces. Checked here: the headlines
converge under uniform refinement (they change by ≤ 5 % from ``mesh.refine`` 1 to 2; the old definition, the
force within three element widths of the level line, fell from 685 to 438 kN/m there), the decomposition sums
to the total normal force, the plates on a pipe give the line load F/L (a closed form: equilibrium of the
plate), uniform along the line, and a band round a full pipe gives whole circles.
"""

from __future__ import annotations

import math
from pathlib import Path

import pytest

import shellcontact
from shellcontact.problem.case import case_from_dict, load_case

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"

#: the headline paths of the contact decomposition under ``contact.<k>`` (the point forces' total: none here)
HEADLINES = ("force_magnitude", "zone.area", "rim.length", "rim.force", "rim.mean_line_force", "rim.point_force")


def _get(entry: dict, path: str) -> float:
    for key in path.split("."):
        entry = entry[key]
    return float(entry)


@pytest.fixture(scope="module")
def panel_levels():
    """The paper's panel at ``mesh.refine`` 0, 1, 2 (18k, 71k, 281k dofs). Measured: refine 2 alone 35 CPU s,
    38 s wall, 2.7 GB peak (load 6); the three levels about 45 CPU s."""
    out = []
    for refine in (0, 1, 2):
        res = shellcontact.solve(load_case(EXAMPLES / "paper_panel.toml", [f"mesh.refine={refine}"]))
        out.append(res.summary()["contact"][0])
    return out


@pytest.mark.slow
def test_panel_headlines_converge_under_refinement(panel_levels):
    """Measured (refine 0, 1, 2): rim length 0.3452, 0.3429, 0.3428 m; mean line force 790.5, 788.7, 783.8 kN/m;
    rim force 272.9, 270.5, 268.7 kN; zone area 8.54, 8.32, 8.24e-3 m². Largest change from 1 to 2: 0.96 %
    (zone area; rim force 0.66 %, mean line force 0.62 %, rim length 0.04 %); bound 5 % (the issue's)."""
    print("\n headline                 refine 0      refine 1      refine 2    change 1→2")
    for path in HEADLINES:
        v = [_get(e, path) for e in panel_levels]
        change = abs(v[2] - v[1]) / max(abs(v[1]), 1e-300) if v[1] or v[2] else 0.0
        print(f" {path:22s} {v[0]:12.6g}  {v[1]:12.6g}  {v[2]:12.6g}   {change:.4f}")
        assert change <= 0.05, path
    # and the change falls from level to level (measured 0→1 vs 1→2: force 136 vs 37 N, zone area 2.1e-4 vs
    # 8.0e-5 m², rim length 2.3e-3 vs 1.4e-4 m, rim force 2 386 vs 1 786 N); not the mean line force (1.8 then
    # 4.9 kN/m: the rim force falls by what the faint contact inside the rim takes, test below)
    for path in ("force_magnitude", "zone.area", "rim.length", "rim.force"):
        v = [_get(e, path) for e in panel_levels]
        assert abs(v[2] - v[1]) < abs(v[1] - v[0]), path


@pytest.mark.slow
def test_panel_interior_pressure_is_labelled_mesh_dependent(panel_levels):
    """Inside the rim the shell grazes the sphere: the largest gap there is 8.8e-7, 7.3e-8, 8.1e-9 m at refine
    0, 1, 2 (measured), so the exact solution touches there and carries a faint pressure that only the finer
    meshes see, on scattered rows between rows that lift off. Measured: interior force 0, 2 250, 4 072 N (0, 0.8,
    1.5 % of the force); pressure where it carries 0, 5.50, 3.49 MPa (the mean over the zone's interior 0, 0.62,
    1.13 MPa). It changes by 37 % from refine 1 to 2, so it is not a headline: each level with an interior force
    says ``interior_resolved`` False (more than half of the carrying rows' area on the edges of that region) and
    the report puts "(mesh-dependent)" next to the number. Not in accuracy.HEADLINES either. At refine 3 (1.12M
    dofs, measured once, docs/outputs.md): interior force 8 354 N (3.1 %), pressure where it carries 3.45 MPa
    over a growing area, still not resolved."""
    from shellcontact.outputs.report import _headline

    for e in panel_levels[1:]:
        rim = e["rim"]
        assert rim["interior_force"] > 0 and rim["interior_force"] <= 0.05 * e["total_normal_force"]
        assert rim["interior_resolved"] is False
        assert "interior pressure (mesh-dependent)" in _headline({"contact": [e], "max_abs_w": 0.0})
    p1, p2 = (e["rim"]["interior_pressure"] for e in panel_levels[1:])
    assert abs(p2 / p1 - 1) > 0.05  # if it ever converges here, make it a headline


@pytest.mark.slow
def test_panel_decomposition(panel_levels):
    """The rim carries nearly all of the force (measured 100, 99.2, 98.5 %: the rest is a faint inner contact at
    the crown), rim + interior = total, the line force's samples lie on the rim inside the zone's extent, and the
    rim lies inside the level line of the gap (shorter than the ellipse through the zone's extents)."""
    for e in panel_levels:
        rim, zone = e["rim"], e["zone"]
        assert rim["kind"] == "area" and rim["lines"] == 1 and rim["samples"]
        assert rim["line_loads"]["force"] == 0.0  # no line contact on the panel
        assert rim["force"] + rim["interior_force"] + rim["point_force"] == pytest.approx(e["total_normal_force"],
                                                                                          rel=1e-12)
        assert rim["point_forces"] == []
        assert rim["force"] >= 0.95 * e["total_normal_force"]
        assert rim["mean_line_force"] == pytest.approx(rim["force"] / rim["length"], rel=1e-12)
        assert rim["peak_line_force"] >= rim["mean_line_force"] > 0
        A = 0.5 * (zone["x"][1] - zone["x"][0])
        B = 0.5 * math.radians(zone["phi"][1] - zone["phi"][0])  # radius 1 m
        ellipse = math.pi * (3 * (A + B) - math.sqrt((3 * A + B) * (A + 3 * B)))
        assert 0.8 * ellipse < rim["length"] < ellipse
        for s in rim["samples"]:
            assert zone["x"][0] <= s["x"] <= zone["x"][1]
            assert zone["phi"][0] <= s["phi"] <= zone["phi"][1]


def test_plates_on_a_pipe_carry_the_line_load_F_over_L():
    """examples/ring_stiffness.toml: each plate's force F = 200 N spreads over the pipe's length L = 0.3 m as a
    line load F/L = 666.7 N/m (both plates: the bottom one carries the same force). Measured: 666.667 N/m for
    both (to 4e-8: the line's length, from the thin zone's perimeter and area, is 0.3 m to 4e-8), samples uniform
    to 1e-4; bounds 1e-6 and 1e-3. The old rim counted both sides of the thin zone round the line: 331 N/m."""
    from shellcontact.outputs.figures.contact import plot_pressure_profiles, rim_line_profiles

    res = shellcontact.solve(load_case(EXAMPLES / "ring_stiffness.toml"))
    L = res.case.shell.length
    for e in res.summary()["contact"]:
        rim, loads = e["rim"], e["rim"]["line_loads"]
        expected = e["total_normal_force"] / L
        print(f"\n plate: line load {loads['mean_line_force']:.6g} N/m, F/L {expected:.6g} N/m, "
              f"samples {[round(s['line_force'], 2) for s in rim['samples']]}")
        assert rim["kind"] == "line" and rim["lines"] == 1
        assert loads["mean_line_force"] == pytest.approx(expected, rel=1e-6)
        assert loads["length"] == pytest.approx(L, rel=1e-6)
        assert rim["force"] == rim["length"] == rim["mean_line_force"] == 0.0  # no area rim: nothing mixed in
        values = [s["line_force"] for s in rim["samples"]]
        assert len(values) >= 3 and max(values) / min(values) - 1 <= 1e-3  # no vertex/midpoint zig-zag
        # all of it on the line: the interior is the round-off of total − line force (measured 2.8e-14 N of 200 N)
        assert abs(rim["interior_force"]) <= 1e-12 * e["total_normal_force"]
        # the figure draws the line load in N/m along the line's length, uniform, = F/L (not the nodal Λ/ω, which
        # zig-zags 88/176 kPa between vertex and midpoint weights); measured: 666.60–666.74 N/m over 0.3 m
        (arc, q), = rim_line_profiles(rim, res.case.shell.radius, 2 * math.pi * res.case.shell.radius)
        assert q == pytest.approx(expected, rel=1e-3)
        assert arc[0] > 0 and arc[-1] < L and arc[-1] - arc[0] >= 0.5 * L  # bin centres along the line
    fig = plot_pressure_profiles(res)
    assert len(fig.axes) == 1 and "N/m" in fig.axes[0].get_ylabel()


def test_band_rim_runs_round_the_pipe():
    """A band round a full pipe: each rim line is a whole circle (length 2πa), however the seam cuts it; in the
    profile (pressure_profiles.png) each line is its own closed curve, uniform round the pipe. Measured: 4 lines
    (the band's edges x = ±15 mm, 103 278 N each, and the edges of the full-contact strip round x = 0, 27 798 N
    each), each curve 2πa long, closed, its line force uniform to 4e-13 (edges) and 9.9e-4 (the strip's edges;
    bound 5e-3). Before: the four lines'
    samples joined into one curve 3.3 m long, open at the seam, with the inner lines at 31 219 and 24 377 N and
    the line force down to 18 kN/m at the seam (the smoothing cut there)."""
    from shellcontact.outputs.figures.contact import rim_line_profiles

    res = shellcontact.solve(load_case(EXAMPLES / "band_clamp.toml"))
    e = res.summary()["contact"][0]
    rim, a = e["rim"], res.case.shell.radius
    curves = rim_line_profiles(rim, a, 2 * math.pi * a)
    assert len(curves) == rim["lines"] == 4
    for (arc, q), line in zip(curves, rim["per_line"]):
        assert line["closed"] and q[0] == q[-1]
        assert arc[-1] == pytest.approx(2 * math.pi * a, rel=0.02)
        assert max(q) / min(q) - 1 <= 5e-3
    inner = sorted(line["force"] for line in rim["per_line"])[:2]
    assert inner[0] == pytest.approx(inner[1], rel=1e-6)  # mirror images (x → −x) of each other
    # pressure.png colours each line by its own samples (before: by the nearest sample of any line, so the band's
    # edges alternated between 164 and 44 kN/m round the pipe)
    from matplotlib.collections import LineCollection

    from shellcontact.outputs.figures.contact import plot_pressure

    lc = next(c for c in plot_pressure(res).axes[0].collections if isinstance(c, LineCollection))
    edge = max(line["mean_line_force"] for line in rim["per_line"])  # 164.4 kN/m at x = ±15 mm
    strip = min(line["mean_line_force"] for line in rim["per_line"])  # 44.2 kN/m round x = 0
    for segment, value in zip(lc.get_segments(), lc.get_array()):
        assert value == pytest.approx(edge if abs(segment[:, 0].mean()) > 0.01 else strip, rel=5e-3)
    circles = rim["length"] / (2 * math.pi * a)
    print(f"\n band clamp: rim {rim['length']:.6f} m = {circles:.5f} circles, {rim['lines']} lines, "
          f"rim force {rim['force']:.6g} of {e['total_normal_force']:.6g}")
    assert circles == pytest.approx(round(circles), abs=1e-3) and round(circles) >= 2
    assert rim["force"] + rim["line_loads"]["force"] + rim["interior_force"] == pytest.approx(
        e["total_normal_force"], rel=1e-12)


@pytest.fixture(scope="module")
def vessel():
    """examples/vessel_saddles.toml (80 x 96): 40 s wall at load 10."""
    return shellcontact.solve(load_case(EXAMPLES / "vessel_saddles.toml"))


def test_mirror_symmetric_saddles_get_the_same_numbers(vessel):
    """examples/vessel_saddles.toml: two saddles mirror images of each other (x → −x) on a mirror-symmetric mesh
    carry the same force, so every quantity of the decomposition must agree. Measured: relative differences
    ≤ 1e-8 (the solve's own asymmetry is 1e-10 in the force); bound 1e-6 (the issue asks for 1e-3). Before: rim
    line forces 2 413.54 vs 2 750.74 N/m, from the element picked for a point on a vertex (its width across the
    line) and from which of two segments a point nearest a corner of the outline took its normal."""
    left, right = vessel.summary()["contact"]
    assert left["total_normal_force"] == pytest.approx(right["total_normal_force"], rel=1e-9)
    for key in ("length", "force", "interior_force", "mean_line_force", "peak_line_force", "interior_area"):
        print(f"\n {key}: {left['rim'][key]:.10g} vs {right['rim'][key]:.10g}")
        assert left["rim"][key] == pytest.approx(right["rim"][key], rel=1e-6, abs=1e-9), key
    assert left["rim"]["lines"] == right["rim"]["lines"]


def test_vessel_saddles_bear_on_their_horns_as_line_loads_without_spikes(vessel):
    """A fixed saddle's outline is the boundary of where it carries (contact/fixed_outline.py), not the gap's level
    line at round-off. Each cradle bears on its two horns (a row of carrying points along φ = 210° and 330°, the
    body's edge) as line loads, and on the rim of the bottom region. Measured per saddle: horns 8 008 N each
    (23.6 % of the saddle's force) over the saddle's width 0.3 m (to 1e-15; the strip round the row reaches half
    a point spacing past the faces, 0.364 m, which the line's ends on the body's edges take off), no point forces;
    the area rim's line force max/mean 1.76 (smoothed over an element along the line; 2.13 before, 2.32 before the
    band was narrowed to the saddle's faces; bound 5).
    Before: the outline was noisy loops inside the cradle, max/mean 9.95 (a 30.7 kN/m spike), and treating the
    horn rows as alone in their outline made them 2 x 8 kN point forces."""
    for e in vessel.summary()["contact"]:
        rim = e["rim"]
        assert rim["point_forces"] == [] and rim["point_force"] == 0.0
        horns = [pl for pl in rim["per_line"] if pl["kind"] == "line"]
        assert len(horns) == 2
        for pl in horns:
            assert pl["length"] == pytest.approx(0.3, rel=1e-9)  # the saddle's width
            assert 0.15 * e["total_normal_force"] <= pl["force"] <= 0.35 * e["total_normal_force"]  # 23.6 %
        area = [q["line_force"] for q in rim["samples"] if rim["per_line"][q["line"]]["kind"] == "area"]
        ratio = max(area) / (sum(area) / len(area))
        print(f"\n area rims' line force max/mean {ratio:.3f}; horns {[round(pl['force'], 1) for pl in horns]} N")
        assert ratio <= 5.0


def test_sleeve_edge_line_force_equals_the_1d_free_boundary_solution():
    """A sleeve of finite length shrunk onto a cylinder (tests/test_finite_punch.py's case: a 1° panel with
    symmetry edges, an exact model of the axisymmetric state) carries a band of pressure from x = 0 to the free
    end x_t and a ring force at its edge x = C (the independent 1D oracle's exact free-boundary solution).
    The zone's outline runs along the panel's symmetry edges there, which carry no rim. Measured at nx = 80:
    the rim's force per unit circumferential length 0.806462 against the oracle's edge ring force 0.806428
    (4e-5), the rest (band and the ring at x_t, which lies inside the zone: the shell lifts off by less than
    the tolerance between x_t and C) 0.838936 against 0.838969 (4e-5); the mean line force 0.806462 (4e-5: the
    rim's length is the panel's width 0.017453 m; the two sides of the sliver of zone at the edge, joined only
    through the closing stretches along the symmetry edges, count once; before: 0.78202, 3.0 % below, and 5.9 %
    below when sides were measured apart the short way round the outline). Bounds 1e-3."""
    from oracles.axisym import Shell1D, sleeve_free_boundary

    a, t, e, mu, delta, c = 1.0, 0.02, 2.0e5, 0.3, 1e-3, 0.3
    rs = a + t / 2 - delta
    ref = sleeve_free_boundary(Shell1D(a, t, e, mu, 0.0, 1.0), rs, c)
    data = {
        "shell": {"radius": a, "length": 1.0, "x_start": 0.0, "angle": [0.0, 1.0], "thickness": t, "young": e,
                  "poisson": mu},
        "supports": {"x_min": "symmetry", "x_max": "clamped", "phi_min": "symmetry", "phi_max": "symmetry"},
        "mesh": {"nx": 80, "nphi": 2},
        "punch": [{"shape": "cylinder", "inverted": True, "center": [0.0, 0.0, 0.0], "axis": [1.0, 0.0, 0.0],
                   "radius": rs, "extent": {"x": [-c, c]}}],
    }
    res = shellcontact.solve(case_from_dict(data))
    rim = res.summary()["contact"][0]["rim"]
    width = a * math.radians(1.0)
    edge, rest = rim["force"] / width, rim["interior_force"] / width
    print(f"\n rim force / width {edge:.6f} (oracle ring at the edge {ref.ring_edge:.6f}); interior / width "
          f"{rest:.6f} (oracle {ref.force_per_length - ref.ring_edge:.6f}); mean line force "
          f"{rim['mean_line_force']:.6f}, rim length {rim['length']:.6f} m (panel width {width:.6f} m)")
    assert edge == pytest.approx(ref.ring_edge, rel=1e-3)
    assert rest == pytest.approx(ref.force_per_length - ref.ring_edge, rel=1e-3)
    assert rim["mean_line_force"] == pytest.approx(ref.ring_edge, rel=1e-3)
    assert rim["length"] == pytest.approx(width, rel=1e-3)
    assert rim["lines"] == 1 and rim["kind"] == "area"


@pytest.fixture(scope="module")
def coarse_vessel():
    """examples/vessel_saddles.toml at 48 x 48 (a mirror-symmetric mesh; each saddle two elements wide)."""
    return shellcontact.solve(load_case(EXAMPLES / "vessel_saddles.toml", ["mesh.nx=48", "mesh.nphi=48"]))


def test_saddle_interior_force_is_not_swallowed_by_the_rim(coarse_vessel):
    """A saddle's rows between its faces carry a distributed pressure (nodal 5–40 kPa at 80 x 96), not a line
    force. Before, the rim's band (three element widths from the outline) covered the whole two-element-wide
    saddle: interior force 0 N over 0.110 m², reported as resolved. Now the band is at most 0.4 of the depth to the
    zone's middle and, as that is most of the band, the interior is flagged unresolved on this mesh. Measured per
    saddle: area rim 13 006 N, line loads (horns) 2 x 8 022 N, interior 4 851 N (1 827 N of it next to idle
    rows), 25.7 kPa over the 0.118 m² that carries; checked: the interior's share of the force is what the
    carrying rows off the rim and horns hold
    (> 0) and the parts sum to the total normal force (conservation, to round-off). The mirror saddles:
    ``test_mirror_saddles_agree_to_round_off``."""
    left, right = coarse_vessel.summary()["contact"]
    for e in (left, right):
        rim = e["rim"]
        parts = rim["force"] + rim["line_loads"]["force"] + rim["interior_force"] + rim["point_force"]
        assert parts == pytest.approx(e["total_normal_force"], rel=1e-12)
        assert rim["interior_force"] > 0.05 * e["total_normal_force"] or not rim["interior_resolved"]
        assert rim["interior_force"] > 0.0 and rim["interior_pressure"] > 0.0  # measured 4 851 N, 25.7 kPa
        assert not rim["interior_resolved"]  # two elements across: the band holds interior pressure


def test_mirror_saddles_agree_to_round_off(coarse_vessel):
    """The saddles at x = ±3.5 m are mirror images (x → −x) on a mirror-symmetric mesh, and the gauge of the free
    rigid motions lies on the mirror plane x = 0 (``supports.gauge_dofs``), so the solution is mirror-symmetric:
    its yaw and pitch (rotations about z and y, odd under the mirror) vanish and every number of the two
    saddles' decompositions agrees. Measured: relative differences ≤ 1.9e-12 (rim force 1.3e-12, interior force
    5.7e-13, line loads 1.9e-12), yaw 3.5e-15 rad; bound 1e-11. Before, the gauge at the end x = −5 m (its
    first vertices in mesh order) shifted the solution by the rigid motions' interpolation error, O(h⁴):
    rim force 5.5e-7, interior force 1.3e-6 (6 mN), line loads 6.3e-8 apart, a yaw of 2.2e-7 rad; the same
    gauge mirrored by hand swapped the two saddles' numbers exactly."""
    left, right = coarse_vessel.summary()["contact"]
    pairs = {key: (left["rim"][key], right["rim"][key])
             for key in ("force", "interior_force", "length", "mean_line_force", "interior_area")}
    pairs["line loads' force"] = (left["rim"]["line_loads"]["force"], right["rim"]["line_loads"]["force"])
    pairs["line loads' mean"] = (left["rim"]["line_loads"]["mean_line_force"],
                                 right["rim"]["line_loads"]["mean_line_force"])
    pairs["total normal force"] = (left["total_normal_force"], right["total_normal_force"])
    for key, (a, b) in pairs.items():
        print(f"\n {key}: {a:.15g} vs {b:.15g} ({abs(a - b) / abs(a):.2g})")
        assert a == pytest.approx(b, rel=1e-11), key
    rigid = coarse_vessel.summary()["rigid_motion"]
    sag = abs(rigid["translation"][2])  # 0.59 mm: the vessel settles into its saddles
    radius = coarse_vessel.case.shell.radius
    for k in (1, 2):  # rotations about y and z, by the radius: measured 5e-16, 3.5e-15 m against 5.9e-4 m
        assert abs(rigid["rotation"][k]) * radius <= 1e-11 * sag, rigid


def test_saddle_horn_line_loads_are_sampled_along_their_length(coarse_vessel):
    """Each horn is a line load (8 022 N over the saddle's width 0.3 m, 26.74 kN/m). Before: one sample at
    15.05 kN/m (below the line's own mean, so ``peak_line_force`` was too); now three bin centres over its
    length, whose mean is the line's mean line force (conservation: the samples integrate to its force),
    within its length, and the peak is at least every line's mean."""
    for e in coarse_vessel.summary()["contact"]:
        rim = e["rim"]
        for i, pl in enumerate(rim["per_line"]):
            if pl["kind"] != "line":
                continue
            own = [q for q in rim["samples"] if q["line"] == i]
            assert len(own) >= 3
            mean = sum(q["line_force"] for q in own) / len(own)
            assert mean == pytest.approx(pl["mean_line_force"], rel=1e-3)
            xs = [q["x"] for q in own]
            assert max(xs) - min(xs) >= 0.5 * pl["length"] and max(xs) - min(xs) < pl["length"]
            assert rim["line_loads"]["peak_line_force"] >= pl["mean_line_force"]


def test_force_at_scattered_points_is_kept_and_flagged(capsys) -> None:
    """A 30 mm thick vessel on its saddles at 40 × 48: each saddle carries 48 kN on six rows round which no zone
    is drawn (zone area 0) and which no point force holds. The decomposition used to be missing (rim None: the
    48 kN in no headline); now it is kept as interior force, `kind` "unresolved", flagged, and the console says
    to refine. Checked against the total normal force (conservation)."""
    from shellcontact.console import Console, print_summary

    case = load_case(EXAMPLES / "vessel_saddles.toml",
                     ["shell.thickness=0.03", "mesh.nx=40", "mesh.nphi=48"])
    result = shellcontact.solve(case)
    entries = result.contact.summary()
    for e in entries:
        rim = e["rim"]
        assert rim["kind"] == "unresolved" and rim["interior_resolved"] is False
        parts = rim["force"] + rim["line_loads"]["force"] + rim["interior_force"] + rim["point_force"]
        assert parts == pytest.approx(e["total_normal_force"], rel=1e-12) and e["total_normal_force"] > 4e4
    print_summary(Console(), {"dofs": 1, "elements": 1, "energy": 0.0, "max_abs_w": 0.0, "contact": entries})
    assert capsys.readouterr().out.count("at scattered points no zone resolves (refine)") == 2
