"""How a case is solved: the typed ``[solver]`` table (validated by ``case.SOLVER``)."""

from __future__ import annotations

from dataclasses import dataclass, replace

from ..errors import InputError
from ..solvers.methods import DEFAULT_METHOD, METHODS

#: the friction load paths of ``[solver] path``
PATHS = ("proportional", "indent-then-slide")


@dataclass(frozen=True)
class SolverOptions:
    """The validated ``[solver]`` table (docs/case-file.md)."""

    method: str = DEFAULT_METHOD
    tolerance: float = 1e-10
    penalty: float | None = None  # ε; default: 1e-6 · a²/(E₂ t), see ``analysis.default_penalty``
    continuation: tuple[float, ...] = ()
    max_iterations: int | None = None
    backend: str = "auto"
    nested: str | bool = "auto"  # "auto": when the G rule would border > screening.NESTED_ROWS rows
    # measured, benchmarks/contact_points.py (docs/solvers.md#contact-points): far more accurate per second
    # than the paper's vertex constraints; "vertices" stays selectable
    contact_points: str = "vertices+midpoints"
    extended_precision: bool = False
    out_of_core: bool = False  # the mumps backend's factors on disk (ICNTL(22))
    substructure: str | bool = "auto"  # "auto": from solvers.substructure.MIN_UNKNOWNS unknowns on
    steps: int = 1  # the friction load path's increments (analysis.friction)
    path: str = "proportional"  # or "indent-then-slide"

    def with_method(self, method: str | None) -> SolverOptions:
        """These options with another contact method (the ``method=`` argument of ``solve``)."""
        if method is None:
            return self
        if method not in METHODS:
            raise InputError("solver.method", f"must be one of {', '.join(METHODS)}, got {method!r}")
        return replace(self, method=method)
