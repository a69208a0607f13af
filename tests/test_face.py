"""The face solve of the exact methods (solvers/face.py) on faces made singular on purpose: a contact row repeated
(dependent rows of S_II) and two columns of D that the face cannot tell apart (S_d singular). Reference: the same
face with the repeated row, or the repeated column, removed by hand, solved by a dense KKT solve (numpy). The
face's x is unique in both cases (the row's force is shared, the column's δ is a reparametrisation), so the
forces and the gaps' change D_I δ must agree to round-off."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp

from shellcontact.solvers.face import _bordered, independent_cholesky, solve_face
from shellcontact.solvers.qp import ContactQP
from shellcontact.solvers.schur import Workspace


def _flexibility(B: np.ndarray, seed: int = 1) -> np.ndarray:
    """S = B A⁻¹ Bᵀ for an SPD A of order B.shape[1]."""
    rng = np.random.default_rng(seed)
    M = rng.standard_normal((B.shape[1], B.shape[1]))
    A = M @ M.T + B.shape[1] * np.eye(B.shape[1])
    return B @ np.linalg.solve(A, B.T)


def _kkt(H: np.ndarray, D: np.ndarray, rhs: np.ndarray, rhs2: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    n, k = D.shape
    K = np.block([[H, D], [D.T, np.zeros((k, k))]])
    sol = np.linalg.solve(K, np.concatenate([rhs, rhs2]))
    return sol[:n], sol[n:]


def test_a_repeated_row_is_dropped_and_its_force_goes_to_its_twin() -> None:
    rng = np.random.default_rng(0)
    B = rng.standard_normal((4, 9))
    B = np.vstack([B, B[1]])  # row 4 repeats row 1: S_II has rank 4
    H = _flexibility(B)
    rhs = rng.standard_normal(5)
    rhs[4] = rhs[1]  # consistent: the repeated row asks for the same gap
    _, keep = independent_cholesky(H)
    assert keep.size == 4 and (1 in keep) != (4 in keep)
    sol = solve_face(H, rhs)
    assert sol.singular and sol.dropped_rows.size == 1
    reference = np.linalg.solve(H[:4, :4], rhs[:4])
    shared = sol.x[[0, 2, 3]], sol.x[1] + sol.x[4]
    assert np.allclose(shared[0], reference[[0, 2, 3]], rtol=1e-10) and shared[1] == pytest.approx(reference[1], 1e-10)
    assert np.abs(H @ sol.x - rhs).max() <= 1e-12 * np.abs(rhs).max()


def test_columns_of_D_the_face_cannot_tell_apart_are_flagged_and_one_is_dropped() -> None:
    """Before, numpy.linalg.solve returned an arbitrary δ from the round-off-singular S_d with no flag."""
    rng = np.random.default_rng(2)
    B = rng.standard_normal((3, 8))
    H = _flexibility(B)
    d0 = np.array([-1.0, -0.8, -0.9])
    D = np.column_stack([d0, 2.0 * d0])  # on this face the second column is twice the first
    rhs, p = rng.standard_normal(3), 0.7
    sol = solve_face(H, rhs, D, np.array([p, 2.0 * p]))
    assert sol.singular and sol.dropped_columns.size == 1 and sol.dropped_rows.size == 0
    assert sol.delta[sol.dropped_columns[0]] == 0.0
    x_ref, delta_ref = _kkt(H, D[:, :1], rhs, np.array([p]))
    assert np.allclose(sol.x, x_ref, rtol=1e-10, atol=1e-12 * np.abs(x_ref).max())
    assert np.allclose(D @ sol.delta, D[:, :1] @ delta_ref, rtol=1e-10)
    # a regular face is not flagged and solves the full system
    full = solve_face(H, rhs, np.column_stack([d0, [0.3, -0.2, 0.5]]), np.array([p, 0.1]))
    assert not full.singular


def test_the_workspace_says_a_face_of_one_row_does_not_determine_two_motions() -> None:
    """The case of the rigid push (tests/test_edges.py): one row on the face, two columns of D (a translation and
    a rotation it sees): S_d is 2 x 2 of rank 1. The workspace flags it and counts it."""
    rng = np.random.default_rng(3)
    n = 12
    M = rng.standard_normal((n, n))
    A = sp.csr_matrix(M @ M.T + n * np.eye(n))
    B = sp.csr_matrix(rng.standard_normal((3, n)))
    D = np.array([[-1.0, 0.0], [-1.0, -0.11], [-1.0, 0.2]])
    qp = ContactQP(A=A, F=np.zeros(n), B=B, G=np.array([-1e-3, -4e-4, 1e-3]), weights=np.ones(3), D=D,
                   P=np.zeros(2))
    ws = Workspace(qp)
    x, delta, singular = ws.face_solve(np.array([1]), -ws.c0[[1]], -qp.P)
    assert singular and ws.dependent_faces == 1
    assert x[0] == pytest.approx(0.0, abs=1e-12) and (qp.D[1] @ delta) == pytest.approx(-ws.c0[1], rel=1e-12)
    x, delta, singular = ws.face_solve(np.array([0, 1]), -ws.c0[[0, 1]], -qp.P)
    assert not singular and delta[0] == pytest.approx(-1e-3, rel=1e-12)


def test_the_bordered_face_system_is_solved_when_regular_and_refused_when_singular() -> None:
    """A face with a row the clamp holds (S_ii = 0: a zero row and column of S_II) is singular, but [[S, D], [Dᵀ, 0]]
    is regular when D sees that row: ``_bordered`` (one LU, its condition estimate as the test) gives numpy's dense
    KKT solution; when no column of D sees the row, the bordered matrix is singular too and it returns None."""
    rng = np.random.default_rng(3)
    B = np.vstack([rng.standard_normal((3, 7)), np.zeros((1, 7))])  # row 3: held by a clamp, S_33 = 0
    H = _flexibility(B)
    rhs, rhs2 = rng.standard_normal(4), np.array([1.0])
    D = np.array([[0.0], [0.0], [0.0], [-1.0]])
    got = _bordered(H, D, rhs, rhs2)
    x, delta = _kkt(H, D, rhs, rhs2)
    assert got is not None
    assert np.allclose(got, np.concatenate([x, delta]), rtol=1e-12, atol=1e-12)  # measured: equal to 1e-16
    blind = np.array([[-1.0], [0.0], [0.0], [0.0]])  # D does not see the held row: singular
    assert _bordered(H, blind, rhs, rhs2) is None
