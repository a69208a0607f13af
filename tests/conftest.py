"""Shared fixtures for the shell-model tests (paths, rate helper, small solve helper)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]

try:  # the fuzzer's profiles (tests/test_fuzz.py): `make test` runs "subset", `make fuzz` "fuzz"
    from hypothesis import HealthCheck, settings
except ImportError:  # the dev extra is not installed: test_fuzz.py then fails to import, by name
    pass
else:
    _slow = [HealthCheck.too_slow, HealthCheck.data_too_large, HealthCheck.filter_too_much]
    # a fixed seed: the same few hundred cases on every machine and every run (75 per template)
    settings.register_profile("subset", max_examples=75, derandomize=True, deadline=None, database=None,
                              suppress_health_check=_slow, print_blob=True)
    # 2 500 per template, 10 000 in all, new ones each run (failures are kept in .hypothesis/)
    settings.register_profile("fuzz", max_examples=2500, deadline=None, suppress_health_check=_slow,
                              print_blob=True)
    settings.load_profile("subset")


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

    Returns (space, U, A, F, reduction); ``loads`` is a shellcontact.shell.loads.Loads or a full
    load vector.
    """
    from shellcontact.linalg import factorize
    from shellcontact.shell import model
    from shellcontact.shell.loads import load_vector
    from shellcontact.shell.spaces import ShellSpace
    from shellcontact.shell.supports import Reduction

    def _solve(mesh, supports, loads):
        space = ShellSpace(mesh)
        A = model.stiffness(space)
        F = loads if isinstance(loads, np.ndarray) else load_vector(space, loads)
        red = Reduction.build(space, supports)
        U = red.expand(factorize(red.reduce_matrix(A)).solve(red.reduce_vector(F)))
        return space, U, A, F, red

    return _solve
