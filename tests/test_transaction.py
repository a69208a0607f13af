"""Output directories as transactions: nothing lost on failure, interruption, a kill, a full disk or a rival run.

The previous result must be byte-identical after a failed, interrupted (SIGINT, SIGTERM) or killed
(SIGKILL) ``--force`` run; a run into a new directory that does not finish leaves nothing that
looks like a result; two runs never mix their files. Small Scordelis–Lo roofs (4 × 4 cells for a
result, 20 × 20 for a run slow enough to be interrupted mid-solve).
"""

from __future__ import annotations

import errno
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from shellcontact import cli
from shellcontact.outputs.transaction import DirectoryLock

ROOT = Path(__file__).resolve().parents[1]
ROOF = str(ROOT / "examples" / "scordelis_lo.toml")
PANEL = str(ROOT / "examples" / "paper_panel.toml")
SMALL = ["--set", "mesh.nx=4", "--set", "mesh.nphi=4"]
SLOW = ["--set", "mesh.nx=60", "--set", "mesh.nphi=60"]  # several seconds of solving: the signal must land
# inside it even when this test process is starved of CPU by a loaded machine (at 20 × 20 it once arrived after
# the run had completed and swapped its result in)
ENV = {**os.environ, "OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1"}


def run(*args: str, cwd: Path, **kw) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "shellcontact.cli", *args], cwd=cwd, env=ENV,
                          capture_output=True, text=True, timeout=300, **kw)


def start(*args: str, cwd: Path) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, "-m", "shellcontact.cli", *args], cwd=cwd, env=ENV,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


def snapshot(directory: Path) -> dict[str, bytes]:
    """Every file under ``directory`` by relative path, with its bytes."""
    return {str(p.relative_to(directory)): p.read_bytes() for p in sorted(directory.rglob("*")) if p.is_file()}


def leftovers(parent: Path) -> list[str]:
    """Staging directories, set-aside results, lock and temporary files of any run in ``parent``."""
    return sorted(p.name for p in parent.iterdir() if p.name.startswith("."))


def wait_for(predicate, proc: subprocess.Popen | None = None, timeout: float = 120.0) -> None:
    deadline = time.monotonic() + timeout
    while not predicate():
        assert proc is None or proc.poll() is None, "the run ended before the awaited moment"
        assert time.monotonic() < deadline, "timed out"
        time.sleep(0.005)


def staging(parent: Path, name: str) -> list[Path]:
    return list(parent.glob(f".{name}.staging-*"))


@pytest.fixture(scope="module")
def previous(tmp_path_factory) -> Path:
    """A complete run directory (with a file of the user's) to be protected."""
    base = tmp_path_factory.mktemp("previous")
    r = run("run", ROOF, *SMALL, "-o", "out", "-q", cwd=base)
    assert r.returncode == 0, r.stderr
    (base / "out" / "notes.txt").write_text("mine")
    return base / "out"


def copy_of(previous: Path, where: Path) -> tuple[Path, dict[str, bytes]]:
    out = where / "out"
    out.mkdir()
    for name, data in snapshot(previous).items():
        (out / name).write_bytes(data)
    return out, snapshot(out)


# -- run: failure, interruption, kill -------------------------------------------------------------------
def test_failed_force_run_keeps_previous_result(tmp_path: Path, previous: Path) -> None:
    out, before = copy_of(previous, tmp_path)
    r = run("run", PANEL, "--set", "mesh.nx=8", "--set", "mesh.nphi=8", "--set", "solver.max_iterations=1",
            "-o", "out", "--force", cwd=tmp_path)
    assert r.returncode == 3 and "solver failed" in r.stderr
    assert snapshot(out) == before
    assert leftovers(tmp_path) == []
    # into a new directory: nothing at all
    r = run("run", PANEL, "--set", "mesh.nx=8", "--set", "mesh.nphi=8", "--set", "solver.max_iterations=1",
            "-o", "new", cwd=tmp_path)
    assert r.returncode == 3 and not (tmp_path / "new").exists() and leftovers(tmp_path) == []


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM])
def test_interrupted_force_run_keeps_previous_result(tmp_path: Path, previous: Path, sig: int) -> None:
    out, before = copy_of(previous, tmp_path)
    proc = start("run", ROOF, *SLOW, "-o", "out", "--force", cwd=tmp_path)
    wait_for(lambda: staging(tmp_path, "out"), proc)  # staged before the solve starts
    proc.send_signal(sig)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 128 + sig, err
    assert "Traceback" not in err and ("interrupted" in err or "terminated by SIGTERM" in err)
    assert snapshot(out) == before
    assert leftovers(tmp_path) == []  # the handler removed the staging directory and the lock


def test_killed_force_run_keeps_previous_result_and_next_run_cleans_up(tmp_path: Path, previous: Path) -> None:
    out, before = copy_of(previous, tmp_path)
    proc = start("run", ROOF, *SLOW, "-o", "out", "--force", cwd=tmp_path)
    wait_for(lambda: staging(tmp_path, "out"), proc)
    proc.kill()
    proc.wait()
    assert snapshot(out) == before
    assert staging(tmp_path, "out")  # SIGKILL leaves the staging directory of a dead process ...
    r = run("run", ROOF, *SMALL, "--set", "shell.thickness=0.3", "-o", "out", "--force", "-q", cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    assert leftovers(tmp_path) == []  # ... which the next run removes
    after = snapshot(out)
    assert after["notes.txt"] == b"mine"  # --force replaces the run's files, not the user's
    assert json.loads(after["summary.json"])["overrides"][-1] == "shell.thickness=0.3"


def test_killed_run_into_new_directory_leaves_no_result(tmp_path: Path) -> None:
    proc = start("run", ROOF, *SLOW, "-o", "new", cwd=tmp_path)
    wait_for(lambda: staging(tmp_path, "new"), proc)
    proc.kill()
    proc.wait()
    assert not (tmp_path / "new").exists()


def test_interrupt_just_after_the_staging_directory_appears_leaves_nothing(tmp_path: Path, monkeypatch) -> None:
    """A signal that lands right after the staging directory's mkdir (the interruption tests send SIGINT the
    moment it appears) must still find it discarded: the Staging object exists before its directory does."""
    from shellcontact.outputs.transaction import replace_dir

    real_mkdir = Path.mkdir

    def mkdir_then_interrupt(self, *args, **kw):
        real_mkdir(self, *args, **kw)
        if ".staging-" in self.name:
            raise KeyboardInterrupt

    monkeypatch.setattr(Path, "mkdir", mkdir_then_interrupt)
    (tmp_path / "out").mkdir()
    (tmp_path / "out" / "summary.json").write_text("previous")
    with pytest.raises(KeyboardInterrupt), replace_dir(tmp_path / "out", overwrite=True, owned={"summary.json"}):
        pytest.fail("the body must not run")
    assert leftovers(tmp_path) == []
    assert (tmp_path / "out" / "summary.json").read_text() == "previous"


def test_remove_stale_puts_back_a_result_left_aside(tmp_path: Path, previous: Path) -> None:
    """Where directories cannot be exchanged atomically the old result is renamed aside first; a run cut
    between the two renames leaves it there, and the next run puts it back before anything else."""
    from shellcontact.outputs.transaction import remove_stale

    out, before = copy_of(previous, tmp_path)
    dead = subprocess.Popen([sys.executable, "-c", "pass"])
    dead.wait()
    os.rename(out, tmp_path / f".out.old-{dead.pid}-00ff")
    (tmp_path / f".out.staging-{dead.pid}-0a0b").mkdir()
    remove_stale(out)
    assert snapshot(out) == before and leftovers(tmp_path) == []


# -- two runs ------------------------------------------------------------------------------------------
def test_second_run_refuses_or_waits(tmp_path: Path) -> None:
    with DirectoryLock(tmp_path / "out"):  # another run is writing out/
        r = run("run", ROOF, *SMALL, "-o", "out", cwd=tmp_path)
        assert r.returncode == 2 and "'out'" in r.stderr and "another shellcontact run" in r.stderr
        assert f"pid {os.getpid()}" in r.stderr and "--wait" in r.stderr
        proc = start("run", ROOF, *SMALL, "-o", "out", "--wait", "-q", cwd=tmp_path)
        time.sleep(3.0)  # long enough to start, solve and write, were it not waiting
        assert proc.poll() is None and not (tmp_path / "out").exists()
    _, err = proc.communicate(timeout=120)
    assert proc.returncode == 0, err
    assert (tmp_path / "out" / "report.html").is_file() and leftovers(tmp_path) == []


def test_concurrent_runs_never_mix_files(tmp_path: Path) -> None:
    meshes = {4: SMALL, 6: ["--set", "mesh.nx=6", "--set", "mesh.nphi=6"]}
    procs = [start("run", ROOF, *sets, "-o", "out", "--force", "--wait", "-q", "--no-figures", cwd=tmp_path)
             for sets in meshes.values()]
    for proc in procs:
        _, err = proc.communicate(timeout=300)
        assert proc.returncode == 0, err
    out = tmp_path / "out"
    summary = json.loads((out / "summary.json").read_text())
    with np.load(out / "results.npz") as npz:
        assert len(npz["t"].T) == summary["elements"] and len(npz["U"]) == summary["dofs"]
    assert f'NumberOfCells="{summary["elements"]}"' in (out / "fields.vtu").read_text()
    assert f'{summary["energy"]:.6g}' in (out / "report.html").read_text()
    assert leftovers(tmp_path) == []


# -- full disk -----------------------------------------------------------------------------------------
def test_full_disk_names_the_file_and_keeps_previous_result(tmp_path: Path, previous: Path, monkeypatch,
                                                             capsys) -> None:
    out, before = copy_of(previous, tmp_path)
    real_fdopen = os.fdopen

    class Full:
        def __init__(self, fh) -> None:
            self.fh = fh

        def __enter__(self):
            return self

        def __exit__(self, *exc) -> None:
            self.fh.close()

        def write(self, data) -> int:
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    def fdopen(fd, *a, **kw):
        fh = real_fdopen(fd, *a, **kw)
        return Full(fh) if "summary.json" in os.readlink(f"/proc/self/fd/{fd}") else fh

    monkeypatch.setattr(os, "fdopen", fdopen)
    monkeypatch.chdir(tmp_path)
    assert cli.main(["run", ROOF, *SMALL, "-o", "out", "--force", "-q", "--no-figures"]) == 2
    err = capsys.readouterr().err
    assert f"{os.path.join('out', 'summary.json')}: No space left on device" in err, err
    assert snapshot(out) == before and leftovers(tmp_path) == []


def test_full_tmpfs(tmp_path: Path, previous: Path) -> None:
    """A real full disk: a tmpfs holding a previous result and 32 KiB of free room, too little for a run."""
    disk = tmp_path / "disk"
    disk.mkdir()
    if subprocess.run(["mount", "-t", "tmpfs", "-o", "size=2m", "tmpfs", str(disk)], capture_output=True).returncode:
        pytest.skip("cannot mount a tmpfs here (needs root)")
    try:
        out, before = copy_of(previous, disk)
        st = os.statvfs(disk)
        (disk / "ballast").write_bytes(bytes(st.f_bavail * st.f_frsize - 32 * 1024))
        r = run("run", ROOF, *SMALL, "--set", "shell.thickness=0.3", "-o", "out", "--force", cwd=disk)
        assert r.returncode == 2 and "No space left on device" in r.stderr and "Traceback" not in r.stderr
        assert "out/" in r.stderr  # names the file it could not write
        assert snapshot(out) == before and leftovers(disk) == []
        (disk / "ballast").unlink()  # room again: the same run succeeds
        r = run("run", ROOF, *SMALL, "--set", "shell.thickness=0.3", "-o", "out", "--force", "-q", cwd=disk)
        assert r.returncode == 0 and snapshot(out) != before and leftovers(disk) == []
    finally:
        subprocess.run(["umount", str(disk)], check=True)


# -- the Python API ------------------------------------------------------------------------------------
def test_result_write_refuses_non_empty_directory_unless_overwrite(tmp_path: Path) -> None:
    import shellcontact as sc
    from shellcontact.errors import InputError

    result = sc.solve(sc.load_case(ROOF, ["mesh.nx=4", "mesh.nphi=4"]))
    written = result.write(tmp_path / "out", figures=False, report=False)
    assert sorted(written) == ["fields.vtu", "results.npz", "summary.json"]
    (tmp_path / "out" / "notes.txt").write_text("mine")
    before = snapshot(tmp_path / "out")
    with pytest.raises(InputError, match="not empty.*overwrite=True"):
        result.write(tmp_path / "out")
    assert snapshot(tmp_path / "out") == before
    (tmp_path / "out" / "pressure.png").write_bytes(b"an older run's")  # a run file this result does not write
    result.write(tmp_path / "out", overwrite=True, figures=False)
    after = snapshot(tmp_path / "out")
    assert after["notes.txt"] == b"mine" and "report.html" in after and "pressure.png" not in after
    assert after["results.npz"] == before["results.npz"]
    assert leftovers(tmp_path) == []


def test_interrupted_api_write_keeps_previous_result(tmp_path: Path, previous: Path, monkeypatch) -> None:
    import shellcontact as sc
    from shellcontact.outputs import run as outputs

    out, before = copy_of(previous, tmp_path)
    result = sc.solve(sc.load_case(ROOF, ["mesh.nx=4", "mesh.nphi=4"]))

    def interrupted(*a, **kw):
        raise KeyboardInterrupt

    monkeypatch.setattr(outputs, "write_report", interrupted)  # after the VTU, NPZ and summary are staged
    with pytest.raises(KeyboardInterrupt):
        result.write(out, overwrite=True)
    assert snapshot(out) == before and leftovers(tmp_path) == []


def test_convergence_is_a_transaction(tmp_path: Path, monkeypatch) -> None:
    import shellcontact as sc
    from shellcontact.errors import InputError
    from shellcontact.studies.refinement import convergence

    case = sc.load_case(ROOF, ["mesh.nx=2", "mesh.nphi=2"])
    convergence(case, 2, tmp_path / "cv", figures=False)
    before = snapshot(tmp_path / "cv")
    with pytest.raises(InputError, match="not empty"):
        convergence(case, 2, tmp_path / "cv", figures=False)
    from shellcontact.studies import refinement as studies

    monkeypatch.setattr(studies, "write_csv", lambda *a: (_ for _ in ()).throw(KeyboardInterrupt()))
    with pytest.raises(KeyboardInterrupt):
        convergence(case, 2, tmp_path / "cv", overwrite=True, figures=False)
    assert snapshot(tmp_path / "cv") == before and leftovers(tmp_path) == []


def test_replace_without_atomic_exchange_and_in_the_working_directory(tmp_path: Path, monkeypatch) -> None:
    """Where directories cannot be swapped in one step (no renameat2), and where the target is the working
    directory (which must stay where it is), --force still replaces the run files and keeps the user's."""
    import shellcontact as sc
    from shellcontact.outputs import transaction

    thin = sc.solve(sc.load_case(ROOF, ["mesh.nx=4", "mesh.nphi=4"]))
    thick = sc.solve(sc.load_case(ROOF, ["mesh.nx=4", "mesh.nphi=4", "shell.thickness=0.3"]))
    for where in ("aside", "cwd"):
        out = tmp_path / where
        thin.write(out, figures=False)
        (out / "notes.txt").write_text("mine")
        (out / "pressure.png").write_bytes(b"an older run's")
        if where == "aside":
            monkeypatch.setattr(transaction, "_exchange", lambda a, b: False)
            thick.write(out, overwrite=True, figures=False)
        else:
            monkeypatch.chdir(out)
            thick.write(".", overwrite=True, figures=False)
        files = snapshot(out)
        assert sorted(files) == ["fields.vtu", "notes.txt", "report.html", "results.npz", "summary.json"]
        assert json.loads(files["summary.json"])["energy"] == thick.summary()["energy"]
        assert leftovers(tmp_path) == [] and leftovers(out) == []
