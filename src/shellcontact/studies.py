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
from collections.abc import Callable, Sequence
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import dataclass, field
from multiprocessing import get_context
from pathlib import Path
from typing import Any

from .arguments import expect_callable, expect_case, expect_integer, expect_numbers, expect_path
from .case import Case, case_from_dict
from .errors import InputError
from .files import atomic_write_bytes, atomic_write_text, write_json
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
def parse_values(spec: str) -> list[float]:
    """``'0:5e-3:11'`` (start:stop:count, both ends included) or ``'1e-3,2e-3,4e-3'``."""
    where = "--values"
    text = spec.strip()
    try:
        if ":" in text:
            parts = text.split(":")
            if len(parts) != 3:
                raise ValueError
            start, stop, count = float(parts[0]), float(parts[1]), int(parts[2])
            if count < 1:
                raise InputError(where, f"count must be >= 1, got {count}")
            if count == 1:
                return [start]
            return [start + (stop - start) * i / (count - 1) for i in range(count)]
        vals = [float(v) for v in text.split(",") if v.strip()]
    except ValueError:
        raise InputError(
            where, f"expected start:stop:count (e.g. 0:5e-3:11) or a comma list (e.g. 1e-3,2e-3), got {spec!r}"
        ) from None
    if not vals:
        raise InputError(where, "no values given")
    if not all(math.isfinite(v) for v in vals):
        raise InputError(where, f"values must be finite, got {spec!r}")
    return vals


def _value(v: float) -> int | float:
    """Integral values of integer keys (mesh.refine=2) stay integers."""
    return int(v) if float(v).is_integer() and abs(v) < 2**53 else float(v)


# -- rows -----------------------------------------------------------------------------------------------
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


def _fingerprint(raw: dict[str, Any], source: Any) -> str:
    text = json.dumps({"case": raw, "source": str(source)}, sort_keys=True, default=str)
    return hashlib.sha256(text.encode()).hexdigest()


def _step_raw(case: Case, param: str, value: Any) -> dict[str, Any]:
    return apply_overrides(case.raw, {param: value})


def _record_path(steps: Path, index: int) -> Path:
    return steps / f"step-{index:04d}.json"


def _load_record(steps: Path, index: int, fingerprint: str) -> dict[str, Any] | None:
    path = _record_path(steps, index)
    try:
        rec = json.loads(path.read_text())
    except (OSError, ValueError):
        return None
    return rec if rec.get("fingerprint") == fingerprint and "row" in rec else None


def _solve_summary(case: Case, previous=None):
    from .analysis import solve

    result = solve(case, warm_start=previous)
    return result, result.summary()


def _step_row(param: str, value: Any, summary: dict[str, Any]) -> dict[str, Any]:
    return {param: value, **summary_row(summary)}


def _worker(raw: dict, source: str | None, param: str, index: int, value: Any, steps: str | None, fp: str):
    """One sweep step in a separate process (the case is re-validated from its raw dictionary)."""
    case = case_from_dict(raw, source=source)
    _, summary = _solve_summary(case)
    row = _step_row(param, value, summary)
    if steps is not None:
        write_json(
            _record_path(Path(steps), index),
            {"index": index, "value": value, "fingerprint": fp, "row": row, "summary": summary},
        )
    return index, row, summary


def sweep(
    case: Case,
    param: str,
    values: Sequence[float],
    output_dir: str | Path | None = None,
    *,
    jobs: int = 1,
    progress: Progress | None = None,
    figures: bool = True,
) -> SweepResult:
    """Solve ``case`` for each value of the case-file key ``param`` (dotted path) in order.

    With ``output_dir``: step records ``steps/step-NNNN.json`` (written as each step finishes;
    a record is reused when its case fingerprint matches), then ``sweep.csv``, ``sweep.json``
    and the figures ``sweep.png`` and, with contact, ``force_indentation.png``. Serial sweeps
    pass the previous step's result to ``solve`` as a warm start when ``solve`` accepts one.
    """
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
    vals = [_value(v) for v in values]
    source = str(case.source) if case.source is not None else None
    # validate every step's case before any work, so a bad parameter fails at once
    step_raws = [_step_raw(case, param, v) for v in vals]
    case_from_dict(step_raws[0], source=source)
    fps = [_fingerprint(r, source) for r in step_raws]
    out = Path(output_dir) if output_dir is not None else None
    steps = out / "steps" if out is not None else None
    if steps is not None and steps.is_dir():
        for tmp in steps.glob(".step-*.tmp"):  # left by a sweep killed while writing a record
            tmp.unlink(missing_ok=True)
    if out is not None:
        write_json(out / "sweep.json", {"case_file": source, "param": param, "values": vals, "jobs": jobs})
    n = len(vals)
    rows: list[dict[str, Any] | None] = [None] * n
    sums: list[dict[str, Any] | None] = [None] * n
    reused = 0
    if steps is not None:
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
    if jobs > 1 and len(todo) > 1:
        with ProcessPoolExecutor(max_workers=min(jobs, len(todo)), mp_context=get_context("spawn")) as pool:
            futs = [
                pool.submit(_worker, step_raws[i], source, param, i, vals[i], str(steps) if steps else None, fps[i])
                for i in todo
            ]
            for fut in as_completed(futs):
                i, row, summary = fut.result()
                rows[i], sums[i] = row, summary
                done += 1
                log.info("step %d/%d: %s = %g done", i + 1, n, param, vals[i])
                if progress:
                    progress(done, n, f"{param} = {vals[i]:g}")
    else:
        previous: tuple[int, Any] = (-2, None)
        for i in todo:
            step_case = case_from_dict(step_raws[i], source=source)
            result, summary = _solve_summary(step_case, previous[1] if previous[0] == i - 1 else None)
            previous = (i, result)
            rows[i], sums[i] = _step_row(param, vals[i], summary), summary
            if steps is not None:
                write_json(
                    _record_path(steps, i),
                    {"index": i, "value": vals[i], "fingerprint": fps[i], "row": rows[i], "summary": summary},
                )
            done += 1
            log.info("step %d/%d: %s = %g, energy %.6g", i + 1, n, param, vals[i], summary.get("energy", math.nan))
            if progress:
                progress(done, n, f"{param} = {vals[i]:g}")
    res = SweepResult(param, [float(v) for v in vals], list(rows), list(sums), reused)  # type: ignore[arg-type]
    if out is not None:
        res.files["sweep.csv"] = write_csv(out / "sweep.csv", res.rows)
        if figures:
            from . import plots

            pngs = {"sweep.png": plots.png_bytes(plots.plot_sweep(res.rows, param))}
            fi = plots.plot_force_indentation(res.rows, param)
            if fi is not None:
                pngs["force_indentation.png"] = plots.png_bytes(fi)
            for name, data in pngs.items():
                atomic_write_bytes(out / name, data)
                res.files[name] = out / name
        from .report import write_study_report

        about = {"case file": source, "parameter": param, "values": len(vals), "reused steps": reused}
        res.files["report.html"] = write_study_report(
            out / "report.html", f"shellcontact sweep: {param}", res.rows, pngs if figures else {}, about, case.raw
        )
    return res


def clear_sweep_dir(path: str | Path) -> None:
    """Remove what ``sweep`` writes (step records, CSV, manifest, figures) — nothing else."""
    path = Path(path)
    steps = path / "steps"
    if steps.is_dir():
        for f in steps.glob("step-*.json"):
            f.unlink()
    for name in ("sweep.csv", "sweep.json", "sweep.png", "force_indentation.png", "report.html"):
        (path / name).unlink(missing_ok=True)


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


def convergence(
    case: Case,
    levels: int = 4,
    output_dir: str | Path | None = None,
    *,
    progress: Progress | None = None,
    figures: bool = True,
) -> ConvergenceResult:
    """Nested refinement study: level l solves with ``mesh.refine = r0 + l`` (r0 = the case's refine).

    Columns: level, refine, vertices, elements, dofs, h, energy, the tracked quantity, and for all
    but the finest level the relative errors against the finest level (``error_energy``,
    ``error_<quantity>``) with observed rates log(e_{l−1}/e_l)/log(h_{l−1}/h_l).
    """
    expect_case(case, "convergence")
    if isinstance(levels, numbers.Integral) and not isinstance(levels, bool) and levels < 2:
        raise InputError("--levels", f"must be an integer >= 2, got {levels!r}")
    levels = expect_integer(levels, "convergence", "levels", 2)
    expect_path(output_dir, "convergence", "output_dir", optional=True)
    expect_callable(progress, "convergence", "progress")
    r0 = case.mesh.refine
    rows, sums = [], []
    qname = None
    for lv in range(levels):
        if progress:
            progress(lv, levels, f"level {lv} (refine {r0 + lv})")
        c = case_from_dict(apply_overrides(case.raw, {"mesh.refine": r0 + lv}), source=case.source)
        result, summary = _solve_summary(c)
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
    if output_dir is not None:
        out = Path(output_dir)
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

            png = plots.png_bytes(plots.plot_convergence(rows))
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


def convergence_table(res: ConvergenceResult) -> str:
    """A fixed-width text table of a convergence study."""
    q = res.quantity
    head = ("level", "dofs", "h", "energy", q, "err energy", "rate", f"err {q}", "rate")
    widths = [max(12, len(h)) for h in head]
    lines = ["  ".join(f"{h:>{w}}" for h, w in zip(head, widths))]

    def f(v: Any) -> str:
        return "—" if v is None else (f"{v:.6g}" if isinstance(v, float) else str(v))

    for r in res.rows:
        vals = (
            r["level"],
            r["dofs"],
            r["h"],
            r["energy"],
            r[q],
            r["error_energy"],
            r["rate_energy"],
            r[f"error_{q}"],
            r[f"rate_{q}"],
        )
        lines.append("  ".join(f"{f(v):>{w}}" for v, w in zip(vals, widths)))
    return "\n".join(lines)
