"""``study(case, points)``: one solve per point ({case-file key: value}), one row per point; for random
samplings the rank correlations of the responses with the keys (sensitivity)."""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ..errors import InputError
from ..inputs.arguments import expect_callable, expect_path
from ..inputs.overrides import split_path
from ..outputs.files import atomic_write_bytes, expand_user
from ..problem.case import Case, expect_case, key_kind
from .rows import _heads, _table, column_kind, column_units, csv_text, summary_row, write_csv, write_parquet
from .runner import (
    FIELDS,
    PROBE_COMPONENTS,
    RECORDS,
    Progress,
    _check_workers,
    _fingerprint,
    _in_directory,
    _keep_files,
    _point_cases,
    _run_points,
)
from .sampling import Point


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
        from ..outputs import figures as plots

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
