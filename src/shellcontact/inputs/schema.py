"""The declarative case-file schema: each table's keys, types, units, ranges, defaults and meaning.

One description serves four purposes: parsing (``Table.parse``), the error messages (``InputError``
naming the key path and what is allowed), the "did you mean" hints for unknown keys, and the key
tables of docs/case-file.md (``Table.markdown``; ``python -m shellcontact.inputs.schema`` rewrites them and a
test keeps them in step). Every value is checked here once; the layers below receive typed values.

This module knows nothing of shells or punches: the tables themselves are declared where their
concept lives (``case`` for the case file, ``punches.shapes`` for each shape's keys).
"""

from __future__ import annotations

import difflib
import math
import numbers
from collections.abc import Collection, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from ..errors import InputError
from .user_functions import user_function


class _Required:
    def __repr__(self) -> str:
        return "required"


REQUIRED: Any = _Required()

#: kinds of value and how the docs name them
KINDS = {
    "number": "number",
    "integer": "integer",
    "bool": "bool",
    "choice": "string",
    "string": "string",
    "vector": "[x, y, z]",
    "pair": "[a, b]",
    "numbers": "list of numbers",
    "function": "string `\"module:function\"`",
    "number_or_function": "number or `\"module:function\"`",
    "vector_or_function": "[fx, fy, fz] or `\"module:function\"`",
    "matrix3": "[[..], [..], [..]]",
    "table": "table",
    "tables": "array of tables",
}


def toml(v: Any) -> str:
    """A value as it is written in a case file."""
    if isinstance(v, bool):
        return str(v).lower()
    return f'"{v}"' if isinstance(v, str) else repr(v)


def _is_number(v: Any) -> bool:
    return isinstance(v, numbers.Real) and not isinstance(v, bool)


#: the largest integer a key accepts: beyond it an integer is refused by name rather than overflowing NumPy
MAX_INTEGER = 2**63 - 1

#: a number with a unit (a length, a modulus, a load, ...) is 0 or of magnitude within [1/MAGNITUDE, MAGNITUDE]:
#: the model raises lengths to the fifth power (Argyris P5) and multiplies them with moduli and loads, and
#: beyond 1e±30 such products leave double precision (1e±308) — no choice of units needs more
MAGNITUDE = 1e30


def plain(v: Any) -> Any:
    """NumPy values as the Python values they hold (``np.float64`` → float, ``np.bool_`` → bool, arrays → lists).

    NumPy scalars are accepted wherever a Python value of the same kind is; ``np.bool_`` is a bool
    (refused as a number, like ``True``).
    """
    if type(v).__module__ == "numpy" and hasattr(v, "tolist"):
        return v.tolist()
    return v


def digits(n: int) -> int:
    """The number of decimal digits of ``n`` (without str(): Python refuses it beyond 4300 digits)."""
    try:
        return len(str(abs(n)))
    except ValueError:  # about: 2^(b-1) <= |n| < 2^b
        return math.floor(abs(n).bit_length() * math.log10(2)) + 1


def shown(v: Any, limit: int = 60) -> str:
    """``repr(v)`` cut to ``limit`` characters for a message."""
    if isinstance(v, int) and abs(v) >= 10**limit:  # also: repr() refuses more than 4300 digits
        return f"an integer of {digits(v)} digits"
    text = repr(v)
    return text if len(text) <= limit else f"{text[:limit - 15]}...{text[-12:]} ({len(text)} characters)"


def to_float(v: Any, where: str) -> float:
    """A finite float from a number (ints too large for a float are refused by name)."""
    v = plain(v)
    if not _is_number(v):
        raise InputError(where, f"must be a number, got {type(v).__name__} {shown(v)}")
    try:
        f = float(v)
    except OverflowError:
        raise InputError(where, f"is too large for a floating-point number: {shown(v)}") from None
    if not math.isfinite(f):
        raise InputError(where, f"must be finite, got {v!r}")
    return f


@dataclass(frozen=True)
class Key:
    """One case-file key: its kind, unit, default, allowed range and meaning.

    ``lo``/``hi`` bound numbers (``open`` excludes the bounds named in it: "lo", "hi");
    ``angle`` means degrees in the file and radians inside; ``table`` is the nested table of a
    ``table``/``tables`` key; ``allowed`` overrides the generated "allowed" column of the docs.
    """

    name: str
    kind: str
    doc: str
    unit: str = "–"
    default: Any = REQUIRED
    lo: float | None = None
    hi: float | None = None
    open: tuple[str, ...] = ()
    choices: Collection[Any] = ()  # a registry (dict) stays live: names registered later are allowed
    length: int = 3
    angle: bool = False
    table: Table | None = None
    allowed: str | None = None
    default_doc: str | None = None

    def __post_init__(self) -> None:
        if self.kind not in KINDS:
            raise ValueError(f"unknown kind {self.kind!r} of key {self.name!r}")

    # -- parsing -----------------------------------------------------------------------------------
    def _in_range(self, v: float) -> bool:
        lo_bad = self.lo is not None and (v <= self.lo if "lo" in self.open else v < self.lo)
        hi_bad = self.hi is not None and (v >= self.hi if "hi" in self.open else v > self.hi)
        return not (lo_bad or hi_bad)

    def _range(self, v: float, where: str) -> float:
        if not self._in_range(v):
            raise InputError(where, f"must be {self.range_text()}, got {v!r}")
        return v

    def range_text(self) -> str:
        lo_op = ">" if "lo" in self.open else ">="
        hi_op = "<" if "hi" in self.open else "<="
        if self.lo is not None and self.hi is not None:
            lb = "(" if "lo" in self.open else "["
            rb = ")" if "hi" in self.open else "]"
            return f"in {lb}{self.lo:g}, {self.hi:g}{rb}"
        if self.lo is not None:
            return f"{lo_op} {self.lo:g}"
        if self.hi is not None:
            return f"{hi_op} {self.hi:g}"
        return "finite"

    def _number(self, v: Any, where: str) -> float:
        f = self._range(to_float(v, where), where)
        if self.unit != "–" and f != 0.0 and not 1.0 / MAGNITUDE <= abs(f) <= MAGNITUDE:
            zero = "0 or " if self._in_range(0.0) else ""
            raise InputError(where, f"must be {zero}of magnitude between {1 / MAGNITUDE:g} and {MAGNITUDE:g} (in "
                             f"{self.unit}; any consistent units keep a real value there), got {f!r}")
        return math.radians(f) if self.angle else f

    def _numbers(self, v: Any, where: str, length: int | None) -> tuple[float, ...]:
        what = f"a list of {length} numbers" if length else "a list of numbers"
        if not isinstance(v, (list, tuple)) or (length is not None and len(v) != length):
            raise InputError(where, f"must be {what}, got {shown(v)}")
        return tuple(self._number(c, where) for c in v)

    def parse(self, v: Any, where: str) -> Any:
        """The typed value of ``v`` (given) at key path ``where``."""
        k = self.kind
        v = plain(v)
        if k == "number":
            return self._number(v, where)
        if k == "integer":
            if not isinstance(v, numbers.Integral) or isinstance(v, bool):
                raise InputError(where, f"must be an integer, got {type(v).__name__} {shown(v)}")
            if abs(v) > MAX_INTEGER:
                raise InputError(where, f"is too large: {digits(v)} digits (at most 2^63 - 1 allowed; "
                                 f"{self.range_text()})")
            return int(self._range(int(v), where))
        if k == "bool":
            if not isinstance(v, bool):
                raise InputError(where, f"must be true or false, got {shown(v)}")
            return v
        if k == "choice":
            if not any(type(v) is type(c) and v == c for c in self.choices):
                *first, last = map(toml, self.choices)
                options = f"{', '.join(first)} or {last}" if first else last
                raise InputError(where, f"must be one of {options}, got {shown(v)}")
            return v
        if k == "string":
            if not isinstance(v, str):
                raise InputError(where, f"must be a string, got {shown(v)}")
            return v
        if k == "vector":
            return self._numbers(v, where, self.length)
        if k == "pair":
            return self._numbers(v, where, 2)
        if k == "numbers":
            return self._numbers(v, where, None)
        if k == "function":
            return user_function(v, where)
        if k in ("number_or_function", "vector_or_function"):
            if isinstance(v, str) or callable(v):
                if isinstance(v, str) and ":" not in v:
                    what = "a number" if k == "number_or_function" else f"a list of {self.length} numbers"
                    raise InputError(where, f"must be {what} (or 'module:function', a function of (x, phi)), "
                                     f"got {shown(v)}")
                return user_function(v, where)
            return self._number(v, where) if k == "number_or_function" else self._numbers(v, where, self.length)
        if k == "matrix3":
            if not isinstance(v, (list, tuple)) or len(v) != 3:
                raise InputError(where, f"must be three 3-vectors [[..], [..], [..]], got {shown(v)}")
            return tuple(self._numbers(r, where, 3) for r in v)
        assert self.table is not None
        if k == "table":
            return self.table.parse(v, where)
        if not isinstance(v, (list, tuple)):
            raise InputError(where, f"must be an array of tables [[{where}]], got {type(v).__name__}")
        return tuple(self.table.parse(item, f"{where}.{i}") for i, item in enumerate(v))

    # -- documentation -----------------------------------------------------------------------------
    def allowed_text(self) -> str:
        if self.allowed is not None:
            return self.allowed
        if self.kind == "choice":
            return ", ".join(f"`{toml(c)}`" for c in self.choices)
        if self.kind == "bool":
            return "`true`/`false`"
        if self.kind in ("number", "integer", "vector", "pair", "numbers", "number_or_function",
                         "vector_or_function"):
            return self.range_text()
        return "–"

    def default_text(self) -> str:
        if self.default_doc is not None:
            return self.default_doc
        d = self.default
        if d is REQUIRED:
            return "required"
        if d is None:
            return "none"
        if isinstance(d, (bool, str)):
            return f"`{toml(d)}`"
        if self.angle and _is_number(d):
            return f"{math.degrees(d):g}"
        if isinstance(d, tuple):
            if self.angle:
                d = tuple(math.degrees(c) for c in d)
            return "`[" + ", ".join(f"{c:g}" for c in d) + "]`"
        return f"{d:g}" if _is_number(d) else f"`{d}`"


@dataclass(frozen=True)
class Table:
    """A case-file table: its keys, in documentation order."""

    name: str
    keys: tuple[Key, ...]
    doc: str = ""

    def key(self, name: str) -> Key:
        for k in self.keys:
            if k.name == name:
                return k
        raise KeyError(name)

    def names(self) -> list[str]:
        return [k.name for k in self.keys]

    def parse(self, raw: Any, where: str | None = None, keys: Sequence[Key] | None = None) -> dict[str, Any]:
        """Typed values of every key of the table (defaults filled in; a missing default is None).

        ``keys`` replaces the table's keys (e.g. the common keys plus a punch shape's own).
        """
        where = self.name if where is None else where
        keys = tuple(self.keys if keys is None else keys)
        if not isinstance(raw, Mapping):
            raise InputError(where, f"must be a table, got {type(raw).__name__} {shown(raw)}")
        check_unknown(where, raw, [k.name for k in keys])
        out: dict[str, Any] = {}
        for k in keys:
            path = f"{where}.{k.name}" if where else k.name
            if k.name in raw:
                out[k.name] = k.parse(raw[k.name], path)
            elif k.default is REQUIRED:
                raise InputError(path, "is required")
            else:
                out[k.name] = k.default
        return out

    def markdown(self, keys: Sequence[Key] | None = None) -> str:
        """The docs' key table: key, type, unit, default, allowed, meaning."""
        rows = ["| key | type | unit | default | allowed | meaning |", "|---|---|---|---|---|---|"]
        for k in self.keys if keys is None else keys:
            unit = "degrees" if k.angle else k.unit
            kind = "[a, b]" if k.kind == "pair" else KINDS[k.kind]
            rows.append(f"| `{k.name}` | {kind} | {unit} | {k.default_text()} | {k.allowed_text()} | {k.doc} |")
        return "\n".join(rows)


def check_unknown(where: str, raw: Mapping, allowed: Sequence[str]) -> None:
    """Unknown keys are errors, with the nearest allowed key as a hint."""
    for k in raw:
        if k not in allowed:
            near = difflib.get_close_matches(str(k), sorted(allowed), n=1)
            hint = f"; did you mean '{near[0]}'?" if near else f"; allowed: {', '.join(sorted(allowed))}"
            raise InputError(f"{where}.{k}" if where else str(k), f"unknown key{hint}")
