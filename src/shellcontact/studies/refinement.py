"""``convergence(case, levels)``: nested uniform refinement ``mesh.refine = r0 … r0+L−1``: dofs, energy, a
force or probe value, errors against the finest level and observed rates."""

from __future__ import annotations

import logging
import math
import numbers
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ..errors import InputError
from ..inputs.arguments import expect_callable, expect_integer, expect_path
from ..inputs.overrides import apply_overrides
from ..inputs.user_functions import code_consent
from ..outputs.files import atomic_write_bytes, expand_user, write_json
from ..outputs.tables import text_table
from ..problem.case import Case, case_from_dict, expect_case
from .rows import _heads, csv_text, write_csv
from .runner import Progress

log = logging.getLogger("shellcontact")


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
            from ..outputs import figures as plots

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
    """A fixed-width text table of a convergence study: h, energy and the tracked value with their units (the
    errors are relative, the rates orders)."""
    q = res.quantity
    unit = _heads(res.rows, (), res.summaries)
    head = ("level", "dofs", unit["h"], unit["energy"], unit.get(q, q), "err energy", "rate", f"err {q}", "rate")
    keys = ("level", "dofs", "h", "energy", q, "error_energy", "rate_energy", f"error_{q}", f"rate_{q}")
    return text_table(head, [[r[k] for k in keys] for r in res.rows])
