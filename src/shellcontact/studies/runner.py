"""Studies on Case objects through ``analysis.solve``: parameter studies, sweeps and mesh convergence.

* ``study(case, points, output_dir=...)`` — one solve per point ({case-file key: value}; ``sampling``
  builds grids, Latin hypercubes, Monte Carlo samples or reads a CSV table); one row per point. Points run
  in this process or as Dask tasks (``engine``); with ``output_dir`` every finished point is recorded
  atomically in ``output_dir/steps/`` and an interrupted study resumes without recomputing them.
* ``sweep(case, param, values, output_dir=...)`` — the one-key study of a load path (``sweep.csv``).
* ``convergence(case, levels)`` — nested uniform refinement ``mesh.refine = r0 … r0+L−1``: dofs,
  energy, a force or probe value, errors against the finest level and observed rates.
"""

from __future__ import annotations

import csv
import hashlib
import io as _io
import json
import logging
import math
import numbers
import os
import shutil
from collections.abc import Callable, Sequence, Sized
from dataclasses import dataclass, field
from fnmatch import fnmatchcase
from pathlib import Path
from typing import Any

from ..inputs.arguments import expect_callable, expect_integer, expect_numbers, expect_path
from ..problem.case import Case, case_from_dict, expect_case, key_kind
from ..errors import InputError
from ..outputs.files import (
    atomic_write_bytes,
    atomic_write_text,
    atomic_write_with,
    check_output_dir,
    expand_user,
    write_json,
)
from ..inputs.overrides import apply_overrides, split_path
from .sampling import (
    Point,
    parse_values,  # noqa: F401 — public here too (the sweep's --values; arguments.py names it)
    whole_value,
)
from ..outputs.tables import text_table
from ..inputs.user_functions import CodeConsent, code_consent

log = logging.getLogger("shellcontact")

Progress = Callable[[int, int, str], None]  # (done, total, message)

CONTACT_COLUMNS = (
    ("force", "force_magnitude"),
    ("normal_force", "total_normal_force"),
    ("area", "area"),
    ("peak_pressure", "peak_pressure"),
    ("active_vertices", "active_vertices"),
    ("punch_travel", "punch_travel"),
)


# -- rows -----------------------------------------------------------------------------------------------
#: the kind of quantity (units.KINDS) of each CSV column, by name pattern (None: a count or dimensionless)
COLUMN_KINDS = (("dofs", None), ("energy", "energy"), ("max_abs_w", "length"), ("probe*_[uvw]", "length"),
                ("normal_force*", "force"), ("force*", "force"), ("zone_area*", "area"), ("area*", "area"),
                ("line_force*", "force/length"),
                ("peak_pressure*", "pressure"), ("active_vertices*", None), ("punch_travel*", "length"),
                ("iterations", None), ("h", "length"))


def column_kind(column: str) -> str | None:
    return next((kind for pattern, kind in COLUMN_KINDS if fnmatchcase(column, pattern)), None)


def summary_row(summary: dict[str, Any], probe_components: Sequence[str] = ("w",)) -> dict[str, Any]:
    """The CSV columns of one solve: dofs, energy, max|w|, the probes' displacements (``probe<i>_<c>`` for
    each of ``probe_components``), and contact columns when present."""
    row: dict[str, Any] = {
        "dofs": summary.get("dofs"),
        "energy": summary.get("energy"),
        "max_abs_w": summary.get("max_abs_w"),
    }
    for i, p in enumerate(summary.get("probes") or []):
        for c in probe_components:
            row[f"probe{i}_{c}"] = p.get(c)
    contact = summary.get("contact")
    if contact:
        entries = contact if isinstance(contact, list) else [contact]
        for i, e in enumerate(entries):
            suffix = "" if len(entries) == 1 else f"_{i}"
            for col, key in CONTACT_COLUMNS:
                if e.get(key) is not None:
                    row[col + suffix] = e[key]
            if isinstance(e.get("zone"), dict) and e["zone"].get("area") is not None:
                row["zone_area" + suffix] = e["zone"]["area"]  # the area that converges (contact.contact_zone)
            # the rim's mean line force, or a line contact's line load; empty where there is no rim (a point
            # force: contact.<k>.rim.point_forces)
            rim = e.get("rim")
            has_rim = isinstance(rim, dict) and rim.get("kind") != "point"
            row["line_force" + suffix] = rim["mean_line_force"] if has_rim else None
    it = summary.get("iterations")
    if isinstance(it, int):
        row["iterations"] = it
    return row


def _cell(v: Any) -> str:
    if v is None:
        return ""
    if isinstance(v, float):
        return repr(v)
    return str(v)


def csv_text(rows: Sequence[dict[str, Any]]) -> str:
    cols: list[str] = []
    for r in rows:
        cols += [c for c in r if c not in cols]
    buf = _io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(cols)
    for r in rows:
        w.writerow([_cell(r.get(c)) for c in cols])
    return buf.getvalue()


def write_csv(path: str | Path, rows: Sequence[dict[str, Any]]) -> Path:
    atomic_write_text(path, csv_text(rows))
    return Path(path)


# -- the study engine ---------------------------------------------------------------------------------------
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


def write_parquet(path: str | Path, rows: Sequence[dict[str, Any]], units: dict[str, str]) -> Path | None:
    """The rows as a Parquet table (each column's unit in its field metadata); None, with a message, when
    pyarrow is not installed (``pip install 'shellcontact[parquet]'``)."""
    try:
        import pyarrow as pa
        import pyarrow.parquet as pq
    except ImportError:
        log.warning("%s not written: Parquet needs pyarrow (pip install 'shellcontact[parquet]'); the CSV has "
                    "the same table", Path(path).name)
        return None
    cols: list[str] = []
    for r in rows:
        cols += [c for c in r if c not in cols]
    arrays = []
    for c in cols:
        values = [r.get(c) for r in rows]
        try:
            arrays.append(pa.array(values))
        except (pa.ArrowInvalid, pa.ArrowTypeError):  # e.g. numbers and words in one column of a points table
            arrays.append(pa.array([None if v is None else str(v) for v in values]))
    table = pa.Table.from_arrays(arrays, names=cols)
    fields = [f.with_metadata({"unit": units[f.name]}) if units.get(f.name) else f for f in table.schema]
    table = table.cast(pa.schema(fields))
    atomic_write_with(path, lambda tmp: pq.write_table(table, tmp))
    return Path(path)


def column_units(columns: Sequence[str], keys: Sequence[str], system: str) -> dict[str, str]:
    """The unit of every column in ``system`` (the case's ``[units] system``); '' when dimensionless."""
    from ..units import label

    out = {}
    for c in columns:
        kind = key_kind(c) if c in keys else column_kind(c)
        unit = label(kind, system) if kind else ""
        out[c] = "" if unit == "–" else unit
    return out


# -- sweep ----------------------------------------------------------------------------------------------
@dataclass
class SweepResult:
    param: str
    values: list[float]
    rows: list[dict[str, Any]]
    summaries: list[dict[str, Any]]
    reused: int = 0
    files: dict[str, Path] = field(default_factory=dict)

    def csv(self) -> str:
        return csv_text(self.rows)


SWEEP_FINAL = ("sweep.csv", "sweep.parquet", "sweep.png", "force_indentation.png", "report.html")
#: what a sweep writes into its directory (``overwrite`` replaces exactly these)
SWEEP_ENTRIES = (*SWEEP_FINAL, "sweep.json", RECORDS, FIELDS)


def sweep(
    case: Case,
    param: str,
    values: Sequence[float],
    output_dir: str | Path | None = None,
    *,
    overwrite: bool = False,
    wait: bool = False,
    jobs: int = 1,
    workers: int | None = None,
    scheduler: str | None = None,
    keep_fields: str | None = None,
    progress: Progress | None = None,
    announce: Callable[[str], None] | None = None,
    figures: bool = True,
    max_memory: float | str | None = None,
) -> SweepResult:
    """Solve ``case`` for each value of the case-file key ``param`` (dotted path): the one-key ``study``.

    Every step's case is validated before the first solve. Where the steps run: ``workers`` as in ``study``
    (0: in this process; N: an embedded Dask cluster of N processes; ``scheduler``: an existing Dask
    cluster), else ``jobs`` (1, the default: in this process, in order; N > 1: N processes). With
    ``output_dir``: step records ``steps/step-NNNN.json`` (written as each step finishes; a record is reused
    when its case fingerprint matches, so running the same sweep again resumes it), then ``sweep.csv``,
    ``sweep.parquet`` (with pyarrow), ``sweep.json`` and the figures ``sweep.png`` and, with contact,
    ``force_indentation.png``, and ``report.html``, which appear together. ``keep_fields`` ("npz" or
    "vtu") keeps each step's ``fields/NNNN/results.npz`` (and ``fields.vtu``). A non-empty directory that
    does not hold this sweep is refused unless ``overwrite``; then the new sweep is staged beside it and
    replaces it only when complete (the previous result is kept until then; an interrupted ``overwrite``
    sweep starts over). ``max_memory`` bounds every step's solve (``analysis.solve``) and the steps' records.
    """
    from ..problem.sizing import check_steps

    expect_case(case, "sweep")
    if not isinstance(param, str):
        raise TypeError(f"sweep(): param must be a dotted case-file key such as 'punch.0.indentation', got "
                        f"{type(param).__name__}")
    if isinstance(values, Sized):  # a range(10**8) is refused before it becomes a list
        check_steps(len(values), max_memory)
    values = expect_numbers(values, "sweep", "values")
    expect_path(output_dir, "sweep", "output_dir", optional=True)
    jobs = expect_integer(jobs, "sweep", "jobs", 1)
    _check_workers(workers)
    expect_callable(progress, "sweep", "progress")
    keep = _keep_files(keep_fields)
    split_path(param)
    if not values:
        raise InputError("--values", "no values given")
    check_steps(len(values), max_memory)
    if workers is None:
        workers = 0 if jobs == 1 else jobs
    vals = [whole_value(v) for v in values]
    source = str(case.source) if case.source is not None else None
    points = _point_cases(case, [{param: v} for v in vals], source, lambda i: f"sweep step {i}: {param} = {vals[i]!r}",
                          "--param")
    fps = [_fingerprint(raw, source) for raw, _ in points]

    def solve(work: Path | None) -> SweepResult:
        rows, sums, reused = _run_points(
            points, source, fps, work, workers=workers, scheduler=scheduler,
            row_of=lambda i, s: {param: vals[i], **summary_row(s)}, label=lambda i: f"{param} = {vals[i]:g}",
            title=f"{param} sweep", progress=progress, announce=announce, keep=keep, max_memory=max_memory)
        return SweepResult(param, [float(v) for v in vals], rows, sums, reused)

    if output_dir is None:
        return solve(None)
    target = expand_user(output_dir)  # one path, checked and written
    manifest = {"case_file": source, "case": _fingerprint(case.raw, source), "param": param, "values": vals}
    res, names = _in_directory(
        target, manifest_name="sweep.json", manifest=manifest, identity=("case", "param", "values"),
        final=SWEEP_FINAL, entries=SWEEP_ENTRIES, overwrite=overwrite, wait=wait, solve=solve,
        write=lambda r, out: _write_sweep_files(r, out, param, figures, source, case.raw))
    res.files = {name: target / name for name in names}
    return res


def _write_sweep_files(res: SweepResult, out: Path, param: str, figures: bool, source: str | None,
                       raw: dict[str, Any]) -> list[str]:
    """sweep.csv, sweep.parquet, the figures and report.html into ``out``; returns their names."""
    names = ["sweep.csv"]
    write_csv(out / "sweep.csv", res.rows)
    system = res.summaries[0].get("unit_system", "SI") if res.summaries else "SI"
    cols = list(dict.fromkeys(c for r in res.rows for c in r))
    if write_parquet(out / "sweep.parquet", res.rows, column_units(cols, [param], system)) is not None:
        names.append("sweep.parquet")
    pngs: dict[str, bytes] = {}
    if figures:
        from ..outputs.figures import run as plots

        kind = key_kind(param)
        pngs["sweep.png"] = plots.png_bytes(plots.plot_sweep(res.rows, param, system=system, param_kind=kind))
        fi = plots.plot_force_indentation(res.rows, param, system=system, param_kind=kind)
        if fi is not None:
            pngs["force_indentation.png"] = plots.png_bytes(fi)
        for name, data in pngs.items():
            atomic_write_bytes(out / name, data)
        names += list(pngs)
    from ..outputs.report import write_study_report

    about = {"case file": source, "parameter": param, "values": len(res.values)}  # the same page when resumed
    write_study_report(out / "report.html", f"shellcontact sweep: {param}", res.rows, pngs, about, raw,
                       _heads(res.rows, [param], res.summaries))
    return [*names, "report.html"]


# -- study ----------------------------------------------------------------------------------------------
@dataclass
class StudyResult:
    keys: list[str]
    points: list[Point]
    rows: list[dict[str, Any]]
    summaries: list[dict[str, Any]]
    sampling: str = "points"
    reused: int = 0
    sensitivity: dict[str, dict[str, float | None]] = field(default_factory=dict)
    files: dict[str, Path] = field(default_factory=dict)

    def csv(self) -> str:
        return csv_text(self.rows)


STUDY_FINAL = ("study.csv", "study.parquet", "sensitivity.csv", "response.png", "histograms.png",
               "sensitivity.png", "report.html")
#: what a study writes into its directory (``overwrite`` replaces exactly these)
STUDY_ENTRIES = (*STUDY_FINAL, "study.json", RECORDS, FIELDS)
#: samplings whose points are random draws (histograms and rank correlations make sense)
RANDOM_SAMPLINGS = ("lhs", "mc")
#: row columns that are counts rather than responses
_COUNTS = ("dofs", "iterations", "active_vertices")


def study(
    case: Case,
    points: Sequence[Point],
    output_dir: str | Path | None = None,
    *,
    sampling: str = "points",
    overwrite: bool = False,
    wait: bool = False,
    workers: int | None = None,
    scheduler: str | None = None,
    keep_fields: str | None = None,
    probe_components: Sequence[str] = ("w",),
    progress: Progress | None = None,
    announce: Callable[[str], None] | None = None,
    figures: bool = True,
    max_memory: float | str | None = None,
) -> StudyResult:
    """Solve ``case`` at every point ({case-file key: value}, e.g. from ``sampling.grid``) in order.

    Every point's case is validated through the schema before the first solve. Where the points run:
    ``workers`` 0 in this process; otherwise as Dask tasks, on ``scheduler`` (or ``SHELLCONTACT_SCHEDULER``)
    when given, else on an embedded cluster of ``workers`` processes (None: one per core); every point is
    solved from its own case alone, so its row is the same wherever and in whatever order it runs. One row
    per point: its keys' values, the summary's figures (``summary_row``) with the probes' displacement
    ``probe_components``. With ``output_dir`` the records ``steps/step-NNNN.json`` are written as the points
    finish (a rerun resumes), then together ``study.csv``, ``study.parquet`` (with pyarrow), the figures
    (``response.png``; for random ``sampling`` "lhs"/"mc" also ``histograms.png``, ``sensitivity.png`` and
    ``sensitivity.csv``: Spearman rank correlations) and ``report.html``. ``keep_fields`` ("npz", "vtu")
    keeps each point's ``fields/NNNN/results.npz`` (and ``fields.vtu``). Directory rules as ``sweep``.
    """
    from ..problem.sizing import check_steps

    expect_case(case, "study")
    expect_path(output_dir, "study", "output_dir", optional=True)
    _check_workers(workers)
    expect_callable(progress, "study", "progress")
    keep = _keep_files(keep_fields)
    components = tuple(probe_components)
    bad = [c for c in components if c not in PROBE_COMPONENTS]
    if bad or not components:
        raise InputError("--probe", f"components among {', '.join(PROBE_COMPONENTS)}, got {','.join(components)!r}")
    points = [dict(p) for p in points]
    if not points:
        raise InputError("-p", "the study has no points")
    check_steps(len(points), max_memory, where="--samples")
    keys = list(dict.fromkeys(k for p in points for k in p))
    for k in keys:
        split_path(k)
    source = str(case.source) if case.source is not None else None

    def label(i: int) -> str:
        return f"point {i}: " + ", ".join(f"{k} = {v!r}" for k, v in points[i].items())

    cases = _point_cases(case, points, source, label, "--points" if sampling == "points" else "-p")
    systems = sorted({c.units for _, c in cases})
    if len(systems) > 1:  # the rows, CSV/Parquet units and figures are labelled in one system
        raise InputError("--points" if sampling == "points" else "-p units.system",
                         f"the points use the unit systems {', '.join(systems)}; a study's table has one: run one "
                         "study per system")
    fps = [_fingerprint({"case": raw, "probe": components}, source) for raw, _ in cases]

    def solve(work: Path | None) -> StudyResult:
        rows, sums, reused = _run_points(
            cases, source, fps, work, workers=workers, scheduler=scheduler,
            row_of=lambda i, s: {**points[i], **summary_row(s, components)},
            label=lambda i: ", ".join(f"{k} = {_short(v)}" for k, v in points[i].items()),
            title=f"{sampling} study", progress=progress, announce=announce, keep=keep, max_memory=max_memory)
        res = StudyResult(keys, points, rows, sums, sampling, reused)
        if sampling in RANDOM_SAMPLINGS:
            res.sensitivity = sensitivity(rows, keys)
        return res

    if output_dir is None:
        return solve(None)
    target = expand_user(output_dir)  # one path, checked and written
    manifest = {"case_file": source, "case": _fingerprint(case.raw, source), "sampling": sampling,
                "probe_components": list(components), "keys": keys, "points": points}
    res, names = _in_directory(
        target, manifest_name="study.json", manifest=manifest, identity=("case", "probe_components", "points"),
        final=STUDY_FINAL, entries=STUDY_ENTRIES, overwrite=overwrite, wait=wait, solve=solve,
        write=lambda r, out: _write_study_files(r, out, figures, source, case.raw))
    res.files = {name: target / name for name in names}
    return res


def _short(v: Any) -> str:
    return f"{v:.6g}" if isinstance(v, float) else str(v)


def response_columns(rows: Sequence[dict[str, Any]], keys: Sequence[str]) -> list[str]:
    """The responses of a study: numeric columns besides the keys and the counts, not constant."""
    cols = list(dict.fromkeys(c for r in rows for c in r))
    out = []
    for c in cols:
        vals = [r.get(c) for r in rows]
        numeric = all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in vals)
        if c not in keys and c not in _COUNTS and numeric and len(set(vals)) > 1:
            out.append(c)
    return out


def _ranks(values: Sequence[float]) -> list[float]:
    """Ranks 1..n, ties sharing their average rank."""
    order = sorted(range(len(values)), key=lambda i: values[i])
    ranks = [0.0] * len(values)
    k = 0
    while k < len(order):
        j = k
        while j + 1 < len(order) and values[order[j + 1]] == values[order[k]]:
            j += 1
        for m in range(k, j + 1):
            ranks[order[m]] = (k + j) / 2 + 1
        k = j + 1
    return ranks


def rank_correlation(x: Sequence[float], y: Sequence[float]) -> float | None:
    """Spearman's rank correlation: the Pearson correlation of the ranks (None when either is constant)."""
    rx, ry = _ranks(x), _ranks(y)
    n = len(rx)
    mx, my = sum(rx) / n, sum(ry) / n
    sxy = sum((a - mx) * (b - my) for a, b in zip(rx, ry))
    sxx, syy = sum((a - mx) ** 2 for a in rx), sum((b - my) ** 2 for b in ry)
    return sxy / math.sqrt(sxx * syy) if sxx > 0 and syy > 0 else None


def sensitivity(rows: Sequence[dict[str, Any]], keys: Sequence[str]) -> dict[str, dict[str, float | None]]:
    """{response: {key: Spearman rank correlation}} over the points (numeric keys only)."""
    numeric = [k for k in keys if all(isinstance(r.get(k), (int, float)) for r in rows)]
    return {c: {k: rank_correlation([r[k] for r in rows], [r[c] for r in rows]) for k in numeric}
            for c in response_columns(rows, keys)}


def _write_study_files(res: StudyResult, out: Path, figures: bool, source: str | None,
                       raw: dict[str, Any]) -> list[str]:
    """study.csv, study.parquet, sensitivity.csv, the figures and report.html into ``out``; their names."""
    names = ["study.csv"]
    write_csv(out / "study.csv", res.rows)
    system = res.summaries[0].get("unit_system", "SI") if res.summaries else "SI"
    cols = list(dict.fromkeys(c for r in res.rows for c in r))
    units = column_units(cols, res.keys, system)
    if write_parquet(out / "study.parquet", res.rows, units) is not None:
        names.append("study.parquet")
    sens_rows = [{"response": c, **by_key} for c, by_key in res.sensitivity.items()]
    if sens_rows:
        write_csv(out / "sensitivity.csv", sens_rows)
        names.append("sensitivity.csv")
    pngs: dict[str, bytes] = {}
    responses = response_columns(res.rows, res.keys)
    if figures and responses:
        from ..outputs.figures import run as plots

        kinds = {c: key_kind(c) if c in res.keys else column_kind(c) for c in cols}
        numeric_keys = [k for k in res.keys if all(isinstance(r.get(k), (int, float)) for r in res.rows)]
        if numeric_keys:
            pngs["response.png"] = plots.png_bytes(plots.plot_response(res.rows, numeric_keys, responses, system,
                                                                       kinds))
        if res.sampling in RANDOM_SAMPLINGS:
            pngs["histograms.png"] = plots.png_bytes(plots.plot_histograms(res.rows, responses, system, kinds))
            if res.sensitivity and numeric_keys:
                pngs["sensitivity.png"] = plots.png_bytes(plots.plot_sensitivity(res.sensitivity, numeric_keys))
        for name, data in pngs.items():
            atomic_write_bytes(out / name, data)
        names += list(pngs)
    from ..outputs.report import write_study_report

    about = {"case file": source, "sampling": res.sampling, "keys": ", ".join(res.keys), "points": len(res.rows),
             "units": ", ".join(f"{c} [{u}]" for c, u in units.items() if u)}
    title = f"shellcontact study: {', '.join(res.keys)}"
    write_study_report(out / "report.html", title, res.rows, pngs, about, raw,
                       _heads(res.rows, res.keys, res.summaries))
    return [*names, "report.html"]


def study_table(res: StudyResult, most: int = 20) -> str:
    """The study's rows as a console table with units (the first ``most`` rows; the CSV has them all)."""
    text = _table(res.rows[:most], res.keys, res.summaries)
    if len(res.rows) > most:
        text += f"\n… {len(res.rows) - most} more rows in study.csv"
    return text


# -- convergence --------------------------------------------------------------------------------------
@dataclass
class ConvergenceResult:
    rows: list[dict[str, Any]]
    quantity: str
    summaries: list[dict[str, Any]]
    files: dict[str, Path] = field(default_factory=dict)

    def csv(self) -> str:
        return csv_text(self.rows)


def _quantity(summary: dict[str, Any]) -> tuple[str, float | None]:
    """The value tracked besides the energy: contact force, else the first probe's w, else max|w|."""
    c = summary.get("contact")
    if c:
        e = c[0] if isinstance(c, list) else c
        for key, name in (("total_normal_force", "normal_force"), ("force_magnitude", "force")):
            if e.get(key) is not None:
                return name, float(e[key])
    if summary.get("probes"):
        return "probe0_w", float(summary["probes"][0]["w"])
    return "max_abs_w", float(summary["max_abs_w"])


def _rate(e0: Any, e1: Any, h0: float, h1: float) -> float | None:
    if not (isinstance(e0, float) and isinstance(e1, float)) or e0 <= 0 or e1 <= 0 or h0 == h1:
        return None
    return math.log(e0 / e1) / math.log(h0 / h1)


#: what a convergence study writes into its directory (``overwrite`` replaces exactly these)
CONVERGENCE_FILES = ("convergence.csv", "convergence.json", "convergence.png", "report.html")


def convergence(
    case: Case,
    levels: int = 4,
    output_dir: str | Path | None = None,
    *,
    overwrite: bool = False,
    wait: bool = False,
    progress: Progress | None = None,
    figures: bool = True,
    max_memory: float | str | None = None,
) -> ConvergenceResult:
    """Nested refinement study: level l solves with ``mesh.refine = r0 + l`` (r0 = the case's refine).

    Columns: level, refine, vertices, elements, dofs, h, energy, the tracked quantity, and for all
    but the finest level the relative errors against the finest level (``error_energy``,
    ``error_<quantity>``) with observed rates log(e_{l−1}/e_l)/log(h_{l−1}/h_l).
    ``output_dir`` (convergence.csv, convergence.json, convergence.png, report.html) appears whole
    or not at all; a non-empty one is refused unless ``overwrite``.
    """
    expect_case(case, "convergence")
    if isinstance(levels, numbers.Integral) and not isinstance(levels, bool) and levels < 2:
        raise InputError("--levels", f"must be an integer >= 2, got {levels!r}")
    levels = expect_integer(levels, "convergence", "levels", 2)
    expect_path(output_dir, "convergence", "output_dir", optional=True)
    expect_callable(progress, "convergence", "progress")
    _check_finest(case, case.mesh.refine + levels - 1, max_memory)
    if output_dir is None:
        return _convergence(case, levels, None, progress, figures, max_memory)
    from ..outputs.transaction import replace_dir

    with replace_dir(output_dir, overwrite=overwrite, owned=CONVERGENCE_FILES, wait=wait) as stage:
        res = _convergence(case, levels, stage, progress, figures, max_memory)
    res.files = {name: expand_user(output_dir) / name for name in res.files}
    return res


def _convergence(case: Case, levels: int, out: Path | None, progress: Progress | None,
                 figures: bool, max_memory: float | str | None = None) -> ConvergenceResult:
    from ..analysis.pipeline import solve

    r0 = case.mesh.refine
    rows, sums = [], []
    qname = None
    for lv in range(levels):
        if progress:
            progress(lv, levels, f"level {lv} (refine {r0 + lv})")
        with code_consent(case.code):
            c = case_from_dict(apply_overrides(case.raw, {"mesh.refine": r0 + lv}), source=case.source)
        result = solve(c, max_memory=max_memory)
        summary = result.summary()
        name, q = _quantity(summary)
        qname = qname or name
        if name != qname:
            name, q = qname, None
        rows.append(
            {
                "level": lv,
                "refine": r0 + lv,
                "vertices": summary.get("vertices"),
                "elements": summary.get("elements"),
                "dofs": summary.get("dofs"),
                "h": result.solution.space.mesh.h(),
                "energy": summary.get("energy"),
                qname: q,
            }
        )
        sums.append(summary)
        log.info("level %d: dofs %s energy %.10g %s %.10g", lv, summary.get("dofs"), summary["energy"], qname, q)
    if progress:
        progress(levels, levels, "done")
    fine = rows[-1]
    for key in ("energy", qname):
        ref = fine[key]
        for r in rows:
            err = None
            if r is not fine and isinstance(r[key], float) and isinstance(ref, float) and ref != 0:
                err = abs(r[key] - ref) / abs(ref)
            r[f"error_{key}"] = err
        for k, r in enumerate(rows):
            r[f"rate_{key}"] = (
                _rate(rows[k - 1][f"error_{key}"], r[f"error_{key}"], rows[k - 1]["h"], r["h"]) if k > 0 else None
            )
    res = ConvergenceResult(rows, qname or "", sums)
    if out is not None:
        res.files["convergence.csv"] = write_csv(out / "convergence.csv", rows)
        write_json(
            out / "convergence.json",
            {
                "case_file": str(case.source) if case.source else None,
                "quantity": qname,
                "rows": rows,
                "summaries": sums,
            },
        )
        res.files["convergence.json"] = out / "convergence.json"
        if figures:
            from ..outputs.figures import run as plots

            png = plots.png_bytes(plots.plot_convergence(rows, system=case.units))
            atomic_write_bytes(out / "convergence.png", png)
            res.files["convergence.png"] = out / "convergence.png"
        from ..outputs.report import write_study_report

        about = {"case file": str(case.source) if case.source else None, "levels": levels, "tracked": qname}
        res.files["report.html"] = write_study_report(
            out / "report.html",
            "shellcontact convergence study",
            rows,
            {"convergence.png": png} if figures else {},
            about,
            case.raw,
            _heads(rows, (), res.summaries),
        )
    return res


def _check_finest(case: Case, refine: int, max_memory: float | str | None) -> None:
    """Refuse a convergence study whose finest level cannot fit, before the first level is solved."""
    import dataclasses

    from ..contact.punches import place_punches
    from ..problem.sizing import check_size

    finest = dataclasses.replace(case, mesh=dataclasses.replace(case.mesh, refine=refine))
    try:
        check_size(finest, place_punches(case.punches, case.shell, case.units), max_memory,
                   what=f"the finest level (refine {refine})")
    except InputError as exc:
        raise InputError("--levels", f"{exc.message} (or fewer --levels)") from None


def convergence_table(res: ConvergenceResult) -> str:
    """A fixed-width text table of a convergence study."""
    q = res.quantity
    head = ("level", "dofs", "h", "energy", q, "err energy", "rate", f"err {q}", "rate")
    keys = ("level", "dofs", "h", "energy", q, "error_energy", "rate_energy", f"error_{q}", f"rate_{q}")
    return text_table(head, [[r[k] for k in keys] for r in res.rows])


def _heads(rows: Sequence[dict[str, Any]], keys: Sequence[str], summaries: Sequence[dict[str, Any]]) -> dict[str, str]:
    """Every column of ``rows`` with its unit (the keys' from the schema, the others' from COLUMN_KINDS)."""
    from ..units import bracket

    system = summaries[0].get("unit_system", "SI") if summaries else "SI"
    cols = list(dict.fromkeys(c for r in rows for c in r))
    return {c: c + (bracket(k, system) if k else "") for c in cols
            for k in [key_kind(c) if c in keys else column_kind(c)]}


def _table(rows: Sequence[dict[str, Any]], keys: Sequence[str], summaries: Sequence[dict[str, Any]]) -> str:
    heads = _heads(rows, keys, summaries)
    return text_table(list(heads.values()), [[r.get(c) for c in heads] for r in rows])


def sweep_table(res: SweepResult) -> str:
    """A fixed-width text table of a sweep (every column of its CSV, with units; the CSV keeps full precision)."""
    return _table(res.rows, [res.param], res.summaries)
