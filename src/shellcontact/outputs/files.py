"""Files written whole or not at all: a temporary name beside the target, then a rename.

Nothing here knows about results: bytes, text, JSON and files written by name (e.g. by meshio),
plus the check that an output directory may be written into.
"""

from __future__ import annotations

import json
import os
import tempfile
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import InputError


def _file_mode() -> int:
    """0o666 minus the process umask: what a plain ``open(path, "w")`` would give."""
    mask = os.umask(0)
    os.umask(mask)
    return 0o666 & ~mask


_MODE = _file_mode()


def _naming(exc: OSError, path: Path) -> OSError:
    """The same error naming the file being written (a write to a full disk names none, or the temporary)."""
    return type(exc)(exc.errno, exc.strerror or str(exc), str(path))


def _atomic(path: str | Path, write: Callable[[int, str], None]) -> None:
    """``write(fd, tmp)`` fills a temporary file beside ``path`` (its descriptor and name), which is then
    renamed into place; on any failure it is removed, and an OSError names ``path``."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    try:
        fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    except OSError as exc:  # a full disk: name the file being written, not its temporary
        raise _naming(exc, path) from exc
    try:
        write(fd, tmp)
        os.chmod(tmp, _MODE)
        os.replace(tmp, path)
    except OSError as exc:
        Path(tmp).unlink(missing_ok=True)
        raise _naming(exc, path) from exc
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def atomic_write_bytes(path: str | Path, data: bytes) -> None:
    """Write ``data`` to a temporary file beside ``path``, then rename it into place."""

    def write(fd: int, tmp: str) -> None:
        with os.fdopen(fd, "wb") as fh:
            fh.write(data)

    _atomic(path, write)


def atomic_write_text(path: str | Path, text: str) -> None:
    atomic_write_bytes(path, text.encode())


def atomic_write_with(path: str | Path, writer: Callable[[str], None]) -> None:
    """Let ``writer(tmp_path)`` write a file by name (e.g. meshio), then rename it to ``path``."""

    def write(fd: int, tmp: str) -> None:
        os.close(fd)
        writer(tmp)

    _atomic(path, write)


def _json_default(obj: Any) -> Any:
    if isinstance(obj, np.generic):
        return obj.item()
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, Path):
        return str(obj)
    return str(obj)


def json_text(data: Any) -> str:
    """Strict JSON (RFC 8259): a NaN or an infinity is a ValueError, never written as ``NaN``."""
    return json.dumps(data, indent=2, sort_keys=False, default=_json_default, allow_nan=False) + "\n"


def write_json(path: str | Path, data: Any) -> None:
    atomic_write_bytes(path, json_text(data).encode())


def expand_user(path: str | os.PathLike) -> Path:
    """The output path as written, but a leading ``~`` of a string is the home directory (the shell leaves it
    in ``--output=~/x``); a ``Path`` object is taken as written, as pathlib does (``Path("./~")`` is ``~``).
    Expanded once, where a path enters, then checked and written as the same path."""
    return Path(os.path.expanduser(path)) if isinstance(path, str) else Path(path)


def check_output_dir(path: str | Path, force: bool, option: str = "--output") -> Path:
    """Refuse an existing non-empty directory unless ``force``; a file in the way is an error."""
    path = Path(path)
    if path.exists() and not path.is_dir():
        raise InputError(option, f"{str(path)!r} exists and is not a directory")
    if path.is_dir() and any(path.iterdir()) and not force:
        raise InputError(
            option, f"{str(path)!r} exists and is not empty; use --force (Python: overwrite=True) to replace it"
        )
    return path
