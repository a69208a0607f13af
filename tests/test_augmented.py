"""solvers.augmented: one factorisation of K = A + B_I0ᵀ R B_I0 for a predicted active set I0.

Checked against the exact active-set method on the synthetic QPs of test_solvers (same U and
forces, every scaled KKT residual ≤ 1e-10); with the right prediction no refactorisation, no
Schur column and one active-set round; with a wrong prediction the same exact answer (PDAS
rounds with numeric refactorisations of K, or the fallback to the active set on A).
"""

from __future__ import annotations

import numpy as np
import pytest
from synthetic import beam_qp, plate_qp, random_qp

from shellcontact.errors import InputError
from shellcontact.linalg import factorize
from shellcontact.solvers import solve_active_set
from shellcontact.solvers.augmented import AugmentedInverse, augmentation, solve_augmented

TOL = 1e-10
CASES = {
    "random": lambda: random_qp(n=30, m=10, seed=0),
    "beam-point": lambda: beam_qp(n_el=64, radius=0.3, indentation=0.01),
    "beam-zone": lambda: beam_qp(n_el=64, radius=1.0, indentation=0.0, load=2000.0),
    "plate-point": lambda: plate_qp(N=24),
    "plate-zone": lambda: plate_qp(N=24, indentation=0.0, load=2000.0, radius=2.0),
}


def _rel(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.linalg.norm(a - b) / max(np.linalg.norm(b), 1e-300))


def _check(sol, ref) -> None:
    assert all(v <= TOL for v in sol.info["scaled_residuals"].values()), sol.info["scaled_residuals"]
    assert np.array_equal(sol.active, ref.active)
    assert _rel(sol.U, ref.U) <= 1e-8
    assert _rel(sol.Lambda, ref.Lambda) <= 1e-6


@pytest.mark.parametrize("name", list(CASES))
def test_right_prediction_one_round_no_columns(name: str) -> None:
    qp = CASES[name]()
    assert qp.k == 0
    ref = solve_active_set(qp, factorization=factorize(qp.A))
    K, r = augmentation(qp, ref.active)
    sol = solve_augmented(qp, ref.active, r, factorize(K))
    _check(sol, ref)
    assert sol.iterations == 1 and sol.info["refactorizations"] == 0 and sol.timings["schur_columns"] == 0


@pytest.mark.parametrize("name", ["beam-zone", "plate-zone", "random"])
@pytest.mark.parametrize("wrong", ["extra", "missing", "empty"])
def test_wrong_prediction_same_exact_answer(name: str, wrong: str) -> None:
    qp = CASES[name]()
    ref = solve_active_set(qp, factorization=factorize(qp.A))
    I0 = ref.active.copy()
    if wrong == "extra":
        I0[np.flatnonzero(~I0)[:2]] = True
    elif wrong == "missing":
        I0[np.flatnonzero(I0)[:2]] = False
    else:
        I0[:] = False
    K, r = augmentation(qp, I0)
    sol = solve_augmented(qp, I0, r, factorize(K))
    _check(sol, ref)
    assert sol.info["fallback_from"] == "augmented"  # exact active set, A⁻¹ by Woodbury on the same factors
    assert sol.info["woodbury_columns"] == int(I0.sum())
    # the optional numeric refactorisations of K for the updated set reach the same answer
    sol2 = solve_augmented(qp, I0, r, factorize(K), max_refactor=2)
    _check(sol2, ref)


def test_woodbury_inverse_is_a_inverse() -> None:
    qp = CASES["plate-zone"]()
    I0 = np.zeros(qp.m, dtype=bool)
    I0[::3] = True
    K, r = augmentation(qp, I0)
    rows = np.flatnonzero(r > 0)
    inv = AugmentedInverse(qp.A, factorize(K), qp.B[rows], r[rows], rows=rows)
    b = np.random.default_rng(0).standard_normal((qp.n, 3))
    x = inv.solve(b)
    fA = factorize(qp.A)
    assert _rel(x, fA.solve(b)) <= 1e-9
    assert _rel(qp.A @ x, b) <= 1e-12
    # the Schur columns S[:, I0] it provides without solves
    got_rows, cols = inv.schur_columns(qp.B)
    assert np.array_equal(got_rows, rows)
    assert _rel(cols, qp.B @ fA.solve(qp.B[rows].T.toarray())) <= 1e-8


@pytest.mark.parametrize("max_add", [4, 16])
def test_active_set_max_add_same_answer(max_add: int) -> None:
    qp = CASES["plate-zone"]()
    fact = factorize(qp.A)
    ref = solve_active_set(qp, factorization=fact)
    sol = solve_active_set(qp, factorization=fact, max_add=max_add)
    _check(sol, ref)


def test_force_control_rejected() -> None:
    qp = random_qp(n=12, m=4, seed=1, force=True)
    assert qp.k > 0
    with pytest.raises(InputError):
        augmentation(qp, np.zeros(qp.m, dtype=bool))
