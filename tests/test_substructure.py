"""solvers.substructure and linalg.bordered: S = B A⁻¹ Bᵀ from the PARDISO Schur complement of the
bordered matrix M.

Checked against dense linear algebra on the synthetic QPs (S = B A⁻¹ Bᵀ by numpy), the solves
against A, the contact solvers against the same solvers with one sparse solve per Schur column
(same active set, every scaled KKT residual ≤ 1e-10), and the fallbacks (other backend, other B,
refactorisation with another matrix).
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp
from synthetic import beam_qp, plate_qp

from shellcontact.linalg import available_backends, factorize
from shellcontact.solvers import solve_active_set, solve_dual
from shellcontact.solvers.schur import Workspace
from shellcontact.solvers.substructure import factorize_contact

HAS_PARDISO = "pardiso" in available_backends()
CASES = {
    "beam-zone": lambda: beam_qp(n_el=64, radius=1.0, indentation=0.0, load=2000.0),
    "plate-point": lambda: plate_qp(N=24),
    "plate-zone": lambda: plate_qp(N=24, indentation=0.0, load=2000.0, radius=2.0),
}


def _dense_S(qp) -> np.ndarray:
    B = qp.B.toarray()
    return B @ np.linalg.solve(qp.A.toarray(), B.T)


@pytest.mark.skipif(not HAS_PARDISO, reason="the Schur complement needs PARDISO, not installed here (the other "
                    "backends' plain factorisation: test_other_backend_or_small_is_plain_factorization)")
@pytest.mark.parametrize("name", list(CASES))
def test_schur_columns_equal_dense(name: str) -> None:
    qp = CASES[name]()
    fac = factorize_contact(qp.A, qp.B, min_unknowns=0)
    assert fac.schur is not None and fac.schur.matches(qp.B)
    S = _dense_S(qp)
    cols = np.arange(qp.m)
    got = fac.schur.columns(cols)
    assert np.max(np.abs(got - S)) <= 1e-8 * np.max(np.abs(S))
    # the same factors solve with A (first block of M⁻¹[b; 0]), refined against A
    b = np.random.default_rng(1).standard_normal(qp.n)
    x = fac.solve(b)
    x_ref = np.linalg.solve(qp.A.toarray(), b)
    assert np.linalg.norm(x - x_ref) <= 1e-10 * np.linalg.norm(x_ref)
    X = fac.solve_many(np.column_stack([b, 2 * b]))
    assert np.linalg.norm(X[:, 1] - 2 * x_ref) <= 1e-10 * np.linalg.norm(2 * x_ref)


@pytest.mark.parametrize("name", list(CASES))
@pytest.mark.parametrize("solver", [solve_active_set, solve_dual])
def test_contact_solvers_same_answer(name: str, solver) -> None:
    qp = CASES[name]()
    ref = solver(qp, factorization=factorize(qp.A))
    sol = solver(qp, factorization=factorize_contact(qp.A, qp.B, min_unknowns=0))
    assert all(v <= 1e-10 for v in sol.info["scaled_residuals"].values()), sol.info["scaled_residuals"]
    assert np.array_equal(sol.active, ref.active)
    assert np.linalg.norm(sol.U - ref.U) <= 1e-8 * np.linalg.norm(ref.U)
    assert np.linalg.norm(sol.Lambda - ref.Lambda) <= 1e-6 * np.linalg.norm(ref.Lambda)
    if HAS_PARDISO:  # no sparse solve per Schur column
        assert sol.timings["schur_columns"] > 0
        assert sol.timings["n_solves"] < ref.timings["n_solves"]


def test_workspace_uses_schur_only_for_its_rows() -> None:
    qp = CASES["plate-zone"]()
    fac = factorize_contact(qp.A, qp.B, min_unknowns=0)
    ws = Workspace(qp, fac)
    assert (ws.dense_schur is not None) == HAS_PARDISO
    assert Workspace(qp, fac, substructure=False).dense_schur is None
    other = qp.B.tolil()
    other[0, other.rows[0][0]] *= 2.0
    qp2 = type(qp)(qp.A, qp.F, sp.csr_matrix(other), qp.G, qp.weights)
    assert Workspace(qp2, fac).dense_schur is None  # a different B: columns by solves
    ws_new = Workspace(qp, substructure=True)  # factorises itself
    assert (ws_new.dense_schur is not None) == HAS_PARDISO
    S = _dense_S(qp)
    idx = np.array([0, qp.m // 2, qp.m - 1])
    for w in (ws, ws_new):
        assert np.max(np.abs(w.columns(idx) - S[:, idx])) <= 1e-8 * np.max(np.abs(S))


def test_refactor_drops_schur_and_solves_new_matrix() -> None:
    qp = CASES["plate-point"]()
    fac = factorize_contact(qp.A, qp.B, min_unknowns=0)
    A2 = (qp.A + sp.diags(np.full(qp.n, 1e-3 * qp.A.diagonal().max()))).tocsr()
    fac.refactor(A2)
    assert fac.schur is None
    assert Workspace(qp, fac).dense_schur is None
    b = np.ones(qp.n)
    x_ref = np.linalg.solve(A2.toarray(), b)
    assert np.linalg.norm(fac.solve(b) - x_ref) <= 1e-10 * np.linalg.norm(x_ref)


def test_other_backend_or_small_is_plain_factorization() -> None:
    qp = CASES["plate-point"]()
    fac = factorize_contact(qp.A, qp.B, backend="superlu", min_unknowns=0)
    assert fac.backend == "superlu" and fac.schur is None
    assert Workspace(qp, fac).dense_schur is None
    assert factorize_contact(qp.A, qp.B).schur is None  # below MIN_UNKNOWNS: plain
    assert factorize_contact(qp.A, qp.B, max_rows=qp.m - 1, min_unknowns=0).schur is None


@pytest.mark.parametrize("name", ["beam-zone", "plate-zone"])
def test_bordered_matrix_equals_its_definition(name: str) -> None:
    """linalg.bordered.bordered_upper = triu([[A + ρBᵀB, −ρBᵀ], [−ρB, ρI]]) built by sparse blocks,
    both when ρBᵀB lies inside A's pattern (added in place) and when it does not (the sparse-sum
    fallback)."""
    from shellcontact.linalg.bordered import bordered_upper
    from shellcontact.linalg.sparse import equilibrate

    qp = CASES[name]()
    scale, As = equilibrate(qp.A, upper=True)
    Bs = (qp.B @ sp.diags(scale)).tocsr()
    rho = 0.7

    def reference(U: sp.csr_matrix) -> np.ndarray:
        K = U + sp.triu(rho * (Bs.T @ Bs))
        return sp.bmat([[K, -rho * Bs.T], [None, rho * sp.identity(qp.m)]]).toarray()

    got = bordered_upper(As.copy(), Bs, rho)
    assert got.has_sorted_indices
    assert np.array_equal(got.toarray(), reference(As))
    # drop an off-diagonal entry that ρBᵀB needs from the pattern: the fallback path
    K = sp.triu(Bs.T @ Bs).tocoo()
    i, j = next((a, b) for a, b in zip(K.row, K.col) if a != b)
    holed = As.tolil()
    holed[i, j] = 0.0
    holed = holed.tocsr()
    holed.eliminate_zeros()
    got = bordered_upper(holed.copy(), Bs, rho)
    assert got.has_sorted_indices
    assert np.allclose(got.toarray(), reference(holed), rtol=0.0, atol=1e-15)


# -- the border's weight: ρ = 1 / (an estimate of S_ii) -------------------------------------------------------
def _shell_qp(sets: list[str], path: str = "examples/paper_panel.toml"):
    from pathlib import Path

    from shellcontact.analysis.discretization import discretize
    from shellcontact.problem.case import load_case

    case = load_case(Path(__file__).resolve().parents[1] / path, sets)
    d = discretize(case)
    return d, d.qp()


@pytest.mark.parametrize("path, sets", [
    ("examples/paper_panel.toml", ["mesh.nx=24", "mesh.nphi=24"]),
    ("examples/ring_stiffness.toml", []),
])
def test_the_flexibility_estimate_is_near_the_schur_diagonal(path: str, sets: list[str]) -> None:
    """contact.point_flexibility (a plate on the hoop-membrane foundation) against S_ii = B_i A⁻¹ B_iᵀ from
    solves: the same order of magnitude (measured 2.2 and 9.4 here), which is what weighing the border
    needs (ρ S_ii near 1: the error of S grows with log ρ S_ii either way, bordered.border_weight)."""
    from shellcontact.solvers.screening import initial_rows

    d, qp = _shell_qp(sets, path)
    rows = initial_rows(qp.G, d.operator.punch)
    pick = rows[np.linspace(0, rows.size - 1, 12).astype(int)]
    B = qp.B[pick]
    S_ii = np.einsum("ij,ji->i", B.toarray(), factorize(qp.A).solve_many(B.T.toarray()))
    ratio = S_ii / qp.flexibility[pick]
    assert np.all((ratio > 1.0) & (ratio < 20.0)), ratio


@pytest.mark.skipif(not HAS_PARDISO, reason="the Schur complement needs PARDISO")
def test_a_border_weighed_by_the_flexibility_gives_S() -> None:
    """The weight ρ = 1/mean(flexibility) is the one used, and S from that bordered factorisation equals
    B A⁻¹ Bᵀ from refined solves (to 1e-9 of its size), its columns cached and equal when asked again."""
    from shellcontact.linalg.bordered import border_weight
    from shellcontact.solvers.screening import initial_rows

    d, qp = _shell_qp(["mesh.nx=24", "mesh.nphi=24"])
    rows = initial_rows(qp.G, d.operator.punch)
    fac = factorize_contact(qp.A, qp.B[rows], min_unknowns=0, flexibility=qp.flexibility[rows])
    assert fac.schur.rho == pytest.approx(1.0 / np.mean(qp.flexibility[rows]), rel=1e-14)
    assert border_weight(sp.csr_matrix(np.ones((2, 3))), 4.0) == 0.25
    cols = np.linspace(0, rows.size - 1, 10).astype(int)
    B = qp.B[rows]
    ref = B @ factorize(qp.A).solve_many(B[cols].T.toarray())
    got = fac.schur.columns(cols)
    assert np.max(np.abs(got - ref)) <= 1e-9 * np.max(np.abs(ref))
    again = fac.schur.columns(cols[::-1])
    assert np.array_equal(again, got[:, ::-1])


@pytest.mark.skipif(not HAS_PARDISO, reason="the Schur complement needs PARDISO")
def test_a_coarser_level_picks_the_border_when_the_overlap_rule_would_border_too_many(monkeypatch) -> None:
    """solver.nested = "auto": once the overlap's rule (a third of the candidate rows) would border more than
    screening.NESTED_ROWS rows, the case is solved on mesh.refine − 1 first and the gaps of that solution on
    this mesh pick the border (screening.predicted_rows). Here the limit is lowered so that a small panel takes
    that path: its border, and the rows screening adds to it, are fewer than the overlap's rule's, and the answer
    is the cold start's to the tolerance."""
    from pathlib import Path

    import shellcontact
    from shellcontact.problem.case import load_case
    from shellcontact.solvers import screening

    path = Path(__file__).resolve().parents[1] / "examples/paper_panel.toml"
    sets = ["mesh.nx=16", "mesh.nphi=16", "mesh.refine=1", "solver.substructure=true"]
    cold = shellcontact.solve(load_case(path, sets))
    assert "nested_iterations" not in cold.info  # "auto" at the default limit: the overlap's rule
    monkeypatch.setattr(screening, "NESTED_ROWS", 10)
    warm = shellcontact.solve(load_case(path, sets))
    assert "nested_iterations" in warm.info
    rows_cold, rows_warm = (r.contact.solution.info["screening"] for r in (cold, warm))
    # measured: 74 rows, then 4 penetrating rows joined (78), against the overlap rule's 209 of 625
    assert rows_warm["rows"][-1] < 0.6 * rows_cold["rows"][0]
    assert np.array_equal(warm.contact.active, cold.contact.active)
    f_cold, f_warm = (r.summary()["contact"][0]["force_magnitude"] for r in (cold, warm))
    assert f_warm == pytest.approx(f_cold, rel=1e-8)
    forced_off = shellcontact.solve(load_case(path, [*sets, "solver.nested=false"]))
    assert "nested_iterations" not in forced_off.info


def test_a_nested_start_reports_the_finest_level_alone(caplog) -> None:
    """The coarser levels of a nested start (``solver.nested``) are solved for their displacements only
    (pipeline._solve_coarse): their contact zone, rim and summary are not made, so the paper panel's warning (its
    deflection equals the thickness) is logged once, by the finest level, and not once per level (3 times before).
    The answer is the cold start's (to the tolerance), the coarse levels' iterations are reported."""
    import logging
    from pathlib import Path

    import shellcontact
    from shellcontact.problem.case import load_case

    path = Path(__file__).resolve().parents[1] / "examples/paper_panel.toml"
    sets = ["mesh.nx=8", "mesh.nphi=8", "mesh.refine=2"]
    cold = shellcontact.solve(load_case(path, sets))
    with caplog.at_level(logging.WARNING):
        caplog.clear()
        warm = shellcontact.solve(load_case(path, [*sets, "solver.nested=true"]))
    logged = [r.getMessage() for r in caplog.records if "deflection is large" in r.getMessage()]
    assert len(logged) == 1, logged
    assert len(warm.info["nested_iterations"]) == 2  # [[refine 0], refine 1's iterations]
    assert np.array_equal(warm.contact.active, cold.contact.active)
    f_cold, f_warm = (r.summary()["contact"][0]["force_magnitude"] for r in (cold, warm))
    assert f_warm == pytest.approx(f_cold, rel=1e-9)
