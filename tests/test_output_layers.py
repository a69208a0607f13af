"""The package's layers import one way, down docs/architecture.md's tree; inside outputs/: fields and files →
transaction, writers, figures, report → run.

Every import inside the package is read from the source (top-level and lazy ones in functions, relative
and absolute), so a circle or an upward import (a figure solving, a writer importing the CLI, the shell
model reading the case file) fails here.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "src" / "shellcontact"

#: the layers from the top down: a module imports only modules of its own layer or of the layers below it
LAYERS = (
    {"__init__", "cli", "console", "demo", "verify"},  # the API's face and the commands
    {"studies"},
    {"analysis"},
    {"outputs"},
    {"problem"},
    {"contact"},
    {"shell"},
    {"solvers"},
    {"linalg"},
    {"inputs"},
    {"errors", "lazy", "units", "launcher"},  # leaves every layer may use
)

#: the package modules each output module may import (and nothing else of the package); ``outputs.results``
#: (the solution's post-processing, below the rest of the output layer) only for its list of surfaces;
#: ``units`` (unit labels, a leaf that imports nothing of the package) for the labels of figures, tables
#: and summary
ALLOWED = {
    "outputs.fields": {"outputs.results"},
    "outputs.files": {"errors"},
    "outputs.writers": {"outputs.fields", "outputs.files"},
    # figures.common: results for the refined sampling the maps share with summary.json's maxima
    "outputs.figures.common": {"outputs.fields", "outputs.files", "outputs.results", "units"},
    "outputs.figures.contact": {"outputs.fields", "outputs.figures.common", "units"},
    "outputs.figures.maps": {"outputs.fields", "outputs.figures.common", "outputs.results"},
    "outputs.figures.deformed": {"outputs.fields", "outputs.figures.common"},
    "outputs.figures.sections": {"outputs.figures.common"},
    "outputs.figures.friction": {"outputs.fields", "outputs.figures.common"},
    "outputs.figures.sweeps": {"outputs.figures.common", "units"},
    "outputs.figures.convergence": {"outputs.figures.common", "units"},
    "outputs.figures.study": {"outputs.figures.common", "units"},
    "outputs.figures.run": {"outputs.figures.common", "outputs.figures.contact", "outputs.figures.maps",
                            "outputs.figures.deformed", "outputs.figures.sections", "outputs.figures.friction"},
    "outputs.figures": {"lazy"},  # the face: every figure's name, imported on first use
    "outputs.report": {"outputs.files", "units"},
    "outputs.transaction": {"errors", "outputs.files"},
    "outputs.run": {"outputs.fields", "outputs.files", "outputs.transaction", "outputs.writers",
                    "outputs.figures", "outputs.report", "units"},
}

#: the only modules that write a run directory
OUTPUTS_IMPORTERS = {"analysis.result", "cli", "demo"}


def module_name(path: Path) -> str:
    """``src/shellcontact/outputs/run.py`` → ``outputs.run``; a package's ``__init__.py`` → the package."""
    parts = list(path.relative_to(PACKAGE).with_suffix("").parts)
    if parts[-1] == "__init__" and len(parts) > 1:
        parts.pop()
    return ".".join(parts)


def package_imports(path: Path, package: Path = PACKAGE) -> set[str]:
    """Package modules imported anywhere in ``path`` (dotted, below ``shellcontact``; ``from .x import y``
    gives ``x.y`` when ``x/y.py`` exists, else ``x``)."""
    here = list(path.relative_to(package).parent.parts)
    found: set[str] = set()

    def add(parts: list[str], names: list[str]) -> None:
        for name in names or [None]:
            full = parts + [name] if name else parts
            if full and ((package.joinpath(*full).with_suffix(".py")).exists() or (package.joinpath(*full)).is_dir()):
                found.add(".".join(full))
            else:  # a name defined in the module ``parts`` (``__version__`` from the package: its face)
                found.add(".".join(parts) if parts else "__init__")

    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.ImportFrom):
            names = [a.name for a in node.names]
            if node.level:
                base = here[: len(here) - (node.level - 1)] if node.level > 1 else list(here)
                add(base + (node.module.split(".") if node.module else []), names)
            elif (node.module or "").split(".")[0] == "shellcontact":
                add(node.module.split(".")[1:], names)
        elif isinstance(node, ast.Import):
            for a in node.names:
                if a.name.startswith("shellcontact."):
                    add(a.name.split(".")[1:], [])
    return found


def layer(module: str) -> int:
    top = module.split(".")[0]
    return next(i for i, names in enumerate(LAYERS) if top in names)


def modules() -> list[Path]:
    return sorted(p for p in PACKAGE.rglob("*.py") if "__pycache__" not in p.parts)


def test_every_module_has_a_layer() -> None:
    tops = {module_name(p).split(".")[0] for p in modules()}
    assert tops <= set().union(*LAYERS), f"not in LAYERS: {sorted(tops - set().union(*LAYERS))}"


@pytest.mark.parametrize("path", modules(), ids=lambda p: module_name(p))
def test_imports_run_down_the_layers(path: Path) -> None:
    me = module_name(path)
    up = sorted(m for m in package_imports(path) if layer(m) < layer(me))
    assert not up, f"{me} (layer {layer(me)}) imports {up} from above"


def test_at_most_ten_modules_at_the_top() -> None:
    assert len(list(PACKAGE.glob("*.py"))) <= 10


def test_units_is_a_leaf() -> None:
    assert package_imports(PACKAGE / "units.py") == set()


@pytest.mark.parametrize("module", sorted(ALLOWED))
def test_output_module_imports_only_below_it(module: str) -> None:
    path = PACKAGE.joinpath(*module.split("."))
    imported = package_imports(path / "__init__.py" if path.is_dir() else path.with_suffix(".py"))
    assert imported <= ALLOWED[module], f"{module} imports {sorted(imported - ALLOWED[module])}"


def test_only_the_top_writes_the_run_directory() -> None:
    importers = {module_name(p) for p in modules() if "outputs.run" in package_imports(p)}
    assert importers <= OUTPUTS_IMPORTERS


def test_reader_sees_lazy_and_absolute_imports(tmp_path: Path) -> None:
    pkg = tmp_path / "shellcontact"
    (pkg / "outputs" / "figures").mkdir(parents=True)
    (pkg / "solvers").mkdir()
    for f in ("cli.py", "errors.py", "outputs/files.py", "outputs/figures/run.py", "solvers/dual.py"):
        (pkg / f).write_text("")
    src = pkg / "outputs" / "m.py"
    src.write_text(
        "from .files import x\nimport shellcontact.cli as cli\n"
        "def f():\n    from .figures import run as plots\n    from ..solvers.dual import y\n"
        "    from shellcontact.problem.case import z\n    from .. import errors\n"
    )
    assert package_imports(src, pkg) == {"outputs.files", "cli", "outputs.figures.run", "solvers.dual",
                                         "problem.case", "errors"}
