"""The points of a study, run: each point's case checked before the first solve, the points solved in this
process or as Dask tasks (``engine``), families of points on one mesh solved together (``curves``), every
finished point recorded atomically in ``output_dir/steps/`` so that an interrupted study resumes without
recomputing it, and the output directory written whole or not at all. ``sweeps``, ``parametric`` and
``refinement`` are the studies built on it; ``rows`` turns their summaries into rows.
"""

from __future__ import annotations

import hashlib
import json
import logging
import math
import os
import shutil
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from ..errors import InputError
from ..inputs.overrides import apply_overrides
from ..inputs.user_functions import CodeConsent, code_consent
from ..outputs.files import atomic_write_bytes, check_output_dir, write_json
from ..problem.case import Case, case_from_dict
from .sampling import Point

log = logging.getLogger("shellcontact")

Progress = Callable[[int, int, str], None]  # (done, total, message)

#: a study's records of finished points (``steps/step-NNNN.json``) and kept fields (``fields/NNNN/``)
RECORDS, FIELDS = "steps", "fields"
#: ``keep_fields``: what each point keeps
KEEP_FILES = {None: (), "npz": ("results.npz",), "vtu": ("results.npz", "fields.vtu")}
PROBE_COMPONENTS = ("u", "v", "w")


def _fingerprint(raw: dict[str, Any], source: Any) -> str:
    """The identity of a case: its contents and its file's real path (``case.toml``, ``./case.toml`` and
    ``/abs/case.toml`` are one case, so a study resumes whichever way it is spelled)."""
    where = os.path.realpath(source) if source is not None else None
    text = json.dumps({"case": raw, "source": str(where)}, sort_keys=True, default=str)
    return hashlib.sha256(text.encode()).hexdigest()


def _point_cases(case: Case, points: Sequence[Point], source: str | None, label: Callable[[int], str],
                 option: str) -> list[tuple[dict, Case]]:
    """Every point's case, validated through the schema before the first solve; a bad key or value names its
    point (a key path that does not fit the case, the ``option`` that gave it)."""
    out = []
    for i, point in enumerate(points):
        try:
            raw = apply_overrides(case.raw, point)
            with code_consent(case.code):  # a point imports only what the case was allowed to
                out.append((raw, case_from_dict(raw, source=source)))
        except InputError as exc:
            where = option + exc.field.removeprefix("--set") if exc.field.startswith("--set ") else exc.field
            raise InputError(where, f"{exc.message} ({label(i)})") from None
    return out


def _record_path(steps: Path, index: int) -> Path:
    return steps / f"step-{index:04d}.json"


def _fields_dir(work: Path, index: int) -> Path:
    return work / FIELDS / f"{index:04d}"


def _load_record(work: Path, index: int, fingerprint: str, keep: Sequence[str] = ()) -> dict[str, Any] | None:
    """A finished point's record when it belongs to this case and holds the fields asked for."""
    try:
        rec = json.loads(_record_path(work / RECORDS, index).read_text())
    except (OSError, ValueError):
        return None
    if not (isinstance(rec, dict) and rec.get("fingerprint") == fingerprint and "row" in rec):
        return None
    return rec if all((_fields_dir(work, index) / name).is_file() for name in keep) else None


def _solve_group(cases: Sequence[Case], max_memory: float | str | None = None) -> list[Any]:
    """The results (``analysis.Result``) of cases that differ at most in their [punch] tables, in order.

    Those of one family (``curves.family_key``: the same mesh too) share the mesh, the assembly and, where
    their contact rows allow, the factorisation (``curves.solve_families``); without a warm start each
    result is bit for bit that of its case solved alone, so a point's numbers do not depend on which
    points share its task.
    """
    from .curves import solve_families

    results: list[Any] = [None] * len(cases)
    for k, result in solve_families(cases, max_memory=max_memory):
        results[k] = result
    return results


def _field_bytes(result: Any, keep: Sequence[str]) -> dict[str, bytes]:
    """The kept files of one point as bytes (a worker need not share the study's filesystem)."""
    if not keep:
        return {}
    import tempfile

    from ..outputs.writers import write_npz, write_vtu

    writers = {"results.npz": write_npz, "fields.vtu": write_vtu}
    out = {}
    with tempfile.TemporaryDirectory(prefix="shellcontact-fields-") as tmp:
        for name in keep:
            path = Path(tmp) / name
            writers[name](result, path)
            out[name] = path.read_bytes()
    return out


def _solve_points(raws: Sequence[dict], source: str | None, keep: Sequence[str],
                  max_memory: float | str | None = None,
                  code: CodeConsent | None = None) -> list[tuple[dict[str, Any], dict[str, bytes]]]:
    """One Dask task: the summaries (and kept files) of a family of points (the worker validates the cases
    again from ``raws``, importing only the code ``code``, the consent the study was given, allows)."""
    with code_consent(code):
        cases = [case_from_dict(raw, source=source) for raw in raws]
    return [(r.summary(), _field_bytes(r, keep)) for r in _solve_group(cases, max_memory)]


def _families(raws: Sequence[dict], todo: Sequence[int]) -> list[list[int]]:
    """The points whose cases differ only in [punch]-table keys (a family shares the shell's stiffness),
    each family in point order."""
    families: dict[str, list[int]] = {}
    for i in todo:
        shell = json.dumps({k: v for k, v in raws[i].items() if k != "punch"}, sort_keys=True, default=str)
        families.setdefault(shell, []).append(i)
    return list(families.values())


#: the most points in one task: past ~16 a shared factorisation saves little more per point (1/16 of one)
#: while a task lost with its worker, or not yet recorded at an interruption, costs more
TASK_POINTS = 16


def _tasks(raws: Sequence[dict], todo: Sequence[int], workers: int) -> list[list[int]]:
    """Families cut into ordered runs of at most ⌈len(todo)/workers⌉ (and TASK_POINTS) points: one task each,
    so that every worker gets work and a family's points stay together."""
    size = max(1, min(TASK_POINTS, math.ceil(len(todo) / max(1, workers))))
    return [fam[k:k + size] for fam in _families(raws, todo) for k in range(0, len(fam), size)]


def _run_points(
    points: Sequence[tuple[dict, Case]],
    source: str | None,
    fps: Sequence[str],
    work: Path | None,
    *,
    workers: int | None,
    scheduler: str | None,
    row_of: Callable[[int, dict[str, Any]], dict[str, Any]],
    label: Callable[[int], str],
    title: str,
    progress: Progress | None,
    announce: Callable[[str], None] | None,
    keep: Sequence[str],
    max_memory: float | str | None,
) -> tuple[list[dict[str, Any]], list[dict[str, Any]], int]:
    """Solve the points without a record in ``work``: serially (``workers == 0``) or as Dask tasks; each
    finished point's kept files and record are written as it arrives (the record last)."""
    from .engine import SCHEDULER_ENV, open_engine, scheduler_address

    n = len(points)
    rows: list[dict[str, Any] | None] = [None] * n
    sums: list[dict[str, Any] | None] = [None] * n
    reused = 0
    if work is not None:
        _own_directories(work)
        (work / RECORDS).mkdir(parents=True, exist_ok=True)
        for tmp in (work / RECORDS).glob(".step-*.tmp"):  # left by a study killed while writing a record
            tmp.unlink(missing_ok=True)
        for i in range(n):
            rec = _load_record(work, i, fps[i], keep)
            if rec is not None:
                rows[i], sums[i] = rec["row"], rec.get("summary", {})
                reused += 1
    if reused:
        log.info("resuming: %d of %d points already done in %s", reused, n, work)
    done = reused
    if progress:
        progress(done, n, title)
    todo = [i for i in range(n) if rows[i] is None]
    if not todo:
        return rows, sums, reused  # type: ignore[return-value]

    def finished(i: int, summary: dict[str, Any], files: dict[str, bytes]) -> None:
        nonlocal done
        row = row_of(i, summary)
        if work is not None:
            for name, data in files.items():
                atomic_write_bytes(_fields_dir(work, i) / name, data)
            write_json(_record_path(work / RECORDS, i),
                       {"index": i, "fingerprint": fps[i], "row": row, "summary": summary, "fields": sorted(files)})
        rows[i], sums[i] = row, summary
        done += 1
        log.info("point %d/%d: %s, energy %.6g", i + 1, n, label(i), summary.get("energy", math.nan))
        if progress:
            progress(done, n, label(i))

    # SHELLCONTACT_SCHEDULER stands for the default (workers None), never for an explicit --workers/--serial
    address = scheduler_address(scheduler) if scheduler is not None or workers is None else None
    if address is None and workers is not None:
        workers = min(workers, len(todo))
    if address is None and (workers == 0 or len(todo) == 1):
        workers = 0  # one point: no cluster to start
    elif address is None and workers is None:
        workers = min(os.cpu_count() or 1, len(todo))
    with open_engine(workers, address, "--scheduler" if scheduler is not None else SCHEDULER_ENV,
                     notice=announce) as engine:
        if announce and workers != 0:
            dashboard = f"; dashboard {engine.dashboard}" if engine.dashboard else ""
            announce(f"solving {len(todo)} points on {engine.description}{dashboard}")
        if workers == 0 and address is None:  # in order, each point recorded as it is solved
            from .curves import solve_families

            for k, result in solve_families([points[i][1] for i in todo], max_memory=max_memory):
                finished(todo[k], result.summary(), _field_bytes(result, keep))
            return rows, sums, reused  # type: ignore[return-value]
        tasks = _tasks([raw for raw, _ in points], todo, engine.workers)
        code = points[0][1].code
        args = [([points[i][0] for i in t], source, keep, max_memory, code) for t in tasks]

        def task_done(k: int, value: list[tuple[dict[str, Any], dict[str, bytes]]]) -> None:
            for i, (summary, files) in zip(tasks[k], value):
                finished(i, summary, files)

        def describe(k: int) -> str:  # a task's points (a family's are not always consecutive)
            t = tasks[k]
            if len(t) == 1:
                return f"the point {t[0]} ({label(t[0])})"
            return f"the points {', '.join(map(str, t[:6]))}{', …' if len(t) > 6 else ''} ({label(t[0])}, …)"

        engine.run(_solve_points, args, task_done, describe)
    return rows, sums, reused  # type: ignore[return-value]


def _own_directories(work: Path) -> None:
    """The records and kept fields are written only inside the study's directory: a symbolic link in their
    place (``steps/``, ``fields/``, ``fields/NNNN/``) would write through it into the link's target."""
    links = [p for p in (work / RECORDS, work / FIELDS) if p.is_symlink()]
    if (work / FIELDS).is_dir() and not (work / FIELDS).is_symlink():
        links += [p for p in (work / FIELDS).iterdir() if p.is_symlink()]
    if links:
        raise InputError("--output", f"{str(links[0])!r} is a symbolic link; a study writes its records only "
                         "inside its own directory: remove the link (or use --force for a fresh study)")


def _same_study(directory: Path, manifest_name: str, manifest: dict[str, Any], identity: Sequence[str]) -> bool:
    """Whether ``directory`` holds (part of) this very study: the same case and points."""
    try:
        old = json.loads((directory / manifest_name).read_text())
    except (OSError, ValueError):
        return False
    return isinstance(old, dict) and all(old.get(k) == manifest[k] for k in identity)


def _in_directory(
    target: Path,
    *,
    manifest_name: str,
    manifest: dict[str, Any],
    identity: Sequence[str],
    final: Sequence[str],
    entries: Sequence[str],
    overwrite: bool,
    wait: bool,
    solve: Callable[[Path], Any],
    write: Callable[[Any, Path], list[str]],
) -> tuple[Any, list[str]]:
    """A resumable study in ``target``: records of finished points in place, the final files together.

    A fresh or resumed study records its points in place (resumable); one replacing another result works
    beside it and keeps that result until the new one is complete. ``solve(work)`` computes, ``write(res,
    directory)`` writes the final files and returns their names.
    """
    from ..outputs.transaction import DirectoryLock, Staging, name_in_target, remove_stale, stale_stagings

    resume = not overwrite and _same_study(target, manifest_name, manifest, identity)
    if not resume:
        check_output_dir(target, overwrite)
    with DirectoryLock(target, wait=wait):
        # an interrupted replacement of another result by this very study: its finished points are kept
        adopt = next((d for d in stale_stagings(target) if _same_study(d, manifest_name, manifest, identity)), None)
        resume = not overwrite and _same_study(target, manifest_name, manifest, identity)
        if not resume:
            check_output_dir(target, overwrite)
        in_place = resume or not target.exists() or not any(target.iterdir())
        remove_stale(target, keep=None if in_place else adopt)
        created, fresh = not target.exists(), in_place and not resume
        stage = None if in_place else Staging(target)
        work = target if stage is None else stage.path
        try:
            if stage is not None and adopt is not None:
                stage.adopt(adopt)
            elif stage is not None:
                stage.create()
            work.mkdir(parents=True, exist_ok=True)
            write_json(work / manifest_name, manifest)
            res = solve(work)
            if stage is None:
                stage = Staging(target)  # the final files appear together beside the records
                stage.create()
            names = write(res, stage.path)
            stage.commit(final if in_place else entries)
        except BaseException as exc:
            if not in_place and stage is not None and any((stage.path / RECORDS).glob("step-*.json")):
                pass  # finished points replacing another result: kept for the next run to take over
            elif stage is not None:
                stage.discard()
                if isinstance(exc, OSError):
                    name_in_target(exc, stage.path, target)
            if fresh and not any((target / RECORDS).glob("step-*.json")):  # nothing worth resuming: leave nothing
                if created:
                    shutil.rmtree(target, ignore_errors=True)
                else:
                    for name in (RECORDS, FIELDS):
                        shutil.rmtree(target / name, ignore_errors=True)
                    (target / manifest_name).unlink(missing_ok=True)
            raise
    return res, names


def _keep_files(keep_fields: str | None) -> tuple[str, ...]:
    if keep_fields not in KEEP_FILES:
        raise InputError("--keep-fields", f"one of npz, vtu, got {keep_fields!r}")
    return KEEP_FILES[keep_fields]


def _check_workers(workers: int | None) -> None:
    from .engine import max_workers

    if workers is not None and (isinstance(workers, bool) or not isinstance(workers, int) or workers < 0
                                or workers > max_workers()):
        raise InputError("--workers", f"must be an integer >= 0 (0: in this process) and at most {max_workers()} "
                         f"(four processes per core), got {workers!r}")


