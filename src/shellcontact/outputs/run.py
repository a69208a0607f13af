"""The run directory: summary.json, fields.vtu, results.npz, PNG figures and report.html.

``write_outputs(result, directory, ...)`` writes it as one transaction (transaction.replace_dir: the
directory appears whole or not at all, and ``overwrite=True`` replaces exactly the files named in
``RUN_FILES``); ``write_run_files`` writes the files into a directory that already exists (a
staging directory).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from ..units import summary_units
from .fields import vertex_fields
from .files import atomic_write_bytes, write_json
from .report import write_report
from .writers import write_npz, write_vtu

#: files a run directory may contain; ``--force`` replaces exactly these (other files are kept)
RUN_FILES = (
    "summary.json",
    "fields.vtu",
    "results.npz",
    "deflection.png",
    "von_mises.png",
    "deformed.png",
    "sections.png",
    "pressure.png",
    "pressure_profiles.png",
    "friction.png",
    "report.html",
)


def write_outputs(
    result,
    directory: str | Path,
    summary: dict[str, Any] | None = None,
    *,
    overwrite: bool = False,
    figures: bool = True,
    report: bool = True,
    log: Callable[[str], None] | None = None,
    profile_x: float | None = None,
    profile_phi: float | None = None,
) -> dict[str, Path]:
    """Write the run directory: summary.json, fields.vtu, results.npz, PNG figures, report.html.

    A non-empty ``directory`` is refused (InputError) unless ``overwrite``; the files are written
    into a staging directory that replaces ``directory`` only when all are complete.
    ``profile_x``/``profile_phi`` (degrees) choose the pressure-profile lines.
    Returns the written files by name. ``summary`` defaults to ``result.summary()``; the time
    spent here is added to ``summary["timings"]["output"]`` (and ``total``).
    """
    from .transaction import replace_dir

    with replace_dir(directory, overwrite=overwrite, owned=RUN_FILES, option="directory") as stage:
        names = write_run_files(result, stage, summary, figures=figures, report=report,
                                profile_x=profile_x, profile_phi=profile_phi)
    written = {name: Path(directory) / name for name in names}
    if log:
        for path in written.values():
            log(f"wrote {path}")
    return written


def write_run_files(
    result,
    directory: Path,
    summary: dict[str, Any] | None = None,
    *,
    figures: bool = True,
    report: bool = True,
    profile_x: float | None = None,
    profile_phi: float | None = None,
) -> dict[str, Path]:
    """The files of the run directory, written into the existing ``directory``; returns them by name."""
    t0 = time.perf_counter()
    summary = result.summary() if summary is None else summary
    written: dict[str, Path] = {}
    fields = vertex_fields(result)
    written["fields.vtu"] = write_vtu(result, directory / "fields.vtu", fields)
    written["results.npz"] = write_npz(result, directory / "results.npz", fields)
    pngs: dict[str, bytes] = {}
    if figures:
        from . import figures as plots  # matplotlib is imported only when figures are drawn

        pngs = plots.run_figures(result, fields, profile_x, profile_phi)
        for name, data in pngs.items():
            atomic_write_bytes(directory / name, data)
            written[name] = directory / name
    timings = summary.setdefault("timings", {})
    timings["output"] = timings.get("output", 0.0) + time.perf_counter() - t0
    timings["total"] = timings.get("total", 0.0) + timings["output"]
    summary["units"] = summary_units(summary, result.case.units)  # now with the new timings
    write_json(directory / "summary.json", summary)
    written["summary.json"] = directory / "summary.json"
    if report:
        written["report.html"] = write_report(result, directory / "report.html", summary=summary, figures=pngs)
    return written
