"""solvers.face_update: face solves of a changing working set through one factor bordered by the rows that joined
and left, against dense linear algebra (S = B A⁻¹ Bᵀ and S_II x = r by numpy), and the active set with the
bordered faces against the same method refactorising every face (same active set and multipliers)."""

from __future__ import annotations

import numpy as np
import pytest
from synthetic import plate_qp

from shellcontact.solvers import solve_active_set
from shellcontact.solvers.face_update import UpdatedFace
from shellcontact.solvers.schur import Workspace


def _dense_S(qp) -> np.ndarray:
    B = qp.B.toarray()
    return B @ np.linalg.solve(qp.A.toarray(), B.T)


def test_a_bordered_face_solves_the_face_it_replaces() -> None:
    """Working sets that each move a few rows against the first (some leave, some join): every answer equals
    numpy's solve of the dense S_II x = r to round-off (measured: ≤ 2.8e-13 relative), and the
    factor was bordered, not refactorised, for all but the first."""
    qp = plate_qp(N=24, indentation=0.0, load=2000.0, radius=2.0)
    ws = Workspace(qp, substructure=False)
    S = _dense_S(qp)
    rng = np.random.default_rng(3)
    face = UpdatedFace(ws)
    base = np.sort(rng.choice(qp.m, size=qp.m // 2, replace=False))
    others = np.setdiff1d(np.arange(qp.m), base)
    sets = [base]
    for step in range(1, 5):  # cumulative changes stay below REBASE_SHARE of the set
        left = base[rng.choice(base.size, size=2 * step, replace=False)]
        joined = others[rng.choice(others.size, size=step, replace=False)]
        sets.append(np.union1d(np.setdiff1d(base, left), joined))
    for idx in sets:
        r = rng.standard_normal(idx.size)
        x, singular = face.solve(idx, r)
        ref = np.linalg.solve(S[np.ix_(idx, idx)], r)
        assert not singular
        assert np.linalg.norm(x - ref) <= 3e-12 * np.linalg.norm(ref)
    assert face.counts == {"refactorised": 1, "bordered": len(sets) - 1}


def test_a_set_far_from_the_base_refactorises() -> None:
    """A working set that shares less than 3/4 of its rows with the base gets a new factor (the bordered system
    would cost more than the factor); its answer is numpy's."""
    qp = plate_qp(N=24, indentation=0.0, load=2000.0, radius=2.0)
    ws = Workspace(qp, substructure=False)
    S = _dense_S(qp)
    face = UpdatedFace(ws)
    face.solve(np.arange(0, qp.m // 2), np.ones(qp.m // 2))
    idx = np.arange(qp.m // 4, qp.m)
    x, _ = face.solve(idx, np.ones(idx.size))
    assert face.counts == {"refactorised": 2, "bordered": 0}
    ref = np.linalg.solve(S[np.ix_(idx, idx)], np.ones(idx.size))
    assert np.linalg.norm(x - ref) <= 1e-10 * np.linalg.norm(ref)


def _demo_qp():
    from pathlib import Path

    from shellcontact.analysis import discretize
    from shellcontact.case import load_case

    case = load_case(Path(__file__).resolve().parents[1] / "examples/paper_panel.toml", ["mesh.nx=24", "mesh.nphi=24"])
    return discretize(case).qp()


@pytest.mark.parametrize("make", [_demo_qp, lambda: plate_qp(N=24, indentation=0.0, load=2000.0, radius=2.0)])
def test_the_active_set_with_bordered_faces_gives_the_refactorised_answer(make) -> None:
    """Same active set and multipliers (to 1e-9 of the largest) with and without the bordered faces, the result a
    KKT point (every scaled residual ≤ the tolerance), and faces were bordered (demo at 24 × 24: measured 6 of
    the 26 face solves bordered)."""
    qp = make()
    new = solve_active_set(qp, update_face=True)
    old = solve_active_set(qp, update_face=False)
    assert np.array_equal(new.active, old.active)
    assert np.max(np.abs(new.Lambda - old.Lambda)) <= 1e-9 * np.max(np.abs(old.Lambda))
    assert max(new.info["scaled_residuals"].values()) <= 1e-10
    assert new.info["faces"]["bordered"] >= 1
    assert old.info["faces"] is None
