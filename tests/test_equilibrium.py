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
    """applied + contact + reactions: not zero on a coarse mesh (the interpolated rotations strain the shell a
    little), but it falls at least fourfold per refinement. The applied loads and prescribed punch forces in it
    are the case file's closed-form totals (tests/oracles/loads.py: the roof's dead weight q a (β − α) L, the
    saddle's 5 kN) and the other punches' Σ Λ_i ∇Z_i, not F and Bᵀ Λ read back: with those the residual would
    be U·A·I_h(r) by the definition R = A U − F − Bᵀ Λ, whatever F or Λ. Measured (refine 0 → 1): paper
    5.3e-7 → 3.5e-8, saddle 4.5e-4 → 4.1e-5, roof 1.4e-5 → 9.4e-7."""
    from oracles.loads import applied_force, prescribed_punch_force

    res = []
    for level in (0, 1):
        r = sc.solve(sc.load_case(case_file, [f"mesh.refine={level}"]))
        eq = r.equilibrium()
        W, P = applied_force(r.case), prescribed_punch_force(r.case)
        gross = np.abs(r.solution.rigid_modes[:3]) @ (np.abs(r.solution._AU) + np.abs(r.solution.F))
        # the balance's applied force is the closed form up to the interpolation of the y, z translations
        assert np.abs(np.array(eq["applied"]["force"]) - W).max() <= 1e-7 * gross.max()
        contact = P.copy()  # the punches: prescribed forces from the case file, the others Σ Λ_i ∇Z_i
        if r.contact is not None:
            by_punch = r.contact.operator.resultant(r.contact.Lambda)
            forced = np.array([p.mode == "force" for p in r.case.punches])
            # the solver's force condition: the force-controlled punches exert P
            assert by_punch[forced].sum(axis=0) == pytest.approx(P, rel=1e-9, abs=1e-9 * np.abs(P).max())
            contact += by_punch[~forced].sum(axis=0)
        total = np.array(eq["reactions"]["force"]) + contact + W
        res.append(max(float(np.abs(total).max() / gross.max()), eq["relative_residual"]))
    print(f"\n{Path(case_file).stem}: relative residual {res[0]:.2e} -> {res[1]:.2e}")
    assert res[1] <= 0.25 * res[0] or res[1] < 1e-10, res


def test_edge_reactions_are_the_closed_form_edge_resultants():
    """Each edge's reaction (``edge_reactions``: the generalised reactions R = A U − F on the edge's dofs, on the
    interpolated rigid translations) against the edge stress resultants of the clamped pressurised cylinder's
    closed form (tests/test_axisymmetric_pressure.py) integrated along the edge: at x = ±H the membrane force
    ±N11 e1 and the transverse shear M11'(H) n over the arc a (β − α); at φ = β (α) the hoop force ±∫ N22 dx
    e2, N22 = B (1 − μ²) w/a + μ N11. The corner dofs count with the x edges, which then carry the corner
    element's share of the hoop force: an O(h) difference. Measured (nx = 40, 80): x edges 6.9e-4, 3.4e-4, φ
    edges 2.0e-4, 9.3e-5 of the edge's largest component."""
    from scipy.integrate import quad
    from test_axisymmetric_pressure import _exact

    from shellcontact.shell.geometry import frame

    errors = []
    for nx in (40, 80):
        case = sc.load_case(EXAMPLES / "pressurized_cylinder.toml", [f"mesh.nx={nx}"])
        ex, sh = _exact(case), case.shell
        a, alpha, beta = sh.radius, sh.alpha, sh.beta
        shear = -ex.D * (ex.w(ex.H, 3) + ex.mu * ex.w(ex.H, 1) / a**2)  # M11'(H) = Q1(H); M11' is odd in x
        arc_normal = a * np.array([0.0, math.sin(beta) - math.sin(alpha), math.cos(alpha) - math.cos(beta)])
        axial = np.array([ex.N * a * (beta - alpha), 0.0, 0.0])
        hoop = quad(lambda x, ex=ex, a=a: ex.B * (1 - ex.mu**2) * ex.w(x) / a + ex.mu * ex.N, -ex.H, ex.H, limit=200)[0]
        expected = {"x_max": axial + shear * arc_normal, "x_min": -axial + shear * arc_normal,
                    "phi_max": hoop * frame(np.array(beta))[1], "phi_min": -hoop * frame(np.array(alpha))[1]}
        edges = sc.solve(case).edge_reactions()
        errors.append({name: float(np.abs(np.array(edges[name]["force"]) - f).max() / np.abs(f).max())
                       for name, f in expected.items()})
    print("\n" + "\n".join(f"nx = {nx}: " + ", ".join(f"{k} {v:.2e}" for k, v in e.items())
                           for nx, e in zip((40, 80), errors)))
    for name in ("x_min", "x_max"):
        assert errors[1][name] <= 1e-3 and errors[1][name] < 0.6 * errors[0][name]
    for name in ("phi_min", "phi_max"):
        assert errors[1][name] <= 3e-4 and errors[1][name] < 0.6 * errors[0][name]


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
