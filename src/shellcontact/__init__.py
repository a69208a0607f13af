"""shellcontact: a thin elastic cylindrical shell pressed by a rigid punch.

Implements Bock & Lovíšek (1983): the linear Kirchhoff–Love cylindrical shell discretised
with P2 (u, v) and C¹ Argyris P5 (w) elements, and its contact with a rigid punch in the
primal (penalty, active set) and dual (Lagrange multiplier) formulations. The mathematics
is specified in MODEL.md (shared with this repository).

The public names below are imported on first use (PEP 562), so ``import shellcontact`` and
``shellcontact --help`` do not pay for NumPy, SciPy and scikit-fem.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from .errors import InputError, ShellContactError, SolverError
from .lazy import lazy_attributes

if TYPE_CHECKING:
    from .analysis.pipeline import solve
    from .analysis.result import Result
    from .problem.case import Case, case_from_dict, load_case
    from .shell.geometry import Shell
    from .studies.accuracy import estimate, refine_to
    from .studies.parametric import study
    from .studies.refinement import convergence
    from .studies.sweeps import sweep

__version__ = "0.1.0"

# public name -> the submodule defining it, imported by __getattr__ on first access
_LAZY = {
    "Result": "analysis.result",
    "solve": "analysis.pipeline",
    "Case": "problem.case",
    "case_from_dict": "problem.case",
    "load_case": "problem.case",
    "Shell": "shell.geometry",
    "convergence": "studies.refinement",
    "estimate": "studies.accuracy",
    "refine_to": "studies.accuracy",
    "study": "studies.parametric",
    "sweep": "studies.sweeps",
}

__all__ = [
    "Case",
    "InputError",
    "Result",
    "Shell",
    "ShellContactError",
    "SolverError",
    "case_from_dict",
    "convergence",
    "estimate",
    "load_case",
    "refine_to",
    "solve",
    "study",
    "sweep",
    "__version__",
]


__getattr__, __dir__ = lazy_attributes(__name__, _LAZY, globals(), __all__)
