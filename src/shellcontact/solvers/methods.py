"""The registry of contact methods: one place names each, its kind and its documentation line.

An *exact* method returns the KKT point of the QP (MODEL.md §8) and is run on the substructured
factorisation with screening (``screening.solve_screened``), with the common signature
``solve(qp, tol=, factorization=, initial_active=, extended=, max_iterations=, callback=)``; the
penalty method solves the regularised problem (6.7)–(6.8) for a given ε. Adding an exact method:
one module in this package with such a function, and one line in ``METHODS``. The functions are
imported when first used, so that reading the registry (the CLI's help, the case-file schema)
costs nothing.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any


@dataclass(frozen=True)
class ContactMethod:
    name: str
    doc: str
    exact: bool  # the KKT point itself (screened); False: the penalty regularisation
    function: str  # "module:function" in this package

    def load(self) -> Callable[..., Any]:
        module, _, name = self.function.partition(":")
        return getattr(importlib.import_module(f"{__package__}.{module}"), name)


METHODS: dict[str, ContactMethod] = {m.name: m for m in (
    ContactMethod("active-set", "exact primal: primal–dual active set / semismooth Newton (default)", True,
                  "active_set:solve_active_set"),
    ContactMethod("dual", "the dual QP (7.9) on the multipliers: MPRGP with exact face solves", True,
                  "dual:solve_dual"),
    ContactMethod("penalty", "the penalty problem (6.7)–(6.8) with penalty ε (`solver.penalty`), optional "
                  "continuation", False, "penalty:solve_penalty"),
)}
DEFAULT_METHOD = "active-set"
