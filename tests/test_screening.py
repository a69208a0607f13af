"""solvers.screening: the Schur complement of a predicted row set, the other rows verified.

Checked against the same solvers on the whole QP (same U, Λ, active set, KKT residuals ≤ 1e-10),
with a good prediction (one round) and a deliberately wrong one (the shallowest rows: several rounds,
the Schur columns of the added rows by solves, reused between rounds), and against dense S.
"""

from __future__ import annotations

import copy

import numpy as np
import pytest
from synthetic import beam_qp, plate_qp

from shellcontact.errors import InputError
from shellcontact.linalg import available_backends, factorize
from shellcontact.solvers import kkt_residuals, solve_active_set, solve_dual, solve_penalty
from shellcontact.solvers.schur import Workspace
from shellcontact.solvers.screening import initial_rows, predicted_rows, solve_screened, solve_screened_curve
from shellcontact.solvers.substructure import factorize_contact

HAS_PARDISO = "pardiso" in available_backends()
CASES = {
    "plate-zone": lambda: plate_qp(N=24, indentation=0.0, load=2000.0, radius=2.0),
    "beam-force": lambda: beam_qp(n_el=64, radius=1.0, indentation=0.0, force=50.0),
}


def test_initial_rows_per_group() -> None:
    G = np.array([5.0, -1.0, 0.0, 3.0, -2.0, 7.0, -9.0, 1.0])
    groups = np.array([0, 0, 0, 0, 1, 1, 1, 1])
    assert initial_rows(G, groups, fraction=0.5, min_rows=1).tolist() == [1, 2, 4, 6]
    assert initial_rows(G, groups, fraction=0.25, min_rows=3).tolist() == [1, 2, 3, 4, 6, 7]
    assert initial_rows(G, None, fraction=0.25, min_rows=1).tolist() == [4, 6]
    assert initial_rows(G, groups, fraction=1.0, min_rows=1).size == 8
    # ties with the last row taken are taken too: a uniform overlap gives G no say, so all rows
    flat = np.full(9, -2e-4)
    assert initial_rows(flat, None, fraction=1 / 3, min_rows=1).size == 9
    G2 = np.array([-3.0, -2.0, -2.0, -2.0, 1.0, 4.0])
    assert initial_rows(G2, None, fraction=1 / 3, min_rows=1).tolist() == [0, 1, 2, 3]
    with pytest.raises(InputError, match="screening.fraction"):
        initial_rows(G, groups, fraction=0.0)


def test_predicted_rows_per_group() -> None:
    """The rows whose predicted gap is within margin × scale of touching, per punch, at least min_rows each."""
    g = np.array([5.0, -1.0, 0.5, 3.0, 2.0, 7.0, 0.9, 1.2])
    groups = np.array([0, 0, 0, 0, 1, 1, 1, 1])
    assert predicted_rows(g, 10.0, groups, margin=0.1, min_rows=1).tolist() == [1, 2, 6]
    assert predicted_rows(g, 10.0, groups, margin=0.01, min_rows=2).tolist() == [1, 2, 6, 7]
    assert predicted_rows(g, 10.0, None, margin=0.0, min_rows=1).tolist() == [1]
    assert predicted_rows(g, 10.0, groups, margin=1.0, min_rows=1).size == 8


@pytest.mark.parametrize("name", list(CASES))
@pytest.mark.parametrize("solver", [solve_active_set, solve_dual], ids=["active-set", "dual"])
@pytest.mark.parametrize("prediction", ["deepest", "shallowest"])
def test_screened_equals_whole(name: str, solver, prediction: str) -> None:
    qp = CASES[name]()
    ref = solver(qp, factorization=factorize(qp.A))
    order = np.argsort(qp.G, kind="stable")
    k = max(4, qp.m // 4)
    rows = np.sort(order[:k] if prediction == "deepest" else order[-k:])
    fac = factorize_contact(qp.A, qp.B[rows], min_unknowns=0)
    sol = solve_screened(qp, rows, solver, fac, tol=1e-10)
    scr = sol.info["screening"]
    assert scr["rows"][0] == k and scr["candidates"] == qp.m
    if prediction == "shallowest":  # the touching rows are missing at first: more rounds, more rows
        assert scr["rounds"] > 1 and scr["rows"][-1] > k
    assert np.array_equal(sol.active, ref.active)
    assert np.linalg.norm(sol.U - ref.U) <= 1e-8 * np.linalg.norm(ref.U)
    assert np.max(np.abs(sol.Lambda - ref.Lambda)) <= 1e-8 * np.max(np.abs(ref.Lambda))
    assert np.all(sol.Lambda[np.setdiff1d(np.arange(qp.m), rows)][~sol.active[np.setdiff1d(np.arange(qp.m), rows)]]
                  == 0.0)
    assert max(sol.info["scaled_residuals"].values()) <= 1e-10
    # the reported residuals are those of the whole QP
    res = kkt_residuals(qp, sol.U, sol.Lambda, sol.delta, fac)
    assert res["penetration"] == pytest.approx(sol.residuals["penetration"], abs=1e-14 * np.abs(qp.G).max())
    assert np.allclose(sol.info["gap"], qp.gap(sol.U, sol.delta))


@pytest.mark.parametrize("name", list(CASES))
@pytest.mark.parametrize("prediction", ["deepest", "shallowest", "all but the weakest"])
def test_screened_penalty_equals_whole(name: str, prediction: str) -> None:
    """The penalty method on the screened rows: an outside row joins as soon as it penetrates at all (each
    penetrating row carries a penalty force), so the result is the penalty solution of the whole QP, to the
    round-off of its Newton system; with the shallowest rows first, over several rounds (warm-started from
    the previous round's U); and with every penetrating row but the one of the weakest force, which must
    join in a later round. (These cases do not tell the zero threshold from a small positive one: no outside
    row here ends penetrating by less than 1e-3 of the length scale; the last assertion states the property.)"""
    qp = CASES[name]()
    eps = 1e-8
    ref = solve_penalty(qp, epsilon=eps, factorization=factorize(qp.A))
    order = np.argsort(qp.G, kind="stable")
    k = max(4, qp.m // 4)
    if prediction == "all but the weakest":
        act = np.flatnonzero(ref.active)
        rows = np.setdiff1d(act, act[np.argmin(ref.Lambda[act])])
    else:
        rows = np.sort(order[:k] if prediction == "deepest" else order[-k:])
    fac = factorize_contact(qp.A, qp.B[rows], min_unknowns=0)
    sol = solve_screened(qp, rows, solve_penalty, fac, tol=1e-10, exact=False, epsilon=eps)
    scr = sol.info["screening"]
    if prediction != "deepest":
        assert scr["rounds"] > 1
    assert sol.method == "penalty" and sol.info["epsilon"] == eps
    assert np.array_equal(sol.active, ref.active)
    assert np.linalg.norm(sol.U - ref.U) <= 1e-8 * np.linalg.norm(ref.U)
    assert np.max(np.abs(sol.Lambda - ref.Lambda)) <= 1e-8 * np.max(np.abs(ref.Lambda))
    assert np.all(qp.gap(sol.U, sol.delta)[~sol.active] >= 0.0)  # no penetrating row without its force


CURVE_POINTS = {
    "beam-force": lambda: beam_qp(n_el=64, radius=1.0, indentation=0.0, force=50.0),
    "plate-indentation": lambda: plate_qp(N=24, indentation=0.004, radius=2.0),
}


def _points(name: str) -> list:
    """Points of a curve on one QP (A, F and B shared): the beam's punch at four forces (P differs), the
    plate's at four indentations 1.7 … 6 mm (G shifted; the rows of the 4 mm indentation)."""
    qp = CURVE_POINTS[name]()
    points = []
    for s in (0.3, 0.6, 1.0, 1.6):
        p = copy.copy(qp)
        if qp.P is not None:
            p.P = s * qp.P
        else:
            p.G = qp.G - (s - 1.0) * 0.0033  # indentation 4 mm + (s − 1) × 3.3 mm
        points.append(p)
    return points


@pytest.mark.parametrize("name", list(CURVE_POINTS))
@pytest.mark.parametrize("solver", [solve_active_set, solve_dual], ids=["active-set", "dual"])
@pytest.mark.parametrize("prediction", ["good", "shallowest"])
def test_curve_points_share_their_final_solves_and_equal_lone_solves(name: str, solver, prediction: str) -> None:
    """solve_screened_curve: each point is its lone screened solve (active set, U, Λ to 1e-8, KKT ≤ 1e-10).
    With a good prediction (the deepest half of the rows and every row any point touches) every point's
    final check runs on the block solves; with the shallowest rows the touching rows are outside at first,
    so points run alone (``solve_screened``) and still agree."""
    points = _points(name)
    qp = points[0]
    order = np.argsort(qp.G, kind="stable")
    if prediction == "good":
        touching = np.flatnonzero(np.any([solver(p, factorization=factorize(p.A)).active for p in points], axis=0))
        rows = np.union1d(order[: qp.m // 2], touching)
        assert rows.size < qp.m  # some rows stay outside: their check is the block solves'
    else:
        rows = np.sort(order[-max(4, qp.m // 4):])
    fac = factorize_contact(qp.A, qp.B[rows], min_unknowns=0)
    curve = list(solve_screened_curve(points, rows, solver, fac, tol=1e-10))
    shared = [sol.info["curve"]["shared_final_solves"] for sol in curve]
    assert all(shared) if prediction == "good" else not all(shared)
    for p, sol in zip(points, curve):
        ref = solve_screened(p, rows, solver, factorize_contact(p.A, p.B[rows], min_unknowns=0), tol=1e-10)
        assert sol.active.any()
        assert np.array_equal(sol.active, ref.active)
        assert np.linalg.norm(sol.U - ref.U) <= 1e-8 * np.linalg.norm(ref.U)
        assert np.max(np.abs(sol.Lambda - ref.Lambda)) <= 1e-8 * np.max(np.abs(ref.Lambda))
        assert max(sol.info["scaled_residuals"].values()) <= 1e-10
        res = kkt_residuals(p, sol.U, sol.Lambda, sol.delta, fac)  # the whole QP's, evaluated afresh
        assert res["duality_gap"] == pytest.approx(sol.residuals["duality_gap"], abs=1e-12)
        assert res["stationarity"] == pytest.approx(sol.residuals["stationarity"], rel=1e-6, abs=1e-16)


def test_a_failing_curve_point_comes_after_the_points_before_it() -> None:
    """A point whose solve fails: the points before it are finished and yielded, then its error is raised."""
    from shellcontact.errors import SolverError

    points = _points("beam-force")
    calls = []

    def solver(qp, **kw):
        calls.append(1)
        if len(calls) == 3:
            raise SolverError("active-set: no convergence to tolerance 1e-10", iterations=1)
        return solve_active_set(qp, **kw)

    got = []
    with pytest.raises(SolverError, match="no convergence"):
        for sol in solve_screened_curve(points, None, solver, factorize(points[0].A)):
            got.append(sol)
    assert len(got) == 2 and all(s.info["curve"]["shared_final_solves"] for s in got)
    for p, sol in zip(points, got):
        assert np.array_equal(sol.active, solve_active_set(p).active)


def test_curve_points_must_share_stiffness_load_and_rows() -> None:
    points = _points("beam-force")
    other = copy.copy(points[1])
    other.B = 2.0 * other.B
    with pytest.raises(InputError, match="point 1"):
        solve_screened_curve([points[0], other], None, solve_active_set, factorize(points[0].A))


@pytest.mark.skipif(not HAS_PARDISO, reason="the dense Schur complement needs PARDISO")
def test_workspace_prefix_schur_and_reuse() -> None:
    qp = CASES["plate-zone"]()
    B = qp.B.toarray()
    S = B @ np.linalg.solve(qp.A.toarray(), B.T)
    rows = np.arange(0, qp.m, 3)
    rest = np.setdiff1d(np.arange(qp.m), rows)
    fac = factorize_contact(qp.A, qp.B[rows], min_unknowns=0)
    first, second = rest[: rest.size // 2], rest[rest.size // 2 :]
    order = np.concatenate([rows, first])
    ws = Workspace(qp.restrict(order), fac)
    assert ws.dense_schur is not None and ws.extra.shape == (order.size, first.size)
    solves = ws.n_solves
    idx = np.arange(order.size)
    assert np.max(np.abs(ws.columns(idx) - S[np.ix_(order, order)])) <= 1e-8 * np.abs(S).max()
    # the next round extends the rows: only the new rows' columns are solved for
    order2 = np.concatenate([order, second])
    ws2 = Workspace(qp.restrict(order2), fac)
    assert ws2.n_solves - 1 == second.size  # U0 = A⁻¹F is the one other solve
    assert ws.n_solves - 1 == first.size and solves == ws.n_solves
    idx2 = np.arange(order2.size)
    assert np.max(np.abs(ws2.columns(idx2) - S[np.ix_(order2, order2)])) <= 1e-8 * np.abs(S).max()


@pytest.mark.skipif(not HAS_PARDISO, reason="the substructured path needs PARDISO")
def test_solve_takes_the_screened_path_and_agrees() -> None:
    """analysis.solve on the paper panel at 52k unknowns (above substructure.MIN_UNKNOWNS): the
    screened, substructured path gives the active set, forces and KKT level of the plain path
    ([solver] substructure = false: one sparse solve per Schur column), for an exact method and for the
    penalty method."""
    from pathlib import Path

    from shellcontact import load_case, solve

    path = Path(__file__).resolve().parent.parent / "src" / "shellcontact" / "cases" / "paper_panel.toml"
    for method in ("active-set", "penalty"):
        screened = solve(load_case(path, ["mesh.nx=56", "mesh.nphi=56"]), method=method)
        plain = solve(load_case(path, ["mesh.nx=56", "mesh.nphi=56", "solver.substructure=false"]), method=method)
        scr = screened.contact.solution.info["screening"]
        assert screened.info["unknowns"] >= 40_000 and scr["rows"][0] < scr["candidates"]
        assert "screening" not in plain.contact.solution.info
        assert np.array_equal(screened.contact.active, plain.contact.active)
        f_s, f_p = (r.contact.summary()[0]["force_magnitude"] for r in (screened, plain))
        # the penalty's force is a penetration times 1/ε (ε = 4.8e-16 of the stiffness scale at the end of its
        # continuation), so the two factorisations' round-off reaches it amplified: measured 1.3e-8 on an AMD
        # EPYC (MKL's AMD code path), below 1e-8 on Intel; the exact method's force agrees to round-off
        assert f_s == pytest.approx(f_p, rel=1e-8 if method == "active-set" else 1e-7)
        if method == "active-set":
            assert max(screened.summary()["kkt_scaled"].values()) <= 1e-10
        else:  # the penalised equation's backward error, as the penalty's own stopping test
            assert screened.contact.solution.info["continuation"][-1]["backward_error"] <= 1e-10


@pytest.mark.skipif(not HAS_PARDISO, reason="the substructured path needs PARDISO")
def test_substructure_option_forces_the_path_below_the_threshold() -> None:
    """[solver] substructure = true takes the screened, substructured path below
    substructure.MIN_UNKNOWNS too ("auto" does not there), with the same answer."""
    from pathlib import Path

    from shellcontact import load_case, solve

    path = Path(__file__).resolve().parent.parent / "src" / "shellcontact" / "cases" / "paper_panel.toml"
    small = ["mesh.nx=20", "mesh.nphi=20"]
    auto = solve(load_case(path, small))
    forced = solve(load_case(path, [*small, "solver.substructure=true"]))
    assert auto.info["unknowns"] < 40_000
    assert "screening" not in auto.contact.solution.info and "screening" in forced.contact.solution.info
    assert np.array_equal(forced.contact.active, auto.contact.active)
    f_f, f_a = (r.contact.summary()[0]["force_magnitude"] for r in (forced, auto))
    assert f_f == pytest.approx(f_a, rel=1e-8)
