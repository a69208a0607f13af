"""The semismooth Newton on the whole friction law (``solvers.coulomb_newton``, issue 26 item 6): Coulomb's
bound μ|∇Z|Λ updated inside the Newton, no outer fixed point. Checked against the fixed point of Tresca
problems, solved by another algorithm (the dual's MPGP) and by the Tresca Newton, on the paper's panel."""

from __future__ import annotations

import tomllib
from pathlib import Path

import numpy as np
import pytest
from test_friction_case import panel as panel_dict
from test_tresca import panel, rel

from shellcontact import solve
from shellcontact.analysis.discretization import discretize
from shellcontact.contact.friction import solve_coulomb, tangential_operator
from shellcontact.linalg import factorize
from shellcontact.problem.case import case_from_dict
from shellcontact.solvers.active_set import solve_active_set
from shellcontact.solvers.coulomb_newton import solve_friction_newton
from shellcontact.solvers.tresca import solve_tresca_dual
from shellcontact.solvers.tresca_newton import solve_tresca_newton

CASE = Path(__file__).resolve().parents[1] / "examples" / "panel_pushed_sideways.toml"


def _warm(sol):
    return {"initial": np.concatenate([sol.Lambda, sol.info["T"]])}


@pytest.mark.parametrize("mu", [0.3, 1.0])
def test_newton_is_the_fixed_points_coulomb_solution(mu):
    """μ = 0.3 and 1, 1 mm axial slide, 8 × 8: the Newton from the frictionless solution converges in a few
    steps (measured 4 and 5, quadratically: residuals 3e-1, 8e-3, 3e-6, 1e-13 at μ = 0.3) to the solution the
    fixed point of Tresca problems converges to, by the Tresca Newton and by the dual (U, Λ and T to 1e-8;
    measured ≤ 1.3e-11 in U, Λ and ≤ 5e-10 in T, the fixed point's own tolerance 1e-9 on the bounds)."""
    _, qp, op, top, C, c, fac = panel()
    law = np.stack([mu * np.linalg.norm(op.grad, axis=0), np.zeros(qp.m)], axis=1)
    free = solve_active_set(qp, factorization=fac)
    newton = solve_friction_newton(qp, C, c, law, factorization=fac,
                                   initial=np.concatenate([free.Lambda, np.zeros(2 * qp.m)]))
    assert newton.info["fallback"] is None and newton.iterations <= 15  # measured 4, 5
    for name, value in newton.residuals.items():  # the Coulomb law itself, with its own bounds μ|∇Z|Λ
        assert value < 1e-9, name  # measured ≤ 3.6e-12
    assert np.array_equal(newton.info["bounds"], top.coulomb_bounds(op, newton.Lambda, mu))
    for tresca in (solve_tresca_newton, solve_tresca_dual):
        fixed, record = solve_coulomb(qp, C, c, lambda L: top.coulomb_bounds(op, L, mu), tresca, factorization=fac,
                                      cache={}, accelerate=True, warm=_warm)
        assert record.converged
        assert rel(newton.U, fixed.U) < 1e-8
        assert rel(newton.Lambda, fixed.Lambda) < 1e-8
        assert rel(newton.info["T"], fixed.info["T"]) < 1e-8


def test_tresca_on_the_contact_set_without_solution_stops():
    """The case's Tresca bound (ω g where Λ > 0) at 1e8 Pa with a 1 mm slide, 8 × 8, where that law has no
    solution (its fixed point cycles, ``test_tresca_newton``): the Newton does not loop, it stops with a reason
    after a few iterations (measured: stalled after 11) and leaves the case to the fixed point's warning."""
    _, qp, op, top, C, c, fac = panel()
    law = np.stack([np.zeros(qp.m), top.tresca_bounds(op.weights, 1e8)], axis=1)
    free = solve_active_set(qp, factorization=fac)
    s = solve_friction_newton(qp, C, c, law, factorization=fac,
                              initial=np.concatenate([free.Lambda, np.zeros(2 * qp.m)]))
    assert s.info["fallback"] in ("cycle", "stalled", "iterations") and s.iterations <= 50


def test_case_reports_the_newton():
    """A Coulomb case (μ = 0.3, 1 mm slide) by the active set: the Newton solves it, no fixed point runs
    (``fixed_point.iterations`` 0, ``contraction`` probed at its solution by 2 Tresca solves, below the warning's
    0.9: measured 0.081), ``fixed_point.newton`` says so, and the friction and
    normal forces equal the dual's fixed point's (measured 1e-11 relative)."""
    slide = (1e-3, 0.0, 0.0)
    a, d = (solve(case_from_dict(panel_dict(friction=0.3, slide=slide)), method=m).summary()["contact"][0]
            for m in ("active-set", "dual"))
    fp = a["friction"]["fixed_point"]
    assert fp["newton"]["converged"] and fp["newton"]["fallback"] is None and fp["newton"]["iterations"] <= 15
    assert fp["iterations"] == 0 and 0 < fp["contraction"] < 0.3 and fp["converged"]
    assert fp["newton"]["contraction_solves"] == 2
    assert a["friction"]["method"] == "coulomb-active-set" and d["friction"]["method"] == "tresca-dual"
    assert "newton" not in d["friction"]["fixed_point"]
    scale = np.linalg.norm(d["friction"]["force"])
    assert np.linalg.norm(np.subtract(a["friction"]["force"], d["friction"]["force"])) < 1e-7 * scale
    assert a["total_normal_force"] == pytest.approx(d["total_normal_force"], rel=1e-9)


def test_polish_ends_the_fixed_point_on_the_law():
    """Where the Newton from the frictionless start does not converge, the fixed point runs and, once its change
    falls below 1 % of the bounds, a Newton from its iterate (``polish``) ends it: the result satisfies Coulomb's
    law (residuals, bounds μ|∇Z|Λ of its own Λ) and equals the fixed point run to its end (to 1e-8). Forced
    here by a polish from every iterate on the 8 × 8 panel, μ = 1."""
    _, qp, op, top, C, c, fac = panel()
    mu = 1.0
    law = np.stack([mu * np.linalg.norm(op.grad, axis=0), np.zeros(qp.m)], axis=1)
    tries: list[int] = []

    def polish(sol):
        out = solve_friction_newton(qp, C, c, law, factorization=fac, max_iterations=6,
                                    initial=np.concatenate([sol.Lambda, sol.info["T"]]))
        tries.append(out.iterations)
        return out if out.info["fallback"] is None else None

    bounds = lambda L: top.coulomb_bounds(op, L, mu)  # noqa: E731
    polished, rp = solve_coulomb(qp, C, c, bounds, solve_tresca_newton, factorization=fac, cache={},
                                 accelerate=True, warm=_warm, polish=polish)
    full, rf = solve_coulomb(qp, C, c, bounds, solve_tresca_newton, factorization=fac, cache={}, accelerate=True,
                             warm=_warm)
    assert rp.converged and rf.converged and tries and rp.iterations <= rf.iterations
    assert polished.method == "coulomb-active-set" and full.method == "tresca-active-set"  # who gave the answer
    for name, value in polished.residuals.items():
        assert value < 1e-9, name
    assert rel(polished.U, full.U) < 1e-8 and rel(polished.info["T"], full.info["T"]) < 1e-8


def test_newton_converges_where_its_sets_cycled():
    """examples/panel_pushed_sideways.toml at refine 1 (16.8k unknowns), μ = 0.3, 1 mm axial slide: before rows
    that join and pull left the step (``coulomb_newton``), the Newton's sets cycled after 7 iterations (two edge
    rows joined at a residual of 1.5e-4 and the step with them raised it to 0.62); now it converges alone
    (measured 6 iterations) to the solution of the fixed point of Tresca problems (Anderson, Tresca Newton)."""
    data = tomllib.loads(CASE.read_text())
    data["mesh"]["refine"] = 1
    data["punch"][0].update(friction=0.3, slide=[1e-3, 0.0, 0.0])
    case = case_from_dict(data)
    d = discretize(case)
    qp, op = d.qp(), d.operator
    top = tangential_operator(d.space, op)
    C, c = (top.C @ d.reduction.P).tocsr(), top.offsets([p.slide for p in case.punches])
    fac = factorize(qp.A)
    law = np.stack([0.3 * np.linalg.norm(op.grad, axis=0), np.zeros(qp.m)], axis=1)
    free = solve_active_set(qp, factorization=fac)
    free.info["T"] = np.zeros(2 * qp.m)
    newton = solve_friction_newton(qp, C, c, law, factorization=fac, max_iterations=12,
                                   initial=np.concatenate([free.Lambda, np.zeros(2 * qp.m)]))
    assert newton.info["fallback"] is None and newton.iterations <= 12  # measured 6
    fixed, record = solve_coulomb(qp, C, c, lambda L: top.coulomb_bounds(op, L, 0.3), solve_tresca_newton,
                                  factorization=fac, cache={}, accelerate=True, warm=_warm, start=free,
                                  fixed_point_tol=1e-12)
    assert record.converged
    assert rel(newton.U, fixed.U) < 5e-12  # measured 6.3e-13 (the fixed point: 20 iterations to 1e-12)
    assert rel(newton.Lambda, fixed.Lambda) < 5e-10  # measured 7.0e-11
    assert rel(newton.info["T"], fixed.info["T"]) < 5e-10  # measured 8.1e-11


def test_coulomb_on_the_screened_rows_equals_the_whole_qp():
    """The pipeline's screened path (the dense Schur complement of the rows predicted to touch, which runs by
    default from 40k unknowns; forced here by ``solver.substructure = true`` on the 8 × 8 panel) solves Coulomb
    as the whole QP does. On integ at 5d18262 it failed with a TypeError (``tresca_screened`` passed ``E=`` to the
    whole-law Newton), so every Coulomb run of 40k unknowns and more failed; checked against the run without
    screening (friction force and normal force, measured 1e-12 relative)."""
    slide = (1e-3, 0.0, 0.0)
    runs = []
    for sub in (True, False):
        d = panel_dict(friction=0.3, slide=slide)
        d.setdefault("solver", {})["substructure"] = sub
        runs.append(solve(case_from_dict(d), method="active-set").summary()["contact"][0])
    a, b = runs
    scale = np.linalg.norm(b["friction"]["force"])
    assert scale > 0 and a["friction"]["method"] == "coulomb-active-set"
    assert np.linalg.norm(np.subtract(a["friction"]["force"], b["friction"]["force"])) < 1e-8 * scale
    assert a["total_normal_force"] == pytest.approx(b["total_normal_force"], rel=1e-9)


@pytest.mark.slow
def test_newton_alone_at_68k_unknowns(monkeypatch):
    """examples/panel_pushed_sideways.toml at refine 2 (68k unknowns), μ = 0.3, 1 mm slide, through the pipeline:
    with the join limit growing with the closed set while the residual falls (``JOIN_SHARE``) the whole-law Newton
    converges alone (measured: 6 iterations since a step's offsets drop the T of pairs that left; before, 20
    on the border rows, then 10 after outside rows joined); with 4 rows per iteration it needed 29 and stopped at
    its cap, and the fixed point of Tresca problems and a polish finished. Its friction and normal forces are
    those of that route (the Newton held to 1 iteration: now the fixed point from its best iterate)."""
    import shellcontact.analysis.friction as friction

    data = tomllib.loads(CASE.read_text())
    data["mesh"]["refine"] = 2
    data["punch"][0].update(friction=0.3, slide=[1e-3, 0.0, 0.0])
    alone = solve(case_from_dict(data), method="active-set").summary()["contact"][0]
    fp = alone["friction"]["fixed_point"]
    assert fp["newton"]["converged"] and fp["iterations"] == 0  # no fixed point ran
    monkeypatch.setattr(friction, "NEWTON_ITERATIONS", 1)
    fixed = solve(case_from_dict(data), method="active-set").summary()["contact"][0]
    assert fixed["friction"]["fixed_point"]["iterations"] > 0 and fixed["friction"]["fixed_point"]["converged"]
    scale = np.linalg.norm(fixed["friction"]["force"])
    difference = np.linalg.norm(np.subtract(alone["friction"]["force"], fixed["friction"]["force"]))
    assert difference < 1e-13 * scale  # measured 1.4e-14
    assert alone["total_normal_force"] == pytest.approx(fixed["total_normal_force"], rel=1e-13)  # measured 0


def test_a_step_closes_its_rows_when_pairs_leave():
    """One Newton step makes gap = 0 on the rows it closes (its equations are linear in (Λ, T) there), also where
    pairs of the iterate leave the system: a start with T ≠ 0 on rows outside the closed set (the open rows of the
    frictionless solution, as rows that opened in an earlier step carry it). Checked on a fresh solve for U
    (G + B U). Before the step's offsets dropped the leaving pairs' B A⁻¹C_jᵀT_j, the closed rows' gaps were off by
    that (8 × 8 panel: 1.5e-2 of the length scale here; at 68k unknowns 1e-6–3e-4 at most steps, the plateaus of
    the law's residual at ≈ 2e-6 with any closed set, benchmarks/RESULTS.md "Branch coul15")."""
    _, qp, op, top, C, c, fac = panel()
    law = np.stack([0.3 * np.linalg.norm(op.grad, axis=0), np.zeros(qp.m)], axis=1)
    free = solve_active_set(qp, factorization=fac)
    open_rows = free.Lambda <= 0
    T0 = np.zeros((qp.m, 2))
    T0[open_rows] = 0.1 * free.Lambda.max()  # N: of the order of the friction bounds μΛ
    step = solve_friction_newton(qp, C, c, law, factorization=fac, max_iterations=1,
                                 initial=np.concatenate([free.Lambda, T0.ravel()]))
    closed = step.Lambda != 0
    assert closed.any() and np.all(step.info["T"].reshape(-1, 2)[open_rows & ~closed] == 0.0)
    gap = qp.gap(step.U)
    scale = float(np.abs(gap - qp.G).max())
    assert float(np.abs(gap[closed]).max()) < 1e-14 * scale  # measured 1.0e-15 (before: 1.5e-2)


def test_fixed_point_starts_from_the_newtons_best_iterate(monkeypatch):
    """examples/panel_pushed_sideways.toml at refine 1 (16.8k unknowns), μ = 0.3, 1 mm slide, the whole-law Newton
    held to 2 iterations (its residual 5.4e-5): the fixed point of Tresca problems that follows starts from the
    Newton's best iterate (g⁰ = μ|∇Z|Λ of it) and converges in 1 iteration and a polish (measured; from the
    frictionless solution, as before: 5 iterations and a polish), to the Newton's own solution where it runs
    alone (5 iterations): friction and normal force to 1e-10 (measured 1.1e-11 and 1.3e-14 relative)."""
    import shellcontact.analysis.friction as friction

    data = tomllib.loads(CASE.read_text())
    data["mesh"]["refine"] = 1
    data["punch"][0].update(friction=0.3, slide=[1e-3, 0.0, 0.0])
    alone = solve(case_from_dict(data), method="active-set").summary()["contact"][0]
    assert alone["friction"]["fixed_point"]["newton"]["converged"]
    monkeypatch.setattr(friction, "NEWTON_ITERATIONS", 2)
    after = solve(case_from_dict(data), method="active-set").summary()["contact"][0]
    fp = after["friction"]["fixed_point"]
    assert not fp["newton"]["converged"] and fp["converged"] and 1 <= fp["iterations"] <= 3  # measured 1
    scale = np.linalg.norm(alone["friction"]["force"])
    assert np.linalg.norm(np.subtract(after["friction"]["force"], alone["friction"]["force"])) < 1e-10 * scale
    assert after["total_normal_force"] == pytest.approx(alone["total_normal_force"], rel=1e-10)
