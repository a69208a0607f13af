"""docs/architecture.md's "Where to add …" examples, run as written: a new punch shape is one class and
one registration; a contact method and a backend are one registration each."""

from __future__ import annotations

import dataclasses
import math
import re
from pathlib import Path

import numpy as np
import pytest
import scipy.sparse as sp

from shellcontact.errors import InputError
from shellcontact.problem.case import case_from_dict

DOC = (Path(__file__).resolve().parents[1] / "docs" / "architecture.md").read_text()


def _block(after: str) -> str:
    """The first ```python block after the paragraph that starts with ``after``."""
    rest = DOC[DOC.index(after):]
    return re.search(r"```python\n(.*?)```", rest, re.S).group(1)


def _panel(punch: dict, method: str = "active-set") -> dict:
    return {
        "shell": {"radius": 1.0, "length": 1.0, "angle": [60.0, 120.0], "thickness": 0.01, "young": 2.1e11,
                  "poisson": 0.3},
        "mesh": {"nx": 8, "nphi": 8},
        "punch": [punch],
        "solver": {"method": method},
    }


@pytest.fixture(scope="module")
def cone():
    from shellcontact.contact.punches import SHAPES, shapes

    exec(_block("**A punch shape.**"), dict(vars(shapes)))  # registers "cone" in the shape registry
    try:
        yield SHAPES["cone"]
    finally:  # other tests see the registry as shipped
        del SHAPES["cone"]


def test_the_documented_cone_is_a_signed_distance(cone):
    body = cone.build({"center": (0.0, 0.0, 2.0), "axis": (0.0, 0.0, -1.0), "angle": math.radians(60.0)}, "c")
    rng = np.random.default_rng(0)
    X = rng.normal(size=(3, 200)) * 0.5 + np.array([[0.0], [0.0], [1.5]])
    Z, g = body(X)
    assert np.allclose(np.linalg.norm(g, axis=0), 1.0, atol=1e-14)
    # a point at distance r outside the lateral surface, on its normal through a surface point
    h, r = 0.4, 0.05
    surface = np.array([h * math.tan(math.radians(60.0)), 0.0, 2.0 - h])
    normal = np.array([math.cos(math.radians(60.0)), 0.0, math.sin(math.radians(60.0))])
    z, _ = body((surface + r * normal)[:, None])
    assert z[0] == pytest.approx(r, abs=1e-14)


def test_the_documented_cone_presses_a_panel_through_the_case_file(cone):
    punch = {"shape": "cone", "center": [0.0, 0.0, 1.1], "axis": [0.0, 0.0, 1.0], "angle": 60.0,
             "indentation": 1e-3}
    from shellcontact import solve

    forces = {}
    for method in ("active-set", "dual"):
        r = solve(case_from_dict(_panel(punch, method)))
        forces[method] = r.summary()["contact"][0]["force_magnitude"]
    assert forces["active-set"] > 0
    assert forces["dual"] == pytest.approx(forces["active-set"], rel=1e-8)
    with pytest.raises(InputError) as e:
        case_from_dict(_panel({**punch, "angle": 95.0}))
    assert e.value.field == "punch.0.angle"


def test_a_registered_contact_method_is_accepted_everywhere():
    from shellcontact import solve
    from shellcontact.solvers.methods import METHODS, ContactMethod

    documented = eval(_block("**A contact method.**"), {"ContactMethod": ContactMethod})
    assert documented.exact and documented.name == "projected-newton"
    # the same registration, pointing at an existing exact solver
    alias = dataclasses.replace(documented, name="pdas-alias", function="active_set:solve_active_set")
    METHODS[alias.name] = alias
    try:
        punch = {"shape": "sphere", "center": [0.0, 0.0, 1.5], "radius": 0.5, "indentation": 1e-3}
        ref = solve(case_from_dict(_panel(punch)))
        new = solve(case_from_dict(_panel(punch, "pdas-alias")))
        assert np.array_equal(new.solution.U, ref.solution.U)
        assert new.contact.solution.method == "active-set"
    finally:
        del METHODS[alias.name]
    with pytest.raises(InputError):
        case_from_dict(_panel(punch, "pdas-alias"))


def test_a_registered_backend_is_used_by_factorize():
    from shellcontact.linalg import BACKENDS, available_backends, factorize, register
    from shellcontact.linalg.registry import _available

    base = BACKENDS["superlu"]
    register(dataclasses.replace(base, name="superlu-copy", priority=99))
    try:
        assert "superlu-copy" in available_backends()
        n = 50
        A = sp.diags([-1.0, 2.5, -1.0], [-1, 0, 1], shape=(n, n), format="csr")
        b = np.arange(n, dtype=float)
        x = factorize(A, "superlu-copy").solve(b)
        assert np.linalg.norm(A @ x - b) <= 1e-12 * np.linalg.norm(b)
    finally:
        del BACKENDS["superlu-copy"]
        _available.cache_clear()
