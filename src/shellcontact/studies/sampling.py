"""The points of a parameter study: which values each varied case-file key takes.

* ``parse_values('0:5e-3:11')`` — a value list (``--values``, and a ``-p`` list).
* ``parse_spec('punch.0.indentation=0:5e-3:11')`` — a ``Spec``: a list of values (``start:stop:count``, both
  ends included, or ``a,b,c`` of numbers or of words such as ``active-set,dual``) or a distribution:
  ``uniform(lo,hi)``, ``normal(mean,sd)``, ``lognormal(median,sigma)`` (ln X normal with mean ln(median) and
  standard deviation sigma).
* ``grid(specs)`` — every combination of the value lists (the first key varies slowest).
* ``latin_hypercube(specs, n, seed)`` / ``monte_carlo(specs, n, seed)`` — ``n`` random points from the
  distributions: in a Latin hypercube each key's probability range is cut into ``n`` equal strata holding one
  point each; Monte Carlo draws independently. Both map uniform numbers through the inverse distribution
  function, from ``random.Random(seed)`` (the standard library's generator, stable across versions).
* ``read_points(path)`` — a CSV table: a header of case-file keys, one point per row (TOML literals).

Points are dicts {key: value}; validating them against the schema is the study's job (``studies``).
"""

from __future__ import annotations

import csv
import math
import os
import random
import re
from collections.abc import Sequence
from dataclasses import dataclass
from itertools import product
from pathlib import Path
from statistics import NormalDist
from typing import Any

from ..errors import InputError
from ..inputs.overrides import parse_value, split_path

DISTRIBUTIONS = ("uniform", "normal", "lognormal")
SAMPLINGS = ("grid", "lhs", "mc")
_CALL = re.compile(r"^\s*(?P<name>[a-z]+)\s*\((?P<args>[^()]*)\)\s*$")
_WORD = re.compile(r"^[A-Za-z_][A-Za-z0-9_+\-]*$")  # a value list of words: solver.method=active-set,dual

Point = dict[str, Any]
#: the largest --points file read (a table of points is a small file; /dev/zero is not one) and cell
MAX_POINTS_BYTES, MAX_CELL = 64 * 2**20, 128 * 2**10


# -- value lists ----------------------------------------------------------------------------------------------
def parse_values(spec: str, max_memory: float | str | None = None) -> list[float]:
    """``'0:5e-3:11'`` (start:stop:count, both ends included) or ``'1e-3,2e-3,4e-3'``. A count
    whose steps cannot be recorded in ``max_memory`` (default: the memory available) is refused
    before any list is built (``sizing.check_steps``)."""
    from ..problem.sizing import check_steps

    where = "--values"
    text = spec.strip()
    usage = f"expected start:stop:count (e.g. 0:5e-3:11) or a comma list (e.g. 1e-3,2e-3), got {spec!r}"
    if ":" in text:
        parts = text.split(":")
        try:
            if len(parts) != 3:
                raise ValueError
            start, stop, count = float(parts[0]), float(parts[1]), int(parts[2])
        except ValueError:
            raise InputError(where, usage) from None
        if count < 1:
            raise InputError(where, f"count must be >= 1, got {count}")
        check_steps(count, max_memory)  # before the list is built
        if not (math.isfinite(start) and math.isfinite(stop)):
            raise InputError(where, f"values must be finite, got {spec!r}")
        if count == 1:
            return [start]
        # to 12 significant digits: 0.006, not the 0.006000000000000001 of the arithmetic
        return [float(f"{start + (stop - start) * i / (count - 1):.12g}") for i in range(count)]
    check_steps(text.count(",") + 1, max_memory)
    try:
        vals = [float(v) for v in text.split(",") if v.strip()]
    except ValueError:
        raise InputError(where, usage) from None
    if not vals:
        raise InputError(where, "no values given")
    if not all(math.isfinite(v) for v in vals):
        raise InputError(where, f"values must be finite, got {spec!r}")
    return vals


def whole_value(v: float) -> int | float:
    """Integral values of integer keys (mesh.refine=2) stay integers."""
    return int(v) if float(v).is_integer() and abs(v) < 2**53 else float(v)


# -- specs -------------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Spec:
    """One varied key: a value list, or a distribution (``dist`` with its two parameters)."""

    key: str
    values: tuple[Any, ...] = ()
    dist: str | None = None
    a: float = 0.0
    b: float = 0.0

    def quantile(self, u: float) -> float:
        """The value whose cumulative probability is ``u`` (0 < u < 1)."""
        if self.dist == "uniform":
            return self.a + (self.b - self.a) * u
        z = NormalDist().inv_cdf(u)
        if self.dist == "normal":
            return self.a + self.b * z
        return self.a * math.exp(self.b * z)  # lognormal(median, sigma)

    def cdf(self, x: float) -> float:
        """The cumulative probability of ``x`` (the inverse of ``quantile``)."""
        if self.dist == "uniform":
            return (x - self.a) / (self.b - self.a)
        if self.dist == "normal":
            return NormalDist(self.a, self.b).cdf(x)
        return NormalDist(math.log(self.a), self.b).cdf(math.log(x))


def parse_spec(item: str, max_memory: float | str | None = None) -> Spec:
    """``KEY=SPEC`` (a ``-p`` option): a value list or a distribution; the key's path is checked here, its
    values by the schema when the points' cases are built."""
    key, sep, text = item.partition("=")
    key, text = key.strip(), text.strip()
    if not sep or not key or not text:
        raise InputError("-p", f"expected KEY=SPEC (e.g. punch.0.indentation=0:5e-3:11 or "
                               f"shell.thickness=normal(0.25,0.01)), got {item!r}")
    split_path(key)
    m = _CALL.match(text)
    if m is None:
        try:
            return Spec(key, tuple(whole_value(v) for v in parse_values(text, max_memory)))
        except InputError as exc:
            words = [w.strip() for w in text.split(",")]
            if ":" in text or not all(words) or not all(_WORD.match(w) for w in words):
                raise InputError(f"-p {key}", exc.message) from None
            return Spec(key, tuple(words))  # e.g. solver.method=active-set,dual
    name, args = m["name"], [s.strip() for s in m["args"].split(",")]
    where = f"-p {key}"
    if name not in DISTRIBUTIONS:
        raise InputError(where, f"unknown distribution {name!r}; one of {', '.join(DISTRIBUTIONS)}")
    try:
        if len(args) != 2:
            raise ValueError
        a, b = float(args[0]), float(args[1])
    except ValueError:
        raise InputError(where, f"{name}() takes two numbers, got {text!r}") from None
    if not (math.isfinite(a) and math.isfinite(b)):
        raise InputError(where, f"{name}() parameters must be finite, got {text!r}")
    if name == "uniform" and not a < b:
        raise InputError(where, f"uniform(lo,hi) needs lo < hi, got {text!r}")
    if name in ("normal", "lognormal") and not b > 0:
        raise InputError(where, f"{name}() needs a standard deviation > 0, got {text!r}")
    if name == "lognormal" and not a > 0:
        raise InputError(where, f"lognormal(median,sigma) needs a median > 0, got {text!r}")
    return Spec(key, dist=name, a=a, b=b)


def _distinct(specs: Sequence[Spec]) -> None:
    seen: set[str] = set()
    for s in specs:
        if s.key in seen:
            raise InputError(f"-p {s.key}", "given twice")
        seen.add(s.key)


def grid(specs: Sequence[Spec]) -> list[Point]:
    """Every combination of the keys' value lists, the first key varying slowest."""
    _distinct(specs)
    for s in specs:
        if s.dist is not None:
            raise InputError(f"-p {s.key}", f"a grid needs a value list (start:stop:count or a,b,c), not {s.dist}(); "
                             "for a distribution use --sample lhs or --sample mc")
    return [dict(zip((s.key for s in specs), combo)) for combo in product(*(s.values for s in specs))]


def _random_specs(specs: Sequence[Spec], n: int, how: str) -> None:
    _distinct(specs)
    if n < 1:
        raise InputError("--samples", f"must be >= 1, got {n}")
    for s in specs:
        if s.dist is None:
            raise InputError(f"-p {s.key}", f"--sample {how} needs a distribution (uniform(lo,hi), "
                                            "normal(mean,sd), lognormal(median,sigma)), not a value list")


def _open_unit(rng: random.Random) -> float:
    """A uniform number in the open interval (0, 1) (the inverse normal CDF is infinite at 0)."""
    while True:
        u = rng.random()
        if u > 0.0:
            return u


def _generator(seed: int) -> random.Random:
    """``random.Random(seed)`` for a seed >= 0 (it would take -1 as 1: two seeds, one sample)."""
    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        raise InputError("--seed", f"must be an integer >= 0, got {seed!r}")
    return random.Random(seed)


def latin_hypercube(specs: Sequence[Spec], n: int, seed: int = 0) -> list[Point]:
    """``n`` points; for every key, each of the ``n`` equal-probability strata holds exactly one point."""
    _random_specs(specs, n, "lhs")
    rng = _generator(seed)
    columns = []
    for s in specs:
        strata = list(range(n))
        rng.shuffle(strata)
        columns.append([s.quantile((k + _open_unit(rng)) / n) for k in strata])
    return [{s.key: col[i] for s, col in zip(specs, columns)} for i in range(n)]


def monte_carlo(specs: Sequence[Spec], n: int, seed: int = 0) -> list[Point]:
    """``n`` independent draws of every key."""
    _random_specs(specs, n, "mc")
    rng = _generator(seed)
    return [{s.key: s.quantile(_open_unit(rng)) for s in specs} for _ in range(n)]


def sample(specs: Sequence[Spec], how: str, n: int | None = None, seed: int = 0,
           max_memory: float | str | None = None) -> list[Point]:
    """The points of ``--sample how`` (grid, lhs, mc); a number of points whose records cannot fit in
    ``max_memory`` (default: the memory available) is refused before any point is built."""
    from ..problem.sizing import check_steps

    if how == "grid":
        check_steps(math.prod(max(1, len(s.values)) for s in specs), max_memory, where="-p")
        return grid(specs)
    if how not in SAMPLINGS:
        raise InputError("--sample", f"one of {', '.join(SAMPLINGS)}, got {how!r}")
    if n is None:
        raise InputError("--samples", f"--sample {how} needs the number of points (--samples N)")
    _generator(seed)
    check_steps(n, max_memory, where="--samples")
    return (latin_hypercube if how == "lhs" else monte_carlo)(specs, n, seed)


def read_points(path: str | Path) -> list[Point]:
    """A CSV table of points: the header names case-file keys, each row one point (cells are TOML literals;
    an empty cell leaves the case's value). UTF-8, at most ``MAX_POINTS_BYTES``, cells of at most ``MAX_CELL``."""
    where = "--points"
    try:
        with open(os.path.expanduser(path) if isinstance(path, str) else path, "rb") as fh:
            data = fh.read(MAX_POINTS_BYTES + 1)  # bounded: --points /dev/zero is refused, not read forever
    except OSError as exc:
        raise InputError(where, f"cannot read {str(path)!r}: {exc.strerror}") from None
    if len(data) > MAX_POINTS_BYTES:
        raise InputError(where, f"{str(path)!r} is larger than {MAX_POINTS_BYTES // 2**20} MiB; a table of points "
                         "is a CSV file of one row per point")
    try:
        text = data.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        raise InputError(where, f"{str(path)!r} is not a UTF-8 text file (byte {exc.start} is not UTF-8)") from None
    try:
        rows = list(csv.reader(text.splitlines()))
    except csv.Error as exc:  # a NUL byte, or a cell over csv.field_size_limit() (128 KiB)
        raise InputError(where, f"{str(path)!r} is not a CSV table of points: {exc} (cells of at most "
                         f"{MAX_CELL // 2**10} KiB)") from None
    if not rows or not any(c.strip() for c in rows[0]):
        raise InputError(where, f"{str(path)!r} has no header of case-file keys")
    keys = [c.strip() for c in rows[0]]
    for k in keys:
        split_path(k)
    if len(set(keys)) != len(keys):
        raise InputError(where, f"{str(path)!r}: a key appears twice in the header")
    points = []
    for line, row in enumerate(rows[1:], 2):
        if not any(c.strip() for c in row):
            continue
        if len(row) != len(keys):
            raise InputError(where, f"{str(path)!r} line {line}: {len(row)} cells for {len(keys)} keys")
        points.append({k: parse_value(c.strip(), f"--points line {line} {k}") for k, c in zip(keys, row)
                       if c.strip()})
    if not points:
        raise InputError(where, f"{str(path)!r} has no points")
    return points
