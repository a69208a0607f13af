"""Every sparse backend solves the shell's SPD systems alike; failures are SolverErrors (issue 5, target 2)."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest
import scipy.sparse as sp

from shellcontact import linalg
from shellcontact.errors import InputError, SolverError
from shellcontact.shell import model
from shellcontact.shell.geometry import Shell
from shellcontact.shell.material import Isotropic
from shellcontact.shell.mesh import structured
from shellcontact.shell.spaces import ShellSpace
from shellcontact.shell.supports import Reduction, Supports

BACKENDS = linalg.available_backends()


@pytest.fixture(scope="module")
def shell_system():
    """Clamped thin panel: a fourth-order stiffness with a wide diagonal range (t/a = 1/200)."""
    sh = Shell(radius=2.0, length=3.0, thickness=0.01, material=Isotropic(7e10, 0.3), alpha=0.0, beta=1.2)
    space = ShellSpace(structured(sh, 8, 6))
    A = model.stiffness(space)
    red = Reduction.build(space, Supports())
    return A, red.reduce_matrix(A)


def test_superlu_is_always_there_and_auto_takes_the_first():
    # superlu is always there, so "auto" never reaches a backend after it (mumps: one model over MPI ranks,
    # chosen by name only)
    assert "superlu" in BACKENDS and set(BACKENDS[BACKENDS.index("superlu") + 1 :]) <= {"mumps"}
    assert set(BACKENDS) <= set(linalg.BACKENDS)
    assert BACKENDS == [name for name in linalg.BACKENDS if name in BACKENDS]  # by priority


def test_docs_list_the_registry():
    """docs/solvers.md's backend table is the registry: every backend, its priority and its line."""
    text = (Path(__file__).resolve().parents[1] / "docs" / "solvers.md").read_text()
    rows = re.findall(r"^\| `(\w+)` \| (\d+) \| (.+?) \|$", text, re.M)
    assert rows == [(b.name, str(b.priority), b.doc) for b in linalg.BACKENDS.values()]
    priorities = [b.priority for b in linalg.BACKENDS.values()]
    assert priorities == sorted(priorities)


@pytest.mark.parametrize("backend", BACKENDS)
def test_schur_capability_is_declared(backend):
    """A backend computes Schur complements exactly when its class says so (``supports_schur``);
    otherwise ``border=`` is an InputError. Without a border, and after ``refactor``, ``schur`` is None."""
    from synthetic import plate_qp

    qp = plate_qp(N=12)
    plain = linalg.factorize(qp.A, backend)
    assert plain.schur is None
    if not linalg.BACKENDS[backend].supports_schur:
        with pytest.raises(InputError, match="border"):
            linalg.factorize(qp.A, backend, border=qp.B)
        return
    fac = linalg.factorize(qp.A, backend, border=qp.B)
    assert fac.schur is not None and fac.schur.matches(qp.B) and fac.info()["schur_rows"] == qp.m
    assert fac.refactor(qp.A).schur is None


def test_solve_takes_a_vector_and_solve_many_a_block(shell_system):
    _, A = shell_system
    f = linalg.factorize(A)
    B = np.random.default_rng(2).standard_normal((A.shape[0], 2))
    with pytest.raises(InputError, match="solve_many"):
        f.solve(B)
    with pytest.raises(InputError, match="block"):
        f.solve_many(B[:, 0])
    f.solve_many(B)
    assert f.backward_error <= 1e-14  # the largest over the columns
    raw = f.solve_many(B, refine=False)  # the factors alone, unchecked: backward stable all the same
    R = np.abs(B - A @ raw).max(axis=0)
    assert np.all(R <= 1e-12 * (f.norm_inf * np.abs(raw).max(axis=0) + np.abs(B).max(axis=0)))


#: every registered backend other than SuperLU, the reference: a missing one is a skip that says why
OTHERS = [name for name in linalg.BACKENDS if name != "superlu"]


def _require(backend: str) -> None:
    if backend not in BACKENDS:
        pytest.skip(f"backend {backend!r} is not installed here ({linalg.BACKENDS[backend].doc}): "
                    "nothing to compare with SuperLU")


def test_superlu_solves_as_dense_lapack(shell_system):
    """SuperLU (the reference of the comparisons below) against a dense LAPACK solve of the same equilibrated
    matrix: relative difference measured 3.9e-14 (asserted 2e-13); the stiffness's condition number makes a
    difference up to cond(A) ε possible, so the residual is checked as well."""
    _, A = shell_system
    b = np.random.default_rng(0).standard_normal(A.shape[0])
    x = linalg.factorize(A, "superlu").solve(b)
    x_dense = np.linalg.solve(A.toarray(), b)
    print(f"\nSuperLU vs dense LAPACK: {np.linalg.norm(x - x_dense) / np.linalg.norm(x_dense):.1e}")
    assert np.linalg.norm(x - x_dense) <= 2e-13 * np.linalg.norm(x_dense)
    assert np.linalg.norm(A @ x - b) <= 1e-12 * np.linalg.norm(b)


@pytest.mark.parametrize("backend", OTHERS)
def test_backends_give_the_same_solution(shell_system, backend):
    """Each backend against SuperLU (different orderings and factorisations): measured 8.6e-16 to 8.8e-16
    (PARDISO), 1.1e-15 (CHOLMOD), asserted 1e-14; each one's residual and backward error below 1e-9 and 1e-14."""
    _require(backend)
    _, A = shell_system
    rng = np.random.default_rng(0)
    b = rng.standard_normal(A.shape[0])
    B = rng.standard_normal((A.shape[0], 3))
    ref = linalg.factorize(A, "superlu")
    f = linalg.factorize(A, backend)
    assert f.backend == backend and ref.backend == "superlu"
    x, x_ref = f.solve(b), ref.solve(b)
    print(f"\n{backend} vs SuperLU: {np.linalg.norm(x - x_ref) / np.linalg.norm(x_ref):.1e}")
    assert np.linalg.norm(x - x_ref) <= 1e-14 * np.linalg.norm(x_ref)
    X = f.solve_many(B)
    assert X.shape == B.shape
    assert np.linalg.norm(X - ref.solve_many(B)) <= 1e-14 * np.linalg.norm(X)
    assert f.residual < 1e-9 and f.backward_error < 1e-14


@pytest.mark.parametrize("backend", ["superlu", *OTHERS])
def test_refactor_reuses_the_analysis(shell_system, backend):
    """New values on the same pattern, then a new pattern: the same answer as a dense LAPACK solve (these
    diagonally dominant matrices are well conditioned: measured 8e-16 to 9e-16 for SuperLU and PARDISO,
    asserted 1e-14)."""
    _require(backend)
    _, A = shell_system
    b = np.random.default_rng(1).standard_normal(A.shape[0])
    f = linalg.factorize(A, backend)
    A2 = A.copy()
    A2.data *= 1.0 + 0.2 * np.cos(np.arange(A2.nnz))  # same pattern, new values …
    A2 = sp.csr_matrix(0.5 * (A2 + A2.T)) + sp.diags(np.abs(A).sum(axis=1).A1)  # … still SPD
    fresh = np.linalg.solve(A2.toarray(), b)  # dense LAPACK: a reference independent of every backend
    x = f.refactor(A2).solve(b)
    assert np.linalg.norm(x - fresh) <= 1e-14 * np.linalg.norm(fresh)
    assert np.linalg.norm(A2 @ x - b) <= 1e-9 * np.linalg.norm(b)
    # a different pattern: a new analysis where the backend needs one, same answer
    n = A.shape[0]
    i = np.arange(0, n - 7, 5)
    E = sp.csr_matrix((1e-3 * np.sqrt(A.diagonal()[i] * A.diagonal()[i + 7]), (i, i + 7)), shape=A.shape)
    A3 = sp.csr_matrix(A2 + E + E.T)
    x3 = f.refactor(A3).solve(b)
    fresh3 = np.linalg.solve(A3.toarray(), b)
    assert np.linalg.norm(x3 - fresh3) <= 1e-14 * np.linalg.norm(fresh3)


def test_iterative_refinement_reduces_the_residual(shell_system):
    """Refinement runs against the stored matrix: with the factors of a nearby matrix it still converges."""
    _, A = shell_system
    b = np.random.default_rng(2).standard_normal(A.shape[0])
    f = linalg.factorize(A)
    A_true = A + sp.diags(1e-6 * A.diagonal())
    f.A = A_true  # the factors are now those of an approximation of f.A
    x0 = f.solve(b, refine_steps=0)
    r0 = np.linalg.norm(A_true @ x0 - b)
    x = f.solve(b, refine_steps=30)
    r = np.linalg.norm(A_true @ x - b)
    assert f.refinements >= 2
    assert r < 1e-6 * r0
    exact = linalg.factorize(A_true).solve(b)
    assert np.linalg.norm(x - exact) <= 1e-10 * np.linalg.norm(exact)


def test_forced_backend_by_argument(shell_system):
    _, A = shell_system
    assert linalg.default_backend() == BACKENDS[0]
    assert linalg.factorize(A, "superlu").backend == "superlu"
    assert linalg.factorize(A).backend == BACKENDS[0]
    with pytest.raises(InputError, match="solver.backend"):
        linalg.factorize(A, backend="umfpack")


@pytest.mark.parametrize("backend", BACKENDS)
def test_indefinite_matrix_is_a_solver_error(shell_system, backend):
    _, A = shell_system
    d = A.diagonal()
    s = 1.0 / np.sqrt(d)
    lam_min = np.linalg.eigvalsh((A.multiply(s[:, None]).multiply(s[None, :])).toarray())[0]
    A_ind = sp.csr_matrix(A - 2.0 * lam_min * sp.diags(d))  # positive diagonal, one negative eigenvalue
    assert np.all(A_ind.diagonal() > 0)
    with pytest.raises(SolverError):
        linalg.factorize(A_ind, backend).solve(np.ones(A.shape[0]))


@pytest.mark.parametrize("backend", BACKENDS)
def test_singular_matrix_is_a_solver_error(shell_system, backend):
    A_free, _ = shell_system  # no supports: six rigid-body motions of zero energy
    assert np.all(A_free.diagonal() > 0)
    b = np.random.default_rng(3).standard_normal(A_free.shape[0])
    with pytest.raises(SolverError):
        linalg.factorize(A_free, backend).solve(b)
    Z = sp.csr_matrix(sp.block_diag([A_free[:5, :5], sp.csr_matrix((1, 1))]))
    with pytest.raises(SolverError):
        linalg.factorize(Z, backend)


@pytest.mark.skipif(np.finfo(np.longdouble).eps >= 1e-17, reason="numpy.longdouble is no wider than double here")
@pytest.mark.parametrize("backend", linalg.available_backends())
def test_extended_refinement_reaches_the_working_precision(backend):
    """Clamped beam with 1000 Hermite elements (cond(A) ≈ 1e12): with the residuals in extended
    precision (x86: 64-bit mantissa, ε_r ≈ 1e-19) the forward error drops by about ε/ε_r ≈ 1000
    (measured 4.0e-7 → 4.5e-10; 300 elements 9.3e-9 → 8.7e-12)."""
    from synthetic import beam_qp

    A = beam_qp(n_el=1000).A
    rng = np.random.default_rng(3)
    x_true = rng.standard_normal(A.shape[0])
    b = A.astype(np.longdouble) @ x_true.astype(np.longdouble)  # exact to ~1e-19 relative
    fac = linalg.factorize(A, backend)
    err_plain = np.linalg.norm(fac.solve(b.astype(float)) - x_true) / np.linalg.norm(x_true)
    x = fac.solve(b, extended=True)
    err_ext = np.linalg.norm(x - x_true) / np.linalg.norm(x_true)
    assert err_ext <= 1e-8
    assert err_plain >= 100 * err_ext
    assert fac.refinements >= 1 and fac.backward_error <= 1e-14
    with pytest.raises(InputError, match="one right-hand side"):
        fac.solve(np.ones((A.shape[0], 2)), extended=True)


def test_csr_helpers_match_scipy_and_dense(monkeypatch) -> None:
    """linalg.sparse.triu equals sp.triu, and the chunked ‖A‖∞ the dense one, also with empty rows and
    chunks smaller than a row."""
    import shellcontact.linalg.sparse as la

    rng = np.random.default_rng(3)
    for n in (1, 7, 60):
        A = sp.random(n, n, density=0.3, format="csr", random_state=rng)
        A = (A + A.T).tolil()
        A[n - 1, :] = 0.0
        A = A.tocsr()
        A.eliminate_zeros()
        scale = rng.uniform(0.5, 2.0, n)
        SAS = sp.triu(sp.diags(scale) @ A @ sp.diags(scale))
        dense = float(np.abs(A.toarray()).sum(axis=1).max())
        for chunk in (3, 1 << 22):
            monkeypatch.setattr(la, "CHUNK", chunk)
            U = la.triu(A)
            assert U.nnz == sp.triu(A).nnz and abs(U - sp.triu(A)).sum() == 0.0
            assert abs(la.triu(A, scale) - SAS).max() <= 1e-15 * abs(SAS).max()
            # columns reversed within every row: the result must come out sorted all the same
            order = np.concatenate([np.arange(a, b)[::-1] for a, b in zip(A.indptr[:-1], A.indptr[1:])])
            Us = la.triu(sp.csr_matrix((A.data[order], A.indices[order], A.indptr), shape=A.shape))
            assert Us.has_sorted_indices and abs(Us - sp.triu(A)).sum() == 0.0
            assert la.norm_inf(A) == pytest.approx(dense, rel=1e-14, abs=0.0)
