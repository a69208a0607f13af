"""The outputs of friction (issue 26 item 3): the VTU fields friction_state / friction_traction / friction_slip and
friction.png. The paper's sphere (8 × 8 panel) with Coulomb μ = 0.3 slid 1 mm along the axis: every touching point
slides, so the fields must obey the law there: |traction| = μ × pressure (the sphere's |∇Z| = 1), the slip against
the traction; frictionless results get neither the fields nor the figure."""

from __future__ import annotations

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from test_friction_case import solved

from shellcontact.outputs.fields import FRICTION_FIELDS, friction_vertex_fields, vertex_fields
from shellcontact.outputs.figures.friction import plot_friction
from shellcontact.outputs.writers import write_vtu


def test_friction_fields_obey_the_law():
    r = solved(friction=0.3, slide=(1e-3, 0.0, 0.0))
    f = friction_vertex_fields(r)
    assert set(f) == set(FRICTION_FIELDS)
    state, traction, slip = f["friction_state"], f["friction_traction"], f["friction_slip"]
    pressure = vertex_fields(r)["contact_pressure"]
    sliding = state == 2
    assert sliding.sum() >= 4 and not np.any(state == 1)  # full slip (the summary's stick area is 0)
    t = np.linalg.norm(traction, axis=1)
    np.testing.assert_allclose(t[sliding], 0.3 * pressure[sliding], rtol=1e-6)  # measured 1e-9
    along = np.sum(slip[sliding] * traction[sliding], axis=1)
    assert np.all(along < 0)  # the shell slips against the traction on it
    # Coulomb on the fields everywhere: no traction without pressure, at most μ p (at a vertex whose own row is open
    # the traction and the pressure are its edges' midpoint rows', both as contact_pressure, contact/nodal_pressure.py)
    assert np.all(t <= 0.3 * pressure * (1.0 + 1e-9))
    # the axial traction drags the shell with the slide, and the total slip is about the slide (1.6 mm measured)
    assert np.all(traction[sliding, 0] > 0)
    assert np.linalg.norm(slip[sliding], axis=1).max() <= 3e-3


def test_friction_fields_in_the_vtu(tmp_path):
    r = solved(friction=0.3, slide=(1e-3, 0.0, 0.0))
    path = write_vtu(r, tmp_path / "fields.vtu")
    text = path.read_text(errors="replace")
    for name in FRICTION_FIELDS:
        assert f'Name="{name}"' in text


def test_friction_figure_only_with_friction():
    assert plot_friction(solved()) is None and not friction_vertex_fields(solved())
    fig = plot_friction(solved(friction=0.3, slide=(1e-3, 0.0, 0.0)))
    FigureCanvasAgg(fig).draw()
    ax = fig.axes[0]
    assert ax.get_xlabel() == "x [m]" and ax.get_ylabel() == "φ [deg]"
    labels = [t.get_text() for t in ax.get_legend().get_texts()]
    assert any(s.startswith("slip (") for s in labels) and any(s.startswith("open (") for s in labels)
    assert "N" in ax.get_title() and "m²" in ax.get_title()
    keys = [c for c in ax.get_children() if type(c).__name__ == "QuiverKey"]
    assert keys and keys[0].text.get_text().endswith("Pa")


def test_arrows_are_clipped_only_where_a_few_run_far_beyond_the_rest():
    """The key's traction is the tractions' 0.75 quantile, and longer arrows are clipped to it (purple) — unless the
    longest is within 1.5× of it: examples/band_clamp_slip.toml's rim arrows were clipped by 0.3 %."""
    from matplotlib.figure import Figure

    from shellcontact.outputs.figures.friction import CLIPPED, _arrows

    class Units:
        class case:
            units = "SI"

    def drawn(mag):
        ax = Figure().add_subplot()
        n = mag.size
        _arrows(ax, Units, np.arange(n, dtype=float), np.zeros(n), mag, np.zeros(n), mag, 1.0)
        key = [c for c in ax.get_children() if type(c).__name__ == "QuiverKey"][0]
        return key.text.get_text()

    assert "clipped" not in drawn(np.array([2.640e7, 2.647e7, 2.650e7, 2.655e7] * 4))
    text = drawn(np.array([1.0e5] * 12 + [5.8e5] * 4))  # the vessel's horns against its faces
    assert "4 arrows clipped" in text and CLIPPED.split(":")[-1] in text
