"""The friction pairs' products from A bordered by the normal and tangential rows (``solvers.pair_block``)
against blocked solves with a plain factorisation, and the Tresca and whole-law Newtons on it against the same
Newtons with a solve per pair and against the dual (another algorithm, every candidate row), on the paper's
panel, 16 × 16 (169 candidate rows)."""

from __future__ import annotations

import numpy as np
import pytest
from test_tresca import panel, rel

from shellcontact.solvers import solve_active_set
from shellcontact.solvers.coulomb_newton import solve_friction_newton
from shellcontact.solvers.pair_block import PairBlock, border_rows, factorize_pairs, pair_rows
from shellcontact.solvers.schur import Workspace
from shellcontact.solvers.tresca import solve_tresca_dual
from shellcontact.solvers.tresca_newton import solve_tresca_newton
from shellcontact.solvers.tresca_screened import solve_tresca_screened


@pytest.fixture(scope="module")
def joint():
    _, qp, op, top, C, c, fac = panel(16)
    free = solve_active_set(qp, factorization=fac)
    rows = border_rows(free.Lambda, qp.gap(free.U, free.delta))
    jf = factorize_pairs(qp, C, rows)
    assert jf is not None and rows.size == int(np.ceil(2 * (free.Lambda > 0).sum()))
    return qp, op, top, C, c, fac, free, rows, jf


@pytest.mark.parametrize("joined", [0, 7])  # rows after the border's (one solve A⁻¹[B_e; C_e]ᵀ each)
def test_products_equal_solves(joint, joined):
    qp, op, top, C, c, fac, free, rows, jf = joint
    outside = np.setdiff1d(np.arange(qp.m), rows)[:joined]
    order = np.concatenate([rows, outside])
    sub, Cs = qp.restrict(order), C[pair_rows(order)]
    assert PairBlock.applies(sub, jf)
    block = PairBlock(sub, Cs, jf, order)
    pairs = np.arange(0, rows.size, 3)
    BX, CX = block.products(pairs)
    X = fac.solve_many(Cs[pair_rows(pairs)].T.toarray())  # refined solves with the plain factorisation
    assert rel(BX, sub.B @ X) < 1e-11  # measured 2.2e-12 (16 × 16; 2.3e-10 at 211k unknowns)
    assert rel(CX, Cs @ X) < 5e-12  # measured 8.7e-13


def test_tresca_newton_on_the_block_equals_pair_solves_and_the_dual(joint):
    """The case's Tresca (1e7 Pa on the rows of the frictionless contact set), 1 mm slide: the Newton on the border's
    rows with the joint factorisation, the same Newton on every row with a solve per pair, and the dual."""
    qp, op, top, C, c, fac, free, rows, jf = joint
    g = np.where(free.Lambda > 0, top.tresca_bounds(op.weights, 1e7), 0.0)
    initial = np.concatenate([free.Lambda, np.zeros(2 * qp.m)])
    cache: dict = {}
    s = solve_tresca_screened(qp, C, c, g, solve_tresca_newton, rows, jf, cache, initial=initial)
    assert "block" in cache["inner"] and s.info["fallback"] is None  # the products came from the block
    old = solve_tresca_newton(qp, C, c, g, factorization=fac, initial=initial)
    d = solve_tresca_dual(qp, C, c, g, factorization=fac)
    for name, value in s.residuals.items():
        assert value < 5e-11, name  # measured ≤ 7.5e-12
    for ref in (old, d):
        assert rel(s.U, ref.U) < 5e-11  # measured 4.4e-12 (pair solves), 8.2e-12 (dual)
        assert rel(s.Lambda, ref.Lambda) < 3e-10  # measured 3.2e-11, 5.5e-11
        assert rel(s.info["T"], ref.info["T"]) < 5e-11  # measured 5.3e-13, 6.0e-12


def test_whole_law_newton_on_the_block_equals_pair_solves(joint):
    """Coulomb μ = 0.3 by the whole-law Newton, on the border's rows (joint factorisation) and on every row with a
    solve per pair (a plain Workspace): the same solution."""
    qp, op, top, C, c, fac, free, rows, jf = joint
    law = np.stack([0.3 * np.linalg.norm(op.grad, axis=0), np.zeros(qp.m)], axis=1)
    initial = np.concatenate([free.Lambda, np.zeros(2 * qp.m)])
    cache: dict = {}
    s = solve_tresca_screened(qp, C, c, law, solve_friction_newton, rows, jf, cache, initial=initial, max_iterations=30)
    old = solve_friction_newton(qp, C, c, law, factorization=fac, initial=initial, max_iterations=30,
                                cache={"ws": Workspace(qp, fac, substructure=False)})
    assert s.info["fallback"] is None and old.info["fallback"] is None
    assert "block" in cache["inner"]
    assert rel(s.U, old.U) < 3e-11  # measured 4.4e-12
    assert rel(s.Lambda, old.Lambda) < 3e-10  # measured 3.1e-11
    assert rel(s.info["T"], old.info["T"]) < 3e-10  # measured 3.1e-11
