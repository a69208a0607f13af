"""Start-up: ``import shellcontact`` and the command line's parser and --help load no heavy library.

Checked on ``sys.modules`` of a fresh interpreter (exact and machine-independent) rather than
on timings; benchmarks/startup.py measures the times. The public names stay importable from the
package (they are loaded on first use, PEP 562).
"""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

import shellcontact

HEAVY = ("numpy", "scipy", "skfem", "matplotlib", "meshio", "pypardiso", "sksparse", "dask", "distributed", "pyarrow")

# prints, as JSON, the heavy top-level packages that the statements before it imported
REPORT = f"import json, sys; print(json.dumps(sorted({{m.split('.')[0] for m in sys.modules}} & set({HEAVY!r}))))"


def heavy_modules_after(code: str) -> list[str]:
    r = subprocess.run([sys.executable, "-c", f"{code}\n{REPORT}"], capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, r.stderr
    return json.loads(r.stdout.strip().splitlines()[-1])


def test_import_package_loads_no_heavy_library() -> None:
    assert heavy_modules_after("import shellcontact") == []


def test_parser_help_and_version_load_no_heavy_library() -> None:
    code = """
import contextlib, io
from shellcontact.cli import main
commands = ("run", "demo", "study", "sweep", "convergence", "verify", "info")
for argv in [["--help"], ["--version"], *([c, "--help"] for c in commands)]:
    with contextlib.redirect_stdout(io.StringIO()) as out:
        try:
            main(argv)
        except SystemExit as exc:
            assert exc.code == 0, (argv, exc.code)
    assert out.getvalue().strip(), argv
"""
    assert heavy_modules_after(code) == []


def test_overrides_does_not_import_case() -> None:
    """case.load_case uses overrides; the other direction would be an import circle."""
    r = subprocess.run(
        [sys.executable, "-c",
         "import sys, shellcontact.inputs.overrides; print('shellcontact.problem.case' in sys.modules)"],
        capture_output=True, text=True, timeout=120,
    )
    assert r.returncode == 0, r.stderr
    assert r.stdout.strip() == "False"


def test_public_names_resolve_to_their_definitions() -> None:
    from shellcontact import errors
    from shellcontact.analysis import pipeline as analysis
    from shellcontact.problem import case
    from shellcontact.shell import geometry
    from shellcontact.studies import accuracy, parametric, refinement, sweeps

    where = {
        "Case": case, "case_from_dict": case, "load_case": case, "Result": analysis, "solve": analysis,
        "Shell": geometry, "convergence": refinement, "study": parametric, "sweep": sweeps,
        "estimate": accuracy, "refine_to": accuracy,
        "InputError": errors, "ShellContactError": errors, "SolverError": errors,
    }
    assert set(shellcontact.__all__) == {*where, "__version__"}
    for name, module in where.items():
        assert getattr(shellcontact, name) is getattr(module, name), name
    assert set(shellcontact.__all__) <= set(dir(shellcontact))
    namespace: dict = {}
    exec("from shellcontact import *", namespace)
    assert {*where, "__version__"} <= set(namespace)


def test_unknown_attribute_is_an_attribute_error() -> None:
    with pytest.raises(AttributeError, match="no attribute 'not_a_name'"):
        shellcontact.not_a_name  # noqa: B018
    assert not hasattr(shellcontact, "not_a_name")


def test_cli_method_choices_come_from_the_registry() -> None:
    """`--method` offers exactly the registered contact methods (solvers.methods), which the registry
    lists without importing a solver (checked by the --help tests above)."""
    from shellcontact import cli
    from shellcontact.solvers.methods import METHODS

    run = cli.build_parser()._subparsers._group_actions[0].choices["run"]
    (action,) = [a for a in run._actions if "--method" in a.option_strings]
    assert tuple(action.choices) == tuple(METHODS)
