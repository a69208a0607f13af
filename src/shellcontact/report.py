"""``report.html``: one self-contained page per run (figures embedded as base64 PNG).

Sections: the warnings first (in a box, each with what to do about it), inputs (every case-file key,
with ``--set`` overrides marked), key results, probes, contact per punch, KKT residuals, solver,
timings, versions, and the full summary.json. Numbers are printed with 6 significant digits
(``{:.6g}``), the JSON verbatim.
"""

from __future__ import annotations

import base64
import datetime as _dt
import html
import platform
from collections.abc import Iterable, Mapping
from importlib import metadata
from pathlib import Path
from typing import Any

from .files import atomic_write_text, json_text

CSS = """
body { font-family: system-ui, sans-serif; max-width: 1100px; margin: 2em auto; color: #222; }
h1 { font-size: 1.5em; } h2 { font-size: 1.2em; border-bottom: 1px solid #ccc; margin-top: 1.6em; }
table { border-collapse: collapse; margin: 0.5em 0; font-size: 0.92em; }
td, th { border: 1px solid #ccc; padding: 0.2em 0.6em; text-align: left; }
td.num { text-align: right; font-family: ui-monospace, monospace; }
th { background: #f3f3f3; } .set { color: #a40; font-weight: bold; }
figure { display: inline-block; margin: 0.5em; } img { max-width: 100%; border: 1px solid #ddd; }
pre { background: #f7f7f7; padding: 0.8em; overflow-x: auto; font-size: 0.85em; }
.warnings { border: 2px solid #c60; background: #fff4e5; padding: 0.4em 1em; margin: 1em 0; }
.warnings li { margin: 0.3em 0; }
"""

PACKAGES = ("shellcontact", "numpy", "scipy", "scikit-fem", "meshio", "matplotlib", "pypardiso")


def versions() -> dict[str, str]:
    """Python and package versions (packages that are not installed are left out)."""
    out = {"python": platform.python_version(), "platform": platform.platform()}
    for name in PACKAGES:
        try:
            out[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            pass
    return out


def fmt(v: Any) -> str:
    """A value as shown in the report: floats with 6 significant digits."""
    if isinstance(v, bool) or v is None:
        return html.escape(str(v).lower() if isinstance(v, bool) else "—")
    if isinstance(v, float):
        return f"{v:.6g}"
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(fmt(c) for c in v) + "]"
    if isinstance(v, dict):
        return "{" + ", ".join(f"{html.escape(str(k))} = {fmt(c)}" for k, c in v.items()) + "}"
    return html.escape(str(v))


def flatten(data: Mapping[str, Any], prefix: str = "") -> list[tuple[str, Any]]:
    """Dotted keys of a nested case dictionary (arrays of tables by index)."""
    out: list[tuple[str, Any]] = []
    for k, v in data.items():
        key = f"{prefix}{k}"
        if isinstance(v, Mapping):
            out += flatten(v, key + ".")
        elif isinstance(v, list) and v and all(isinstance(c, Mapping) for c in v):
            for i, c in enumerate(v):
                out += flatten(c, f"{key}.{i}.")
        else:
            out.append((key, v))
    return out


def table(rows: Iterable[Iterable[Any]], header: Iterable[str] | None = None) -> str:
    parts = ["<table>"]
    if header is not None:
        parts.append("<tr>" + "".join(f"<th>{html.escape(str(h))}</th>" for h in header) + "</tr>")
    for row in rows:
        cells = []
        for c in row:
            cls = ' class="num"' if isinstance(c, (int, float)) and not isinstance(c, bool) else ""
            cells.append(f"<td{cls}>{c if isinstance(c, _Raw) else fmt(c)}</td>")
        parts.append("<tr>" + "".join(cells) + "</tr>")
    parts.append("</table>")
    return "\n".join(parts)


class _Raw(str):
    """HTML that ``table`` must not escape."""


def image(name: str, png: bytes) -> str:
    data = base64.b64encode(png).decode()
    alt = html.escape(name)
    return f'<figure><img alt="{alt}" src="data:image/png;base64,{data}"><figcaption>{alt}</figcaption></figure>'


def page(title: str, sections: Iterable[tuple[str, str]]) -> str:
    body = "\n".join(f"<h2>{html.escape(h)}</h2>\n{content}" for h, content in sections if content)
    return (
        f'<!DOCTYPE html>\n<html lang="en">\n<head>\n<meta charset="utf-8">\n<title>{html.escape(title)}</title>\n'
        f"<style>{CSS}</style>\n</head>\n<body>\n<h1>{html.escape(title)}</h1>\n{body}\n</body>\n</html>\n"
    )


def _warnings(s: Mapping[str, Any]) -> str:
    """A box listing every warning of the run (each says what it means and what to do), or nothing."""
    items = s.get("warnings") or []
    if not items:
        return ""
    li = "\n".join(f"<li>{html.escape(str(w))}</li>" for w in items)
    return f'<div class="warnings"><strong>{len(items)} warning{"s" * (len(items) != 1)}</strong><ul>{li}</ul></div>'


def _key_results(s: Mapping[str, Any]) -> str:
    keys = ("dofs", "unknowns", "elements", "vertices", "energy", "max_abs_w", "reaction_resultant", "backend")
    rows = [(k, s[k]) for k in keys if k in s]
    for k in ("solver", "iterations"):
        if k in s and not isinstance(s[k], Mapping):
            rows.append((k, s[k]))
    return table(rows, ("quantity", "value"))


def _stresses(s: Mapping[str, Any]) -> str:
    st = s.get("stresses") or {}
    if not st:
        return ""
    util = any("utilisation_max" in v for v in st.values())
    rows = [[name, v["von_mises_max"], v["at"]["x"], v["at"]["phi"], v["max_principal"], v["min_principal"],
             *([v["utilisation_max"]] if util else [])] for name, v in st.items()]
    return table(rows, ["surface", "max von Mises", "at x", "at φ (deg)", "max principal", "min principal",
                        *(["utilisation"] if util else [])])


def _equilibrium(s: Mapping[str, Any]) -> str:
    eq = s.get("equilibrium")
    if not eq:
        return ""
    rows = [[k, eq[k]["force"], eq[k]["moment"]] for k in ("applied", "contact", "reactions", "residual") if k in eq]
    return table(rows, ("", "force [Fx, Fy, Fz]", "moment about the origin [Mx, My, Mz]")) + (
        f"<p>relative residual {eq['relative_residual']:.2e} (of the gross size of each balance)</p>")


def _probes(s: Mapping[str, Any]) -> str:
    pr = s.get("probes") or []
    if not pr:
        return ""
    return table(
        [(p["x"], p["phi"], p["u"], p["v"], p["w"], p["displacement"]) for p in pr],
        ("x", "φ (deg)", "u", "v", "w", "displacement [ux, uy, uz]"),
    )


def _contact(s: Mapping[str, Any]) -> str:
    c = s.get("contact")
    if not c:
        return ""
    entries = c if isinstance(c, list) else [c]
    keys: list[str] = []
    for e in entries:
        keys += [k for k in e if k not in keys]
    return table([[i, *(e.get(k) for k in keys)] for i, e in enumerate(entries)], ["punch", *keys])


def _mapping(s: Mapping[str, Any], key: str) -> str:
    v = s.get(key)
    if isinstance(v, Mapping) and v:
        return table(list(v.items()), (key, "value"))
    return ""


def render(
    summary: Mapping[str, Any],
    inputs: Mapping[str, Any] | None = None,
    overrides: Iterable[str] = (),
    figures: Mapping[str, bytes] | None = None,
    title: str = "shellcontact run",
) -> str:
    """The HTML text of a run report."""
    set_keys = {o.partition("=")[0].strip() for o in overrides}
    input_rows = [
        (_Raw(f'<span class="set">{html.escape(k)}</span> (--set)') if k in set_keys else k, v)
        for k, v in flatten(inputs or {})
    ]
    solver = summary.get("solver")
    sections = [
        ("Warnings", _warnings(summary)),
        (
            "Run",
            table(
                [
                    ("date (UTC)", _dt.datetime.now(_dt.UTC).strftime("%Y-%m-%d %H:%M:%S")),
                    ("case file", summary.get("case_file", "—")),
                ]
            ),
        ),
        ("Inputs", table(input_rows, ("key", "value")) if input_rows else ""),
        ("Key results", _key_results(summary)),
        ("Stresses", _stresses(summary)),
        ("Equilibrium", _equilibrium(summary)),
        ("Probes", _probes(summary)),
        ("Contact", _contact(summary)),
        ("KKT residuals", _mapping(summary, "kkt")),
        ("Solver", _mapping(summary, "solver") if isinstance(solver, Mapping) else ""),
        ("Iterations", _mapping(summary, "iterations")),
        ("Timings (seconds)", _mapping(summary, "timings")),
        ("Figures", "\n".join(image(n, b) for n, b in (figures or {}).items())),
        ("Versions", table(list(versions().items()), ("package", "version"))),
        ("summary.json", f"<details><summary>show</summary><pre>{html.escape(json_text(summary))}</pre></details>"),
    ]
    return page(title, sections)


def write_report(
    result,
    path: str | Path,
    summary: Mapping[str, Any] | None = None,
    figures: Mapping[str, bytes] | None = None,
    overrides: Iterable[str] | None = None,
) -> Path:
    """Write ``report.html`` for ``result`` (figures: PNG bytes by name, e.g. from ``plots.run_figures``)."""
    summary = result.summary() if summary is None else summary
    if overrides is None:
        overrides = summary.get("overrides", ())
    src = getattr(result.case, "source", None)
    title = f"shellcontact: {Path(src).name}" if src else "shellcontact run"
    atomic_write_text(path, render(summary, getattr(result.case, "raw", {}), overrides, figures, title))
    return Path(path)


def write_study_report(
    path: str | Path,
    title: str,
    rows: list[Mapping[str, Any]],
    figures: Mapping[str, bytes] | None = None,
    about: Mapping[str, Any] | None = None,
    inputs: Mapping[str, Any] | None = None,
) -> Path:
    """A self-contained page for a sweep or a convergence study: what was run, the table, the figures."""
    cols: list[str] = []
    for r in rows:
        cols += [c for c in r if c not in cols]
    sections = [
        ("Study", table(list((about or {}).items()), ("", "value"))),
        ("Results", table([[r.get(c) for c in cols] for r in rows], cols)),
        ("Figures", "\n".join(image(n, b) for n, b in (figures or {}).items())),
        ("Inputs", table(flatten(inputs or {}), ("key", "value"))),
        ("Versions", table(list(versions().items()), ("package", "version"))),
    ]
    atomic_write_text(path, page(title, sections))
    return Path(path)
