"""Tresca friction on the screened rows (``solvers.tresca_screened``: the pipeline's factorisation bordered by
the rows predicted to touch, reused by the Newton) against the dual on every candidate row (another algorithm,
no screening, a plain factorisation) on the paper's panel, 16 × 16 (169 candidate rows, 65 screened)."""

from __future__ import annotations

import numpy as np
import pytest
from test_tresca import panel, rel

from shellcontact.solvers import solve_active_set
from shellcontact.solvers.screening import factorize_screened, solve_screened
from shellcontact.solvers.tresca import solve_tresca_dual
from shellcontact.solvers.tresca_newton import solve_tresca_newton
from shellcontact.solvers.tresca_screened import solve_tresca_screened


@pytest.fixture(scope="module")
def screened():
    _, qp, op, top, C, c, fac = panel(16)
    bordered, screen = factorize_screened(qp, op.punch, min_unknowns=0)  # bordered at any size
    assert screen is not None and screen.size < qp.m
    free = solve_screened(qp, screen, solve_active_set, bordered)
    return qp, op, top, C, c, fac, bordered, screen, free


@pytest.mark.parametrize("rows", ["screened", "three"])  # the screened rows; only 3 of them (rows join later)
@pytest.mark.parametrize("start", ["frictionless", "none"])
def test_screened_newton_equals_the_dual(screened, rows, start):
    """The case's Tresca (1e7 Pa on the rows of the frictionless contact set), 1 mm axial slide. Started from
    the frictionless solution, the rows in contact join at once; started from nothing on 3 rows with the bound
    on 4 rows only, the rows outside penetrate and join in a second round."""
    qp, op, top, C, c, fac, bordered, screen, free = screened
    g = np.where(free.Lambda > 0, top.tresca_bounds(op.weights, 1e7), 0.0)
    if start == "none":
        g[np.flatnonzero(g)[4:]] = 0.0
    d = solve_tresca_dual(qp, C, c, g, factorization=fac)
    initial = np.concatenate([free.Lambda, np.zeros(2 * qp.m)]) if start == "frictionless" else None
    s = solve_tresca_screened(qp, C, c, g, solve_tresca_newton, screen if rows == "screened" else screen[:3],
                              bordered, {}, initial=initial)
    rounds = s.info["screening"]["rounds"]
    assert rounds == (2 if (start, rows) == ("none", "three") else 1) and s.info["screening"]["rows"][-1] < qp.m
    for name, value in s.residuals.items():
        assert value < 1e-9, name  # measured ≤ 7.8e-12
    assert rel(s.U, d.U) < 1e-9  # measured 9e-12
    assert rel(s.Lambda, d.Lambda) < 5e-10  # measured 5.4e-11
    assert rel(s.info["T"], d.info["T"]) < 1e-9  # measured 6e-12
