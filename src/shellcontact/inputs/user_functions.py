"""User code named in a case file (``"module:function"``) or passed from Python, and its checked calls.

A ``UserFunction`` remembers the key it was given for; every call is guarded there, so a function
that raises, returns the wrong shape, returns NaN or calls ``sys.exit`` — when the case is read (the
functions are sampled on the shell then) or later, during assembly — is an ``InputError`` naming that
key, not a traceback from deep inside the package. Only the standard library is imported at module level.

The trust model (docs/case-file.md): a case file is data that people send each other, so a
``"module:function"`` string is imported only with the user's consent for that run, a ``CodeConsent``
(``--allow-code``: modules in the case file's own directory; ``--allow-module NAME``: a module the user
names, from the Python path). Without it the string is an ``InputError`` naming the key and the flag,
before anything is imported. A module of the standard library is never imported unless named. A
callable passed from Python is the caller's own code and needs no consent. ``code_consent(consent)``
sets the consent for the cases validated inside it (a study's points, a Dask worker's task).
"""

from __future__ import annotations

import contextlib
import importlib
import importlib.machinery
import importlib.util
import os
import sys
from collections.abc import Callable, Iterable, Iterator
from contextvars import ContextVar
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ..errors import InputError


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
        except SystemExit as exc:  # sys.exit() in user code ends its call, not the run
            raise InputError(self.where, f"{self.spec} called sys.exit({exc.code!r})") from None
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


@dataclass(frozen=True)
class CodeConsent:
    """The user's permission, for one run, to import the code a case file names (picklable: a Dask task
    carries it to its worker, which imports nothing else).

    ``directory``: modules found there (the case file's own directory, ``--allow-code``) are imported from
    there, never from elsewhere on the Python path; ``modules``: top-level modules the user named
    (``--allow-module``), imported from the Python path, the standard library's too."""

    directory: str | None = None
    modules: tuple[str, ...] = ()

    def names(self, module: str) -> bool:
        """Whether the user named ``module`` (or the package it belongs to)."""
        return any(module == m or module.startswith(m + ".") for m in self.modules)


_CONSENT: ContextVar[CodeConsent | None] = ContextVar("shellcontact_code_consent", default=None)


def current_consent() -> CodeConsent | None:
    return _CONSENT.get()


@contextlib.contextmanager
def code_consent(consent: CodeConsent | None) -> Iterator[None]:
    """The cases validated inside may import the code ``consent`` allows (None: none)."""
    token = _CONSENT.set(consent)
    try:
        yield
    finally:
        _CONSENT.reset(token)


def consent_for(allow_code: bool, allow_modules: Iterable[str], source: str | Path | None,
                option: str = "allow_modules") -> CodeConsent | None:
    """The consent the flags give for a case read from ``source`` (None: no consent given)."""
    if isinstance(allow_modules, str):
        allow_modules = [allow_modules]
    modules = tuple(allow_modules)
    for m in modules:
        if not isinstance(m, str) or not all(part.isidentifier() for part in m.split(".")):
            raise InputError(option, f"must name a Python module such as 'mymodule', got {m!r}")
    if not allow_code and not modules:
        return None
    directory = os.path.realpath(Path(source).parent) if allow_code and source is not None else None
    return CodeConsent(directory, modules)


def _refuse(where: str, spec: str, why: str) -> InputError:
    return InputError(where, f"{spec!r} {why}")


def _import(module: str, where: str, spec: str) -> Any:
    """``module`` imported as the current consent allows; an ``InputError`` naming ``where`` otherwise."""
    consent = _CONSENT.get()
    top = module.partition(".")[0]
    if consent is None:
        raise _refuse(where, spec, f"is Python code (importing {module!r} runs it), and a case file runs code only "
                      f"when you allow it for this run: add --allow-code to import it from the case file's "
                      f"directory, or --allow-module {top} to import it from the Python path (Python: "
                      f"load_case(..., allow_code=True) or allow_modules=[{top!r}], or pass the function itself)")
    if consent.names(module):
        return importlib.import_module(module)
    found = None
    if consent.directory is not None:
        found = importlib.machinery.PathFinder.find_spec(top, [consent.directory])
    if found is None:
        place = f"in the case file's directory {consent.directory}" if consent.directory else "named"
        raise _refuse(where, spec, f"names the module {top!r}, which is not {place}; to import it from the Python "
                      f"path name it: --allow-module {top} (Python: allow_modules=[{top!r}])")
    if top in sys.stdlib_module_names or top in sys.builtin_module_names:
        raise _refuse(where, spec, f"names {top!r}, a module of the standard library, which the file {found.origin} "
                      "beside the case file would shadow; rename that file")
    origin = os.path.realpath(found.origin) if found.origin else None
    loaded = sys.modules.get(top)
    if loaded is not None:
        if os.path.realpath(getattr(loaded, "__file__", None) or "") != origin:
            raise _refuse(where, spec, f"names {top!r} beside the case file, but another module of that name is "
                          f"already imported (from {getattr(loaded, '__file__', None) or 'built in'}); rename yours")
    else:
        mod = importlib.util.module_from_spec(found)
        sys.modules[top] = mod  # its submodules, and a second case naming it, find it here
        try:
            assert found.loader is not None
            found.loader.exec_module(mod)
        except BaseException:
            sys.modules.pop(top, None)
            raise
    return importlib.import_module(module)


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
    if not all(part.isidentifier() for part in mod.split(".")):
        raise InputError(where, f"must be 'module:function' with a Python module name, got {spec!r}")
    try:
        obj = getattr(_import(mod, where, spec), name)
    except InputError:
        raise
    except SystemExit as exc:
        raise InputError(where, f"importing {spec!r} called sys.exit({exc.code!r})") from None
    except Exception as exc:  # noqa: BLE001 — importing user code may raise anything
        raise InputError(where, f"cannot import {spec!r}: {type(exc).__name__}: {exc}") from None
    if not callable(obj):
        raise InputError(where, f"{spec!r} is not callable")
    return UserFunction(obj, where, spec)
