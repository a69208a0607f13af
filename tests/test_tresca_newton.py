"""Tresca friction by the exact primal method (``solvers.tresca_newton``, semismooth Newton on the open/closed
and stick/slip sets) against the other two methods on the paper's panel: the dual (MPGP on the disc-constrained
dual QP, another algorithm on another formulation) to round-off, and the penalty (regularised friction) to O(ε);
the case's Tresca on the contact set where it has no solution; the friction keys of the schema."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from test_friction_case import panel as panel_dict
from test_tresca import panel, rel

from shellcontact import solve
from shellcontact.analysis.pipeline import default_penalty
from shellcontact.errors import InputError
from shellcontact.problem.case import case_from_dict, key_kind, load_case
from shellcontact.solvers import solve_active_set
from shellcontact.solvers.tresca import solve_tresca_dual, solve_tresca_penalty
from shellcontact.solvers.tresca_newton import solve_tresca_newton

PANEL = Path(__file__).resolve().parents[1] / "src/shellcontact/cases/paper_panel.toml"


def test_zero_bound_is_the_frictionless_active_set():
    _, qp, op, top, C, c, fac = panel()
    free = solve_active_set(qp, factorization=fac)
    s = solve_tresca_newton(qp, C, c, np.zeros(qp.m), factorization=fac)
    assert np.all(s.info["T"] == 0.0) and s.info["fallback"] is None
    assert rel(s.U, free.U) < 1e-11  # measured 5e-15
    assert rel(s.Lambda, free.Lambda) < 1e-11  # measured 8e-14


@pytest.mark.parametrize("bound", [1e6, 1e8, 1e9, 1e12])  # Pa: all slip; 6 stick 75 slip; 80 stick 1 slip; all stick
def test_newton_equals_the_dual(bound):
    """The classical Tresca problem (the bound on every candidate row), 1 mm axial slide: Newton converges
    (4–10 iterations measured) and its solution is the dual's to round-off. At 1e8 Pa its sets revisit one
    (7 iterations) and the dual finishes from its iterate, as the frictionless active set's fallback does."""
    _, qp, op, top, C, c, fac = panel()
    g = top.tresca_bounds(op.weights, bound)
    d = solve_tresca_dual(qp, C, c, g, factorization=fac)
    n = solve_tresca_newton(qp, C, c, g, factorization=fac)
    assert n.info["fallback"] is (None if bound != 1e8 else "cycle") and n.iterations <= 30  # measured 4-13
    for name, value in n.residuals.items():
        assert value < 1e-9, name  # measured ≤ 3.6e-12
    assert rel(n.U, d.U) < 1e-9  # measured ≤ 9.2e-11 (1e8 Pa), ≤ 9e-13 elsewhere
    assert rel(n.Lambda, d.Lambda) < 1e-9  # measured ≤ 2e-11
    assert rel(n.info["T"], d.info["T"]) < 2e-9  # measured ≤ 2.5e-10 (1e8 Pa: the dual's own tolerance)
    assert np.array_equal(top.states(n.info["T"], g), top.states(d.info["T"], g))


def test_newton_and_penalty_agree_to_order_epsilon():
    """The penalty converges to the Newton solution like ε (as to the dual: ``test_tresca``)."""
    case, qp, op, top, C, c, fac = panel()
    g = top.tresca_bounds(op.weights, 1e8)
    n = solve_tresca_newton(qp, C, c, g, factorization=fac)
    eps = default_penalty(case)
    errors = [rel(solve_tresca_penalty(qp, C, c, g, e).U, n.U) for e in (eps, eps / 10)]
    assert errors[0] / errors[1] > 7.0  # measured 9.5-10 against the dual
    assert errors[1] < 1e-3


def test_contact_set_tresca_without_solution():
    """1e8 Pa, 0.1 mm slide: the bounds on the frictionless contact set 𝒜 close the set ℬ, and the bounds on ℬ
    close 𝒜 again (checked by the dual, independently of Newton): the fixed point on the contact set alternates,
    and none of the 1024 sets between 𝒜 ∩ ℬ and 𝒜 ∪ ℬ is consistent (measured, 120 s: docs/theory.md §9a).
    The case warns with friction_no_solution for every method, the fixed point stopping at the cycle (2
    iterations, not 50). (A Newton that gates the bounds by its own closed set cycles here too, and wandered
    where this fixed point converges in 2 iterations: 32 × 32, 1e7 Pa, 1 mm slide.)"""
    _, qp, op, top, C, c, fac = panel()
    g = top.tresca_bounds(op.weights, 1e8)
    c = 0.1 * c
    closed = [solve_tresca_dual(qp, C, c, np.zeros(qp.m), factorization=fac).Lambda > 0]
    for _ in range(3):
        closed.append(solve_tresca_dual(qp, C, c, np.where(closed[-1], g, 0.0), factorization=fac).Lambda > 0)
    assert not np.array_equal(closed[1], closed[2]) and np.array_equal(closed[1], closed[3])
    for method in ("active-set", "dual"):
        s = solve(case_from_dict(panel_dict(friction={"model": "tresca", "bound": 1e8}, slide=(1e-4, 0.0, 0.0))),
                  method=method).summary()
        assert "friction_no_solution" in [w["code"] for w in s["warnings"]]
        fp = s["contact"][0]["friction"]["fixed_point"]
        assert fp["cycle"] and not fp["converged"] and fp["iterations"] <= 3


@pytest.mark.parametrize("friction", [0.3, {"model": "tresca", "bound": 1e7}])
def test_case_active_set_equals_dual(friction):
    """A case with Coulomb (μ = 0.3, 1 mm slide) or Tresca (1e7 Pa, 0.1 mm): method = "active-set" runs the
    Newton (the summary says which: the whole law's for Coulomb, the Tresca problems' fixed point for the case's
    Tresca) and gives the dual's friction and normal forces."""
    slide = (1e-3 if friction == 0.3 else 1e-4, 0.0, 0.0)
    a, d = (solve(case_from_dict(panel_dict(friction=friction, slide=slide)), method=m).summary()["contact"][0]
            for m in ("active-set", "dual"))
    newton = "coulomb-active-set" if friction == 0.3 else "tresca-active-set"
    assert a["friction"]["method"] == newton and d["friction"]["method"] == "tresca-dual"
    scale = np.linalg.norm(d["friction"]["force"])
    assert np.linalg.norm(np.subtract(a["friction"]["force"], d["friction"]["force"])) < 1e-7 * scale  # ≤ 4.1e-9
    assert a["total_normal_force"] == pytest.approx(d["total_normal_force"], rel=1e-9)  # measured 4e-11
    assert a["friction"]["fixed_point"]["converged"]


def test_friction_keys_in_the_schema():
    """``--set punch.0.friction.bound=g`` sets a Tresca bound (a pressure: the unit of sweeps and tables);
    a bad value is refused by its key's name."""
    assert key_kind("punch.0.friction.bound") == "pressure"
    assert key_kind("punch.0.friction.coefficient") is None  # μ: dimensionless
    case = load_case(PANEL, ["punch.0.friction.bound=1e7"])
    assert (case.punches[0].friction.model, case.punches[0].friction.bound) == ("tresca", 1e7)
    with pytest.raises(InputError) as e:
        load_case(PANEL, ["punch.0.friction.bound=-1"])
    assert str(e.value).startswith("punch.0.friction.bound:")


def test_tresca_on_the_frictionless_contact_set():
    """``surface = "frictionless-contact"``: the bound on the rows in contact in the frictionless solution, held
    fixed — one convex Tresca problem. Where the case's Tresca on the contact set has no solution (1e8 Pa, 0.1 mm
    slide: above) it is solved in one iteration, no warning, and equals that problem solved directly by the dual
    (bounds ω g on the frictionless dual solution's contact set)."""
    _, qp, op, top, C, c, fac = panel()
    c = 0.1 * c
    surface = solve_tresca_dual(qp, C, c, np.zeros(qp.m), factorization=fac).Lambda > 0
    direct = solve_tresca_dual(qp, C, c, np.where(surface, top.tresca_bounds(op.weights, 1e8), 0.0), factorization=fac)
    friction = {"model": "tresca", "bound": 1e8, "surface": "frictionless-contact"}
    for method in ("active-set", "dual"):
        result = solve(case_from_dict(panel_dict(friction=friction, slide=(1e-4, 0.0, 0.0))), method=method)
        s = result.summary()
        assert "friction_no_solution" not in [w["code"] for w in s["warnings"]]
        fp = s["contact"][0]["friction"]["fixed_point"]
        assert fp["converged"] and fp["iterations"] == 1
        assert rel(result.contact.Lambda, direct.Lambda) < 4e-12, method  # measured 7.5e-13, 4.4e-13
        assert rel(result.contact.solution.U, direct.U) < 1e-12, method  # measured 1.5e-13, 1.3e-13
    with pytest.raises(InputError) as e:
        case_from_dict(panel_dict(friction={"coefficient": 0.3, "surface": "frictionless-contact"}))
    assert str(e.value).startswith("punch.0.friction.surface:")
