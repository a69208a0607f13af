"""Studies on Case objects through ``analysis.solve``: parameter sweeps and mesh convergence.

* ``sweep(case, param, values, output_dir=...)`` — one solve per value of a case-file key
  (dotted path, e.g. ``punch.0.indentation``); one CSV row per step. With ``output_dir`` every
  finished step is recorded atomically in ``output_dir/steps/`` and an interrupted sweep resumes
  without recomputing them; ``jobs > 1`` solves steps in parallel processes.
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
from collections.abc import Callable, Sequence
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import dataclass, field
from fnmatch import fnmatchcase
from multiprocessing import get_context
from pathlib import Path
from typing import Any

from .arguments import expect_callable, expect_integer, expect_numbers, expect_path
from .case import Case, case_from_dict, expect_case, key_kind
from .errors import InputError
from .files import atomic_write_bytes, atomic_write_text, check_output_dir, write_json
from .overrides import apply_overrides, split_path

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


# -- values ----------------------------------------------------------------------------------------------
def parse_values(spec: str, max_memory: float | str | None = None) -> list[float]:
    """``'0:5e-3:11'`` (start:stop:count, both ends included) or ``'1e-3,2e-3,4e-3'``. A count
    whose steps cannot be recorded in ``max_memory`` (default: the memory available) is refused
    before any list is built (``sizing.check_steps``)."""
    from .sizing import check_steps

    where = "--values"
    text = spec.strip()
    usage = f"expected start:stop:count (e.g. 0:5e-3:11) or a comma list (e.g. 1e-3,2e-3), got {spec!r}"
    if ":" in text:
        parts = text.split(":")
        try:
            if len(parts) != 3:
                raise ValueError
            start, stop, count = float(parts[0]), float(parts[1]), int(parts[2])
        except ValueError:
            raise InputError(where, usage) from None
        if count < 1:
            raise InputError(where, f"count must be >= 1, got {count}")
        check_steps(count, max_memory)  # before the list is built
        if not (math.isfinite(start) and math.isfinite(stop)):
            raise InputError(where, f"values must be finite, got {spec!r}")
        if count == 1:
            return [start]
        # to 12 significant digits: 0.006, not the 0.006000000000000001 of the arithmetic
        return [float(f"{start + (stop - start) * i / (count - 1):.12g}") for i in range(count)]
    check_steps(text.count(",") + 1, max_memory)
    try:
        vals = [float(v) for v in text.split(",") if v.strip()]
    except ValueError:
        raise InputError(where, usage) from None
    if not vals:
        raise InputError(where, "no values given")
    if not all(math.isfinite(v) for v in vals):
        raise InputError(where, f"values must be finite, got {spec!r}")
    return vals


def _value(v: float) -> int | float:
    """Integral values of integer keys (mesh.refine=2) stay integers."""
    return int(v) if float(v).is_integer() and abs(v) < 2**53 else float(v)


# -- rows -----------------------------------------------------------------------------------------------
#: the kind of quantity (units.KINDS) of each CSV column, by name pattern (None: a count or dimensionless)
COLUMN_KINDS = (("dofs", None), ("energy", "energy"), ("max_abs_w", "length"), ("probe*_w", "length"),
                ("normal_force*", "force"), ("force*", "force"), ("zone_area*", "area"), ("area*", "area"),
                ("peak_pressure*", "pressure"), ("active_vertices*", None), ("punch_travel*", "length"),
                ("iterations", None))


def column_kind(column: str) -> str | None:
    return next((kind for pattern, kind in COLUMN_KINDS if fnmatchcase(column, pattern)), None)


def summary_row(summary: dict[str, Any]) -> dict[str, Any]:
    """The CSV columns of one solve: dofs, energy, max|w|, probe w, and contact columns when present."""
    row: dict[str, Any] = {
        "dofs": summary.get("dofs"),
        "energy": summary.get("energy"),
        "max_abs_w": summary.get("max_abs_w"),
    }
    for i, p in enumerate(summary.get("probes") or []):
        row[f"probe{i}_w"] = p.get("w")
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


SWEEP_FINAL = ("sweep.csv", "sweep.png", "force_indentation.png", "report.html")
#: what a sweep writes into its directory (``overwrite`` replaces exactly these)
SWEEP_ENTRIES = (*SWEEP_FINAL, "sweep.json", "steps")


def _fingerprint(raw: dict[str, Any], source: Any) -> str:
    text = json.dumps({"case": raw, "source": str(source)}, sort_keys=True, default=str)
    return hashlib.sha256(text.encode()).hexdigest()


def _step_cases(case: Case, param: str, vals: Sequence[Any], source: str | None) -> list[tuple[dict, Case]]:
    """Every step's case, validated before the first solve; a bad value names its step."""
    steps = []
    for i, v in enumerate(vals):
        raw = apply_overrides(case.raw, {param: v})
        try:
            steps.append((raw, case_from_dict(raw, source=source)))
        except InputError as exc:
            raise InputError(exc.field, f"{exc.message} (sweep step {i}: {param} = {v!r})") from None
    return steps


def _record_path(steps: Path, index: int) -> Path:
    return steps / f"step-{index:04d}.json"


def _load_record(steps: Path, index: int, fingerprint: str) -> dict[str, Any] | None:
    path = _record_path(steps, index)
    try:
        rec = json.loads(path.read_text())
    except (OSError, ValueError):
        return None
    return rec if rec.get("fingerprint") == fingerprint and "row" in rec else None


def _solve_summary(case: Case, max_memory: float | str | None = None):
    from .analysis import solve

    result = solve(case, max_memory=max_memory)
    return result, result.summary()


def _step_row(param: str, value: Any, summary: dict[str, Any]) -> dict[str, Any]:
    return {param: value, **summary_row(summary)}


def _solve_step(raw: dict, source: str | None, param: str, index: int, value: Any, steps: str | None, fp: str,
                case: Case | None = None, max_memory: float | str | None = None):
    """One sweep step, recorded in ``steps/`` when given (in a worker the case is re-validated from ``raw``).

    Every step starts from its own case alone (no warm start from a neighbour), so a step's numbers
    do not depend on the order, on ``jobs`` or on an interruption: a resumed sweep writes the CSV an
    uninterrupted one would.
    """
    _, summary = _solve_summary(case if case is not None else case_from_dict(raw, source=source), max_memory)
    return _record_step(param, index, value, steps, fp, summary)


def _record_step(param: str, index: int, value: Any, steps: str | None, fp: str, summary: dict[str, Any]):
    row = _step_row(param, value, summary)
    if steps is not None:
        write_json(
            _record_path(Path(steps), index),
            {"index": index, "value": value, "fingerprint": fp, "row": row, "summary": summary},
        )
    return index, row, summary


def _worker_init(parent: int) -> None:
    """A sweep worker dies with its parent (SIGKILL included) and leaves Ctrl-C to it."""
    import signal
    import sys

    signal.signal(signal.SIGINT, signal.SIG_IGN)  # the parent stops the pool on Ctrl-C
    if sys.platform.startswith("linux"):
        import ctypes

        try:  # PR_SET_PDEATHSIG = 1: the kernel kills us when the parent (its forking thread) ends
            ctypes.CDLL(None, use_errno=True).prctl(1, signal.SIGKILL, 0, 0, 0)
        except (OSError, AttributeError):
            pass
    if os.getppid() != parent:  # the parent died before the death signal was armed
        os._exit(1)


def _stop(pool: ProcessPoolExecutor) -> None:
    """Cancel what has not started and kill the workers now (a shutdown would wait for running steps)."""
    processes = list(getattr(pool, "_processes", {}).values())
    pool.shutdown(wait=False, cancel_futures=True)
    for proc in processes:
        proc.kill()
    for proc in processes:
        proc.join(timeout=1.0)


def _run_steps(
    param: str,
    vals: list[Any],
    steps_in: list[tuple[dict, Case]],
    source: str | None,
    fps: list[str],
    steps: Path | None,
    jobs: int,
    progress: Progress | None,
    max_memory: float | str | None = None,
) -> tuple[list[dict[str, Any]], list[dict[str, Any]], int]:
    """Solve the steps without a record in ``steps`` (serially or in ``jobs`` processes)."""
    n = len(vals)
    rows: list[dict[str, Any] | None] = [None] * n
    sums: list[dict[str, Any] | None] = [None] * n
    reused = 0
    if steps is not None:
        steps.mkdir(parents=True, exist_ok=True)
        for tmp in steps.glob(".step-*.tmp"):  # left by a sweep killed while writing a record
            tmp.unlink(missing_ok=True)
        for i in range(n):
            rec = _load_record(steps, i, fps[i])
            if rec is not None:
                rows[i], sums[i] = rec["row"], rec.get("summary", {})
                reused += 1
    if reused:
        log.info("resuming: %d of %d steps already done in %s", reused, n, steps)
    done = reused
    if progress:
        progress(done, n, f"{param} sweep")
    todo = [i for i in range(n) if rows[i] is None]
    where = str(steps) if steps is not None else None

    def finished(i: int, row: dict[str, Any], summary: dict[str, Any]) -> None:
        nonlocal done
        rows[i], sums[i] = row, summary
        done += 1
        log.info("step %d/%d: %s = %g, energy %.6g", i + 1, n, param, vals[i], summary.get("energy", math.nan))
        if progress:
            progress(done, n, f"{param} = {vals[i]:g}")

    if jobs > 1 and len(todo) > 1:
        pool = ProcessPoolExecutor(max_workers=min(jobs, len(todo)), mp_context=get_context("spawn"),
                                   initializer=_worker_init, initargs=(os.getpid(),))
        try:
            futs = [pool.submit(_solve_step, steps_in[i][0], source, param, i, vals[i], where, fps[i], None, max_memory)
                    for i in todo]
            for fut in as_completed(futs):
                finished(*fut.result())
        except BaseException:  # Ctrl-C, SIGTERM, a failed step: stop at once
            _stop(pool)
            raise
        pool.shutdown()
    elif split_path(param)[0] == "punch":  # one mesh and factorisation per family (curves), results as solve's
        from .curves import solve_families

        for k, result in solve_families([steps_in[i][1] for i in todo], max_memory=max_memory):
            i = todo[k]
            finished(*_record_step(param, i, vals[i], where, fps[i], result.summary()))
    else:
        for i in todo:
            finished(*_solve_step(steps_in[i][0], source, param, i, vals[i], where, fps[i], steps_in[i][1], max_memory))
    return rows, sums, reused  # type: ignore[return-value]


def _same_sweep(directory: Path, manifest: dict[str, Any]) -> bool:
    """Whether ``directory`` holds (part of) this very sweep: same case, parameter and values."""
    try:
        old = json.loads((directory / "sweep.json").read_text())
    except (OSError, ValueError):
        return False
    return isinstance(old, dict) and all(old.get(k) == manifest[k] for k in ("case", "param", "values"))


def sweep(
    case: Case,
    param: str,
    values: Sequence[float],
    output_dir: str | Path | None = None,
    *,
    overwrite: bool = False,
    wait: bool = False,
    jobs: int = 1,
    progress: Progress | None = None,
    figures: bool = True,
    max_memory: float | str | None = None,
) -> SweepResult:
    """Solve ``case`` for each value of the case-file key ``param`` (dotted path) in order.

    Every step's case is validated before the first solve. With ``output_dir``: step records
    ``steps/step-NNNN.json`` (written as each step finishes; a record is reused when its case
    fingerprint matches, so running the same sweep again resumes it), then ``sweep.csv``,
    ``sweep.json`` and the figures ``sweep.png`` and, with contact, ``force_indentation.png``, and
    ``report.html``, which appear together. A non-empty directory that does not hold this sweep is
    refused unless ``overwrite``; then the new sweep is staged beside it and replaces it only when
    complete (the previous result is kept until then; an interrupted ``overwrite`` sweep starts over).
    ``max_memory`` bounds every step's solve (``analysis.solve``) and the steps' records.
    """
    from .sizing import check_steps
    from .transaction import DirectoryLock, Staging, name_in_target, remove_stale

    expect_case(case, "sweep")
    if not isinstance(param, str):
        raise TypeError(f"sweep(): param must be a dotted case-file key such as 'punch.0.indentation', got "
                        f"{type(param).__name__}")
    values = expect_numbers(values, "sweep", "values")
    expect_path(output_dir, "sweep", "output_dir", optional=True)
    jobs = expect_integer(jobs, "sweep", "jobs", 1)
    expect_callable(progress, "sweep", "progress")
    split_path(param)
    if not values:
        raise InputError("--values", "no values given")
    check_steps(len(values), max_memory)
    vals = [_value(v) for v in values]
    source = str(case.source) if case.source is not None else None
    steps_in = _step_cases(case, param, vals, source)
    fps = [_fingerprint(raw, source) for raw, _ in steps_in]
    if output_dir is None:
        rows, sums, reused = _run_steps(param, vals, steps_in, source, fps, None, jobs, progress, max_memory)
        return SweepResult(param, [float(v) for v in vals], rows, sums, reused)

    target = Path(output_dir)
    manifest = {"case_file": source, "case": _fingerprint(case.raw, source), "param": param, "values": vals}
    resume = not overwrite and _same_sweep(target, manifest)
    if not resume:
        check_output_dir(target, overwrite)
    with DirectoryLock(target, wait=wait):
        remove_stale(target)
        resume = not overwrite and _same_sweep(target, manifest)
        if not resume:
            check_output_dir(target, overwrite)
        # a fresh or resumed sweep records its steps in place (resumable); one replacing another
        # result works beside it and keeps that result until the new one is complete
        in_place = resume or not target.exists() or not any(target.iterdir())
        created, fresh = not target.exists(), in_place and not resume
        stage = None if in_place else Staging(target)
        work = target if stage is None else stage.path
        try:
            work.mkdir(parents=True, exist_ok=True)
            write_json(work / "sweep.json", manifest)
            rows, sums, reused = _run_steps(param, vals, steps_in, source, fps, work / "steps", jobs, progress,
                                            max_memory)
            res = SweepResult(param, [float(v) for v in vals], rows, sums, reused)
            if stage is None:
                stage = Staging(target)  # the final files appear together beside the step records
            names = _write_sweep_files(res, stage.path, param, figures, source, case.raw)
            stage.commit(SWEEP_FINAL if in_place else SWEEP_ENTRIES)
        except BaseException as exc:
            if stage is not None:
                stage.discard()
                if isinstance(exc, OSError):
                    name_in_target(exc, stage.path, target)
            if fresh and not any((target / "steps").glob("step-*.json")):  # nothing worth resuming: leave nothing
                if created:
                    shutil.rmtree(target, ignore_errors=True)
                else:
                    shutil.rmtree(target / "steps", ignore_errors=True)
                    (target / "sweep.json").unlink(missing_ok=True)
            raise
    res.files = {name: target / name for name in names}
    return res


def _write_sweep_files(res: SweepResult, out: Path, param: str, figures: bool, source: str | None,
                       raw: dict[str, Any]) -> list[str]:
    """sweep.csv, the figures and report.html into ``out``; returns their names."""
    names = ["sweep.csv"]
    write_csv(out / "sweep.csv", res.rows)
    pngs: dict[str, bytes] = {}
    if figures:
        from . import plots

        system = res.summaries[0].get("unit_system", "SI") if res.summaries else "SI"
        kind = key_kind(param)
        pngs["sweep.png"] = plots.png_bytes(plots.plot_sweep(res.rows, param, system=system, param_kind=kind))
        fi = plots.plot_force_indentation(res.rows, param, system=system, param_kind=kind)
        if fi is not None:
            pngs["force_indentation.png"] = plots.png_bytes(fi)
        for name, data in pngs.items():
            atomic_write_bytes(out / name, data)
        names += list(pngs)
    from .report import write_study_report

    about = {"case file": source, "parameter": param, "values": len(res.values), "reused steps": res.reused}
    write_study_report(out / "report.html", f"shellcontact sweep: {param}", res.rows, pngs, about, raw)
    return [*names, "report.html"]


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
    from .transaction import replace_dir

    with replace_dir(output_dir, overwrite=overwrite, owned=CONVERGENCE_FILES, wait=wait) as stage:
        res = _convergence(case, levels, stage, progress, figures, max_memory)
    res.files = {name: Path(output_dir) / name for name in res.files}
    return res


def _convergence(case: Case, levels: int, out: Path | None, progress: Progress | None,
                 figures: bool, max_memory: float | str | None = None) -> ConvergenceResult:
    r0 = case.mesh.refine
    rows, sums = [], []
    qname = None
    for lv in range(levels):
        if progress:
            progress(lv, levels, f"level {lv} (refine {r0 + lv})")
        c = case_from_dict(apply_overrides(case.raw, {"mesh.refine": r0 + lv}), source=case.source)
        result, summary = _solve_summary(c, max_memory)
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
            from . import plots

            png = plots.png_bytes(plots.plot_convergence(rows, system=case.units))
            atomic_write_bytes(out / "convergence.png", png)
            res.files["convergence.png"] = out / "convergence.png"
        from .report import write_study_report

        about = {"case file": str(case.source) if case.source else None, "levels": levels, "tracked": qname}
        res.files["report.html"] = write_study_report(
            out / "report.html",
            "shellcontact convergence study",
            rows,
            {"convergence.png": png} if figures else {},
            about,
            case.raw,
        )
    return res


def _check_finest(case: Case, refine: int, max_memory: float | str | None) -> None:
    """Refuse a convergence study whose finest level cannot fit, before the first level is solved."""
    import dataclasses

    from .punches import place_punches
    from .sizing import check_size

    finest = dataclasses.replace(case, mesh=dataclasses.replace(case.mesh, refine=refine))
    try:
        check_size(finest, place_punches(case.punches, case.shell), max_memory,
                   what=f"the finest level (refine {refine})")
    except InputError as exc:
        raise InputError("--levels", f"{exc.message} (or fewer --levels)") from None


def text_table(head: Sequence[str], rows: Sequence[Sequence[Any]]) -> str:
    """A fixed-width text table for the console: numbers to 6 significant digits, None as —."""

    def f(v: Any) -> str:
        return "—" if v is None else (f"{v:.6g}" if isinstance(v, float) else str(v))

    cells = [[f(v) for v in r] for r in rows]
    widths = [max(len(h), *(len(c[i]) for c in cells)) if cells else len(h) for i, h in enumerate(head)]
    lines = ["  ".join(f"{h:>{w}}" for h, w in zip(head, widths))]
    lines += ["  ".join(f"{c:>{w}}" for c, w in zip(r, widths)) for r in cells]
    return "\n".join(lines)


def convergence_table(res: ConvergenceResult) -> str:
    """A fixed-width text table of a convergence study."""
    q = res.quantity
    head = ("level", "dofs", "h", "energy", q, "err energy", "rate", f"err {q}", "rate")
    keys = ("level", "dofs", "h", "energy", q, "error_energy", "rate_energy", f"error_{q}", f"rate_{q}")
    return text_table(head, [[r[k] for k in keys] for r in res.rows])


def sweep_table(res: SweepResult) -> str:
    """A fixed-width text table of a sweep (every column of its CSV, with units; the CSV keeps full precision)."""
    from .units import bracket

    system = res.summaries[0].get("unit_system", "SI") if res.summaries else "SI"
    cols: list[str] = []
    for r in res.rows:
        cols += [c for c in r if c not in cols]
    kinds = [key_kind(c) if c == res.param else column_kind(c) for c in cols]
    head = [c + (bracket(k, system) if k else "") for c, k in zip(cols, kinds)]
    return text_table(head, [[r.get(c) for c in cols] for r in res.rows])
