"""The run figures: units on every axis and colour bar, tick labels that never overlap, the contact boundary
on the maps, and a von Mises map of the worse surface whose maximum is the summary's."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from matplotlib.backends.backend_agg import FigureCanvasAgg

from shellcontact.analysis.pipeline import solve
from shellcontact.outputs import figures as plots
from shellcontact.problem.case import case_from_dict, key_kind, load_case

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def panel():
    """The paper's panel, coarse, written in N, mm, MPa (yield stress inside the stress range). 8 x 8: at 6 x 6
    the whole contact lies in the elements round one vertex, a point force, without a rim's line-force axes."""
    case = load_case(ROOT / "examples" / "paper_panel.toml", [
        "mesh.nx=8", "mesh.nphi=8", 'units.system="mm"', "material.yield_stress=5e8"])
    return solve(case)


def _figures(result) -> dict:
    return {"deflection": plots.plot_deflection(result), "von_mises": plots.plot_von_mises(result),
            "deformed": plots.plot_deformed(result), "sections": plots.plot_sections(result),
            "pressure": plots.plot_pressure(result),
            "profiles": plots.plot_pressure_profiles(result)}


def _overlaps(boxes) -> list:
    return [(a, b) for i, a in enumerate(boxes) for b in boxes[i + 1:] if a.overlaps(b)]


def test_units_on_every_axis_and_colour_bar(panel) -> None:
    """Every axis that shows numbers (visible tick labels, after drawing) is labelled, with the unit of the case's
    system; only an axis without numbers (a colour bar's short side) may go unlabelled. 25 labelled axes in the
    six figures (24 since deformed.png leaves out a nearly empty pressure view)."""
    labelled = 0
    for name, fig in _figures(panel).items():
        FigureCanvasAgg(fig).draw()  # tick labels get their text when drawn
        for i, ax in enumerate(fig.axes):
            for axis in (ax.xaxis, ax.yaxis) + ((ax.zaxis,) if hasattr(ax, "zaxis") else ()):
                numbers = [t.get_text() for t in axis.get_ticklabels() if t.get_visible() and t.get_text()]
                text = axis.get_label_text()
                if not numbers:
                    continue
                assert text, f"{name}: axes {i} shows {numbers[:3]} … with no label"
                assert text.endswith(("[mm]", "[MPa]", "[deg]", "[N/mm]")), (name, text)
                labelled += 1
    assert labelled >= 24  # (deformed.png's pressure view is left out when contact covers < 10 % of the vertices)
    # the system's labels, not SI ones, and the titles' figures too
    fig = plots.plot_von_mises(panel)
    assert "MPa" in fig.axes[0].get_title() and "mm" in fig.axes[0].get_title()


def test_tick_labels_never_overlap(panel) -> None:
    for name, fig in _figures(panel).items():
        canvas = FigureCanvasAgg(fig)
        canvas.draw()
        renderer = canvas.get_renderer()
        for ax in fig.axes:
            for axis in (ax.xaxis, ax.yaxis):
                boxes = [t.get_window_extent(renderer) for t in axis.get_ticklabels()
                         if t.get_visible() and t.get_text()]
                assert not _overlaps(boxes), (name, [t.get_text() for t in axis.get_ticklabels()])


def test_maps_show_the_contact_boundary_and_von_mises_of_the_worse_surface(panel) -> None:
    s = panel.summary()
    for fig in (plots.plot_deflection(panel), plots.plot_von_mises(panel), plots.plot_pressure(panel)):
        legend = fig.axes[0].get_legend()
        assert legend is not None and "contact boundary" in [t.get_text() for t in legend.get_texts()]
    worst = max(s["stresses"], key=lambda k: s["stresses"][k]["von_mises_max"])
    ax = plots.plot_von_mises(panel).axes[0]
    assert f"({worst} surface)" in ax.get_title()
    assert f"{s['stresses'][worst]['von_mises_max']:.4g}" in ax.get_title()
    assert f"utilisation {s['stresses'][worst]['utilisation_max']:.4g}" in ax.get_title()
    labels = [t.get_text() for t in ax.get_legend().get_texts()]
    assert "yield stress" in labels and "maximum" in labels
    assert np.isfinite(s["stresses"][worst]["von_mises_max"])


def test_sections_pass_through_the_largest_deflection(panel) -> None:
    """The generator through the point of largest |w| reaches the summary's max |w| (vertex values), and the
    ring section states its magnification."""
    fig = plots.plot_sections(panel)
    ring, gen = fig.axes[:2]
    w = gen.get_lines()[0].get_ydata()
    assert float(np.max(np.abs(w))) == pytest.approx(panel.summary()["max_abs_w"], rel=1e-3)
    assert f"× {plots.exaggeration(panel):g}" in " ".join(t.get_text() for t in ring.get_legend().get_texts())


def test_one_colour_scale_per_quantity(panel) -> None:
    """w and the contact pressure have the same colour range on the maps and on the 3D views. The 3D view shows
    the pressure only where the contact covers at least a tenth of the shell's vertices (the panel's 2 % was a
    speck on an otherwise grey panel): here a sleeve gripping the whole of a long pipe
    (the band clamp without its extent)."""
    from shellcontact.problem.case import read_case_dict

    bars = [ax for ax in plots.plot_deformed(panel).axes if ax.name != "3d"]
    assert len(bars) == 1
    raw = read_case_dict(ROOT / "examples" / "band_clamp.toml")
    del raw["punch"][0]["extent"]
    raw["mesh"].update(nx=24, nphi=8)
    raw["supports"].update(x_min="symmetry", x_max="symmetry")  # a long pipe: the ends may shrink too
    raw.pop("probes")
    sleeve = solve(case_from_dict(raw))
    bars = [ax for ax in plots.plot_deformed(sleeve).axes if ax.name != "3d"]
    assert len(bars) == 2
    for fig, bar in ((plots.plot_deflection(sleeve), bars[0]), (plots.plot_pressure(sleeve), bars[1])):
        assert fig.axes[1].get_ylim() == pytest.approx(bar.get_ylim(), rel=1e-12, abs=0.0), fig.axes[0].get_title()


def test_study_figures_carry_units() -> None:
    """The swept key's unit comes from the case-file schema, the results' from the case's system."""
    rows = [{"punch.0.indentation": d, "force": 1e3 * d, "zone_area": d, "energy": d, "max_abs_w": d}
            for d in (1.0, 2.0)]
    kind = key_kind("punch.0.indentation")
    fig = plots.plot_sweep(rows, "punch.0.indentation", system="mm", param_kind=kind)
    labels = {ax.get_ylabel(): ax.get_xlabel() for ax in fig.axes}
    assert set(labels.values()) == {"punch.0.indentation [mm]"}
    assert set(labels) == {"contact force |F| [N]", "contact zone area [mm²]", "strain energy [N·mm]", "max |w| [mm]"}
    ax = plots.plot_force_indentation(rows, "punch.0.indentation", system="SI", param_kind=kind).axes[0]
    assert ax.get_xlabel() == "punch.0.indentation [m]" and ax.get_ylabel().endswith("[N]")
    counts = [{"mesh.nx": n, "energy": 1.0 / n} for n in (4, 8)]
    assert key_kind("mesh.nx") is None and key_kind("loads.normal") == "pressure"
    assert key_kind("probes.0.phi") == "angle"
    assert plots.plot_sweep(counts, "mesh.nx").axes[0].get_xlabel() == "mesh.nx"  # a count has no unit
    conv = [{"h": h, "error_force": h**2} for h in (0.1, 0.05, 0.025)]
    assert plots.plot_convergence(conv, system="mm").axes[0].get_xlabel().endswith("[mm]")


def test_pressure_title_gives_the_peak_the_report_gives(panel) -> None:
    """Issue 22: one value wherever a quantity appears. The title's peak nodal pressure is the summary's
    ``peak_pressure`` (it read the vertices' 1.59e8 Pa where the report said 2.13e8 Pa on the demo case, when the
    summary's peak was over the edge-midpoint rows' Λ/ω too); both are now the largest value of the map's field."""
    from shellcontact.outputs.figures.contact import plot_pressure

    fig = plot_pressure(panel)
    peak = panel.summary()["contact"][0]["peak_pressure"]  # in the case's units (N, mm, MPa), as the title
    title = fig.axes[0].get_title()
    shown = float(title.split("peak nodal pressure ")[1].split()[0])
    assert shown == pytest.approx(peak, rel=5e-4), (title, peak)  # 4 digits shown


def test_a_straight_line_load_is_coloured_along_its_length() -> None:
    """A saddle horn's line load is a straight polyline of two points with three samples along it (26 013,
    23 364, 30 706 N/m at refine 0 of examples/vessel_saddles.toml). pressure.png drew it as one segment in the
    colour of the middle sample, so the colour bar stopped at 23 364 N/m, below the line's own mean 26 694 N/m;
    now the line's colours span its samples (the independent reference: the samples themselves)."""
    from types import SimpleNamespace

    from matplotlib.collections import LineCollection
    from matplotlib.figure import Figure

    from shellcontact.outputs.figures.contact import _draw_line_force

    a = 2.0
    phi = 210.0
    samples = [{"x": x, "phi": phi, "line_force": q, "line": 0}
               for x, q in ((-3.6, 26013.0), (-3.5, 23364.0), (-3.4, 30706.0))]
    rim = {"samples": samples, "per_line": [{"kind": "line", "length": 0.3, "closed": False}]}
    line = np.array([[-3.65, a * np.radians(phi)], [-3.35, a * np.radians(phi)]])
    result = SimpleNamespace(solution=SimpleNamespace(shell=SimpleNamespace(radius=a, full=False)),
                             case=SimpleNamespace(units="SI"))
    fig = Figure()
    ax = fig.add_subplot()
    assert _draw_line_force(ax, fig, result, rim, [line])
    (lc,) = [c for c in ax.collections if isinstance(c, LineCollection)]
    colours = np.asarray(lc.get_array())
    assert colours.min() == 23364.0 and colours.max() == 30706.0 and lc.get_clim()[1] == 30706.0


def test_point_force_markers_draw_without_a_warning() -> None:
    """pressure.png's point-force star was drawn with the format "r*" and a colour, which matplotlib warns about on
    stderr ("color is redundantly defined") on every run with a point force; the markers are now given as markers
    alone, in the colours of the legend (the reference: matplotlib's own warning, turned into an error here)."""
    import warnings
    from types import SimpleNamespace

    from matplotlib.figure import Figure

    from shellcontact.outputs.figures.contact import _draw_point_forces

    rim = {"point_forces": [{"force": 1.5e3, "x": 0.0, "phi": 90.0}],
           "per_line": [{"end_forces": [{"force": 2.5e3, "x": 0.1, "phi": 80.0}]}],
           "samples": [{"x": 0.05, "phi": 85.0}]}
    ax = Figure().add_subplot()
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        _draw_point_forces(ax, SimpleNamespace(case=SimpleNamespace(units="SI")), rim)
    drawn = {(line.get_marker(), line.get_color()) for line in ax.get_lines()}
    assert drawn == {("*", "darkred"), ("D", "darkorange")}
