"""Tresca friction on the paper's panel (MODEL.md §11): the dual with disc constraints (MPGP) against the
frictionless dual (g = 0), the penalty (regularised friction, converging like ε), and a tied contact (g large)."""

from __future__ import annotations

from functools import cache

import numpy as np
import pytest
import scipy.sparse as sp
from test_contact_solve import sphere_dict

from shellcontact.analysis.discretization import discretize
from shellcontact.analysis.pipeline import default_penalty
from shellcontact.contact.friction import solve_coulomb, tangential_operator
from shellcontact.linalg import factorize
from shellcontact.problem.case import case_from_dict
from shellcontact.solvers import solve_dual
from shellcontact.solvers.tresca import solve_tresca_dual, solve_tresca_penalty

SLIDE = np.array([1e-3, 0.0, 0.0])  # m, along the axis, tangent to the sphere at the crown


@cache
def panel(n: int = 8):
    """The paper's panel on an n × n mesh: its reduced QP, tangential rows, slide offsets, factorisation."""
    case = case_from_dict(sphere_dict(n=n))
    d = discretize(case)
    qp, op = d.qp(), d.operator
    top = tangential_operator(d.space, op)
    return case, qp, op, top, (top.C @ d.reduction.P).tocsr(), top.offsets([SLIDE]), factorize(qp.A)


def rel(a, b) -> float:
    return float(np.linalg.norm(a - b) / np.linalg.norm(b))


def test_zero_bound_is_frictionless():
    """g = 0 pins T = 0: the disc QP's solution is the frictionless dual's (MPRGP, another algorithm)."""
    _, qp, op, top, C, c, fac = panel()
    free = solve_dual(qp, factorization=fac)
    s = solve_tresca_dual(qp, C, c, np.zeros(qp.m), factorization=fac)
    assert np.all(s.info["T"] == 0.0)
    assert rel(s.U, free.U) < 1e-11  # measured 1.3e-14
    assert rel(s.Lambda, free.Lambda) < 1e-11


@pytest.mark.parametrize("bound", [1e8, 1e9])  # Pa: 6 stick and 75 slip pairs; 80 stick and 1 slip
def test_dual_and_penalty_agree_to_order_epsilon(bound):
    case, qp, op, top, C, c, fac = panel()
    g = top.tresca_bounds(op.weights, bound)
    d = solve_tresca_dual(qp, C, c, g, factorization=fac)
    for name, value in d.residuals.items():
        assert value < 1e-9, name  # measured ≤ 3e-12
    state = top.states(d.info["T"], g)
    assert np.any(state == 2) and np.any(state == 1)  # both stick and slip rows
    errors = []
    eps0 = default_penalty(case)
    for eps in (eps0, eps0 / 10, eps0 / 100):
        p = solve_tresca_penalty(qp, C, c, g, eps)
        errors.append((rel(p.U, d.U), rel(p.info["T"], d.info["T"]), rel(p.Lambda, d.Lambda)))
    errors = np.array(errors)
    print("penalty vs dual (U, T, Λ) at ε0, ε0/10, ε0/100:", errors)
    # O(ε): each decade of ε takes a decade off every difference (measured ratios 9.5-10.0)
    assert np.all(errors[:-1] / errors[1:] > 7.0)
    assert np.all(errors[-1] < 2e-4)  # measured at ε0/100: ≤ 3.2e-6 (1e8 Pa), ≤ 4.4e-5 (1e9 Pa)


def test_large_bound_is_tied_contact():
    """g → ∞: every pair sticks; the solution is the tied contact on the same active set (a direct KKT solve
    with B_active U = −G_active and C U = c as equalities)."""
    _, qp, op, top, C, c, fac = panel()
    d = solve_tresca_dual(qp, C, c, np.full(qp.m, 1e12), factorization=fac)
    assert np.all(top.states(d.info["T"], np.full(qp.m, 1e12)) == 1)
    act = np.flatnonzero(d.Lambda > 0)
    E = sp.vstack([qp.B[act], C], format="csr")
    K = sp.bmat([[qp.A, E.T], [E, None]], format="csc")
    rhs = np.concatenate([qp.F, -qp.G[act], c])
    x = sp.linalg.spsolve(K, rhs)
    for _ in range(3):  # refinement: the saddle-point matrix mixes entries of 1e11 (A) and 1 (B, C)
        x += sp.linalg.spsolve(K, rhs - K @ x)
    U, mult = x[:qp.n], -x[qp.n:]
    assert rel(d.U, U) < 1e-9  # measured 1.5e-12
    assert rel(d.Lambda[act], mult[:act.size]) < 1e-8
    assert rel(d.info["T"], mult[act.size:]) < 1e-8
    assert np.all(mult[:act.size] > 0)  # the same active set is consistent: compression everywhere


@pytest.mark.parametrize("mu", [0.3, 3.0])
def test_coulomb_full_slip_is_mu_times_normal_force(mu):
    """A 1 mm slide is far beyond the elastic stick range: every touching point slips, and the law's identity
    Σ|T_i| = μ Σ Λ_i|∇Z_i| holds; the force points along the slide (off it only by the cap's curvature)."""
    _, qp, op, top, C, c, fac = panel()
    sol, rec = solve_coulomb(qp, C, c, lambda L: top.coulomb_bounds(op, L, mu), solve_tresca_dual,
                             factorization=fac, cache={})
    T, g = sol.info["T"], sol.info["bounds"]
    state = top.states(T, g, sol.Lambda)
    assert np.count_nonzero(state == 2) >= 6 and np.count_nonzero(state == 1) == 0  # measured: 6 slip, 75 open
    N = op.total_normal_force(sol.Lambda)[0]
    assert np.linalg.norm(T.reshape(-1, 2), axis=1).sum() == pytest.approx(mu * N, rel=1e-8)  # measured 1e-10
    F = top.force(T)[0]
    assert F[0] / np.linalg.norm(F) > 0.99  # along the slide (measured 0.99997 at μ = 3)
    assert 0.9 < F[0] / (mu * N) <= 1.0  # measured 0.984 (μ = 0.3), 0.967 (μ = 3)
    # the fixed point: converged, contraction (geometric mean) measured 0.029 (μ = 0.3, 7 iterations), 0.33 (μ = 3,
    # 19 iterations)
    assert rec.converged and rec.iterations <= 60
    assert rec.contraction < (0.15 if mu < 1 else 0.9)


def test_coulomb_contraction_grows_with_mu():
    """The fixed point's contraction factor grows with μ (measured 0.012, 0.029, 0.11, 0.33 for μ = 0.1, 0.3, 1,
    3; at μ = 5 it does not converge in 50 iterations): the measurement behind the ``friction_contraction``
    warning."""
    _, qp, op, top, C, c, fac = panel()
    cache: dict = {}
    q = [solve_coulomb(qp, C, c, lambda L, mu=mu: top.coulomb_bounds(op, L, mu), solve_tresca_dual,
                       factorization=fac, cache=cache)[1].contraction for mu in (0.1, 1.0, 3.0)]
    assert q[0] < q[1] < q[2] < 1.0


@pytest.mark.parametrize("mu", [0.3, 3.0, 5.0])
def test_anderson_fixed_point_is_coulombs(mu):
    """Anderson's mixing of the bounds (``accelerate``) reaches the plain fixed point's solution in fewer Tresca
    solves (measured 5 vs 7 at μ = 0.3, 10 vs 19 at μ = 3) and, at μ = 5 where the plain iteration falls into a
    2-cycle, a fixed point: its bounds are μ|∇Z|Λ of its own multipliers, the law of Coulomb."""
    _, qp, op, top, C, c, fac = panel()
    runs = [solve_coulomb(qp, C, c, lambda L: top.coulomb_bounds(op, L, mu), solve_tresca_dual, factorization=fac,
                          cache={}, accelerate=acc) for acc in (False, True)]
    (plain, rp), (fast, rf) = runs
    assert rf.converged and rf.acceleration == "anderson"
    g = top.coulomb_bounds(op, fast.Lambda, mu)
    assert np.abs(fast.info["bounds_used"] - g).max() <= 1e-9 * g.max()  # the fixed point's own test
    for name, value in fast.residuals.items():
        assert value < 1e-8, name  # measured ≤ 4e-12
    if mu < 5:
        assert rp.converged and rf.iterations < rp.iterations
        assert rel(fast.U, plain.U) < 1e-9  # measured 1e-11 (Newton), the dual's tolerance
    else:
        assert not rp.converged and rf.iterations <= 30  # measured 11
