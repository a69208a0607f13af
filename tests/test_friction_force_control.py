"""Force control along the surface (issue 26 item 3): ``punch.<i>.tangential_force`` finds the slide whose friction
force on the shell equals the prescribed force, and refuses a force the friction cannot hold. The paper's sphere
(8 × 8 panel, 10 mm indentation) with Coulomb μ = 0.3, dual method."""

from __future__ import annotations

from functools import cache

import pytest
from test_friction_case import panel

from shellcontact import solve
from shellcontact.errors import InputError
from shellcontact.problem.case import case_from_dict


@cache
def pushed(fx: float, **extra) -> dict:
    return solve(case_from_dict(panel(friction=0.3, tangential_force=[fx, 0.0, 0.0], **extra)),
                 method="dual").summary()["contact"][0]


def test_force_control_holds_the_prescribed_force():
    """20 kN along the axis (a quarter of the 86 kN the friction holds): the friction force's axial component is the
    force to 1e-8 (measured 4e-15; its component along the punch's travel, 1.9 kN, is the indentation's), and the
    slide it found, given as a slide, gives that force again (an independent solve)."""
    c = pushed(2e4)
    f = c["friction"]
    assert f["force"][0] == pytest.approx(2e4, rel=1e-8) and abs(f["force"][1]) <= 1e-8 * 2e4
    assert f["tangential_force"] == [2e4, 0.0, 0.0] and f["units"]["slide"] == "m"
    assert f["slide"][0] > 0 and f["slide"][1:] == [0.0, 0.0]
    assert f["force_control_solves"] <= 30  # measured 7
    again = solve(case_from_dict(panel(friction=0.3, slide=f["slide"])), method="dual").summary()["contact"][0]
    assert again["friction"]["force"][0] == pytest.approx(2e4, rel=1e-7)
    assert pushed(6e4)["friction"]["slide"][0] > f["slide"][0]  # a larger force: further (measured ×4.8)


def test_force_above_the_capacity_is_refused():
    """100 kN: more than μ × the normal force (85.6 kN at full slip): refused, naming the key and the force that
    slides; the capacity in the message is μ × the normal force of a slide far past the stick range."""
    with pytest.raises(InputError, match=r"^punch\.0\.tangential_force: 100000 N is more than the friction holds: "
                                         r"the punch slides without bound at (\S+) N") as e:
        pushed(1e5)
    held = float(str(e.value).split("without bound at ")[1].split(" N")[0])
    far = solve(case_from_dict(panel(friction=0.3, slide=[1e-2, 0.0, 0.0])), method="dual").summary()["contact"][0]
    assert held == pytest.approx(0.3 * far["total_normal_force"], rel=2e-2)  # measured 85576.7 against 0.3 × N


@pytest.mark.parametrize("punch, solver, where", [
    ({"friction": 0.3, "tangential_force": [0.0, 0.0, 1e3]}, {}, "punch.0.tangential_force"),  # along travel
    ({"friction": 0.3, "tangential_force": [0.0, 0.0, 0.0]}, {}, "punch.0.tangential_force"),
    ({"friction": 0.3, "tangential_force": [1e3, 0.0, 0.0], "slide": [1e-3, 0.0, 0.0]}, {}, "punch.0.tangential_force"),
    ({"tangential_force": [1e3, 0.0, 0.0]}, {}, "punch.0.tangential_force"),  # no friction
    ({"friction": 0.3, "tangential_force": [1e3, 0.0, 0.0]}, {"steps": 2}, "solver.steps"),
])
def test_bad_tangential_force_refused_by_name(punch, solver, where):
    d = panel(**punch)
    d.setdefault("solver", {}).update(solver)
    with pytest.raises(InputError) as e:
        case_from_dict(d)
    assert str(e.value).startswith(where + ":"), str(e.value)
