"""``sweep(case, param, values)``: the one-key study of a load path (sweep.csv, sweep.png,
force_indentation.png, report.html)."""

from __future__ import annotations

from collections.abc import Callable, Sequence, Sized
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ..errors import InputError
from ..inputs.arguments import expect_callable, expect_integer, expect_numbers, expect_path
from ..inputs.overrides import split_path
from ..outputs.files import atomic_write_bytes, expand_user
from ..problem.case import Case, expect_case, key_kind
from .rows import _heads, _table, column_units, csv_text, summary_row, write_csv, write_parquet
from .runner import (
    FIELDS,
    RECORDS,
    Progress,
    _check_workers,
    _fingerprint,
    _in_directory,
    _keep_files,
    _point_cases,
    _run_points,
)
from .sampling import (
    parse_values,  # noqa: F401 — public here too (the sweep's --values; arguments.py names it)
    whole_value,
)


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
        from ..outputs import figures as plots

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


def sweep_table(res: SweepResult) -> str:
    """A fixed-width text table of a sweep (every column of its CSV, with units; the CSV keeps full precision)."""
    return _table(res.rows, [res.param], res.summaries)
