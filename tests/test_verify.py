"""``shellcontact verify``: the MODEL.md §9 checks run, pass, and print their measured figures."""

from __future__ import annotations

import os
import re
import subprocess
import sys
import time

import pytest

from shellcontact import cli, verify

SEED_RESULTS = (
    "Lemma 1, Theorem 2",
    "(6.5) coercivity",
    "(6.5) P_V = {0}",
    "Theorem 2 proof",
    "Lemma 4-6, Theorem 3",
    "Lemma 7",
    "Lemma 8, Theorem 5",
)


@pytest.fixture(scope="module")
def verify_output(tmp_path_factory):
    """One run of ``shellcontact verify`` as a subprocess (exit status, stdout, seconds)."""
    env = {**os.environ, "OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1"}
    t0 = time.perf_counter()
    r = subprocess.run(
        [sys.executable, "-m", "shellcontact.cli", "verify"],
        cwd=tmp_path_factory.mktemp("verify"),
        env=env,
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert "Traceback" not in r.stderr, r.stderr
    # issue 23: "11/11 checks passed" followed by lines of "warning:" (the checks' own solves) read as a failure
    assert "warning:" not in r.stderr, r.stderr
    return r.returncode, r.stdout, time.perf_counter() - t0


def test_verify_passes_and_prints_the_table(verify_output):
    rc, out, seconds = verify_output
    print(out)
    assert rc == 0, out
    for result in SEED_RESULTS:  # one row (at least) per result of MODEL.md §9
        assert result in out
    rows = re.findall(r"^\s*\d+\. \[(PASS|FAIL)\]", out, flags=re.M)
    assert len(rows) >= len(SEED_RESULTS) and set(rows) == {"PASS"}
    assert f"{len(rows)}/{len(rows)} checks passed" in out
    assert seconds < 120  # the command is meant to take < ~60 s on one core


def test_verify_reports_measured_figures(verify_output):
    _, out, _ = verify_output
    measured = [ln for ln in out.splitlines() if ln.strip().startswith("measured:")]
    assert len(measured) == len(re.findall(r"\[(?:PASS|FAIL)\]", out))
    assert all(re.search(r"\d\.\d+e[-+]\d\d", ln) for ln in measured)  # every row carries numbers
    # the penalty row gives the ε table and observed orders; the h row gives rates
    assert re.search(r"orders \[1\.0, 1\.0, 1\.0\]", out)
    assert re.search(r"rates \[\d\.\d+, \d\.\d+\]", out)


def test_a_failing_check_gives_status_1(monkeypatch):
    def fake(progress=None):
        return [
            verify.Check("Lemma 7", "balance", "imbalance 1.0e-01", "<= 1e-3", False),
            verify.Check("Theorem 3", "gap", "gap 1.0e-15", "<= 1e-10", True),
        ]

    monkeypatch.setattr(verify, "run_checks", fake)
    assert verify.run_verify(quiet=True) == 1
    assert cli.main(["verify", "--quiet"]) == 1
    text = verify.format_table(fake())
    assert "[FAIL] Lemma 7" in text and "[PASS] Theorem 3" in text and "1/2 checks passed" in text


def test_a_raising_check_is_a_failed_row(monkeypatch):
    def boom(runs):
        raise RuntimeError("solver exploded")

    monkeypatch.setattr(verify, "CHECKS", (boom,))
    rows = verify.run_checks()
    assert len(rows) == 1 and not rows[0].passed and "solver exploded" in rows[0].measured
