"""The QP with half-line and disc constraints (the dual of Tresca friction, MODEL.md §11), checked against a
general-purpose constrained minimiser (scipy's SLSQP on the same convex problem) and against the law."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import minimize

from shellcontact.solvers.disc_qp import disc_qp, project


def random_problem(seed: int, m: int, p: int, cond: float = 1e3, load: float = 3.0):
    rng = np.random.default_rng(seed)
    n = m + 2 * p
    Q, _ = np.linalg.qr(rng.normal(size=(n, n)))
    H = Q @ np.diag(np.geomspace(1.0, cond, n)) @ Q.T
    c = rng.normal(size=n) * load
    g = rng.uniform(0.0, 1.5, size=p)
    g[0] = 0.0  # a disc that is a point
    return H, c, m, g


def reference(H, c, m, g):
    """SLSQP from several starts, the best: an independent minimiser of the same problem."""
    n = c.size
    cons = [{"type": "ineq", "fun": lambda y, i=i: y[i], "jac": lambda y, i=i: np.eye(n)[i]} for i in range(m)]
    for j in range(g.size):
        k = m + 2 * j

        def disc(y, k=k, j=j):
            return g[j] ** 2 - y[k] ** 2 - y[k + 1] ** 2

        def ddisc(y, k=k):
            out = np.zeros(n)
            out[k:k + 2] = -2 * y[k:k + 2]
            return out
        cons.append({"type": "ineq", "fun": disc, "jac": ddisc})
    best = None
    for y0 in (np.zeros(n), project(-np.linalg.solve(H, c), m, g)):
        r = minimize(lambda y: 0.5 * y @ H @ y + c @ y, y0, jac=lambda y: H @ y + c, constraints=cons,
                     method="SLSQP", options={"ftol": 1e-15, "maxiter": 2000})
        if best is None or r.fun < best.fun:
            best = r
    return best.x


@pytest.mark.parametrize("seed", [0, 1, 3, 4, 5])  # seed 2 has no Λ > 0
def test_disc_qp_matches_slsqp(seed):
    H, c, m, g = random_problem(seed, m=5, p=6)
    hist: list = []
    y, its, ok = disc_qp(H, c, m, g, tol=1e-12, history=hist)
    assert ok
    ref = reference(H, c, m, g)
    # measured: |y − y_ref| ≤ ~1e-9 (SLSQP's own accuracy); the energies agree to ~1e-14 relative
    assert np.max(np.abs(y - ref)) < 1e-6 * max(1.0, np.abs(ref).max())
    f = lambda z: 0.5 * z @ H @ z + c @ z  # noqa: E731
    assert f(y) <= f(project(ref, m, g)) + 1e-12 * abs(f(ref))  # SLSQP ends slightly infeasible
    # the problem exercises every case: some Λ = 0 and > 0, discs inside (stick) and on their circle (slip)
    T = np.linalg.norm(y[m:].reshape(-1, 2), axis=1)
    print(seed, its, "iterations", [h["step"] for h in hist].count("face"), "face steps")
    assert np.all(T <= g * (1 + 1e-12))
    assert np.any(y[:m] == 0) and np.any(y[:m] > 0) and np.any(T >= g * (1 - 1e-12)) and np.any(T[1:] < 0.99 * g[1:])
    assert its <= 40  # measured 4-11


def test_disc_qp_law_slip_opposes_gradient():
    """At the solution the gradient on a disc in slip is −κ T/|T| (κ ≥ 0): the slip opposes the force."""
    H, c, m, g = random_problem(11, m=3, p=8, cond=1e4, load=30.0)
    y, _, ok = disc_qp(H, c, m, g, tol=1e-13)
    assert ok
    grad = H @ y + c
    T, G = y[m:].reshape(-1, 2), grad[m:].reshape(-1, 2)
    r = np.linalg.norm(T, axis=1)
    slip = (r >= g * (1 - 1e-9)) & (g > 0)
    stick = r < g * (1 - 1e-6)
    assert slip.any() and stick.any()
    cross = T[:, 0] * G[:, 1] - T[:, 1] * G[:, 0]
    scale = np.abs(c).max()
    assert np.all(np.abs(cross[slip]) <= 1e-9 * scale * g[slip])  # parallel
    assert np.all(np.sum(T * G, axis=1)[slip] <= 1e-9 * scale)  # antiparallel
    assert np.all(np.abs(G[stick]) <= 1e-9 * scale)  # stick: no slip


def singular_problem(seed: int, m: int = 6, p: int = 4, rank: int = 5):
    """A dual Hessian of rank 5 < 14, built element by element (no BLAS: the same round-off on every machine): two
    half-lines carry the same row (a ring's repeated node), the discs' second components are unseen by H (the
    circumferential slip of a symmetric panel). c = J w + s with s ≥ 0 on the half-lines only: bounded below
    (c·v = s·v ≥ 0 along every null direction v with v_Λ ≥ 0)."""
    rng = np.random.default_rng(seed)
    n = m + 2 * p
    J = rng.normal(size=(n, rank))
    J[1] = J[0]
    J[m + 1::2] = 0.0
    H = (J[:, None, :] * J[None, :, :]).sum(-1)
    s = np.zeros(n)
    s[:m] = rng.uniform(0.0, 0.5, size=m)
    s[1] = s[0]
    c = (J * rng.normal(size=rank)).sum(1) + s
    return H, c, m, rng.uniform(0.1, 1.0, size=p)


@pytest.mark.parametrize("seed", [3, 16, 23])
def test_disc_qp_singular_hessian(seed):
    """The stall of issue 26: a face whose Hessian is singular. The old face step solved it by a Cholesky that
    either failed or passed on round-off pivots (a 1e32 step), or dropped the part of the gradient the face's Hessian
    does not see: 1000 face steps without progress on these seeds (of seeds 0-199, 26 failed within 200 iterations;
    now 0, in ≤ 15 iterations). Checked against the projected-gradient fixed point y = P(y − ∇f) and SLSQP's energy."""
    H, c, m, g = singular_problem(seed)
    hist: list = []
    y, its, ok = disc_qp(H, c, m, g, tol=1e-10, max_iterations=200, history=hist)
    assert ok and its <= 40  # measured 9, 12, 9
    grad = H @ y + c
    assert np.abs(y - project(y - grad, m, g)).max() <= 2e-15 * np.abs(c).max()  # KKT: measured ≤ 2.4e-16
    f = lambda z: 0.5 * z @ H @ z + c @ z  # noqa: E731
    n = c.size
    cons = [{"type": "ineq", "fun": lambda z, i=i: z[i]} for i in range(m)]
    cons += [{"type": "ineq", "fun": lambda z, k=m + 2 * j, j=j: g[j] ** 2 - z[k] ** 2 - z[k + 1] ** 2}
             for j in range(g.size)]
    ref = minimize(f, np.zeros(n), jac=lambda z: H @ z + c, constraints=cons, method="SLSQP",
                   options={"ftol": 1e-15, "maxiter": 2000})
    assert f(y) <= f(project(ref.x, m, g)) + 4e-15 * abs(f(y))  # SLSQP's energy: measured ≤ 5.4e-16 relative
