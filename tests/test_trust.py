"""The trust model (docs/case-file.md): a case file is data, so the code it names (``"module:function"``) runs
only with the user's consent for that run — ``--allow-code`` (modules in the case file's own directory) or
``--allow-module NAME`` (that module, from the Python path); never a module of the standard library by
accident; ``sys.exit`` in user code is an error by its key; a Dask task imports only what the consent allows.

Each user module here writes a marker file when it is imported, so "not imported" is observed, not assumed.
"""

from __future__ import annotations

import subprocess
import sys
import textwrap
from pathlib import Path

import pytest
from inprocess import run_cli

import shellcontact as sc
from shellcontact.errors import InputError
from shellcontact.problem.case import read_case_dict
from shellcontact.studies import runner as studies

ROOT = Path(__file__).resolve().parents[1]
ENV_THREADS = {"OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1"}

CASE = """\
[shell]
radius = 1.0
length = 1.0
angle = [60.0, 120.0]
thickness = "{thickness}"
young = 2.1e11
poisson = 0.3

[mesh]
nx = 4
nphi = 4
"""


def module_text(name: str, marker: Path) -> str:
    """A user module that leaves ``marker`` when imported; ``t`` a constant thickness, ``leave`` sys.exit."""
    return textwrap.dedent(f"""\
        import sys
        from pathlib import Path
        Path({str(marker)!r}).write_text({name!r})

        def t(x, phi):
            return 0.01 + 0.0 * x

        def leave(x, phi):
            sys.exit(3)
        """)


@pytest.fixture
def beside(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> tuple[Path, Path]:
    """A case file naming ``sidefx_<id>:t`` with that module beside it; the working directory elsewhere."""
    name = f"sidefx_{tmp_path.name.replace('-', '_')}"
    cases, elsewhere = tmp_path / "cases", tmp_path / "elsewhere"
    cases.mkdir()
    elsewhere.mkdir()
    marker = tmp_path / "imported"
    (cases / f"{name}.py").write_text(module_text(name, marker))
    (cases / "case.toml").write_text(CASE.format(thickness=f"{name}:t"))
    monkeypatch.chdir(elsewhere)
    monkeypatch.delitem(sys.modules, name, raising=False)
    return cases / "case.toml", marker


def test_no_consent_is_exit_2_naming_the_key_and_the_flag_and_imports_nothing(beside) -> None:
    case, marker = beside
    code, err = run_cli(["run", str(case), "-o", "out", "--no-figures", "--no-report"])
    assert code == 2, err
    assert err.startswith("error: shell.thickness: ") and "--allow-code" in err, err
    assert not marker.exists()  # its import-time code never ran
    assert not Path("out").exists()


def test_allow_code_imports_from_the_case_files_directory_only(beside) -> None:
    case, marker = beside
    code, err = run_cli(["run", str(case), "-o", "out", "--no-figures", "--no-report", "--allow-code"])
    assert code == 0, err
    assert marker.exists()
    # the same name elsewhere on the Python path is not what --allow-code imports from
    code, err = run_cli(["run", str(case), "-o", "out2", "--no-figures", "--no-report", "--allow-code", "--set",
                         'shell.thickness="json:dumps"'])
    assert code == 2 and "--allow-module json" in err, err


@pytest.mark.parametrize("spec", ["this:s", "venv.__main__:f", "os:getcwd"])
def test_the_standard_library_is_never_imported_by_accident(beside, spec: str, capfd) -> None:
    """``this`` prints the Zen of Python when imported, ``venv.__main__`` creates a virtualenv."""
    case, _ = beside
    code, err = run_cli(["run", str(case), "-o", "out", "--no-figures", "--allow-code", "--set",
                         f'shell.thickness="{spec}"'])
    assert code == 2, err
    assert f"--allow-module {spec.split('.')[0].split(':')[0]}" in err, err
    assert "Zen of Python" not in capfd.readouterr().out
    assert sorted(p.name for p in Path.cwd().iterdir()) == []


def test_a_file_beside_the_case_may_not_shadow_the_standard_library(beside) -> None:
    case, marker = beside
    (case.parent / "this.py").write_text(module_text("this", marker))
    code, err = run_cli(["run", str(case), "-o", "out", "--no-figures", "--allow-code", "--set",
                         'shell.thickness="this:t"'])
    assert code == 2 and "standard library" in err and "rename" in err, err
    assert not marker.exists()


def test_allow_module_imports_a_named_module_from_the_python_path(beside, monkeypatch) -> None:
    case, marker = beside
    monkeypatch.syspath_prepend(str(case.parent))
    name = case.read_text().split('"')[1].split(":")[0]
    code, err = run_cli(["run", str(case), "-o", "out", "--no-figures", "--no-report", "--allow-module", name])
    assert code == 0, err
    code, err = run_cli(["run", str(case), "-o", "out2", "--allow-module", "not a module"])
    assert code == 2 and err.startswith("error: --allow-module: "), err


def test_sys_exit_in_user_code_is_an_error_by_its_key(beside) -> None:
    """Run as a separate process: a SystemExit that escaped would end it with the user's status 3."""
    case, _ = beside
    name = case.read_text().split('"')[1].split(":")[0]
    r = subprocess.run([sys.executable, "-m", "shellcontact.cli", "run", str(case), "-o", "out", "--no-figures",
                        "--allow-code", "--set", f'shell.thickness="{name}:leave"'],
                       capture_output=True, text=True, env={**__import__("os").environ, **ENV_THREADS}, timeout=120)
    assert r.returncode == 2, (r.returncode, r.stderr)
    assert f"error: shell.thickness: {name}:leave called sys.exit(3)" in r.stderr, r.stderr


def test_python_api_needs_consent_for_strings_not_for_callables(beside) -> None:
    from shellcontact.inputs.user_functions import CodeConsent

    case, marker = beside
    with pytest.raises(InputError) as exc:
        sc.load_case(case)
    assert exc.value.field == "shell.thickness" and "allow_code=True" in exc.value.message
    assert not marker.exists()
    assert sc.load_case(case, allow_code=True).code == CodeConsent(str(case.parent.resolve()), ())
    raw = sc.load_case(case, allow_code=True).raw
    given = sc.case_from_dict({**raw, "shell": {**raw["shell"], "thickness": lambda x, phi: 0.01 + 0.0 * x}})
    assert given.code is None  # the caller's own function: no consent asked


def test_a_dask_task_imports_only_what_the_study_was_allowed(beside, monkeypatch) -> None:
    """``_solve_points`` is what a worker runs: without the study's consent it imports nothing, even a module
    on its Python path; with it, the module beside the case."""
    from shellcontact.inputs.user_functions import CodeConsent

    case, marker = beside
    monkeypatch.syspath_prepend(str(case.parent))  # a worker started there would find it
    raw = read_case_dict(case)
    with pytest.raises(InputError) as exc:
        studies._solve_points([raw], str(case), (), None, None)
    assert exc.value.field == "shell.thickness"
    assert not marker.exists()
    summaries = studies._solve_points([raw], str(case), (), None, CodeConsent(str(case.parent), ()))
    assert summaries[0][0]["dofs"] > 0 and marker.exists()


def test_a_study_on_an_embedded_cluster_runs_the_allowed_code(beside) -> None:
    case, _ = beside
    r = subprocess.run([sys.executable, "-m", "shellcontact.cli", "study", str(case), "-o", "st", "--no-figures",
                        "--allow-code", "-p", "mesh.nx=4,5", "--workers", "2"],
                       capture_output=True, text=True, env={**__import__("os").environ, **ENV_THREADS}, timeout=300)
    assert r.returncode == 0, r.stderr
    assert len(list((Path("st") / "steps").glob("step-*.json"))) == 2
