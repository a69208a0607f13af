"""The output modules import one way: fields and files → transaction, writers, plots, report → outputs.

Every import inside the package is read from the source (top-level and lazy ones in functions),
so a circle or an upward import (a figure solving, a writer importing the CLI) fails here.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "src" / "shellcontact"

#: the package modules each output module may import (and nothing else of the package); ``results``
#: (the solution's post-processing, below the output layer) only for its list of surfaces; ``units``
#: (unit labels, a leaf that imports nothing of the package) for the labels of figures, tables and summary
ALLOWED = {
    "fields": {"results"},
    "files": {"errors"},
    "writers": {"fields", "files"},
    "figure_common": {"fields", "files", "units"},
    "contact_figures": {"fields", "figure_common", "units"},
    # plots: results for the refined sampling the von Mises map shares with summary.json's maxima
    "plots": {"fields", "figure_common", "contact_figures", "results", "units"},
    "report": {"files", "units"},
    "transaction": {"errors", "files"},
    "outputs": {"fields", "files", "transaction", "writers", "plots", "report", "units"},
}


def test_units_is_a_leaf() -> None:
    assert package_imports(PACKAGE / "units.py") == set()

#: the only modules that write a run directory
OUTPUTS_IMPORTERS = {"analysis", "cli", "demo"}


def package_imports(path: Path) -> set[str]:
    """Top-level package modules imported anywhere in ``path`` (``from .x.y import z`` → x)."""
    found: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.ImportFrom):
            if node.level == 1 and node.module:
                found.add(node.module.split(".")[0])
            elif node.level == 1:
                found.update(alias.name for alias in node.names)  # from . import plots
            elif node.level == 0 and (node.module or "").startswith("shellcontact."):
                found.add(node.module.split(".")[1])
        elif isinstance(node, ast.Import):
            found.update(a.name.split(".")[1] for a in node.names if a.name.startswith("shellcontact."))
    return found


@pytest.mark.parametrize("module", sorted(ALLOWED))
def test_output_module_imports_only_below_it(module: str) -> None:
    imported = package_imports(PACKAGE / f"{module}.py")
    assert imported <= ALLOWED[module], f"{module} imports {sorted(imported - ALLOWED[module])}"


def test_only_the_top_writes_the_run_directory() -> None:
    importers = {p.stem for p in PACKAGE.rglob("*.py") if "outputs" in package_imports(p)}
    assert importers <= OUTPUTS_IMPORTERS


def test_reader_sees_lazy_and_absolute_imports(tmp_path: Path) -> None:
    src = tmp_path / "m.py"
    src.write_text(
        "from .files import x\nimport shellcontact.cli\n"
        "def f():\n    from . import plots\n    from .solvers.dual import y\n    from shellcontact.problem.case import z\n"
    )
    assert package_imports(src) == {"files", "cli", "plots", "solvers", "case"}
