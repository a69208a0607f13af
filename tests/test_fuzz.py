"""Property-based fuzzing of the command line with case files generated from the schema (fuzz_cases.py).

The invariant, for every generated case: ``shellcontact run`` exits 0, 2 (bad input) or 3 (solver
failure), never prints a traceback, and on exit 0 writes a summary.json that is strict JSON with every
number finite. ``make test`` runs a fixed-seed subset (the hypothesis profile ``subset`` of
conftest.py); ``make fuzz`` runs ``--hypothesis-profile=fuzz`` (10 000 cases).
"""

from __future__ import annotations

import json
import math
import os
from pathlib import Path

import pytest
from fuzz_cases import TEMPLATES, fuzz_case
from hypothesis import given
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
