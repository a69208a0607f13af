"""README's quick start is exactly ``make demo`` and ``make test``, and both targets do what it says:
create the virtual environment when it is missing, install the package, then run the demo / the tests.
CI (.ci/run) runs ``make test`` verbatim."""

from __future__ import annotations

import os
import re
import subprocess
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def quick_start_commands() -> list[str]:
    text = (ROOT / "README.md").read_text()
    m = re.search(r"^## Quick start\s*$(.*?)(?=^## )", text, re.S | re.M)
    assert m, "README.md has no '## Quick start' section"
    blocks = re.findall(r"```[a-z]*\n(.*?)```", m.group(1), re.S)
    assert len(blocks) == 1, "the quick start has exactly one code block"
    return [ln.split("#", 1)[0].strip() for ln in blocks[0].splitlines() if ln.split("#", 1)[0].strip()]


def test_quick_start_is_make_demo_and_make_test() -> None:
    assert quick_start_commands() == ["make demo", "make test"]


def dry_run(target: str, tmp_path: Path) -> list[str]:
    venv = tmp_path / "fresh-venv"  # does not exist: what a fresh clone would do
    env = {k: v for k, v in os.environ.items() if k not in ("MAKEFLAGS", "MAKELEVEL", "MFLAGS")}
    cmd = ["make", "-n", "--no-print-directory", f"VENV={venv}", target]
    r = subprocess.run(cmd, cwd=ROOT, env=env, capture_output=True, text=True, timeout=60)
    assert r.returncode == 0, r.stderr
    return r.stdout.splitlines()


def test_make_demo_creates_venv_installs_and_runs_demo(tmp_path: Path) -> None:
    lines = dry_run("demo", tmp_path)
    text = "\n".join(lines)
    assert "-m venv" in text and "pip install" in text and "-e " in text
    assert lines[-1].endswith("/bin/shellcontact demo -o demo-out --force")


def test_make_test_creates_venv_installs_and_runs_pytest(tmp_path: Path) -> None:
    text = "\n".join(dry_run("test", tmp_path))
    assert "-m venv" in text and "pip install" in text
    assert "ruff check" in text and "-m pytest" in text


def test_ci_runs_make_test() -> None:
    lines = [ln.strip() for ln in (ROOT / ".ci" / "run").read_text().splitlines()]
    assert "make test" in lines


def test_demo_command_exists() -> None:
    """``make demo`` calls ``shellcontact demo -o demo-out --force``: the CLI accepts exactly that."""
    from shellcontact.cli import build_parser

    args = build_parser().parse_args(["demo", "-o", "demo-out", "--force"])
    assert args.command == "demo" and args.output == "demo-out" and args.force
