"""A contact area that converges (contact.contact_zone): the zone where the linearised gap is below 1e-3 of
the punch's travel, sampled at quadrature points, against the weights of the active constraint points."""

from __future__ import annotations

import numpy as np

import shellcontact as sc
from shellcontact.demo import demo_case_path


def test_the_touching_zone_converges_while_the_active_weights_shrink():
    zones, active_area = [], []
    for level in (0, 1, 2):
        c = sc.solve(sc.load_case(demo_case_path(), [f"mesh.refine={level}"])).summary()["contact"][0]
        z = c["zone"]
        zones.append([z["area"], z["x"][1] - z["x"][0], z["phi"][1] - z["phi"][0]])
        active_area.append(c["area"])
        # the symmetric punch touches a symmetric zone around the crown (x = 0, φ = 90°)
        assert abs(z["x"][0] + z["x"][1]) <= 1e-9 and abs(z["phi"][0] + z["phi"][1] - 180.0) <= 1e-9
        assert z["gap_tolerance"] == 1e-3 * 1e-2  # the demo's indentation is 10 mm
    zones = np.array(zones)
    print("\nlevel  zone area [m²]  x extent [m]  φ extent [deg]  active-weights area [m²]")
    for level, (z, a) in enumerate(zip(zones, active_area)):
        print(f"{level}  {z[0]:.5e}  {z[1]:.5f}  {z[2]:.4f}  {a:.4e}")
    # the zone's area and extents converge: successive differences fall at least twofold ...
    d = np.abs(np.diff(zones, axis=0))
    assert np.all(d[1] <= 0.5 * d[0])
    # ... and settle within 2 % from level 1 to 2, while the active points' weights keep shrinking by > 30 %
    assert np.all(d[1] <= 0.02 * zones[2])
    assert all(b < 0.7 * a for a, b in zip(active_area, active_area[1:]))
