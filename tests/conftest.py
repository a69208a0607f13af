"""Shared fixtures for the shell-model tests (paths, rate helper, small solve helper)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="session")
def examples_dir() -> Path:
    """The directory of the example case files."""
    return ROOT / "examples"


@pytest.fixture(scope="session")
def rates():
    """Observed convergence rates log(e_k/e_{k+1}) / log(h_k/h_{k+1}) of an error sequence."""

    def _rates(h, err) -> np.ndarray:
        h, err = np.asarray(h, float), np.asarray(err, float)
        return np.log(err[:-1] / err[1:]) / np.log(h[:-1] / h[1:])

    return _rates


@pytest.fixture(scope="session")
def solve_fe():
    """Assemble and solve the linear shell problem on a given mesh (no case file involved).

    Returns (space, U, A, F, reduction); ``loads`` is a shellcontact.loads.Loads or a full
    load vector.
    """
    from shellcontact import model
    from shellcontact.linalg import factorize
    from shellcontact.loads import load_vector
    from shellcontact.spaces import ShellSpace
    from shellcontact.supports import Reduction

    def _solve(mesh, supports, loads):
        space = ShellSpace(mesh)
        A = model.stiffness(space)
        F = loads if isinstance(loads, np.ndarray) else load_vector(space, loads)
        red = Reduction.build(space, supports)
        U = red.expand(factorize(red.reduce_matrix(A)).solve(red.reduce_vector(F)))
        return space, U, A, F, red

    return _solve
