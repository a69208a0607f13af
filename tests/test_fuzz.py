"""Property-based fuzzing of the command line with case files generated from the schema (fuzz_cases.py).

The invariant, for every generated case: ``shellcontact run`` exits 0, 2 (bad input) or 3 (solver
failure), never prints a traceback, and on exit 0 writes a summary.json that is strict JSON with every
number finite. The other surfaces are fuzzed too: output paths (``~``, symbolic links, existing
directories and files, a tmpfs mount point where the machine allows one), ``--points`` files and
``--scheduler`` addresses. ``make test`` runs a fixed-seed subset (the hypothesis profile ``subset`` of
conftest.py); ``make fuzz`` runs ``--hypothesis-profile=fuzz`` (10 000 cases).
"""

from __future__ import annotations

import json
import math
import os
import shutil
import subprocess
import tempfile
from pathlib import Path

import pytest
from fuzz_cases import TEMPLATES, fuzz_case, output_path, points_file, scheduler_address, toml_text
from hypothesis import given, settings
from inprocess import run_cli

ALLOWED_EXITS = {0, 2, 3}


def _refuse_constant(name: str) -> float:
    raise ValueError(f"summary.json is not strict JSON: it contains {name}")


def finite_numbers(value, where: str = "summary") -> list[str]:
    """Paths of the non-finite numbers in a JSON value."""
    if isinstance(value, bool):
        return []
    if isinstance(value, (int, float)):
        return [] if math.isfinite(value) else [where]
    if isinstance(value, dict):
        return [p for k, v in value.items() for p in finite_numbers(v, f"{where}.{k}")]
    if isinstance(value, list):
        return [p for i, v in enumerate(value) for p in finite_numbers(v, f"{where}[{i}]")]
    return []


def check_case(directory: Path, text: str, args: list[str]) -> None:
    case, out = directory / "case.toml", directory / "out"
    case.write_text(text, encoding="utf-8")
    code, stderr = run_cli(["run", str(case), "-o", str(out), "--force", "--no-figures", "--no-report",
                            "--allow-module", "fuzz_cases", *args])
    report = f"exit {code}\n--- case.toml\n{text}--- args {args}\n--- stderr\n{stderr}"
    assert code in ALLOWED_EXITS, report
    assert "Traceback" not in stderr, report
    if code == 0:
        summary = json.loads((out / "summary.json").read_text(), parse_constant=_refuse_constant)
        assert not finite_numbers(summary), (finite_numbers(summary), report)
    else:
        assert stderr.strip(), report  # every refusal is explained


@pytest.mark.parametrize("template", sorted(TEMPLATES))
def test_generated_cases(template: str, tmp_path_factory: pytest.TempPathFactory) -> None:
    directory = tmp_path_factory.mktemp(f"fuzz-{template}")
    cwd = os.getcwd()

    @given(fuzz_case(template))
    def one(case: tuple[str, list[str]]) -> None:
        text, args = case
        check_case(directory, text, args)

    os.chdir(directory)  # relative paths a case may name (mesh.file) stay in the temporary directory
    try:
        one()
    finally:
        os.chdir(cwd)


# -- output paths, --points files, scheduler addresses (issue 24) ---------------------------------------------
#: the profile's number of examples, at most 300 each (a path or points example costs about 0.3 s: a solve)
SURFACE = settings(settings.default, max_examples=min(settings.default.max_examples, 300))

def _scratch(directory: Path) -> Path:
    """A fresh example directory: home/ ($HOME), target/, link -> target, full/keep.txt, file, and mnt/m a
    tmpfs mount holding data (where the machine allows mounting)."""
    ex = Path(tempfile.mkdtemp(dir=directory, prefix="ex-"))
    (ex / "home").mkdir()
    (ex / "target").mkdir()
    (ex / "link").symlink_to(ex / "target")
    (ex / "full").mkdir()
    (ex / "full" / "keep.txt").write_text("keep")
    (ex / "file").write_text("a file in the way")
    (ex / "mnt" / "m").mkdir(parents=True)
    (ex / "mnt" / "summary.json").write_text("{}")  # a previous result there
    mounted = subprocess.run(["mount", "-t", "tmpfs", "-o", "size=1m", "tmpfs", str(ex / "mnt" / "m")],
                             capture_output=True).returncode == 0 if shutil.which("mount") else False
    (ex / "mnt" / "m" / "data").write_text("mounted" if mounted else "plain")
    return ex


def test_generated_output_paths(tmp_path_factory: pytest.TempPathFactory) -> None:
    """-o/--output spelled with ~, symlinks, existing directories, files and mount points: exit 0 or 2, no
    traceback; the result is where the expanded path points; a user's file and a mounted file survive; no
    staging directory is left; nothing is written outside the example's directory."""
    directory = tmp_path_factory.mktemp("fuzz-paths")
    case = directory / "case.toml"
    case.write_text(toml_text(TEMPLATES["panel"]), encoding="utf-8")
    cwd, home = os.getcwd(), os.environ.get("HOME")

    @SURFACE
    @given(output_path())
    def one(drawn: tuple[str, bool, str]) -> None:
        path, force, how = drawn
        ex = _scratch(directory)
        os.chdir(ex)
        os.environ["HOME"] = str(ex / "home")
        try:
            option = [f"--output={path}"] if how == "--output=" else ["-o", path]
            code, stderr = run_cli(["run", str(case), *option, "--no-figures", "--no-report",
                                    *(["--force"] if force else [])])
            report = f"exit {code}, -o {path!r}, force {force}\n{stderr}"
            assert code in (0, 2) and "Traceback" not in stderr, report
            if code == 0:  # a leading ~ of the string is $HOME; "./~" is a directory named ~
                assert (Path(os.path.expanduser(path)) / "summary.json").is_file(), report
                assert path.startswith(("./~", "~")) or not (ex / "~").exists() or "/~" in path, report
            else:
                assert stderr.startswith("error: "), report
            assert (ex / "full" / "keep.txt").read_text() == "keep", report
            assert (ex / "mnt" / "m" / "data").read_text() in ("mounted", "plain"), report
            leftovers = [p for p in ex.rglob("*") if p.name.startswith(".") and (".staging-" in p.name
                                                                                 or p.name.endswith(".tmp"))]
            assert not leftovers, (leftovers, report)
            assert sorted(p.name for p in directory.iterdir() if not p.name.startswith("ex-")) == ["case.toml"]
        finally:
            os.chdir(cwd)
            if home is not None:
                os.environ["HOME"] = home
            subprocess.run(["umount", "-l", str(ex / "mnt" / "m")], capture_output=True)

    one()


def test_generated_points_files(tmp_path_factory: pytest.TempPathFactory) -> None:
    """--points files of broken bytes, encodings, keys and cells: exit 0, 2 or 3, never a traceback; a refusal
    names its option or key."""
    directory = tmp_path_factory.mktemp("fuzz-points")
    case = directory / "case.toml"
    case.write_text(toml_text(TEMPLATES["panel"]), encoding="utf-8")

    @SURFACE
    @given(points_file())
    def one(data: bytes) -> None:
        points = directory / "points.csv"
        points.write_bytes(data)
        out = directory / "out"
        code, stderr = run_cli(["study", str(case), "--points", str(points), "--serial", "-o", str(out), "--force",
                                "--no-figures"])
        report = f"exit {code}\n--- points {data[:300]!r}\n--- stderr\n{stderr}"
        assert code in ALLOWED_EXITS and "Traceback" not in stderr, report
        if code == 0:
            assert (out / "study.csv").is_file(), report
        else:
            assert stderr.startswith(("error: ", "solver failed: ")), report

    one()


def test_generated_scheduler_addresses(tmp_path_factory: pytest.TempPathFactory) -> None:
    """--scheduler values: check_address accepts only tcp:// (tls:// with Dask's TLS settings) with a host and a
    port 1-65535, and refuses everything else by the option's name; a refused one is exit 2 from the command
    line, before any connection is tried (accepted ones are not connected to: nothing listens)."""
    from shellcontact.errors import InputError
    from shellcontact.studies.engine import check_address

    directory = tmp_path_factory.mktemp("fuzz-scheduler")
    case = directory / "case.toml"
    case.write_text(toml_text(TEMPLATES["panel"]), encoding="utf-8")

    @SURFACE
    @given(scheduler_address())
    def one(address: str) -> None:
        try:
            check_address(address, "--scheduler")
        except InputError as exc:
            assert exc.field == "--scheduler", (address, exc)
            code, stderr = run_cli(["study", str(case), "-p", "shell.thickness=0.2,0.25", f"--scheduler={address}",
                                    "-o", str(directory / "out")])
            assert code == 2 and stderr.startswith("error: --scheduler: "), (address, stderr)
            assert not (directory / "out").exists()
        else:
            scheme, _, rest = address.partition("://")
            host, _, port = rest.rpartition(":")
            assert scheme == "tcp" and host and 0 < int(port) < 65536, address

    one()
