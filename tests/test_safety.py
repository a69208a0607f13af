"""Nothing lost, nothing exposed, every refusal by name (issue 24): one output path however it is spelled
(``~``); ``--force`` never descends into a mounted filesystem; a study's finished points survive a
``--force`` interruption and any spelling of the case path, and never go through a symlink; a full disk
names its file; the embedded cluster listens on loopback only; bad ``--points`` and ``--scheduler`` values,
a silent or foreign scheduler port and a scheduler without workers are exit 2 by name.

Mount points are real tmpfs mounts where this machine allows it (root); elsewhere those tests are skipped.
"""

from __future__ import annotations

import errno
import os
import shutil
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest
from inprocess import run_cli

import shellcontact as sc
from shellcontact.errors import InputError
from shellcontact.studies.parametric import study

ROOT = Path(__file__).resolve().parents[1]
PANEL = str(ROOT / "examples" / "paper_panel.toml")
SMALL = ["--set", "mesh.nx=4", "--set", "mesh.nphi=4"]
ENV = {**os.environ, "OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1"}


def panel():
    return sc.load_case(PANEL, ["mesh.nx=4", "mesh.nphi=4"])


def tmpfs(path: Path, size: str = "4m") -> bool:
    """Mount a tmpfs at ``path``; False where that is not allowed."""
    path.mkdir(parents=True, exist_ok=True)
    if shutil.which("mount") is None:
        return False
    r = subprocess.run(["mount", "-t", "tmpfs", "-o", f"size={size}", "tmpfs", str(path)], capture_output=True)
    return r.returncode == 0


def umount(path: Path) -> None:
    subprocess.run(["umount", "-l", str(path)], capture_output=True)


# -- 1. a "~" in the output path --------------------------------------------------------------------------
def test_tilde_output_is_checked_where_it_is_written(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """``--output=~/res`` (the shell leaves that ~) over a non-empty $HOME/res: refused without --force."""
    home, work = tmp_path / "home", tmp_path / "work"
    (home / "res").mkdir(parents=True)
    (home / "res" / "mine.txt").write_text("keep")
    work.mkdir()
    monkeypatch.setenv("HOME", str(home))
    monkeypatch.chdir(work)
    code, err = run_cli(["run", PANEL, *SMALL, "--output=~/res", "--no-figures", "--no-report"])
    assert code == 2 and "--force" in err, err
    assert sorted(p.name for p in (home / "res").iterdir()) == ["mine.txt"]
    code, err = run_cli(["study", PANEL, *SMALL, "-p", "shell.thickness=0.01,0.012", "--serial", "--no-figures",
                         "--output=~/st"])
    assert code == 0, err
    assert not (work / "~").exists()  # not split between ./~/st and $HOME/st
    assert {"study.csv", "steps", "study.json"} <= {p.name for p in (home / "st").iterdir()}


# -- 2. --force and a mount point -------------------------------------------------------------------------
def test_force_never_deletes_files_on_a_mounted_filesystem(tmp_path: Path) -> None:
    out = tmp_path / "out"
    mnt = out / "mnt"
    if not tmpfs(mnt):
        pytest.skip("cannot mount a tmpfs here")
    try:
        (mnt / "data.bin").write_bytes(b"on another filesystem")
        (out / "summary.json").write_text("{}")  # a previous result to replace
        code, err = run_cli(["run", PANEL, *SMALL, "-o", str(out), "--force", "--no-figures", "--no-report"])
        assert code == 0, err  # the new result is committed: never a failure
        assert (mnt / "data.bin").read_bytes() == b"on another filesystem"
        assert os.path.ismount(mnt)
        assert (out / "fields.vtu").is_file() and (out / "summary.json").read_text() != "{}"
        assert [p.name for p in tmp_path.iterdir() if p.name.startswith(".")] == []  # no staging left
    finally:
        umount(mnt)


def test_remove_tree_stops_at_a_mount_point(tmp_path: Path) -> None:
    from shellcontact.outputs.transaction import remove_tree

    tree = tmp_path / "tree"
    mnt = tree / "a" / "mnt"
    if not tmpfs(mnt):
        pytest.skip("cannot mount a tmpfs here")
    try:
        (mnt / "x").write_text("x")
        (tree / "a" / "b.txt").write_text("b")
        (tree / "c.txt").write_text("c")
        assert remove_tree(tree) == [str(mnt)]
        assert (mnt / "x").read_text() == "x"
        assert not (tree / "c.txt").exists() and not (tree / "a" / "b.txt").exists()
    finally:
        umount(mnt)


# -- 3. study resume ------------------------------------------------------------------------------------
class Stop(Exception):
    pass


def stop_after(n: int):
    def progress(done: int, total: int, message: str) -> None:
        if done >= n:
            raise KeyboardInterrupt  # as Ctrl-C between two points
    return progress


POINTS = [{"shell.thickness": t} for t in (0.01, 0.011, 0.012, 0.013)]


def test_interrupted_force_study_keeps_its_points(tmp_path: Path) -> None:
    out = tmp_path / "st"
    study(panel(), [{"shell.thickness": 0.02}], out, workers=0, figures=False)  # an earlier, different study
    with pytest.raises(KeyboardInterrupt):
        study(panel(), POINTS, out, overwrite=True, workers=0, figures=False, progress=stop_after(2))
    assert (out / "study.csv").read_text().count("\n") == 2  # the earlier result is still there
    res = study(panel(), POINTS, out, overwrite=True, workers=0, figures=False)
    assert res.reused == 2
    assert len(res.rows) == 4 and [p.name for p in tmp_path.iterdir() if p.name.startswith(".")] == []


def test_resume_whatever_the_case_path_spelling(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    shutil.copy(PANEL, tmp_path / "case.toml")
    monkeypatch.chdir(tmp_path)
    sets = ["mesh.nx=4", "mesh.nphi=4"]
    with pytest.raises(KeyboardInterrupt):
        study(sc.load_case("case.toml", sets), POINTS, "st", workers=0, figures=False, progress=stop_after(2))
    res = study(sc.load_case(str(tmp_path / "case.toml"), sets), POINTS, "st", workers=0, figures=False)
    assert res.reused == 2


def test_a_symlinked_steps_directory_is_never_written_through(tmp_path: Path) -> None:
    out, elsewhere = tmp_path / "st", tmp_path / "elsewhere"
    with pytest.raises(KeyboardInterrupt):
        study(panel(), POINTS, out, workers=0, figures=False, progress=stop_after(1))
    shutil.move(out / "steps", elsewhere)
    (out / "steps").symlink_to(elsewhere)
    before = sorted(p.name for p in elsewhere.iterdir())
    with pytest.raises(InputError) as exc:
        study(panel(), POINTS, out, workers=0, figures=False)
    assert exc.value.field == "--output" and "symbolic link" in exc.value.message
    assert sorted(p.name for p in elsewhere.iterdir()) == before


def test_resumed_study_report_is_byte_identical(tmp_path: Path) -> None:
    """docs/studies.md: a resumed study writes the same files (issue 23 item 6)."""
    out = tmp_path / "st"
    study(panel(), POINTS, out, workers=0, figures=False)
    first = {name: (out / name).read_bytes() for name in ("report.html", "study.csv")}
    for name in first:
        (out / name).unlink()
    (out / "steps" / "step-0002.json").unlink()  # two points reused, one solved again
    res = study(panel(), POINTS, out, workers=0, figures=False)
    assert res.reused == 3
    for name, data in first.items():
        assert (out / name).read_bytes() == data, name


# -- 4. a full disk ---------------------------------------------------------------------------------------
def test_log_on_a_full_disk_is_exit_2_by_name(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(tmp_path)
    code, err = run_cli(["run", PANEL, *SMALL, "-o", "out", "--no-figures", "--log", "/dev/full"])
    assert code == 2, err
    assert err.strip() == "error: --log: cannot write the log file '/dev/full': No space left on device", err
    assert not (tmp_path / "out").exists()


def test_a_full_disk_names_the_file(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """The first write of a run is its lock file's pid: refused by a full disk, it is named."""
    import shellcontact.outputs.transaction as transaction

    def full(fd: int, data: bytes) -> int:
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(transaction.os, "write", full)
    code, err = run_cli(["run", PANEL, *SMALL, "-o", "out", "--no-figures"])
    assert code == 2 and err.strip() == f"error: {tmp_path / '.out.lock'}: No space left on device", err


def test_a_really_full_disk_names_the_file(tmp_path: Path) -> None:
    disk = tmp_path / "disk"
    if not tmpfs(disk, "256k"):
        pytest.skip("cannot mount a tmpfs here")
    try:
        fd = os.open(disk / "filler", os.O_WRONLY | os.O_CREAT)  # fill it
        try:
            while os.write(fd, b"\0" * 4096):
                pass
        except OSError:
            pass
        finally:
            os.close(fd)
        code, err = run_cli(["run", PANEL, *SMALL, "-o", str(disk / "out"), "--no-figures", "--no-report"])
        assert code == 2 and "No space left on device" in err and str(disk) in err, err
        assert "error: : " not in err
    finally:
        umount(disk)


# -- 6. the embedded cluster's network exposure ---------------------------------------------------------------
def test_the_embedded_cluster_listens_on_loopback_only() -> None:
    import psutil

    from shellcontact.studies.engine import Dask

    engine = Dask(1, None)
    try:
        # every child too: an earlier in-process mumps test in this worker initialised MPI as a singleton, which
        # starts no helper daemon (orted) and no TCP transport (linalg.mpi.SINGLETON_MCA)
        procs = [psutil.Process(), *psutil.Process().children(recursive=True)]
        listening = {(c.laddr.ip, c.laddr.port) for p in procs for c in p.net_connections(kind="inet")
                     if c.status == psutil.CONN_LISTEN}
        dashboard_port = int(engine.dashboard.split("//")[1].split("/")[0].split(":")[1])
        assert dashboard_port in {port for _, port in listening}
        assert {ip for ip, _ in listening} == {"127.0.0.1"}, listening
    finally:
        engine.close()


# -- 7, 8. --scheduler ----------------------------------------------------------------------------------------
@pytest.mark.parametrize("address", ["http://127.0.0.1:8786", "tls://127.0.0.1:8786", "inproc://x", "ucx://h:1",
                                     "tcp://127.0.0.1", " tcp://127.0.0.1:8786", "tcp://127.0.0.1:70000", "tcp://"])
def test_bad_scheduler_addresses_are_exit_2_by_name(tmp_path: Path, monkeypatch, address: str) -> None:
    monkeypatch.chdir(tmp_path)
    monkeypatch.delenv("DASK_DISTRIBUTED__COMM__TLS__CA_FILE", raising=False)
    code, err = run_cli(["study", PANEL, *SMALL, "-p", "shell.thickness=0.01,0.012", "--scheduler", address])
    assert code == 2 and err.startswith("error: --scheduler: "), err
    assert sorted(p.name for p in tmp_path.iterdir()) == []


def _server(answer: bytes | None) -> int:
    """A port that accepts and then says nothing (None) or ``answer``."""
    s = socket.socket()
    s.bind(("127.0.0.1", 0))
    s.listen(8)
    held = []

    def serve() -> None:
        while True:
            c, _ = s.accept()
            held.append(c)
            if answer:
                c.sendall(answer)

    threading.Thread(target=serve, daemon=True).start()
    return s.getsockname()[1]


def _connect_within(address: str, seconds: float) -> BaseException | None:
    from shellcontact.studies.engine import Dask

    box: dict = {}

    def connect() -> None:
        try:
            Dask(None, address).close()
        except BaseException as exc:  # noqa: BLE001
            box["error"] = exc

    t = threading.Thread(target=connect, daemon=True)
    t.start()
    t.join(seconds)
    assert not t.is_alive(), f"still connecting to {address} after {seconds} s"
    return box.get("error")


@pytest.mark.parametrize("answer", [None, b"HTTP/1.1 400 Bad Request\r\nContent-Length: 0\r\n\r\n" * 50],
                         ids=["silent", "http"])
def test_a_port_that_is_no_scheduler_is_refused_in_time(monkeypatch, answer) -> None:
    """Measured: the silent port is refused after CONNECT_TIMEOUT + 5 s (here 1 + 5); a web server at once."""
    import shellcontact.studies.engine as engine

    monkeypatch.setattr(engine, "CONNECT_TIMEOUT", 1.0)
    exc = _connect_within(f"tcp://127.0.0.1:{_server(answer)}", 30)
    assert isinstance(exc, InputError) and exc.field == "--scheduler", repr(exc)


def test_a_scheduler_without_workers_is_said_and_refused(monkeypatch) -> None:
    import shellcontact.studies.engine as engine

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    proc = subprocess.Popen([sys.executable, "-m", "distributed.cli.dask_scheduler", "--host", "127.0.0.1", "--port",
                             str(port), "--no-dashboard"], env=ENV, stdout=subprocess.DEVNULL,
                            stderr=subprocess.DEVNULL)
    try:
        deadline = time.monotonic() + 60
        while socket.socket().connect_ex(("127.0.0.1", port)) != 0:
            assert time.monotonic() < deadline
            time.sleep(0.1)
        said: list[str] = []
        monkeypatch.setattr(engine, "WORKER_TIMEOUT", 1.0)
        with pytest.raises(InputError) as exc:
            engine.Dask(None, f"tcp://127.0.0.1:{port}", notice=said.append)
        assert "has no worker" in exc.value.message and "dask worker" in exc.value.message
        assert said and "no worker yet" in said[0]
    finally:
        proc.kill()
        proc.wait()


# -- 7, 9. --points -------------------------------------------------------------------------------------------
@pytest.mark.parametrize("content", ["latin1", "cell", "big", "zero"])
def test_bad_points_files_are_exit_2_by_name(tmp_path: Path, monkeypatch, content: str) -> None:
    monkeypatch.chdir(tmp_path)
    path = Path("points.csv")
    if content == "latin1":
        path.write_bytes("shell.thickness\n0.01 \xb5m\n".encode("latin-1"))
    elif content == "cell":
        path.write_text("shell.thickness\n" + "1" * (200 * 1024) + "\n")
    elif content == "big":
        with open(path, "wb") as fh:
            fh.truncate(65 * 2**20)  # sparse: 65 MiB of zeros
    else:
        path = Path("/dev/zero")
    code, err = run_cli(["study", PANEL, *SMALL, "--points", str(path), "--serial"])
    assert code == 2 and err.startswith("error: --points: "), err


# -- 9. seeds, unit systems, workers, -q -------------------------------------------------------------------
def test_negative_seed_is_refused() -> None:
    from shellcontact.studies.sampling import latin_hypercube, parse_spec

    spec = [parse_spec("shell.thickness=uniform(0.01,0.02)")]
    assert latin_hypercube(spec, 4, 1) != latin_hypercube(spec, 4, 2)
    with pytest.raises(InputError) as exc:
        latin_hypercube(spec, 4, -1)
    assert exc.value.field == "--seed"
    code, err = run_cli(["study", PANEL, *SMALL, "-p", "shell.thickness=uniform(0.01,0.02)", "--samples", "2",
                         "--seed", "-1"])
    assert code == 2 and err.startswith("error: --seed: "), err


def test_a_study_varying_the_unit_system_is_refused(tmp_path: Path, monkeypatch) -> None:
    monkeypatch.chdir(tmp_path)
    code, err = run_cli(["study", PANEL, *SMALL, "-p", "units.system=SI,mm", "--serial"])
    assert code == 2 and err.startswith("error: -p units.system: ") and "one study per system" in err, err


@pytest.mark.parametrize("option", ["--workers", "--jobs"])
def test_workers_have_an_upper_bound(tmp_path: Path, monkeypatch, option: str) -> None:
    monkeypatch.chdir(tmp_path)
    command = ["study", "-p", "shell.thickness=0.01,0.012"] if option == "--workers" else \
        ["sweep", "--param", "shell.thickness", "--values", "0.01,0.012"]
    code, err = run_cli([command[0], PANEL, *SMALL, *command[1:], option, "1000000"])
    assert code == 2 and err.startswith(f"error: {option}: ") and "at most" in err, err
    with pytest.raises(InputError):
        study(panel(), POINTS, workers=10**6)


def test_quiet_verify_prints_nothing(monkeypatch, capsys) -> None:
    """The checks' solves warn as designed (a penalty's residuals); -q prints nothing but errors."""
    import logging

    import shellcontact.verify as verify

    def checks():
        logging.getLogger("shellcontact").warning("warning: KKT: scaled residuals above the tolerance")
        return []

    monkeypatch.setattr(verify, "run_checks", checks)
    code, err = run_cli(["verify", "-q"])
    assert code == 0 and err == "", err
    assert capsys.readouterr().out == ""


def test_ctrl_c_while_the_cluster_starts_prints_no_traceback(tmp_path: Path) -> None:
    """SIGINT to the whole process group (a terminal's Ctrl-C) right after the first worker process appears,
    and later: exit 130 and one line, from the parent and from every worker."""
    import signal

    import psutil

    for delay in (0.0, 0.3, 1.0):
        proc = subprocess.Popen([sys.executable, "-m", "shellcontact.cli", "study", PANEL, *SMALL, "-p",
                                 "shell.thickness=0.01,0.012", "-o", str(tmp_path / f"st{delay}"), "--workers", "2"],
                                env=ENV, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                                start_new_session=True)
        deadline = time.monotonic() + 60
        while not psutil.Process(proc.pid).children(recursive=True):
            assert proc.poll() is None and time.monotonic() < deadline
            time.sleep(0.005)
        time.sleep(delay)
        os.killpg(proc.pid, signal.SIGINT)
        _, err = proc.communicate(timeout=60)
        assert proc.returncode == 130 and err == "interrupted\n", (delay, err)


def test_a_worker_spawned_after_an_abandoned_cluster_start_exits_silently() -> None:
    """The race behind a traceback after "interrupted": a nanny spawning (or restarting) a worker after the start
    was abandoned. Such a process must exit at once, before Python starts, and spawning must recover afterwards."""
    import multiprocessing
    import multiprocessing.spawn

    from shellcontact.studies import engine

    real = multiprocessing.spawn.get_executable()
    with engine._workers_ignore_sigint() as abandon:
        abandon()
    ctx = multiprocessing.get_context("spawn")
    late = ctx.Process(target=print, args=("a late worker ran Python",))
    started = time.monotonic()
    late.start()
    late.join(30)
    assert late.exitcode == 1 and time.monotonic() - started < 5  # `false`, not Python (which would exit 0)
    deadline = time.monotonic() + engine.RESTORE_DELAY + 10
    while multiprocessing.spawn.get_executable() != real:
        assert time.monotonic() < deadline, multiprocessing.spawn.get_executable()
        time.sleep(0.05)
    again = ctx.Process(target=print, args=("",))
    again.start()
    again.join(60)
    assert again.exitcode == 0
