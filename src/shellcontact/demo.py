"""``shellcontact demo``: the paper's problem solved by the penalty, primal and dual methods.

A cylindrical panel clamped on its whole boundary (Bock & Lovíšek (2.3)) is pressed by a
spherical punch (``cases/paper_panel.toml``). The three formulations of the paper solve the
same discrete problem; the demo prints them side by side and writes each run's outputs
(summary.json, fields.vtu, results.npz, figures, report.html) to ``DIR/<method>/`` plus a
comparison table ``DIR/comparison.json`` and ``DIR/comparison.md``.
"""

from __future__ import annotations

import logging
import time
from importlib import resources
from pathlib import Path

from .analysis.pipeline import solve
from .analysis.result import Result
from .outputs.files import atomic_write_text, write_json
from .outputs.run import write_run_files
from .outputs.tables import split_markdown
from .outputs.transaction import replace_dir
from .problem.case import load_case
from .units import bracket, label

CASE_FILE = "paper_panel.toml"
#: the paper's three formulations, in its order (registered in solvers.methods)
PAPER_METHODS = ("penalty", "active-set", "dual")
#: what the demo writes into its directory (``--force`` replaces exactly these)
DEMO_ENTRIES = (*PAPER_METHODS, "comparison.json", "comparison.md")


def demo_case_path() -> Path:
    return Path(str(resources.files("shellcontact") / "cases" / CASE_FILE))


def _row(method: str, result: Result, seconds: float) -> dict:
    s = result.summary()
    c = s["contact"][0]
    return {
        "method": method,
        "force": c["force_magnitude"],
        "zone_area": c["zone"]["area"],
        "active_vertices": c["active_vertices"],
        "line_force": c["rim"]["mean_line_force"] if "rim" in c else 0.0,
        "max_deflection": s["max_abs_w"],
        "stationarity": s["kkt"]["stationarity"],
        "penetration": s["kkt"]["penetration"],
        "complementarity": s["kkt"]["complementarity"],
        "duality_gap": s["kkt"]["duality_gap"],
        "iterations": s["iterations"],
        "seconds": seconds,
        "penalty": s.get("penalty"),
    }


#: the comparison table: key, title, kind of quantity (its unit comes from the case's system; [–]: dimensionless,
#: as summary.json's ``units`` has these residuals), format
COLUMNS = (
    ("method", "method", None, "{}"),
    ("force", "resultant force", "force", "{:.6e}"),  # the report's "resultant force", not its total normal force
    ("zone_area", "zone area", "area", "{:.4e}"),
    ("active_vertices", "active", None, "{}"),
    ("line_force", "rim line force", "force/length", "{:.4e}"),
    ("max_deflection", "max|w|", "length", "{:.6e}"),
    ("stationarity", "stationarity [–]", None, "{:.1e}"),
    ("penetration", "penetration", "length", "{:.1e}"),
    ("complementarity", "complement. [–]", None, "{:.1e}"),
    ("duality_gap", "duality gap [–]", None, "{:.1e}"),
    ("iterations", "iter", None, "{}"),
    ("seconds", "time", "time", "{:.2f}"),
)


def format_table(rows: list[dict], system: str = "SI") -> str:
    """The comparison as a Markdown table whose column titles carry the units of ``system``."""
    cells = [[title + (bracket(kind, system) if kind else "") for _, title, kind, _ in COLUMNS]]
    cells += [[fmt.format(r[key]) for key, _, _, fmt in COLUMNS] for r in rows]
    widths = [max(len(c[i]) for c in cells) for i in range(len(COLUMNS))]
    lines = ["| " + " | ".join(c[i].rjust(widths[i]) for i in range(len(widths))) + " |" for c in cells]
    lines.insert(1, "|" + "|".join("-" * (w + 2) for w in widths) + "|")
    return "\n".join(lines)


def run_demo(output_dir: str | Path = "demo-out", quiet: bool = False, *, overwrite: bool = False,
             wait: bool = False) -> int:
    """Solve the paper's problem three ways, print the comparison, write the results (one transaction)."""
    out = Path(output_dir)
    with replace_dir(out, overwrite=overwrite, owned=DEMO_ENTRIES, wait=wait) as stage:
        table, agreement, eps, warnings, system = _demo(stage, quiet)
    compliance = label("length/pressure", system)
    if not quiet:
        print("")
        print(split_markdown(table))  # comparison.md keeps the table whole
        same = " (the dual ends with the exact solve on the set it found: the primal's)" \
            if agreement["primal_vs_dual"] == 0.0 else ""
        print(f"\n||U_primal - U_dual||/||U|| = {agreement['primal_vs_dual']:.2e}{same}; "
              f"penalty (eps = {eps:.3g} {compliance}) differs by {agreement['primal_vs_penalty']:.2e}")
        print(f"wrote {out}/ (comparison.md, and per method: summary.json, fields.vtu, results.npz; "
              f"figures and report.html for active-set)"
              + (f"; {warnings} warning{'s' * (warnings != 1)} above" if warnings else ""))
    return 0


class _Once(logging.Filter):
    """Lets each message through once."""

    def __init__(self) -> None:
        super().__init__()
        self.seen: set[str] = set()

    def filter(self, record: logging.LogRecord) -> bool:
        message = record.getMessage()
        if message in self.seen:
            return False
        self.seen.add(message)
        return True


def _demo(out: Path, quiet: bool) -> tuple[str, dict[str, float], float, int, str]:
    say = (lambda *a: None) if quiet else print
    case = load_case(demo_case_path())
    length = label("length", case.units)
    say(f"shellcontact demo: clamped panel (a = {case.shell.radius} {length}, t = {case.shell.thickness} {length}) "
        f"pressed by a spherical punch, case {demo_case_path().name}")
    rows, results = [], {}
    once = _Once()  # the three methods solve one case: its warnings (the deflection against t) would show 3 times
    logger = logging.getLogger("shellcontact")
    logger.addFilter(once)
    try:
        for method in PAPER_METHODS:
            t0 = time.perf_counter()
            result = solve(case, method=method)
            seconds = time.perf_counter() - t0
            results[method] = result
            rows.append(_row(method, result, seconds))
            say(f"  {method:<10} solved in {seconds:.2f} s ({result.summary()['iterations']} iterations)")
    finally:
        logger.removeFilter(once)
    warnings = len({str(w) for r in results.values() for w in r.warnings()})  # each once on stderr already
    for method, result in results.items():
        (out / method).mkdir()
        summary = {**result.summary(), "case_file": str(demo_case_path())}  # the reports name their case file
        write_run_files(result, out / method, summary, figures=(method == "active-set"),
                        report=(method == "active-set"))
    exact = results["active-set"].solution.U
    dual = results["dual"].solution.U
    pen = results["penalty"].solution.U
    norm = float((exact @ exact) ** 0.5)
    agreement = {
        "primal_vs_dual": float(((exact - dual) @ (exact - dual)) ** 0.5 / norm),
        "primal_vs_penalty": float(((exact - pen) @ (exact - pen)) ** 0.5 / norm),
    }
    table = format_table(rows, case.units)
    write_json(out / "comparison.json", {"case": str(demo_case_path().name), "rows": rows, "agreement": agreement})
    atomic_write_text(out / "comparison.md", table + "\n\n"
                      + f"||U_primal - U_dual||/||U|| = {agreement['primal_vs_dual']:.2e}, "
                      + f"||U_primal - U_penalty||/||U|| = {agreement['primal_vs_penalty']:.2e} "
                      + f"(penalty eps = {rows[0]['penalty']:.3g} {label('length/pressure', case.units)})\n")
    return table, agreement, rows[0]["penalty"], warnings, case.units
