"""Sweeps you can trust: every step validated first, resumed CSV byte-identical, workers that die with
their parent (SIGKILL included), Ctrl-C honoured within 2 s, a replaced sweep kept until the new one is whole.

Long steps are made by a load function that sleeps (``loads.normal = "slowload:normal"``), so the
process tests cost seconds, not solves.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

import shellcontact as sc
from shellcontact.studies.sweeps import sweep

ROOT = Path(__file__).resolve().parents[1]
ROOF = str(ROOT / "examples" / "scordelis_lo.toml")
PANEL = str(ROOT / "examples" / "paper_panel.toml")
SMALL = ["--set", "mesh.nx=4", "--set", "mesh.nphi=4"]
SLOW_LOAD = '''
import os, time
from pathlib import Path

def normal(x, phi):
    if getattr(x, "shape", None) != (9, 9):  # not the 9 × 9 sample taken when a case is read: assembly
        Path(os.environ["SLOWLOAD_DIR"], f"step-in-{os.getpid()}").touch()  # a process is inside a step
        time.sleep(120)
    return 0.0 * x
'''


def descendants(pid: int) -> set[int]:
    """Live (not zombie) processes below ``pid``, from /proc."""
    parent = {}
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            text = stat.read_text()
        except OSError:
            continue
        fields = text[text.rindex(")") + 2:].split()
        if fields[0] != "Z":
            parent[int(stat.parent.name)] = int(fields[1])
    found, frontier = set(), {pid}
    while frontier:
        frontier = {p for p, pp in parent.items() if pp in frontier} - found
        found |= frontier
    return found


def alive(pids: set[int]) -> set[int]:
    out = set()
    for p in pids:
        try:
            state = Path(f"/proc/{p}/stat").read_text()
        except OSError:
            continue
        if state[state.rindex(")") + 2] != "Z":
            out.add(p)
    return out


def gone(pids: set[int], within: float = 2.0) -> bool:
    """Whether every process in ``pids`` has ended within ``within`` seconds (named in the failure)."""
    deadline = time.monotonic() + within
    while alive(pids) and time.monotonic() < deadline:
        time.sleep(0.02)
    left = {p: Path(f"/proc/{p}/cmdline").read_bytes().replace(b"\0", b" ")[:200] for p in alive(pids)}
    assert not left, f"still running: {left}"
    return True


def slow_sweep(tmp_path: Path, jobs: int) -> tuple[subprocess.Popen, Path]:
    (tmp_path / "slowload.py").write_text(SLOW_LOAD)
    marks = tmp_path / "marks"
    marks.mkdir()
    env = {**os.environ, "OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1",
           "SLOWLOAD_DIR": str(marks), "PYTHONPATH": os.pathsep.join([str(tmp_path), os.environ.get("PYTHONPATH", "")])}
    proc = subprocess.Popen(
        [sys.executable, "-m", "shellcontact.cli", "sweep", ROOF, *SMALL, "--set", 'loads.normal="slowload:normal"',
         "--allow-module", "slowload",
         "--param", "shell.thickness", "--values", "0.2:0.3:4", "--jobs", str(jobs), "-o", "sw", "--no-figures"],
        cwd=tmp_path, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 120
    while len(list(marks.iterdir())) < jobs:  # every worker (or the serial parent) is inside a step
        assert proc.poll() is None, proc.communicate()
        assert time.monotonic() < deadline
        time.sleep(0.01)
    return proc, marks


def test_every_step_is_validated_before_the_first_solve(tmp_path: Path) -> None:
    env = {**os.environ, "OMP_NUM_THREADS": "1"}
    r = subprocess.run(
        [sys.executable, "-m", "shellcontact.cli", "sweep", ROOF, *SMALL, "--param", "shell.thickness",
         "--values", "0.2,0.25,0.3,-0.1", "-o", "sw"], cwd=tmp_path, env=env, capture_output=True, text=True)
    assert r.returncode == 2 and "Traceback" not in r.stderr
    assert "shell.thickness" in r.stderr and "sweep step 3" in r.stderr and "-0.1" in r.stderr
    assert not (tmp_path / "sw").exists()  # not one step was solved or recorded


def test_failed_parallel_step_is_exit_3_with_residuals(tmp_path: Path) -> None:
    """A step that fails in a worker process stops the sweep with the step's own error (here exit 3)."""
    r = subprocess.run(
        [sys.executable, "-m", "shellcontact.cli", "sweep", PANEL, "--set", "mesh.nx=8", "--set", "mesh.nphi=8",
         "--set", "solver.max_iterations=1", "--param", "punch.0.indentation", "--values", "4e-3,5e-3",
         "--jobs", "2", "-o", "sw"], cwd=tmp_path, env={**os.environ, "OMP_NUM_THREADS": "1"},
        capture_output=True, text=True)
    assert r.returncode == 3 and "solver failed" in r.stderr and "Traceback" not in r.stderr, r.stderr
    assert not (tmp_path / "sw" / "sweep.csv").exists()


def test_input_error_survives_a_worker_process() -> None:
    import pickle

    from shellcontact.errors import InputError

    err = pickle.loads(pickle.dumps(InputError("loads.normal", "must be finite")))
    assert isinstance(err, InputError) and (err.field, err.message) == ("loads.normal", "must be finite")


def test_resumed_contact_sweep_csv_is_byte_identical(tmp_path: Path) -> None:
    """Interrupt a contact sweep after 2 of 4 steps, resume it: the CSV of an uninterrupted sweep, byte for byte."""
    case = sc.load_case(PANEL, ["mesh.nx=6", "mesh.nphi=6"])
    values = [1e-3, 2e-3, 3e-3, 4e-3]
    ref = sweep(case, "punch.0.indentation", values, tmp_path / "ref", figures=False)

    def stop_after_two(done: int, total: int, message: str) -> None:
        if done == 2:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        sweep(case, "punch.0.indentation", values, tmp_path / "cut", progress=stop_after_two, figures=False)
    cut = tmp_path / "cut"
    assert sorted(p.name for p in (cut / "steps").iterdir()) == ["step-0000.json", "step-0001.json"]
    assert not (cut / "sweep.csv").exists() and not (cut / "report.html").exists()  # no half result
    resumed = sweep(case, "punch.0.indentation", values, cut, figures=False)
    assert resumed.reused == 2
    assert (cut / "sweep.csv").read_bytes() == (tmp_path / "ref" / "sweep.csv").read_bytes()
    assert resumed.csv() == ref.csv()
    assert [p.name for p in tmp_path.iterdir() if p.name.startswith(".")] == []


def test_different_sweep_is_refused_and_force_keeps_previous_until_complete(tmp_path: Path) -> None:
    from shellcontact.errors import InputError

    case = sc.load_case(ROOF, ["mesh.nx=4", "mesh.nphi=4"])
    sweep(case, "shell.thickness", [0.2, 0.3], tmp_path / "sw", figures=False)
    before = {p: p.read_bytes() for p in (tmp_path / "sw").rglob("*") if p.is_file()}
    with pytest.raises(InputError, match="not empty"):  # another sweep would silently replace this one
        sweep(case, "shell.thickness", [0.2, 0.25], tmp_path / "sw", figures=False)

    def stop(done: int, total: int, message: str) -> None:
        if done == 1:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        sweep(case, "shell.thickness", [0.2, 0.25, 0.3], tmp_path / "sw", overwrite=True, progress=stop,
              figures=False)
    assert {p: p.read_bytes() for p in (tmp_path / "sw").rglob("*") if p.is_file()} == before
    res = sweep(case, "shell.thickness", [0.2, 0.25, 0.3], tmp_path / "sw", overwrite=True, figures=False)
    assert len(res.rows) == 3 and len(list((tmp_path / "sw" / "steps").iterdir())) == 3
    assert (tmp_path / "sw" / "sweep.csv").read_text() == res.csv()


def test_killed_sweep_parent_leaves_no_orphan_worker(tmp_path: Path) -> None:
    proc, _ = slow_sweep(tmp_path, jobs=2)
    below = descendants(proc.pid)
    assert len(below) >= 2  # two workers (and the resource tracker)
    proc.kill()
    proc.wait()
    assert gone(below, within=5.0)  # the steps themselves would last 120 s


@pytest.mark.parametrize("jobs", [1, 2])
def test_ctrl_c_stops_a_sweep_within_two_seconds(tmp_path: Path, jobs: int) -> None:
    proc, _ = slow_sweep(tmp_path, jobs=jobs)
    below = descendants(proc.pid)
    t0 = time.monotonic()
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=60)
    latency = time.monotonic() - t0
    assert proc.returncode == 128 + signal.SIGINT and "interrupted" in err and "Traceback" not in err, err
    assert latency < 2.0, f"Ctrl-C took {latency:.2f} s"
    assert gone(below)
    assert not (tmp_path / "sw").exists()  # no step finished: nothing to resume, nothing left
