"""Issue 22 items 2 and 4 (task 3): a fixed punch's contact zone is where it carries force
(``zone_points.py``), so it is the same for two mirror-image saddles and does not move with the gap tolerance.
"""

from __future__ import annotations

import logging
from pathlib import Path

import numpy as np
import pytest

import shellcontact as sc
from shellcontact.contact.operator import contact_zone
from shellcontact.contact.punches import place_punches
from shellcontact.contact.zone_points import nearest_point_class
from shellcontact.problem.sizing import mesh_lines
from shellcontact.shell.mesh import build_mesh

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


def test_nearest_point_class_wraps_around_a_closed_cylinder():
    """A point just below s = 2π a is nearest to the touching point at s = 0 only across the seam."""
    period = 2.0 * np.pi
    got = nearest_point_class(np.array([0.0, 0.0]), np.array([period - 0.01, 3.0]), np.array([0.0, 0.0]),
                              np.array([0.0, 3.2]), np.array([True, False]), period)
    assert got.tolist() == [True, False]
    assert nearest_point_class(np.array([0.0]), np.array([period - 0.01]), np.array([0.0, 0.0]),
                               np.array([0.0, 3.2]), np.array([True, False])).tolist() == [False]


def test_mirror_saddles_get_one_zone_that_the_gap_tolerance_does_not_move(caplog):
    """examples/vessel_saddles.toml at 48 x 48 (a mesh that is its own mirror image about x = 0, checked):
    the two saddles' zones agree to 1e-3 in area and extents, and a gap tolerance 10x smaller or larger gives
    the same zone (before: the interpolated gap put 0.096, 0.140, 0.343 m² of the left saddle in contact at
    tolerances 7.6e-9, 7.6e-8, 7.6e-7 m, 40 x 48, and 0.140 against 0.147 m² for the mirror saddle). Measured:
    areas equal to 1e-15; the same to the last digit at all three tolerances."""
    case = sc.load_case(EXAMPLES / "vessel_saddles.toml", sets=["mesh.nx=48", "mesh.nphi=48"])
    mesh = build_mesh(case.shell, case.mesh, *mesh_lines(case, place_punches(case.punches, case.shell)))
    vertices = set(map(tuple, np.round(mesh.p.T, 9)))
    assert vertices == {(-x, s) for x, s in vertices}  # the mesh respects the mirror symmetry
    caplog.set_level(logging.ERROR, logger="shellcontact")  # restored after the test
    result = sc.solve(case)
    c = result.contact
    zones = {rel: contact_zone(result.solution.space, result.punches, result.solution.U, c.delta, rel_gap=rel,
                               carrying=(c.operator, c.Lambda, c.gap)) for rel in (1e-4, 1e-3, 1e-2)}
    left, right = zones[1e-3]
    assert left["area"] > 0.05 * 0.3 * 2.0 * np.pi / 3.0  # a real part of the 0.63 m² cradle
    assert right["area"] == pytest.approx(left["area"], rel=1e-3)
    assert right["x"] == pytest.approx([-left["x"][1], -left["x"][0]], rel=1e-3)
    assert right["phi"] == pytest.approx(left["phi"], rel=1e-3)
    for rel in (1e-4, 1e-2):
        assert [z["area"] for z in zones[rel]] == pytest.approx([left["area"], right["area"]], rel=1e-12)
    assert result.summary()["contact"][0]["zone"]["area"] == pytest.approx(left["area"], rel=1e-12)
