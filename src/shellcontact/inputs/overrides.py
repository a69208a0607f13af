"""``--set key=value``: override case-file keys by dotted path before validation.

A path walks the raw TOML dictionary: table keys by name, arrays of tables by index, e.g.
``mesh.refine``, ``punch.0.indentation``, ``loads.point.1.force``. Values are TOML literals
(``2e-3``, ``true``, ``[0, 0, -1]``, ``"dual"``, ``{ x = [0.0], ratio = 2.0 }``); a bare word
such as ``dual`` or ``clamped`` is taken as a string. The overridden dictionary is then
validated exactly like a case file, so unknown keys and bad values get the usual messages.
"""

from __future__ import annotations

import copy
import re
import sys
import tomllib
from collections.abc import Iterable, Mapping
from typing import Any

from ..errors import InputError
from .schema import shown

_BARE = re.compile(r"^[^\s\[\]{}\"'=,#]+$")  # a word or a path: taken as a string
_SEGMENT = re.compile(r"^([A-Za-z_][A-Za-z0-9_\-]*|\d+)$")


def parse_value(text: str, where: str = "--set") -> Any:
    """A TOML literal (number, bool, string, array, inline table); a bare word is a string."""
    try:
        return tomllib.loads(f"v = {text}")["v"]
    except RecursionError:  # tomllib parses nested arrays and inline tables recursively
        raise InputError(where, "the value nests arrays or inline tables too deeply to be read") from None
    except tomllib.TOMLDecodeError:
        if _BARE.match(text) and not text[0].isdigit() and text[0] not in "+-.":
            return text
        raise InputError(where, f'value {shown(text)} is not a TOML literal (e.g. 2e-3, true, "dual", '
                         "[0, 0, -1])") from None
    except ValueError:  # int(): Python reads at most sys.get_int_max_str_digits() digits
        raise InputError(where, f"the value holds an integer of more than {sys.get_int_max_str_digits()} digits, "
                         "more than Python reads") from None


def parse_assignment(item: str) -> tuple[str, Any]:
    """``'punch.0.indentation=2e-3'`` → ``('punch.0.indentation', 0.002)``."""
    key, sep, text = item.partition("=")
    key, text = key.strip(), text.strip()
    if not sep or not key or not text:
        raise InputError("--set", f"expected key=value (e.g. mesh.refine=2), got {item!r}")
    split_path(key)
    return key, parse_value(text, f"--set {key}")


def split_path(key: str) -> list[str]:
    parts = key.split(".")
    for part in parts:
        if not _SEGMENT.match(part):
            raise InputError(
                "--set", f"bad key path {key!r}: use dotted names and array indices, e.g. punch.0.indentation"
            )
    return parts


def apply_overrides(data: dict[str, Any], assignments: Mapping[str, Any] | Iterable[tuple[str, Any]]) -> dict:
    """A deep copy of the raw case dictionary ``data`` with the assignments applied.

    Missing tables on the way are created (``--set solver.method=dual`` with no [solver]);
    array indices must exist; a scalar cannot be descended into.
    """
    out = copy.deepcopy(data)
    items = assignments.items() if isinstance(assignments, Mapping) else assignments
    for key, value in items:
        parts = split_path(key)
        node: Any = out
        for depth, part in enumerate(parts):
            last = depth == len(parts) - 1
            here = ".".join(parts[: depth + 1])
            if isinstance(node, list):
                if not part.isdigit():
                    raise InputError(f"--set {key}", f"{'.'.join(parts[:depth])!r} is an array; index it by number")
                i = int(part)
                if i >= len(node):
                    raise InputError(
                        f"--set {key}",
                        f"index {i} is out of range: {'.'.join(parts[:depth])!r} has {len(node)} entries",
                    )
                if last:
                    node[i] = value
                else:
                    node = node[i]
            elif isinstance(node, dict):
                if part.isdigit():
                    raise InputError(f"--set {key}", f"{here!r}: a table key cannot be a number")
                if last:
                    node[part] = value
                else:
                    if part not in node:
                        if parts[depth + 1].isdigit():
                            raise InputError(
                                f"--set {key}", f"{here!r} has no entries: add [[{here}]] tables to the case file"
                            )
                        node[part] = {}
                    node = node[part]
            else:
                raise InputError(
                    f"--set {key}", f"{'.'.join(parts[:depth])!r} is a value ({node!r}), not a table or array"
                )
    return out

