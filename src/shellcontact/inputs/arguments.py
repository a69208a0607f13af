"""Checks of the Python API's arguments (``solve``, ``load_case``, ``case_from_dict``, ``sweep``, ...).

A wrong Python type is a ``TypeError`` that names the function, the argument and what was expected
(``solve("case.toml")`` says to call ``load_case`` first); a value of the right type outside its
range is an ``InputError`` naming the argument. NumPy scalars are accepted wherever a Python number
is (``np.int64`` for an integer, ``np.float32`` for a number); ``bool`` and ``np.bool_`` are not
numbers. Only the standard library is imported here.
"""

from __future__ import annotations

import numbers
import os
from collections.abc import Iterable
from typing import Any

from ..errors import InputError


def described(value: Any) -> str:
    """A value as error messages show it: its type and its repr, shortened."""
    text = repr(value)
    return f"{type(value).__name__} {text if len(text) <= 60 else text[:57] + '...'}"


def expect_path(value: Any, function: str, name: str, optional: bool = False) -> None:
    """``value`` must be a str or os.PathLike (or None if ``optional``), and not empty."""
    if value is None and optional:
        return
    if not isinstance(value, (str, os.PathLike)):
        what = "a path (str or os.PathLike)" + (" or None" if optional else "")
        raise TypeError(f"{function}(): {name} must be {what}, got {described(value)}")
    if not os.fspath(value):
        raise InputError(name, "must name a file or directory, got an empty path")


def expect_strings(value: Any, function: str, name: str, example: str) -> list[str]:
    """``value`` must be an iterable of str, not a str itself (``sets=["mesh.refine=1"]``)."""
    if isinstance(value, (str, bytes)) or not isinstance(value, Iterable):
        raise TypeError(f"{function}(): {name} must be a list of strings such as [{example!r}], got {described(value)}"
                        + ("; wrap it in a list" if isinstance(value, str) else ""))
    items = list(value)
    for item in items:
        if not isinstance(item, str):
            raise TypeError(f"{function}(): every item of {name} must be a string such as {example!r}, "
                            f"got {described(item)}")
    return items


def expect_integer(value: Any, function: str, name: str, lo: int) -> int:
    """An integer >= ``lo`` (NumPy integers too; bools refused)."""
    if not isinstance(value, numbers.Integral) or isinstance(value, bool) or type(value).__name__ == "bool_":
        raise TypeError(f"{function}(): {name} must be an integer >= {lo}, got {described(value)}")
    if value < lo:
        raise InputError(name, f"must be an integer >= {lo}, got {value}")
    return int(value)


def expect_numbers(value: Any, function: str, name: str) -> list[float | int]:
    """A non-empty sequence of real numbers (NumPy scalars and 1-D arrays too; not a string)."""
    if hasattr(value, "tolist") and type(value).__module__ == "numpy":
        value = value.tolist()
    if isinstance(value, (str, bytes)) or not isinstance(value, Iterable):
        hint = "; parse a CLI spec with shellcontact.studies.sweeps.parse_values" if isinstance(value, str) else ""
        raise TypeError(f"{function}(): {name} must be a list of numbers, got {described(value)}{hint}")
    items = list(value)
    for item in items:
        if not isinstance(item, numbers.Real) or isinstance(item, bool):
            raise TypeError(f"{function}(): every item of {name} must be a number, got {described(item)}")
    return items


def expect_callable(value: Any, function: str, name: str) -> None:
    if value is not None and not callable(value):
        raise TypeError(f"{function}(): {name} must be a function or None, got {described(value)}")


def expect_choice(value: Any, function: str, name: str, choices: Iterable[str]) -> None:
    """None or one of ``choices`` (a registry's names)."""
    if value is None:
        return
    names = list(choices)
    if not isinstance(value, str):
        raise TypeError(f"{function}(): {name} must be a string, one of {', '.join(map(repr, names))}, "
                        f"got {described(value)}")
    if value not in names:
        raise InputError(name, f"must be one of {', '.join(map(repr, names))}, got {value!r}")
