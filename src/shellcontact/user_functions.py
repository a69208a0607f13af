"""User code named in a case file (``"module:function"``) or passed from Python, and its checked calls.

A ``UserFunction`` remembers the key it was given for; every call is guarded there, so a function
that raises, returns the wrong shape or returns NaN — when the case is read (the functions are
sampled on the shell then) or later, during assembly — is an ``InputError`` naming that key, not a
traceback from deep inside the package. Only the standard library is imported at module level.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from .errors import InputError


@dataclass(frozen=True)
class UserFunction:
    """``function`` given for the key ``where`` (``spec``: as written, e.g. ``"mymod:t"``)."""

    function: Callable[..., Any]
    where: str
    spec: str

    @property
    def __name__(self) -> str:  # read like a function's name in messages and summaries
        return self.spec

    def __call__(self, *args: Any) -> Any:
        """The raw return value; an exception raised by the user's code becomes an ``InputError``."""
        try:
            return self.function(*args)
        except InputError:
            raise
        except Exception as exc:  # noqa: BLE001 — user code may raise anything
            raise InputError(self.where, f"{self.spec} raised {type(exc).__name__}: {exc}") from None

    def array(self, value: Any, shape: tuple[int, ...], what: str):
        """``value`` as a finite float array broadcast to ``shape`` (the message says ``what`` was expected)."""
        import numpy as np

        try:
            out = np.broadcast_to(np.asarray(value, dtype=float), shape)
        except (TypeError, ValueError):
            got = (f"shape {np.shape(value)}" if isinstance(value, np.ndarray)
                   else f"{type(value).__name__} {value!r:.40}")
            raise InputError(self.where, f"{self.spec} must return {what}, got {got}") from None
        if not np.all(np.isfinite(out)):
            bad = int(np.size(out) - np.count_nonzero(np.isfinite(out)))
            raise InputError(self.where, f"{self.spec} returned {bad} non-finite value(s) (NaN or infinity)")
        return out

    def field(self, x, phi):
        """A scalar field f(x, φ) at points x, φ of one shape: a finite array of that shape."""
        import numpy as np

        shape = np.shape(x)
        return self.array(self(x, phi), shape, f"a number or an array shaped like x {shape}")

    def vector_field(self, x, phi):
        """A vector field f(x, φ) → [fx, fy, fz]: a finite array of shape (3, *x.shape)."""
        import numpy as np

        shape = (3, *np.shape(x))
        return self.array(self(x, phi), shape, f"[fx, fy, fz] with each component shaped like x {shape[1:]}")


def user_function(spec: Any, where: str) -> UserFunction:
    """``"package.module:function"`` or a Python callable → a ``UserFunction`` for the key ``where``."""
    if isinstance(spec, UserFunction):
        return spec if spec.where == where else UserFunction(spec.function, where, spec.spec)
    if callable(spec):  # programmatic use
        return UserFunction(spec, where, getattr(spec, "__name__", type(spec).__name__))
    if not isinstance(spec, str) or ":" not in spec:
        raise InputError(where, f"must be 'module:function', got {spec!r}")
    mod, _, name = spec.partition(":")
    if not mod or not name:
        raise InputError(where, f"must be 'module:function' with both names given, got {spec!r}")
    try:
        obj = getattr(importlib.import_module(mod), name)
    except Exception as exc:  # noqa: BLE001 — importing user code may raise anything
        raise InputError(where, f"cannot import {spec!r}: {type(exc).__name__}: {exc}") from None
    if not callable(obj):
        raise InputError(where, f"{spec!r} is not callable")
    return UserFunction(obj, where, spec)
