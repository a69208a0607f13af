"""The documentation's commands, run as a reader would: every ```sh line (but `make`) and every ```python block
of docs/*.md, in the order written (getting-started first), in one fresh directory holding a copy of
examples/; each must succeed, and every file or directory they create must be ignored by .gitignore."""

from __future__ import annotations

import os
import re
import shlex
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
ORDER = ["getting-started.md", "case-file.md", "outputs.md", "solvers.md", "examples.md", "theory.md",
         "architecture.md"]
ENV = {**os.environ, "OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1"}


def _blocks() -> list[tuple[str, str, str]]:
    """(file, language, code) of every sh and python block, in reading order (architecture.md's are
    plug-in examples run by tests/test_architecture.py)."""
    docs = sorted((ROOT / "docs").glob("*.md"), key=lambda p: ORDER.index(p.name) if p.name in ORDER else 99)
    out = []
    for doc in docs:
        if doc.name == "architecture.md":
            continue
        for lang, code in re.findall(r"```(sh|python)\n(.*?)```", doc.read_text(), re.S):
            out.append((doc.name, lang, code))
    return out


def test_every_documented_command_runs_in_order(tmp_path: Path) -> None:
    shutil.copytree(ROOT / "examples", tmp_path / "examples")
    before = set(os.listdir(tmp_path))
    ran = 0
    for doc, lang, code in _blocks():
        if lang == "python":
            r = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, env=ENV, capture_output=True, text=True,
                               timeout=600)
            assert r.returncode == 0, f"{doc}: python block failed:\n{code}\n{r.stderr}"
            ran += 1
            continue
        for line in code.splitlines():
            args = shlex.split(line, comments=True)  # as a shell reads it: quotes kept, comments dropped
            cmd = " ".join(args)
            if not args or args[0] == "make":
                continue
            assert args[0] == "shellcontact", f"{doc}: unexpected command {cmd!r}"
            r = subprocess.run([sys.executable, "-m", "shellcontact.cli", *args[1:]], cwd=tmp_path, env=ENV,
                               capture_output=True, text=True, timeout=600)
            assert r.returncode == 0, f"{doc}: {cmd!r} exited {r.returncode}:\n{r.stderr}"
            assert "Traceback" not in r.stderr
            ran += 1
    assert ran >= 10
    created = sorted(set(os.listdir(tmp_path)) - before)
    assert created, "the documented commands wrote nothing"
    for name in created:
        path = name + "/" if (tmp_path / name).is_dir() else name  # directory patterns need the slash
        ignored = subprocess.run(["git", "check-ignore", "-q", "--no-index", path], cwd=ROOT).returncode == 0
        assert ignored, f"{name!r}, created by the docs' commands, is not in .gitignore"


@pytest.mark.parametrize("path", ["roof/", "paper_panel-out/", "fi/", "roof.vtu", "w.png"])
def test_gitignore_names_the_docs_outputs(path: str) -> None:
    assert subprocess.run(["git", "check-ignore", "-q", "--no-index", path], cwd=ROOT).returncode == 0
