"""The face factor kept between faces (solvers/face_factor.py): the updated factor against a fresh Cholesky
factorisation of the new face in the same order, for rows that join, rows that leave, and both."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg as sla

from shellcontact.solvers.face import solve_face
from shellcontact.solvers.face_factor import FaceFactor


def _spd(m: int, seed: int = 0) -> np.ndarray:
    """A Schur complement–like SPD matrix: couplings decaying with the distance in row numbers (faces of 250 rows:
    condition ~40–70)."""
    rng = np.random.default_rng(seed)
    X = rng.standard_normal((m, m)) * np.exp(-np.abs(np.subtract.outer(np.arange(m), np.arange(m))) / 20.0)
    return X @ X.T / m + 1e-3 * np.eye(m)


def _factor(ff: FaceFactor, S: np.ndarray, idx: np.ndarray):
    return ff.factor(idx, lambda r, c: S[np.ix_(r, c)], np.diag(S)[idx])


def _check(S: np.ndarray, order: np.ndarray, L: np.ndarray, idx: np.ndarray) -> float:
    """max |L − chol(S[order, order])| / max |L|, after checking ``order`` is a permutation of ``idx``."""
    assert np.array_equal(np.sort(order), idx)
    fresh = sla.cholesky(S[np.ix_(order, order)], lower=True)
    return float(np.abs(L - fresh).max() / np.abs(fresh).max())


@pytest.mark.parametrize("change", ["join", "leave", "both"])
def test_updated_factor_equals_a_fresh_cholesky(change: str) -> None:
    S = _spd(400)
    rng = np.random.default_rng(1)
    ff = FaceFactor()
    idx = np.sort(rng.choice(400, 250, replace=False))
    order, L = _factor(ff, S, idx)
    assert not ff.updated and np.array_equal(order, idx)
    outside = np.setdiff1d(np.arange(400), idx)
    for step in range(4):  # several updates in a row: no error may accumulate from face to face
        # rows leave from the last quarter of the factor (the most recent joins): the update keeps ~3/4 of it
        none = np.zeros(0, dtype=np.int64)
        leave = rng.choice(order[-len(order) // 4 :], 6, replace=False) if change != "join" else none
        join = rng.choice(outside, 8, replace=False) if change != "leave" else none
        idx = np.sort(np.union1d(np.setdiff1d(idx, leave), join))
        outside = np.setdiff1d(np.arange(400), idx)
        order, L = _factor(ff, S, idx)
        assert ff.updated, f"step {step}: the factor was made afresh"
        # measured 2.1e-16 – 7.6e-16 (the same arithmetic as a fresh factorisation, blocked)
        assert _check(S, order, L, idx) < 5e-15
        # the face solved by the kept factor against a dense solve of S_II x = b
        b = np.linspace(-1.0, 2.0, idx.size)
        sol = solve_face(None, b, factor=(np.searchsorted(idx, order), L))
        x = np.linalg.solve(S[np.ix_(idx, idx)], b)
        assert np.abs(sol.x - x).max() < 1e-14 * np.abs(x).max()  # measured 5.1e-16 – 2.5e-15
    assert ff.updates == 4 and ff.fresh == 1


def test_a_face_that_moves_early_rows_is_factorised_afresh() -> None:
    """The first row of the factor leaves: nothing of the old factor can be kept."""
    S = _spd(200)
    ff = FaceFactor()
    _factor(ff, S, np.arange(100))
    order, L = _factor(ff, S, np.arange(1, 120))
    assert not ff.updated and ff.fresh == 2
    assert _check(S, order, L, np.arange(1, 120)) < 5e-15


def test_a_dependent_row_gives_no_factor() -> None:
    """A row that repeats another (the same point twice) has a pivot at round-off: no factor (the caller's pivoted
    factorisation drops it), before and after an update, and the cache is cleared."""
    S = _spd(120)
    S[:, 119] = S[:, 3]
    S[119, :] = S[3, :]
    ff = FaceFactor()
    assert _factor(ff, S, np.arange(100)) is not None
    assert _factor(ff, S, np.append(np.arange(100), 119)) is None
    assert ff.order is None and ff.L is None
