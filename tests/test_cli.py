"""The command line, run as a subprocess: run, sweep (resumable, parallel), convergence, info, --help.

Small cases: the Scordelis–Lo roof on 4 × 4 (run, sweep) or 2 × 2 (convergence) cells.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
CASE = str(ROOT / "examples" / "scordelis_lo.toml")
# a coarse mesh, and a tenth of the roof's load: the full load deflects it 1.1 x its thickness, beyond the
# small-deflection range (a warning on every run); these tests are about the command line, not that
SMALL = ["--set", "mesh.nx=4", "--set", "mesh.nphi=4", "--set", "loads.surface=[0, 0, -9]"]
ENV = {**os.environ, "OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1"}
SWEEP = ["sweep", CASE, *SMALL, "--param", "shell.thickness", "--values", "0.2:0.3:3", "--no-figures"]


def cli(*args: str, cwd: Path, check: bool = True) -> subprocess.CompletedProcess:
    r = subprocess.run(
        [sys.executable, "-m", "shellcontact.cli", *args], cwd=cwd, env=ENV, capture_output=True, text=True, timeout=300
    )
    if check:
        assert r.returncode == 0, r.stderr
        assert "Traceback" not in r.stderr
    return r


def test_help_documents_every_command(tmp_path: Path) -> None:
    r = cli("--help", cwd=tmp_path)
    for cmd in ("run", "demo", "sweep", "convergence", "verify", "info", "--set", "Exit status"):
        assert cmd in r.stdout, cmd
    for cmd, opts in {
        "run": ("--output", "--method", "--set", "--force", "--quiet", "--verbose", "--log"),
        "sweep": ("--param", "--values", "--jobs", "start:stop:count", "resum"),
        "convergence": ("--levels",),
        "demo": ("--output",),
    }.items():
        h = cli(cmd, "--help", cwd=tmp_path).stdout
        for o in opts:
            assert o in h, (cmd, o)


def test_run_summary_and_overrides(tmp_path: Path) -> None:
    r = cli("run", CASE, "-o", "out", *SMALL, "--method", "dual", "--log", "run.log", cwd=tmp_path)
    s = json.loads((tmp_path / "out" / "summary.json").read_text())
    for key in ("dofs", "elements", "energy", "max_abs_w", "probes", "timings"):
        assert key in s
    assert s["elements"] == 2 * 4 * 4  # --set mesh.nx=4 --set mesh.nphi=4 took effect
    assert set(s["timings"]) >= {"mesh", "assembly", "factorization", "solve", "output", "total"}
    assert s["timings"]["output"] > 0
    assert s["overrides"] == ["mesh.nx=4", "mesh.nphi=4", "loads.surface=[0, 0, -9]", 'solver.method="dual"']
    p = s["probes"][0]
    assert set(p) >= {"x", "phi", "u", "v", "w", "displacement"} and (p["x"], p["phi"]) == (0.0, 50.0)
    assert f"{s['energy']:.6g}" in r.stdout and "wrote out/" in r.stdout
    assert "wrote" in (tmp_path / "run.log").read_text()

    # the same case through the Python API gives the same numbers
    from shellcontact import load_case, solve

    # (this process may use other BLAS/PARDISO thread counts: equal up to round-off)
    ref = solve(load_case(CASE, ["mesh.nx=4", "mesh.nphi=4", "loads.surface=[0, 0, -9]"])).summary()
    assert s["dofs"] == ref["dofs"]
    assert s["energy"] == pytest.approx(ref["energy"], rel=1e-10)
    assert p["w"] == pytest.approx(ref["probes"][0]["w"], rel=1e-10)


def test_run_quiet_force_and_default_dir(tmp_path: Path) -> None:
    r = cli("run", CASE, *SMALL, "-q", "--no-figures", "--no-report", cwd=tmp_path)
    assert r.stdout == "" and r.stderr == ""
    out = tmp_path / "scordelis_lo-out"
    assert (out / "summary.json").is_file() and not (out / "report.html").exists()
    stale = out / "pressure.png"
    stale.write_bytes(b"old")
    assert cli("run", CASE, *SMALL, "-q", "--no-figures", cwd=tmp_path, check=False).returncode == 2
    cli("run", CASE, *SMALL, "-q", "--no-figures", "--force", cwd=tmp_path)
    assert not stale.exists()  # --force removes what an earlier run wrote
    assert (out / "report.html").is_file()
    assert not list(out.glob(".*.tmp"))  # no temporary files left behind


def _csv(path: Path) -> str:
    return path.read_text()


def test_sweep_csv_and_plots(tmp_path: Path) -> None:
    r = cli("sweep", CASE, *SMALL, "--param", "shell.thickness", "--values", "0.2,0.25,0.3", "-o", "sw", cwd=tmp_path)
    lines = _csv(tmp_path / "sw" / "sweep.csv").splitlines()
    assert lines[0].split(",")[:4] == ["shell.thickness", "dofs", "energy", "max_abs_w"]
    assert len(lines) == 4 and [ln.split(",")[0] for ln in lines[1:]] == ["0.2", "0.25", "0.3"]
    energy = [float(ln.split(",")[2]) for ln in lines[1:]]
    assert energy[0] > energy[1] > energy[2]  # a thicker roof stores less energy under its own load
    assert (tmp_path / "sw" / "sweep.png").stat().st_size > 1000
    report = (tmp_path / "sw" / "report.html").read_text()
    assert all(f">{e:.6g}<" in report for e in energy) and report.count("data:image/png;base64,") == 1
    assert "shell.thickness" in r.stdout
    # the middle step equals a single run with the same thickness
    cli("run", CASE, *SMALL, "--set", "shell.thickness=0.25", "-o", "one", "--no-figures", "--no-report", cwd=tmp_path)
    s = json.loads((tmp_path / "one" / "summary.json").read_text())
    assert energy[1] == pytest.approx(s["energy"], rel=1e-12)


def test_sweep_resumes_after_lost_step_and_parallel_agrees(tmp_path: Path) -> None:
    cli(*SWEEP, "-o", "full", cwd=tmp_path)
    reference = _csv(tmp_path / "full" / "sweep.csv")
    # simulate an interruption: one step record and the final CSV are missing
    (tmp_path / "full" / "steps" / "step-0001.json").unlink()
    (tmp_path / "full" / "sweep.csv").unlink()
    r = cli(*SWEEP, "-o", "full", cwd=tmp_path)
    assert "resumed: 2 of 3 steps were already done" in r.stdout
    assert _csv(tmp_path / "full" / "sweep.csv") == reference
    # completed steps are not recomputed: their records are untouched
    t = (tmp_path / "full" / "steps" / "step-0000.json").stat().st_mtime_ns
    cli(*SWEEP, "-o", "full", cwd=tmp_path)
    assert (tmp_path / "full" / "steps" / "step-0000.json").stat().st_mtime_ns == t
    # parallel worker processes give the same CSV up to round-off (a threaded factorisation need
    # not add in the same order in every process; one such 1e-11 difference was seen)
    cli(*SWEEP, "-o", "par", "--jobs", "2", cwd=tmp_path)
    par = [ln.split(",") for ln in _csv(tmp_path / "par" / "sweep.csv").splitlines()]
    ref = [ln.split(",") for ln in reference.splitlines()]
    assert par[0] == ref[0] and len(par) == len(ref)
    for a, b in zip(par[1:], ref[1:]):
        assert [float(v) for v in a if v] == pytest.approx([float(v) for v in b if v], rel=1e-9, abs=1e-300)


def test_sweep_killed_then_resumed(tmp_path: Path) -> None:
    values = "0.2:0.3:6"
    args = ["sweep", CASE, *SMALL, "--param", "shell.thickness", "--values", values, "--no-figures"]
    cli(*args, "-o", "ref", cwd=tmp_path)
    reference = _csv(tmp_path / "ref" / "sweep.csv")
    proc = subprocess.Popen(
        [sys.executable, "-m", "shellcontact.cli", *args, "-o", "cut"],
        cwd=tmp_path,
        env=ENV,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    first = tmp_path / "cut" / "steps" / "step-0000.json"
    deadline = time.monotonic() + 120
    while not first.exists() and proc.poll() is None and time.monotonic() < deadline:
        time.sleep(0.01)
    proc.send_signal(signal.SIGKILL)
    proc.wait()
    done = len(list((tmp_path / "cut" / "steps").glob("step-*.json")))
    assert done >= 1
    r = cli(*args, "-o", "cut", cwd=tmp_path)
    if done < 6:
        assert f"resumed: {done} of 6 steps" in r.stdout
    assert _csv(tmp_path / "cut" / "sweep.csv") == reference


def test_sweep_refuses_foreign_directory(tmp_path: Path) -> None:
    (tmp_path / "busy").mkdir()
    (tmp_path / "busy" / "notes.txt").write_text("x")
    r = cli(*SWEEP, "-o", "busy", cwd=tmp_path, check=False)
    assert r.returncode == 2 and "use --force" in r.stderr
    assert (tmp_path / "busy" / "notes.txt").exists()


def test_convergence(tmp_path: Path) -> None:
    r = cli(
        "convergence", CASE, "--set", "mesh.nx=2", "--set", "mesh.nphi=2", "--levels", "3", "-o", "cv", cwd=tmp_path
    )
    rows = json.loads((tmp_path / "cv" / "convergence.json").read_text())["rows"]
    assert [row["refine"] for row in rows] == [0, 1, 2]
    assert rows[0]["dofs"] < rows[1]["dofs"] < rows[2]["dofs"]
    assert rows[1]["h"] == pytest.approx(rows[0]["h"] / 2, rel=1e-12)  # nested red refinement
    assert rows[0]["error_energy"] > rows[1]["error_energy"] > 0 and rows[2]["error_energy"] is None
    assert rows[1]["rate_energy"] == pytest.approx(
        __import__("math").log2(rows[0]["error_energy"] / rows[1]["error_energy"]), rel=1e-12
    )
    assert "probe0_w" in rows[0] and "error_probe0_w" in rows[0]
    header = (tmp_path / "cv" / "convergence.csv").read_text().splitlines()[0]
    assert header.startswith("level,refine,vertices,elements,dofs,h,energy,probe0_w,error_energy")
    assert (tmp_path / "cv" / "convergence.png").stat().st_size > 1000
    report = (tmp_path / "cv" / "report.html").read_text()
    assert all(f">{row['energy']:.6g}<" in report for row in rows) and "data:image/png;base64," in report
    assert "err energy" in r.stdout and f"{rows[2]['energy']:.6g}" in r.stdout
    units = json.loads((tmp_path / "cv" / "convergence.json").read_text())["summaries"][0]["units"]
    head = next(line for line in r.stdout.splitlines() if line.lstrip().startswith("level"))
    for title in ("h [m]", f"energy [{units['energy']}]", f"probe0_w [{units['probes.w']}]"):  # as summary.json
        assert title in head, (title, head)


def test_info(tmp_path: Path) -> None:
    r = cli("info", cwd=tmp_path)
    assert "shellcontact" in r.stdout and "linear-algebra backends" in r.stdout and "numpy" in r.stdout
    assert "OMP_NUM_THREADS=1" in r.stdout


def test_contact_sweep_force_indentation(tmp_path: Path) -> None:
    panel = str(ROOT / "examples" / "paper_panel.toml")
    args = ["sweep", panel, "--set", "mesh.nx=6", "--set", "mesh.nphi=6", "--param", "punch.0.indentation"]
    args += ["--values", "1e-3,2e-3,3e-3", "-o", "fi"]
    cli(*args, cwd=tmp_path)
    text = _csv(tmp_path / "fi" / "sweep.csv")
    header = text.splitlines()[0].split(",")
    for col in ("punch.0.indentation", "energy", "max_abs_w", "force", "normal_force", "zone_area", "line_force"):
        assert col in header, col
    rows = [dict(zip(header, ln.split(","))) for ln in text.splitlines()[1:]]
    force = [float(r["force"]) for r in rows]
    assert 0 < force[0] < force[1] < force[2]  # more indentation, more force
    assert (tmp_path / "fi" / "force_indentation.png").stat().st_size > 1000
    (tmp_path / "fi" / "steps" / "step-0002.json").unlink()
    r = cli(*args, cwd=tmp_path)
    assert "resumed: 2 of 3" in r.stdout
    # every step starts from its own case alone: the step solved again gives the same CSV, byte for byte
    assert _csv(tmp_path / "fi" / "sweep.csv") == text


def test_demo(tmp_path: Path) -> None:
    """``make demo`` runs ``shellcontact demo -o demo-out --force``: three methods, one table, one directory."""
    (tmp_path / "demo-out").mkdir()
    (tmp_path / "demo-out" / "old.txt").write_text("x")
    r = cli("demo", "-o", "demo-out", cwd=tmp_path, check=False)
    assert r.returncode == 2 and "use --force" in r.stderr and "Traceback" not in r.stderr
    r = cli("demo", "-o", "demo-out", "--force", cwd=tmp_path)
    comparison = json.loads((tmp_path / "demo-out" / "comparison.json").read_text())
    methods = [row["method"] for row in comparison["rows"]]
    assert sorted(methods) == ["active-set", "dual", "penalty"]
    for m in methods:
        assert m in r.stdout
        s = json.loads((tmp_path / "demo-out" / m / "summary.json").read_text())
        assert s["contact"][0]["force_magnitude"] > 0 and (tmp_path / "demo-out" / m / "fields.vtu").is_file()
        # the table's force is the one the report calls "resultant force", with one value everywhere
        assert f"{s['contact'][0]['force_magnitude']:.6e}" in r.stdout
    assert "resultant force [N]" in r.stdout
    assert (tmp_path / "demo-out" / "active-set" / "report.html").is_file()
    # one case, three methods: each warning of the case once on stderr (the deflection's was shown 3 times), counted
    shown = [line for line in r.stderr.splitlines() if line.startswith("warning: ")]
    assert shown and len(shown) == len(set(shown)), r.stderr
    assert f"; {len(shown)} warning{'s' * (len(shown) != 1)} above" in r.stdout


def test_warnings_reach_stderr_the_closing_line_and_the_top_of_the_report(tmp_path: Path) -> None:
    """A yield stress far below the roof's stresses: the 'beyond yield' warning is printed on stderr (also
    with --quiet), counted in the closing line, and shown in a box at the top of report.html, before the case and
    the results table (issue 23: the README says warnings come first)."""
    run = ["run", CASE, *SMALL, "--set", "material.yield_stress=1.0", "--no-figures"]
    r = cli(*run, "-o", "out", cwd=tmp_path)
    assert r.stderr.count("warning: ") == 1 and "beyond yield" in r.stderr
    assert "(1 warning, see above)" in r.stdout.splitlines()[-1]
    report = (tmp_path / "out" / "report.html").read_text()
    assert report.index('class="warnings"') < report.index("<h2>The case</h2>") < report.index("<h2>Results</h2>")
    assert "beyond yield" in report[report.index('class="warnings"'):report.index("<h2>The case</h2>")]
    q = cli(*run, "-o", "quiet", "--quiet", cwd=tmp_path)
    assert "beyond yield" in q.stderr and q.stdout == ""
    # and nothing of the kind without a reason
    r = cli("run", CASE, *SMALL, "--no-figures", "-o", "plain", cwd=tmp_path)
    assert "warning" not in r.stderr and "warning" not in r.stdout
    assert 'class="warnings"' not in (tmp_path / "plain" / "report.html").read_text()


def test_sweep_prints_a_table_and_progress_lines_without_float_noise(tmp_path: Path) -> None:
    """Off a terminal, a sweep logs one progress line per step on stderr, prints an aligned table (6
    significant digits) on stdout, and its values carry no float noise (0.22, not 0.22000000000000003)."""
    r = cli("sweep", CASE, *SMALL, "--param", "shell.thickness", "--values", "0.2:0.3:6", "--no-figures",
            "-o", "sw", cwd=tmp_path)
    assert [ln for ln in r.stderr.splitlines() if ln.startswith("[")] == [
        f"[{i}/6] shell.thickness = {v:g}" for i, v in enumerate((0.2, 0.22, 0.24, 0.26, 0.28, 0.3), 1)]
    table = [ln for ln in r.stdout.splitlines() if ln.strip() and not ln.startswith("wrote")]
    assert table[0].split()[:4] == ["shell.thickness", "[m]", "dofs", "energy"] and len(table) == 7
    assert "energy [J]" in table[0] and "max_abs_w [m]" in table[0]  # units of the case's system (SI)
    assert len({len(ln) for ln in table}) == 1  # aligned columns
    csv = (tmp_path / "sw" / "sweep.csv").read_text().splitlines()
    assert [ln.split(",")[0] for ln in csv[1:]] == ["0.2", "0.22", "0.24", "0.26", "0.28", "0.3"]
    q = cli("sweep", CASE, *SMALL, "--param", "shell.thickness", "--values", "0.2:0.3:2", "--no-figures",
            "-o", "sq", "--quiet", cwd=tmp_path)
    assert q.stdout == "" and not any(ln.startswith("[") for ln in q.stderr.splitlines())


def test_a_command_leaves_the_logger_as_it_found_it(tmp_path: Path) -> None:
    """The command's handlers go when it returns: one left on the stderr it was given (closed by its caller,
    as pytest's capture is) printed "Logging error … I/O operation on closed file" at the next message of a
    later, unrelated call, and --log's file stayed open."""
    import contextlib
    import io
    import logging

    from shellcontact.cli import main

    logger = logging.getLogger("shellcontact")
    before = (list(logger.handlers), logger.propagate, logger.level)
    err = io.StringIO()
    with contextlib.redirect_stderr(err):
        assert main(["info", "--log", str(tmp_path / "info.log")]) == 0
    err.close()
    assert (list(logger.handlers), logger.propagate, logger.level) == before
    problems = io.StringIO()
    with contextlib.redirect_stderr(problems):
        logger.warning("a message after the command")  # the closed stream is no longer written to
    assert "Logging error" not in problems.getvalue()
    assert (tmp_path / "info.log").read_text().startswith("shellcontact log")
