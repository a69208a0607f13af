"""Parameter studies on Dask (shellcontact.studies.parametric.study, shellcontact.studies.engine): the same rows,
bit for bit, in this process, on an embedded cluster and on a separate scheduler with two worker processes one of
which is killed in the middle; resumed studies recompute nothing and write the same files; bad keys and values named.

Tiny meshes (the paper's panel and the Scordelis–Lo roof on 4 × 4 to 6 × 6 cells), a few points each.
"""

from __future__ import annotations

import json
import os
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

import shellcontact as sc
import shellcontact.studies.curves as curves
import shellcontact.studies.runner as studies
from shellcontact.errors import InputError
from shellcontact.studies.parametric import study
from shellcontact.studies.sampling import grid, latin_hypercube, parse_spec

ROOT = Path(__file__).resolve().parents[1]
PANEL = str(ROOT / "examples" / "paper_panel.toml")
ROOF = str(ROOT / "examples" / "scordelis_lo.toml")
ENV = {**os.environ, "OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1"}


def panel():
    return sc.load_case(PANEL, ["mesh.nx=6", "mesh.nphi=6"])


def panel_points():
    """Two families of three points: the indentation varies within a family (one task), the thickness across."""
    return grid([parse_spec("shell.thickness=0.01,0.012"), parse_spec("punch.0.indentation=1e-3:3e-3:3")])


def test_families_share_a_task_in_point_order() -> None:
    raws = [{"shell": {"thickness": t}, "punch": [{"indentation": d}]} for t in (1, 2) for d in (1, 2, 3)]
    assert studies._families(raws, range(6)) == [[0, 1, 2], [3, 4, 5]]
    assert studies._tasks(raws, [0, 2, 3, 4, 5], workers=2) == [[0, 2], [3, 4, 5]]
    assert studies._tasks(raws, range(6), workers=4) == [[0, 1], [2], [3, 4], [5]]


def test_embedded_cluster_equals_serial_bit_for_bit(tmp_path: Path) -> None:
    case, points = panel(), panel_points()
    serial = study(case, points, tmp_path / "serial", workers=0, keep_fields="npz", figures=False)
    said: list[str] = []
    cluster = study(case, points, tmp_path / "cluster", workers=2, keep_fields="npz", figures=False,
                    announce=said.append)
    assert "an embedded Dask cluster of 2 worker processes; dashboard http://127.0.0.1:" in said[0]
    assert cluster.rows == serial.rows  # every float equal, not close
    for name in ("study.csv", "study.parquet"):
        assert (tmp_path / "cluster" / name).read_bytes() == (tmp_path / "serial" / name).read_bytes(), name
    for i in range(len(points)):
        a = np.load(tmp_path / "serial" / "fields" / f"{i:04d}" / "results.npz")
        b = np.load(tmp_path / "cluster" / "fields" / f"{i:04d}" / "results.npz")
        assert np.array_equal(a["U"], b["U"]) and np.array_equal(a["w"], b["w"])
    # the rows are those of single runs of the same cases, and the table's columns carry units
    one = sc.solve(sc.load_case(PANEL, ["mesh.nx=6", "mesh.nphi=6", "shell.thickness=0.012",
                                        "punch.0.indentation=2e-3"])).summary()
    assert serial.rows[4]["energy"] == one["energy"] and serial.rows[4]["force"] == one["contact"][0]["force_magnitude"]
    import pyarrow.parquet as pq

    table = pq.read_table(tmp_path / "serial" / "study.parquet")
    assert table.column("energy").to_pylist() == [r["energy"] for r in serial.rows]
    units = {f.name: (f.metadata or {}).get(b"unit") for f in table.schema}
    assert units["punch.0.indentation"] == b"m" and units["force"] == b"N" and units["dofs"] is None


def test_study_keys_and_values_are_validated_by_the_schema(tmp_path: Path) -> None:
    case = panel()
    with pytest.raises(InputError) as err:
        study(case, [{"shell.thicknes": 0.01}], workers=0)
    assert "thickness" in err.value.message and "point 0" in err.value.message  # did you mean, and which point
    with pytest.raises(InputError) as err:
        study(case, [{"shell.thickness": 0.01}, {"shell.thickness": -0.01}], tmp_path / "bad", workers=0)
    assert err.value.field == "shell.thickness" and "point 1" in err.value.message and "-0.01" in err.value.message
    assert not (tmp_path / "bad").exists()  # nothing solved or written


def test_random_study_writes_histograms_and_rank_sensitivity(tmp_path: Path) -> None:
    case = sc.load_case(ROOF, ["mesh.nx=4", "mesh.nphi=4"])
    specs = [parse_spec("shell.thickness=normal(0.25,0.01)"), parse_spec("shell.radius=uniform(24,26)")]
    res = study(case, latin_hypercube(specs, 8, seed=1), tmp_path / "lhs", sampling="lhs", workers=0,
                probe_components=("u", "w"))
    for name in ("study.csv", "sensitivity.csv", "response.png", "histograms.png", "sensitivity.png"):
        assert (tmp_path / "lhs" / name).stat().st_size > 100, name
    assert {"probe0_u", "probe0_w"} <= set(res.rows[0])
    t = [r["shell.thickness"] for r in res.rows]
    e = [r["energy"] for r in res.rows]
    from scipy import stats

    assert res.sensitivity["energy"]["shell.thickness"] == pytest.approx(stats.spearmanr(t, e).statistic, abs=1e-12)


def test_interrupted_study_resumes_without_recomputing(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Interrupt a study on the embedded cluster after 2 points, run it again: the files of an uninterrupted
    study, the finished points' records untouched and not solved again."""
    case, points = panel(), panel_points()
    study(case, points, tmp_path / "ref", workers=0, figures=False)

    def stop_after_two(done: int, total: int, message: str) -> None:
        if done == 2:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        study(case, points, tmp_path / "cut", workers=2, progress=stop_after_two, figures=False)
    records = sorted((tmp_path / "cut" / "steps").glob("step-*.json"))
    assert len(records) >= 2 and not (tmp_path / "cut" / "study.csv").exists()
    stamps = {p.name: p.stat().st_mtime_ns for p in records}
    solved = []
    families = curves.solve_families
    monkeypatch.setattr(curves, "solve_families", lambda cases, **kw: solved.extend(cases) or families(cases, **kw))
    res = study(case, points, tmp_path / "cut", workers=0, figures=False)
    assert res.reused == len(records) and len(solved) == len(points) - len(records)
    assert {p.name: p.stat().st_mtime_ns for p in records} == stamps
    for name in ("study.csv", "study.parquet"):
        assert (tmp_path / "cut" / name).read_bytes() == (tmp_path / "ref" / name).read_bytes(), name
    assert sorted(os.listdir(tmp_path / "cut")) == sorted(os.listdir(tmp_path / "ref"))


def test_study_command_grid(tmp_path: Path) -> None:
    r = subprocess.run(
        [sys.executable, "-m", "shellcontact.cli", "study", PANEL, "--set", "mesh.nx=4", "--set", "mesh.nphi=4",
         "-p", "punch.0.indentation=1e-3,2e-3", "-p", "shell.thickness=0.01,0.012", "--serial", "-o", "g"],
        cwd=tmp_path, env=ENV, capture_output=True, text=True, timeout=300)
    assert r.returncode == 0 and "Traceback" not in r.stderr, r.stderr
    lines = (tmp_path / "g" / "study.csv").read_text().splitlines()
    assert lines[0].startswith("punch.0.indentation,shell.thickness,dofs,energy") and len(lines) == 5
    assert "punch.0.indentation [m]" in r.stdout and "force [N]" in r.stdout
    assert (tmp_path / "g" / "response.png").stat().st_size > 1000
    bad = subprocess.run(
        [sys.executable, "-m", "shellcontact.cli", "study", PANEL, "-p", "shell.thickness=normal(0.01,0.001)",
         "--sample", "lhs", "-o", "h"], cwd=tmp_path, env=ENV, capture_output=True, text=True, timeout=300)
    assert bad.returncode == 2 and "--samples" in bad.stderr and not (tmp_path / "h").exists()


# -- an external cluster: a scheduler and two workers as separate processes ---------------------------------
def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@pytest.fixture
def dask_cluster(tmp_path: Path):
    """``dask scheduler`` and two ``dask worker`` processes on 127.0.0.1 (each in its own process group,
    killed at teardown whatever happened)."""
    port = free_port()
    address = f"tcp://127.0.0.1:{port}"
    procs: list[subprocess.Popen] = []

    def start(*args: str) -> subprocess.Popen:
        p = subprocess.Popen([sys.executable, "-m", "dask", *args], cwd=tmp_path, env=ENV, start_new_session=True,
                             stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        procs.append(p)
        return p

    try:
        start("scheduler", "--host", "127.0.0.1", "--port", str(port), "--no-dashboard")
        workers = [start("worker", address, "--host", "127.0.0.1", "--nthreads", "1", "--nworkers", "1",
                         "--no-dashboard", "--name", f"w{k}") for k in range(2)]
        from distributed import Client

        with Client(address, timeout="60s") as client:
            client.wait_for_workers(2, timeout=120)
        yield address, workers
    finally:
        for p in procs:
            try:
                os.killpg(p.pid, signal.SIGKILL)
            except ProcessLookupError:
                pass
            p.wait()


def test_external_cluster_with_a_killed_worker_equals_serial(tmp_path: Path, dask_cluster) -> None:
    address, workers = dask_cluster
    args = ["study", ROOF, "--set", "mesh.nx=6", "--set", "mesh.nphi=6", "-p", "shell.thickness=0.2:0.3:8",
            "--no-figures"]
    serial = subprocess.run([sys.executable, "-m", "shellcontact.cli", *args, "--serial", "-o", "serial"],
                            cwd=tmp_path, env=ENV, capture_output=True, text=True, timeout=300)
    assert serial.returncode == 0, serial.stderr
    proc = subprocess.Popen([sys.executable, "-m", "shellcontact.cli", *args, "--scheduler", address, "-o", "ext"],
                            cwd=tmp_path, env=ENV, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        steps = tmp_path / "ext" / "steps"
        deadline = time.monotonic() + 120
        while not list(steps.glob("step-*.json")) and proc.poll() is None and time.monotonic() < deadline:
            time.sleep(0.01)
        assert proc.poll() is None, "the study ended before a worker could be killed"
        os.killpg(workers[0].pid, signal.SIGKILL)  # its nanny and worker process, in the middle of the study
        out, err = proc.communicate(timeout=300)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == 0 and "Traceback" not in err, err
    assert f"the Dask cluster at {address}" in out
    done = len(list(steps.glob("step-*.json")))
    assert done == 8
    assert (tmp_path / "ext" / "study.csv").read_bytes() == (tmp_path / "serial" / "study.csv").read_bytes()
    # the environment variable names the same cluster; a finished study is only read back
    again = subprocess.run([sys.executable, "-m", "shellcontact.cli", *args, "-o", "ext"], cwd=tmp_path,
                           env={**ENV, "SHELLCONTACT_SCHEDULER": address}, capture_output=True, text=True, timeout=300)
    assert again.returncode == 0 and "resumed: 8 of 8 points" in again.stdout, again.stderr
    other = subprocess.run([sys.executable, "-m", "shellcontact.cli", *args[:-2], "shell.thickness=0.2,0.3",
                            "--no-figures", "-o", "env"], cwd=tmp_path, env={**ENV, "SHELLCONTACT_SCHEDULER": address},
                           capture_output=True, text=True, timeout=300)
    assert other.returncode == 0 and f"the Dask cluster at {address}" in other.stdout, other.stderr
    rows = json.loads((tmp_path / "env" / "study.json").read_text())["points"]
    assert [p["shell.thickness"] for p in rows] == [0.2, 0.3]


def test_parquet_keeps_types_and_writes_a_mixed_column_as_text(tmp_path: Path) -> None:
    import pyarrow.parquet as pq

    from shellcontact.studies.rows import write_parquet

    rows = [{"solver.method": "dual", "mesh.refine": 1, "energy": 1.5}, {"solver.method": 2, "mesh.refine": 2}]
    write_parquet(tmp_path / "t.parquet", rows, {"energy": "J"})
    table = pq.read_table(tmp_path / "t.parquet")
    assert table.to_pylist() == [{"solver.method": "dual", "mesh.refine": 1, "energy": 1.5},
                                 {"solver.method": "2", "mesh.refine": 2, "energy": None}]
    assert table.schema.field("energy").metadata == {b"unit": b"J"}


def test_a_task_that_kills_every_worker_is_named() -> None:
    """A point whose worker dies each time it runs (here: exits; in practice out of memory) stops the study
    with an input error naming it, after Dask's allowed failures (0 here, to be quick)."""
    import dask

    from shellcontact.studies.engine import open_engine

    with dask.config.set({"distributed.scheduler.allowed-failures": 0}), pytest.raises(InputError) as err:
        with open_engine(1, None) as engine:
            engine.run(lambda: os._exit(1), [()], lambda k, v: None, lambda k: "the point 7")
    assert err.value.field == "--workers" and "the point 7 ended every worker" in err.value.message


def test_without_pyarrow_the_parquet_file_is_skipped_with_a_message(tmp_path: Path,
                                                                    monkeypatch: pytest.MonkeyPatch) -> None:
    import logging

    from shellcontact.studies.rows import write_parquet

    monkeypatch.setitem(sys.modules, "pyarrow", None)  # import pyarrow now raises ImportError
    messages: list[str] = []
    handler = logging.Handler()
    handler.emit = lambda record: messages.append(record.getMessage())
    logger = logging.getLogger("shellcontact")
    logger.addHandler(handler)
    try:
        assert write_parquet(tmp_path / "study.parquet", [{"energy": 1.0}], {}) is None
    finally:
        logger.removeHandler(handler)
    assert not (tmp_path / "study.parquet").exists()
    assert any("study.parquet not written" in m and "shellcontact[parquet]" in m for m in messages)
