"""Case files generated and mutated from the case schema itself, for the property-based fuzzer (test_fuzz.py).

A case is drawn in three steps:

1. a cheap, valid template (a linear panel, a punched panel (a finite punch: its extent), a full
   cylinder, a force-controlled custom punch) — so that a good share of the cases is solved and the
   exit-0 path is exercised;
2. a few edits, each at a key path found by walking ``case.CASE`` (and, inside ``[[punch]]``, the
   keys of the punch's shape in ``punches.SHAPES``): a valid value drawn from the ``Key``'s kind,
   range and choices, or a mutation — a wrong type, an out-of-range or extreme number, a huge
   integer, a NaN-like string or a TOML ``nan``/``inf``, the key removed (required keys too), an
   unknown key beside it, a table swapped with an array of tables;
3. each edit is written into the TOML file or passed as ``--set path=value``.

Mesh sizes stay small (nx, nphi ≤ 6, refine ≤ 1): every valid draw is cheap. Huge integers start at
10¹⁹, beyond a 64-bit integer, where the schema refuses them before anything is allocated.

The functions below are the user code (``"fuzz_cases:NAME"``) the generated cases name: some good,
some that raise, return the wrong shape or NaN. Only these are ever named, never an arbitrary
module.
"""

from __future__ import annotations

import copy
import json
import math
import re
from typing import Any

import numpy as np
from hypothesis import strategies as st

from shellcontact.contact.punches import SHAPES
from shellcontact.inputs.schema import REQUIRED, Key, Table
from shellcontact.problem.case import CASE


# -- user functions named by generated cases ---------------------------------------------------------------
def thickness(x, phi):
    return 0.01 + 0.002 * np.cos(phi) ** 2 + 0.0 * x


def pressure(x, phi):
    return 1e5 * np.sin(phi) + 0.0 * x


def weight(x, phi):
    return np.stack([0.0 * x, 0.0 * x, -1e3 + 0.0 * x])


def sphere_z(X):
    d = X - np.array([[0.0], [0.0], [3.0]])
    r = np.linalg.norm(d, axis=0)
    return r - 2.0, d / r


def raises(*args):
    raise RuntimeError("fuzz: this user function always fails")


def nan_field(*args):
    return np.full(np.shape(args[0]), np.nan)


def wrong_shape(*args):
    return np.ones(7)


def returns_text(*args):
    return "not numbers"


def returns_none(*args):
    return None


def negative_field(x, phi):
    return -1.0 + 0.0 * x


def nan_later(x, phi):
    """Finite where the case is read (a 9 × 9 grid), NaN where it is assembled."""
    return np.full(np.shape(x), 0.01 if np.size(x) == 81 else np.nan)


def z_nan(X):
    return np.full(X.shape[1], np.nan), np.zeros(X.shape)


def z_shape(X):
    return np.ones(3), np.ones(3)


NOT_CALLABLE = 3.0
FIELD_FUNCTIONS = ["thickness", "pressure", "raises", "nan_field", "wrong_shape", "returns_text", "returns_none",
                   "negative_field", "nan_later"]
VECTOR_FUNCTIONS = ["weight", "raises", "nan_field", "wrong_shape", "returns_text", "nan_later"]
Z_FUNCTIONS = ["sphere_z", "raises", "z_nan", "z_shape", "returns_none", "wrong_shape"]
FUNCTION_SPECS = ["fuzz_cases:NOT_CALLABLE", "fuzz_cases:missing", "no_such_module_xyz:f", ":", "fuzz_cases:",
                  "not a function"]


# -- templates: small valid cases --------------------------------------------------------------------------
PANEL = {
    "shell": {"radius": 25.0, "length": 25.0, "x_start": 0.0, "angle": [50.0, 90.0], "thickness": 0.25,
              "young": 4.32e8, "poisson": 0.0},
    "supports": {"x_min": "symmetry", "x_max": "simply_supported", "phi_min": "free", "phi_max": "symmetry"},
    "mesh": {"nx": 2, "nphi": 2},
    "loads": {"surface": [0.0, 0.0, -90.0], "point": [{"x": 12.5, "phi": 70.0, "force": [0.0, 0.0, -1e3]}],
              "line": [{"x": 12.5, "normal": 10.0}]},
    "probes": [{"x": 0.0, "phi": 50.0}],
}
PUNCHED = {
    "shell": {"radius": 1.0, "length": 1.0, "angle": [60.0, 120.0], "thickness": 0.01, "young": 2.1e11,
              "poisson": 0.3},
    "supports": {"x_min": "clamped", "x_max": "clamped", "phi_min": "clamped", "phi_max": "clamped"},
    "mesh": {"nx": 4, "nphi": 4},
    "punch": [{"shape": "sphere", "center": [0.0, 0.0, 3.5], "radius": 2.0, "direction": [0.0, 0.0, -1.0],
               "indentation": 1e-2, "side": "outer", "zone": {"x": [-0.2, 0.2], "phi": [78.0, 102.0]},
               "extent": {"x": [-0.3, 0.3], "z": [1.0, 2.0],
                          "half_spaces": [{"point": [0.0, 0.3, 0.0], "normal": [0.0, 1.0, 0.0]}]}}],
    "solver": {"method": "active-set", "tolerance": 1e-10},
    "probes": [{"x": 0.0, "phi": 90.0}],
}
CYLINDER = {
    "shell": {"radius": 1.0, "length": 2.0, "full": True, "thickness": "fuzz_cases:thickness"},
    "material": {"model": "orthotropic", "e1": 2e10, "e2": 4e10, "g12": 5e9, "nu12": 0.2},
    "supports": {"x_min": "clamped", "x_max": "simply_supported"},
    "mesh": {"nx": 3, "nphi": 4, "pattern": "crossed"},
    "loads": {"normal": "fuzz_cases:pressure", "surface": "fuzz_cases:weight"},
    "probes": [{"x": 0.0, "phi": 90.0}],
}
FORCED = {
    "shell": {"radius": 1.0, "length": 1.0, "angle": [60.0, 120.0], "thickness": 0.01, "young": 2.1e11,
              "poisson": 0.3},
    "mesh": {"nx": 4, "nphi": 4},
    "punch": [{"shape": "custom", "function": "fuzz_cases:sphere_z", "direction": [0.0, 0.0, -1.0],
               "force": 1e4, "zone": {"x": [-0.2, 0.2], "phi": [78.0, 102.0]}}],
    "solver": {"method": "dual"},
}
TEMPLATES = {"panel": PANEL, "punched": PUNCHED, "cylinder": CYLINDER, "forced": FORCED}

#: valid draws of these keys stay below these values: every generated case is cheap
SIZE_LIMITS = {"nx": 6, "nphi": 6, "refine": 1, "max_iterations": 60}
LIST_MAX = 3  # entries of a drawn list (node lines, continuation, probes, ...)


# -- values from a Key -------------------------------------------------------------------------------------
def _finite(lo: float | None, hi: float | None) -> st.SearchStrategy[float]:
    lo_ = -1e6 if lo is None else lo
    hi_ = (lo_ + 1e6 if lo is not None else 1e6) if hi is None else hi
    return st.floats(min_value=lo_, max_value=hi_, allow_nan=False, allow_infinity=False)


def valid_value(key: Key, name: str) -> st.SearchStrategy[Any]:
    """A value of ``key`` as a case file writes it (degrees for angles), within its declared range."""
    k = key.kind
    if k == "number":
        return _finite(key.lo, key.hi)
    if k == "integer":
        lo = int(key.lo or 0)
        return st.integers(min_value=lo, max_value=max(lo, SIZE_LIMITS.get(name, lo + 5)))
    if k == "bool":
        return st.booleans()
    if k == "choice":
        return st.sampled_from(list(key.choices))
    if k == "string":
        return st.text(max_size=12)
    if k in ("vector", "pair", "numbers"):
        n = {"vector": key.length, "pair": 2}.get(k)
        size = {"min_size": n, "max_size": n} if n else {"max_size": LIST_MAX}
        return st.lists(_finite(key.lo, key.hi), **size)
    if k == "matrix3":
        return st.one_of(st.just([[1.0, 0, 0], [0, 1.0, 0], [0, 0, 1.0]]),
                         st.lists(st.lists(_finite(-1, 1), min_size=3, max_size=3), min_size=3, max_size=3))
    if k == "function":
        return st.sampled_from([f"fuzz_cases:{f}" for f in Z_FUNCTIONS])
    if k == "number_or_function":
        return st.one_of(_finite(key.lo, key.hi), st.sampled_from([f"fuzz_cases:{f}" for f in FIELD_FUNCTIONS]))
    if k == "vector_or_function":
        return st.one_of(st.lists(_finite(key.lo, key.hi), min_size=3, max_size=3),
                         st.sampled_from([f"fuzz_cases:{f}" for f in VECTOR_FUNCTIONS]))
    assert key.table is not None
    if k == "table":
        return valid_table(key.table)
    return st.lists(valid_table(key.table), max_size=2)


@st.composite
def valid_table(draw, table: Table, keys: tuple[Key, ...] | None = None) -> dict[str, Any]:
    """Some keys of ``table`` with drawn values (required keys always, optional ones at random)."""
    out: dict[str, Any] = {}
    for key in table.keys if keys is None else keys:
        if key.default is REQUIRED or draw(st.booleans()):
            out[key.name] = draw(valid_value(key, key.name))
    return out


@st.composite
def valid_punch(draw) -> dict[str, Any]:
    shape = draw(st.sampled_from(list(SHAPES)))
    punch_table = CASE.key("punch").table
    raw = draw(valid_table(punch_table, tuple(k for k in punch_table.keys if k.name != "shape") + SHAPES[shape].keys))
    return {"shape": shape, **raw}


HUGE_INTS = st.integers(min_value=19, max_value=4000).map(lambda d: 10**d - 1)  # str() takes <= 4300
EXTREME = st.sampled_from([1e308, -1e308, 5e-324, -5e-324, 1e-300, 1e300, 0.0, -0.0, -1.0, 2**53 + 1.0])
NAN_LIKE = st.sampled_from([math.nan, math.inf, -math.inf, "nan", "NaN", "inf", "-inf", "1e999", "Infinity", ""])
WRONG_TYPE = st.one_of(st.text(max_size=8), st.booleans(), st.integers(-5, 5), st.floats(allow_nan=False),
                       st.just([]), st.just({}), st.just([1, "a"]), st.just({"x": 1}), st.just([[1.0, 2.0]]))


def out_of_range(key: Key) -> st.SearchStrategy[Any]:
    """Numbers at and beyond the bounds of ``key`` (and extreme magnitudes for any number)."""
    edges: list[float] = []
    for bound, sign in ((key.lo, -1.0), (key.hi, 1.0)):
        if bound is not None:
            edges += [bound, bound + sign * 1e-12, bound + sign * 1.0, bound + sign * 1e6]
    opts: list[st.SearchStrategy[Any]] = [EXTREME, HUGE_INTS, HUGE_INTS.map(lambda n: -n)]
    if edges:
        opts.append(st.sampled_from(edges))
    if key.kind == "integer":
        return st.one_of(*opts).map(lambda v: int(v) if isinstance(v, float) and math.isfinite(v) and abs(v) < 1e18
                                    else v)
    return st.one_of(*opts)


def mutated_value(key: Key, name: str) -> st.SearchStrategy[Any]:
    """A value that the key should refuse, or a boundary value it may accept."""
    k = key.kind
    opts: list[st.SearchStrategy[Any]] = [WRONG_TYPE, NAN_LIKE]
    if k in ("number", "integer", "number_or_function"):
        opts.append(out_of_range(key))
    if k in ("vector", "pair", "numbers", "vector_or_function", "matrix3"):
        n = key.length if k != "pair" else 2
        opts += [st.lists(st.one_of(out_of_range(key), NAN_LIKE), min_size=1, max_size=4),
                 st.lists(_finite(None, None), min_size=0, max_size=n + 2),
                 st.just([0.0] * n)]
    if k in ("function", "number_or_function", "vector_or_function"):
        opts.append(st.sampled_from(FUNCTION_SPECS + [f"fuzz_cases:{f}" for f in Z_FUNCTIONS + FIELD_FUNCTIONS]))
    if k in ("table", "tables"):
        assert key.table is not None
        opts.append(valid_table(key.table).map(lambda t: [t] if k == "table" else t))  # table <-> array swapped
    if k == "integer":
        # an integer in range but beyond the size limits only where it cannot allocate (never a mesh size)
        opts.append(st.integers(min_value=-3, max_value=SIZE_LIMITS.get(name, 40)))
    return st.one_of(*opts)


# -- key paths of a case -----------------------------------------------------------------------------------
def _keys_at(case: dict[str, Any], path: list[str]) -> tuple[Key, ...] | None:
    """The keys allowed in the table at ``path`` of ``case`` (None if that is no table of the schema)."""
    table: Table | None = CASE
    keys: tuple[Key, ...] = CASE.keys
    node: Any = case
    i = 0
    while i < len(path):
        seg = path[i]
        if not isinstance(node, dict) or seg not in node:
            return None
        key = next((k for k in keys if k.name == seg), None)
        if key is None or key.table is None:
            return None
        node = node[seg]
        table = key.table
        keys = table.keys
        if key.kind == "tables":
            if i + 1 >= len(path) or not isinstance(node, list):
                return None
            node = node[int(path[i + 1])]
            i += 1
        if table is CASE.key("punch").table and isinstance(node, dict) and str(node.get("shape")) in SHAPES:
            keys = keys + SHAPES[node["shape"]].keys
        i += 1
    return keys if isinstance(node, dict) else None


def table_paths(case: Any, path: list[str] | None = None) -> list[list[str]]:
    """Paths of every table of ``case`` that the schema declares (the top level included)."""
    path = path or []
    out = [path] if _keys_at(case, path) is not None else []
    node = case
    for seg in path:
        node = node[int(seg)] if isinstance(node, list) else node[seg]
    if isinstance(node, dict):
        for k, v in node.items():
            if isinstance(v, dict):
                out += table_paths(case, [*path, k])
            elif isinstance(v, list):
                for j, item in enumerate(v):
                    if isinstance(item, dict):
                        out += table_paths(case, [*path, k, str(j)])
    return out


def _node(case: dict[str, Any], path: list[str]) -> Any:
    node: Any = case
    for seg in path:
        node = node[int(seg)] if isinstance(node, list) else node[seg]
    return node


@st.composite
def edit(draw, case: dict[str, Any]) -> tuple[list[str], str, Any]:
    """One edit of ``case``: (key path, action, value); action is "set", "delete" or "unknown"."""
    paths = table_paths(case)
    path = draw(st.sampled_from(paths))
    keys = _keys_at(case, path)
    assert keys is not None
    key = draw(st.sampled_from(list(keys)))
    action = draw(st.sampled_from(["valid", "valid", "mutated", "mutated", "delete", "unknown"]))
    if action == "delete":
        return [*path, key.name], "delete", None
    if action == "unknown":
        name = draw(st.sampled_from([key.name + "s", key.name[:-1] or "x", "bogus", key.name.upper()]))
        return [*path, name], "unknown", draw(WRONG_TYPE)
    if key.name == "shape" and action == "valid":  # a new shape: the whole punch drawn from its keys
        return path, "replace", draw(valid_punch())
    value = draw(valid_value(key, key.name) if action == "valid" else mutated_value(key, key.name))
    return [*path, key.name], "set", value


def apply(case: dict[str, Any], path: list[str], action: str, value: Any) -> None:
    value = copy.deepcopy(value)  # a drawn value (st.just({}) too) is never edited in place later
    if action == "replace":
        parent = _node(case, path[:-1])
        parent[int(path[-1])] = value
        return
    parent = _node(case, path[:-1])
    if action == "delete":
        parent.pop(path[-1], None)
    else:
        parent[path[-1]] = value


# -- TOML --------------------------------------------------------------------------------------------------
_BARE = re.compile(r"^[A-Za-z0-9_-]+$")


def toml_value(v: Any) -> str:
    """``v`` as a one-line TOML literal (tables inline)."""
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        if math.isnan(v):
            return "nan"
        if math.isinf(v):
            return "inf" if v > 0 else "-inf"
        return repr(v)
    if isinstance(v, str):
        return json.dumps(v)
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(toml_value(x) for x in v) + "]"
    if isinstance(v, dict):
        return "{" + ", ".join(f"{toml_key(k)} = {toml_value(x)}" for k, x in v.items()) + "}"
    raise TypeError(type(v))


def toml_key(k: str) -> str:
    return k if _BARE.match(k) else json.dumps(k)


def toml_text(case: dict[str, Any]) -> str:
    """A case file: each top-level value on its own line (tables and arrays of tables inline)."""
    return "".join(f"{toml_key(k)} = {toml_value(v)}\n" for k, v in case.items())


@st.composite
def fuzz_case(draw, template: str) -> tuple[str, list[str]]:
    """(TOML text, extra CLI arguments) of a case derived from ``TEMPLATES[template]`` by up to three edits.

    An edit given as ``--set`` is not written into the file: the CLI applies it on top of the file.
    """
    case = copy.deepcopy(TEMPLATES[template])
    args: list[str] = []
    for _ in range(draw(st.integers(min_value=0, max_value=3))):
        path, action, value = draw(edit(case))
        if action in ("set", "unknown") and draw(st.integers(0, 3)) == 0:
            args += ["--set", f"{'.'.join(path)}={toml_value(value)}"]
        else:
            apply(case, path, action, value)
    if draw(st.integers(0, 7)) == 0:
        args += ["--method", draw(st.sampled_from(["active-set", "dual", "penalty"]))]
    return toml_text(case), args


# -- the other surfaces: output paths, --points files, scheduler addresses (issue 24) -------------------------
#: components of a generated output path, relative to a scratch directory whose ``home`` is $HOME;
#: ``link`` is a symbolic link to ``target``, ``full`` a non-empty directory, ``file`` a file, ``mnt`` a
#: directory holding a mount point (where the machine allows one)
PATH_STARTS = ["~", "~/", "./~", "", "link", "full", "file", "mnt", "./"]
PATH_PARTS = ["out", "a b", "é", "~", ".", "x.staging-1-00", "link", "full", "deep/er"]


@st.composite
def output_path(draw) -> tuple[str, bool, str]:
    """(a spelling of -o, whether --force is given, how it is given: ``-o P`` or ``--output=P``)."""
    start = draw(st.sampled_from(PATH_STARTS))
    parts = draw(st.lists(st.sampled_from(PATH_PARTS), min_size=0 if start not in ("", "./") else 1, max_size=3))
    text = "/".join(p for p in [start.rstrip("/"), *parts] if p)
    if start == "~/" and not parts:
        text = "~/"
    return text or "out", draw(st.booleans()), draw(st.sampled_from(["-o", "--output="]))


POINT_KEYS = ["shell.thickness", "mesh.nx", "shell.poisson", "units.system", "no.such.key", "", " "]
POINT_CELLS = ["0.01", "0.012", "4", "5", "0.3", '"SI"', "nan", "1e400", "", "x", '"unterminated', "[1, 2]",
               "0.01 µm", "\"é\""]


@st.composite
def points_file(draw) -> bytes:
    """The bytes of a --points file: mostly a CSV of case-file keys and TOML cells, mutated — invalid UTF-8, a
    NUL, a byte-order mark, a cell over 128 KiB, ragged rows, nothing at all."""
    keys = draw(st.lists(st.sampled_from(POINT_KEYS[:3]), min_size=1, max_size=2, unique=True))
    if draw(st.integers(0, 5)) == 0:
        keys.append(draw(st.sampled_from(POINT_KEYS)))
    rows = [",".join(keys)]
    for _ in range(draw(st.integers(0, 3))):
        n = len(keys) + (draw(st.sampled_from([0, 0, 0, 1, -1])))
        rows.append(",".join(draw(st.sampled_from(POINT_CELLS[:5])) if draw(st.integers(0, 4)) else
                             draw(st.sampled_from(POINT_CELLS)) for _ in range(max(n, 0))))
    data = ("\n".join(rows) + "\n").encode()
    mutation = draw(st.sampled_from(["none"] * 4 + ["latin1", "nul", "bom", "bom16", "huge", "empty", "binary"]))
    if mutation == "latin1":
        data += "0.01,\xb5\n".encode("latin-1")
    elif mutation == "nul":
        data = data.replace(b"\n", b"\0\n", 1)
    elif mutation == "bom":
        data = b"\xef\xbb\xbf" + data
    elif mutation == "bom16":
        data = data.decode().encode("utf-16")
    elif mutation == "huge":
        data += b"1" * (129 * 1024) + b"\n"
    elif mutation == "empty":
        data = b""
    elif mutation == "binary":
        data = draw(st.binary(max_size=64))
    return data


SCHEMES = ["tcp", "tls", "TCP", "http", "https", "inproc", "ucx", "ws", "", "tcp:", "tcp:/"]
HOSTS = ["127.0.0.1", "localhost", "[::1]", "", "host name", "[::1", "é.example", "10.0.0.5"]
PORTS = [None, "0", "1", "8786", "65535", "65536", "99999", "-1", "", "abc", "8786/path", "8786?x=1"]


@st.composite
def scheduler_address(draw) -> str:
    """A --scheduler value: a scheme, a host and a port drawn from the valid and the broken, sometimes with
    whitespace around it or arbitrary text instead."""
    if draw(st.integers(0, 9)) == 0:
        return draw(st.text(max_size=30))
    scheme, host, port = draw(st.sampled_from(SCHEMES)), draw(st.sampled_from(HOSTS)), draw(st.sampled_from(PORTS))
    text = f"{scheme}://{host}" + ("" if port is None else f":{port}")
    pad = draw(st.sampled_from(["", "", "", " ", "\t", "\n"]))
    return draw(st.sampled_from([pad + text, text + pad]))
