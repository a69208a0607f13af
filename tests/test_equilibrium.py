"""Forces where they act: the global balance of applied loads, contact forces and support reactions, and the
reaction of each supported edge (analysis.Result.equilibrium, edge_reactions)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

import shellcontact as sc
from shellcontact.demo import demo_case_path

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


@pytest.mark.parametrize("case_file", [demo_case_path(), EXAMPLES / "saddle_support.toml",
                                       EXAMPLES / "scordelis_lo.toml"], ids=["paper", "saddle", "scordelis"])
def test_balance_residual_is_the_interpolation_error_of_rigid_motions(case_file):
    """applied + contact + reactions = U·A·I_h(r) for the six rigid motions r: not zero on a coarse mesh (the
    interpolated rotations strain the shell a little), but it falls at least fourfold per refinement."""
    res = []
    for level in (0, 1):
        r = sc.solve(sc.load_case(case_file, [f"mesh.refine={level}"]))
        eq = r.equilibrium()
        sol = r.solution
        # the residual is exactly U·A·I_h(r) (the definition of the reactions R = A U − F − Bᵀ Λ)
        expected = sol.rigid_modes @ (sol.A @ sol.U)
        got = np.array(eq["residual"]["force"] + eq["residual"]["moment"])
        gross = np.abs(sol.rigid_modes) @ (np.abs(sol.A @ sol.U) + np.abs(sol.F))
        assert np.all(np.abs(got - expected) <= 1e-12 * gross + 1e-300)
        res.append(eq["relative_residual"])
    assert res[1] <= 0.25 * res[0] or res[1] < 1e-10, res


def test_axial_balance_is_exact_and_edges_add_up():
    """The axial translation is represented exactly, so the axial balance holds to round-off; the edge
    reactions add up to the total reaction; under internal pressure a clamped cylinder's ends carry no net
    axial force but the hoop pressure's resultant on a panel."""
    r = sc.solve(sc.load_case(EXAMPLES / "pressurized_cylinder.toml"))
    eq = r.equilibrium()
    gross = np.abs(r.solution.rigid_modes[0]) @ np.abs(r.solution.F)
    assert abs(eq["residual"]["force"][0]) <= 1e-12 * max(gross, 1.0)
    edges = r.edge_reactions()
    assert set(edges) == {"x_min", "x_max", "phi_min", "phi_max"}
    total = np.sum([e["force"] for e in edges.values()], axis=0)
    scale = np.abs(eq["applied"]["force"]).max()
    assert np.allclose(total, r.solution.reaction_resultant(), rtol=0, atol=1e-10 * scale)
    # the applied pressure's resultant on the 2° panel: p · a · L · (sin β − sin α, …) along y, z
    sh = r.case.shell
    p, a, L = float(r.case.loads.normal), sh.radius, sh.length
    fy = p * a * L * (math.sin(sh.beta) - math.sin(sh.alpha))
    fz = p * a * L * (math.cos(sh.alpha) - math.cos(sh.beta))
    assert eq["applied"]["force"][1] == pytest.approx(fy, rel=1e-9)
    assert eq["applied"]["force"][2] == pytest.approx(fz, rel=1e-9)


def test_contact_balances_the_reactions_of_the_paper_panel():
    """The punch's force on the shell is carried by the clamped edges: contact + reactions = residual, and the
    summary names the balance, per edge the force and moment about the edge centre."""
    r = sc.solve(sc.load_case(demo_case_path()))
    s = r.summary()
    eq = s["equilibrium"]
    fz_contact, fz_reac = eq["contact"]["force"][2], eq["reactions"]["force"][2]
    # BᵀΛ on the rigid translation: the punch's resultant Σ Λ_i ∇Z_i (force on the shell)
    assert fz_contact == pytest.approx(s["contact"][0]["force"][2], rel=1e-12)
    assert abs(fz_contact + fz_reac) <= 1e-5 * abs(fz_reac)
    edges = s["reactions"]
    # symmetric panel and punch: the two x-edges carry equal shares, as do the two φ-edges
    assert edges["x_min"]["force"][2] == pytest.approx(edges["x_max"]["force"][2], rel=1e-6)
    assert edges["phi_min"]["force"][2] == pytest.approx(edges["phi_max"]["force"][2], rel=1e-6)
    assert sum(e["force"][2] for e in edges.values()) == pytest.approx(fz_reac, rel=1e-9)
