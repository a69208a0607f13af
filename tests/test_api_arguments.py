"""The Python API fails clearly (issue 12, item 7): a wrong argument type is a TypeError saying what was expected,
a value out of range an InputError naming the argument; NumPy scalars are accepted wherever a number is."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

import shellcontact
from shellcontact import InputError
from shellcontact.inputs.schema import Key
from shellcontact.studies.refinement import convergence
from shellcontact.studies.sweeps import sweep

CASE = {
    "shell": {"radius": 25.0, "length": 25.0, "x_start": 0.0, "angle": [50.0, 90.0], "thickness": 0.25,
              "young": 4.32e8, "poisson": 0.0},
    "supports": {"x_min": "symmetry", "x_max": "simply_supported", "phi_min": "free", "phi_max": "symmetry"},
    "mesh": {"nx": 2, "nphi": 2},
    "loads": {"surface": [0.0, 0.0, -90.0]},
    "probes": [{"x": 0.0, "phi": 50.0}],
}


@pytest.fixture(scope="module")
def case() -> shellcontact.Case:
    return shellcontact.case_from_dict(CASE)


@pytest.fixture
def case_file(tmp_path: Path) -> Path:
    path = tmp_path / "case.toml"
    path.write_text("[shell]\nradius = 25.0\nlength = 25.0\nangle = [50.0, 90.0]\nthickness = 0.25\n"
                    "young = 4.32e8\npoisson = 0.0\n[supports]\nx_min = 'symmetry'\nx_max = 'simply_supported'\n"
                    "phi_min = 'free'\nphi_max = 'symmetry'\n[mesh]\nnx = 2\nnphi = 2\n")
    return path


@pytest.mark.parametrize(
    "call,fragments",
    [
        (lambda c: shellcontact.solve("case.toml"), ["solve()", "shellcontact.Case", "str", "load_case('case.toml')"]),
        (lambda c: shellcontact.solve(CASE), ["solve()", "case_from_dict(data)"]),
        (lambda c: shellcontact.solve(c, method=3), ["solve()", "method must be a string", "'dual'"]),
        (lambda c: shellcontact.solve(c, warm_start="previous"), ["warm_start must be a Result"]),
        (lambda c: shellcontact.solve(c, progress=True), ["progress must be a function"]),
        (lambda c: shellcontact.case_from_dict(["x"]), ["case_from_dict()", "dict of case-file tables", "list"]),
        (lambda c: shellcontact.case_from_dict(CASE, source=3), ["case_from_dict()", "source must be a path"]),
        (lambda c: shellcontact.load_case(3), ["load_case()", "path must be a path", "int"]),
        (lambda c: sweep(c, "shell.thickness", "0.2,0.3"), ["sweep()", "list of numbers", "parse_values"]),
        (lambda c: sweep(c, "shell.thickness", [0.2, "0.3"]), ["sweep()", "every item of values must be a number"]),
        (lambda c: sweep(c, 3, [0.2]), ["sweep()", "param must be a dotted case-file key"]),
        (lambda c: sweep(c, "shell.thickness", [0.2], jobs=2.0), ["sweep()", "jobs must be an integer >= 1", "float"]),
        (lambda c: sweep(c, "shell.thickness", [0.2], jobs=True), ["jobs must be an integer", "bool"]),
        (lambda c: sweep("case.toml", "shell.thickness", [0.2]), ["sweep()", "load_case"]),
        (lambda c: convergence(c, levels="3"), ["convergence()", "levels must be an integer >= 2", "str"]),
    ],
)
def test_wrong_types_are_type_errors(case, call, fragments: list[str]) -> None:
    with pytest.raises(TypeError) as info:
        call(case)
    for fragment in fragments:
        assert fragment in str(info.value), (fragment, str(info.value))


def test_sets_must_be_a_list(case_file: Path) -> None:
    with pytest.raises(TypeError, match=r"sets must be a list of strings .*got str 'mesh.nx=3'; wrap it in a list"):
        shellcontact.load_case(case_file, sets="mesh.nx=3")
    with pytest.raises(TypeError, match="every item of sets must be a string"):
        shellcontact.load_case(case_file, sets=[("mesh.nx", 3)])
    assert shellcontact.load_case(case_file, sets=("mesh.nx=3",)).mesh.nx == 3  # any iterable of strings


@pytest.mark.parametrize(
    "call,field,fragment",
    [
        (lambda c: sweep(c, "shell.thickness", [0.2], jobs=0), "jobs", "must be an integer >= 1, got 0"),
        (lambda c: sweep(c, "shell.thickness", []), "--values", "no values given"),
        (lambda c: shellcontact.solve(c, method="magic"), "method", "'active-set'"),
        (lambda c: shellcontact.solve(c, backend="gpu"), "backend", "'auto'"),
        (lambda c: convergence(c, levels=1), "--levels", ">= 2"),
        (lambda c: shellcontact.load_case(""), "path", "empty path"),
    ],
)
def test_values_out_of_range_are_input_errors(case, call, field: str, fragment: str) -> None:
    with pytest.raises(InputError) as info:
        call(case)
    assert info.value.field == field and fragment in info.value.message, str(info.value)


NUMBER = Key("x", "number", "a number", lo=0.0)
INTEGER = Key("n", "integer", "an integer", lo=1)
FLAG = Key("flag", "bool", "a flag")
VECTOR = Key("v", "vector", "a vector")


@pytest.mark.parametrize("value", [np.float64(0.25), np.float32(0.25), np.int64(2), np.int8(2), np.uint16(2)])
def test_numpy_numbers_are_numbers(value) -> None:
    parsed = NUMBER.parse(value, "x")
    assert type(parsed) is float and parsed == float(value)


@pytest.mark.parametrize("value", [np.int64(3), np.int32(3), np.uint8(3)])
def test_numpy_integers_are_integers(value) -> None:
    parsed = INTEGER.parse(value, "n")
    assert type(parsed) is int and parsed == 3


def test_numpy_floats_are_not_integers() -> None:
    with pytest.raises(InputError, match="must be an integer, got float 3.0"):
        INTEGER.parse(np.float64(3.0), "n")


def test_numpy_bools_are_bools_not_numbers() -> None:
    """np.bool_ is taken exactly like Python's bool: a bool for a bool key, refused as a number."""
    assert FLAG.parse(np.bool_(True), "flag") is True and FLAG.parse(np.bool_(False), "flag") is False
    for key in (NUMBER, INTEGER):
        with pytest.raises(InputError, match="got bool True"):
            key.parse(np.bool_(True), key.name)
    with pytest.raises(InputError, match="true or false"):
        FLAG.parse(np.int64(1), "flag")


def test_numpy_arrays_are_lists() -> None:
    assert VECTOR.parse(np.array([1.0, 2.0, 3.0]), "v") == (1.0, 2.0, 3.0)
    assert VECTOR.parse([np.float32(1.5), np.int64(2), 3.0], "v") == (1.5, 2.0, 3.0)
    with pytest.raises(InputError, match="list of 3 numbers"):
        VECTOR.parse(np.ones(2), "v")


def test_numpy_values_in_a_case_dictionary(case) -> None:
    """The same case with NumPy scalars and arrays everywhere a number is: the same validated case."""
    data = {
        **CASE,
        "shell": {**CASE["shell"], "radius": np.float64(25.0), "angle": np.array([50.0, 90.0]),
                  "thickness": np.float32(0.25), "young": np.int64(432_000_000)},
        "mesh": {"nx": np.int64(2), "nphi": np.int32(2)},
        "loads": {"surface": np.array([0.0, 0.0, -90.0])},
    }
    numpy_case = shellcontact.case_from_dict(data)
    assert numpy_case.shell == case.shell and numpy_case.mesh == case.mesh and numpy_case.loads == case.loads


def test_numpy_sweep_arguments(case) -> None:
    res = sweep(case, "shell.thickness", np.array([0.2, 0.25]), jobs=np.int64(1), figures=False)
    assert res.values == [0.2, 0.25] and all(math.isfinite(r["energy"]) for r in res.rows)
