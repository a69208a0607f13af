"""shellcontact: a thin elastic cylindrical shell pressed by a rigid punch.

Implements Bock & Lovíšek (1983): the linear Kirchhoff–Love cylindrical shell discretised
with P2 (u, v) and C¹ Argyris P5 (w) elements, and its contact with a rigid punch in the
primal (penalty, active set) and dual (Lagrange multiplier) formulations. The mathematics
is specified in MODEL.md (shared with this repository).
"""

from .analysis import Result, solve
from .case import Case, case_from_dict, load_case
from .errors import InputError, ShellContactError, SolverError
from .geometry import Shell
from .studies import convergence, sweep

__version__ = "0.1.0"

__all__ = [
    "Case",
    "InputError",
    "Result",
    "Shell",
    "ShellContactError",
    "SolverError",
    "case_from_dict",
    "convergence",
    "load_case",
    "solve",
    "sweep",
    "__version__",
]
