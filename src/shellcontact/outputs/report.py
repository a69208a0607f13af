"""``report.html``: one self-contained page per run (figures embedded as base64 PNG), laid out as an
engineering calculation.

The page opens with the warnings in a box (each with what to do about it: they change what every number
means), then the case in one paragraph (geometry, material, supports, loads, punches, mesh,
method), then a headline table of the results with their units (forces, travel, contact zone, peak
pressure, deflection, von Mises stress and utilisation, equilibrium and KKT residuals), then the figures,
then the details: stresses, support reactions, equilibrium, probes, contact per punch, KKT residuals,
solver, timings, the run, the inputs (every case-file key, ``--set`` overrides marked),
versions and the full summary.json.
Numbers are printed with 6 significant digits (``{:.6g}``), the JSON verbatim; units are those of
the case's ``[units] system`` (units.py). Long cells wrap: no table is wider than the page.
"""

from __future__ import annotations

import base64
import datetime as _dt
import html
import math
import platform
from collections.abc import Iterable, Mapping
from importlib import metadata
from pathlib import Path
from typing import Any

from ..units import bracket, label, with_unit
from .files import atomic_write_text, json_text

CSS = """
body { font-family: system-ui, sans-serif; max-width: 1100px; margin: 2em auto; padding: 0 1em; color: #222;
       line-height: 1.4; }
h1 { font-size: 1.5em; } h2 { font-size: 1.2em; border-bottom: 1px solid #ccc; margin-top: 1.6em; }
h3 { font-size: 1.05em; margin: 1.2em 0 0.3em; }
p.case { max-width: 60em; }
table { border-collapse: collapse; margin: 0.5em 0; font-size: 0.92em; max-width: 100%; }
td, th { border: 1px solid #ccc; padding: 0.2em 0.6em; text-align: left; vertical-align: top;
         overflow-wrap: anywhere; }
td.num { text-align: right; font-family: ui-monospace, monospace; white-space: nowrap; }
td.unit { color: #555; white-space: nowrap; }
table.headline td:first-child { font-weight: 600; }
th { background: #f3f3f3; overflow-wrap: break-word; } .set { color: #a40; font-weight: bold; }
table.accuracy td:nth-child(-n+5) { overflow-wrap: normal; white-space: nowrap; }
figure { display: inline-block; margin: 0.5em 0; max-width: 100%; vertical-align: top; }
figure.half { max-width: calc(50% - 0.5em); }
img { max-width: 100%; height: auto; border: 1px solid #ddd; }
pre { background: #f7f7f7; padding: 0.8em; white-space: pre-wrap; overflow-wrap: anywhere; font-size: 0.85em; }
.warnings { border: 2px solid #c60; background: #fff4e5; padding: 0.4em 1em; margin: 1em 0; }
.warnings li { margin: 0.3em 0; }
.ok { color: #2a6; }
body.wide { max-width: 1360px; } .scroll { overflow-x: auto; max-width: 100%; }
table.study { font-size: 0.8em; } table.study th { overflow-wrap: normal; }
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


def table(rows: Iterable[Iterable[Any]], header: Iterable[str] | None = None, cls: str = "") -> str:
    parts = [f'<table class="{cls}">' if cls else "<table>"]
    if header is not None:
        parts.append("<tr>" + "".join(f"<th>{html.escape(str(h))}</th>" for h in header) + "</tr>")
    for row in rows:
        cells = []
        for c in row:
            if isinstance(c, _Unit):
                cls_ = ' class="unit"'
            elif isinstance(c, (int, float)) and not isinstance(c, bool):
                cls_ = ' class="num"'
            else:
                cls_ = ""
            cells.append(f"<td{cls_}>{c if isinstance(c, _Raw) else fmt(c)}</td>")
        parts.append("<tr>" + "".join(cells) + "</tr>")
    parts.append("</table>")
    return "\n".join(parts)


class _Raw(str):
    """HTML that ``table`` must not escape."""


class _Unit(str):
    """A unit label, shown in its own column."""


def image(name: str, png: bytes) -> str:
    """A figure; maps (narrower than 800 px) take half the page, so that two stand side by side."""
    data = base64.b64encode(png).decode()
    alt = html.escape(name)
    width = int.from_bytes(png[16:20], "big") if png[:8] == b"\x89PNG\r\n\x1a\n" else 0  # IHDR
    cls = ' class="half"' if 0 < width < 800 else ""
    return (f'<figure{cls}><img alt="{alt}" src="data:image/png;base64,{data}"><figcaption>{alt}</figcaption>'
            "</figure>")


def page(title: str, sections: Iterable[tuple[str, str] | tuple[str, str, int]]) -> str:
    """The HTML page: ``sections`` are (heading, content[, level]); empty contents are left out."""
    parts = []
    for heading, content, *level in sections:
        if content:
            h = level[0] if level else 2
            parts.append(f"<h{h}>{html.escape(heading)}</h{h}>\n{content}")
    body = "\n".join(parts)
    return (
        f'<!DOCTYPE html>\n<html lang="en">\n<head>\n<meta charset="utf-8">\n<title>{html.escape(title)}</title>\n'
        f"<style>{CSS}</style>\n</head>\n<body>\n<h1>{html.escape(title)}</h1>\n{body}\n</body>\n</html>\n"
    )


def _lines(message: str) -> str:
    """A warning's text as HTML, its line breaks kept (the accuracy warning puts one headline on a line)."""
    return "<br>".join(html.escape(line) for line in message.split("\n"))


def _warnings(s: Mapping[str, Any]) -> str:
    """A box listing every warning of the run (each says what it means and what to do), or a line saying none."""
    items = s.get("warnings") or []
    if not items:
        return ('<p class="ok">No warnings: every check of the result passed (KKT residuals, penalty ε, contact '
                "outside the zones or between the constraint points, the thin-shell and small-deflection range, "
                "yield stress: where they apply).</p>")
    # each {"code", "message"} (summary.json since the codes; older summaries hold plain strings)
    li = "\n".join(f"<li>{_lines(w if isinstance(w, str) else str(w.get('message', '')))}</li>" for w in items)
    return f'<div class="warnings"><strong>{len(items)} warning{"s" * (len(items) != 1)}</strong><ul>{li}</ul></div>'


# -- the case in one paragraph -------------------------------------------------------------------------------
def _g(v: float) -> str:
    return f"{v:.4g}"


def _describe_case(case: Any, s: Mapping[str, Any]) -> str:
    """Geometry, material, supports, loads, punches, mesh and method of ``case`` (a ``Case``), in sentences."""
    system = s.get("unit_system", "SI")

    def q(v: float, kind: str) -> str:
        unit = label(kind, system)
        return f"{_g(v)} {unit}" if unit else _g(v)

    sh = case.shell
    t = sh.thickness
    thick = f"thickness {q(t, 'length')}" if isinstance(t, (int, float)) else "a thickness t(x, φ) given by a function"
    if sh.full:
        geom = f"A full cylinder of radius {q(sh.radius, 'length')}, length {q(sh.length, 'length')} and {thick}"
    else:
        geom = (f"A cylindrical panel of radius {q(sh.radius, 'length')}, length {q(sh.length, 'length')}, "
                f"φ from {_g(math.degrees(sh.alpha))}° to {_g(math.degrees(sh.beta))}°, {thick}")
    m = sh.material
    if m.model == "isotropic":
        mat = f"isotropic, E = {q(m.young, 'pressure')}, ν = {_g(m.poisson)}"
    else:
        mat = (f"orthotropic, E1 = {q(m.e1, 'pressure')}, E2 = {q(m.e2, 'pressure')}, G12 = {q(m.g12, 'pressure')}, "
               f"ν12 = {_g(m.nu12)}")
    if case.yield_stress is not None:
        mat += f", yield stress {q(case.yield_stress, 'pressure')}"
    sup = case.supports
    if sh.full:
        edges = f"the end x_min {sup.x_min.replace('_', ' ')}, the end x_max {sup.x_max.replace('_', ' ')}"
    else:
        by_kind: dict[str, list[str]] = {}
        for edge in ("x_min", "x_max", "phi_min", "phi_max"):
            by_kind.setdefault(getattr(sup, edge), []).append(edge.replace("phi", "φ"))
        edges = "; ".join(f"{', '.join(e)} {k.replace('_', ' ')}" for k, e in by_kind.items())
    out = [f"{geom} ({mat}), supported as follows: {edges}."]
    loads = case.loads
    applied = []
    if loads.normal != 0.0:
        applied.append("a normal pressure" + (f" of {q(loads.normal, 'pressure')}" if isinstance(loads.normal, float)
                                               else " (a function)"))
    if loads.surface != (0.0, 0.0, 0.0):
        applied.append("a surface load")
    if loads.lines:
        applied.append(f"{len(loads.lines)} line load{'s' * (len(loads.lines) != 1)}")
    if loads.points:
        applied.append(f"{len(loads.points)} point load{'s' * (len(loads.points) != 1)}")
    if applied:
        out.append("Loaded by " + ", ".join(applied) + ".")
    for p in case.punches:
        size = getattr(p.body, "radius", None)
        sized = isinstance(size, float) and math.isfinite(size)
        shape = ("the outside of a " if p.inverted else "a ") + p.shape + (
            f" of radius {q(size, 'length')}" if sized else "")
        if p.extent is not None:  # a body of finite size: its box and cutting planes
            e = p.extent
            limits = [f"{axis} from {q(e.lower[k], 'length')} to {q(e.upper[k], 'length')}"
                      for k, axis in enumerate("xyz") if math.isfinite(e.lower[k])]
            if len(e.points):
                limits.append(f"{len(e.points)} cutting plane{'s' * (len(e.points) != 1)}")
            shape += " limited to " + ", ".join(limits)
        if p.mode == "indentation":
            how = f"pressed {q(p.indentation, 'length')} past first contact"
        elif p.mode == "force":
            how = f"pressed with a force of {q(p.force, 'force')}"
        else:
            how = "in its given position"
        out.append(f"Punch {p.index}: {shape} on the {p.side} surface, {how}.")
    mesh = f"{s['elements']} triangles, {s['vertices']} vertices, {s['dofs']} dofs (P2 × P2 × Argyris P5)"
    method = case.solver.method if case.punches else None
    if method:
        mesh += (f"; contact solved by the {method} method at the {case.solver.contact_points.replace('+', ' and ')} "
                 f"of the zone, KKT tolerance {case.solver.tolerance:g}")
    out.append(f"Mesh: {mesh}.")
    sys_text = {"SI": "N, m, Pa", "mm": "N, mm, MPa"}.get(system, "consistent units, unlabelled")
    out.append(f"Units: {sys_text}; angles in degrees.")
    return '<p class="case">' + html.escape(" ".join(out)) + "</p>"


# -- the headline table ----------------------------------------------------------------------------------------
def _headline(s: Mapping[str, Any]) -> str:
    """The results an engineer decides with: quantity, value, unit, where / note."""
    system = s.get("unit_system", "SI")

    def u(kind: str) -> _Unit:
        return _Unit(label(kind, system))

    rows: list[list[Any]] = []
    paths: dict[int, str] = {}  # a row's summary path: its estimated error (``run --estimate``) beside it

    def mark(path: str) -> None:
        paths[len(rows) - 1] = path

    contact = s.get("contact") or []
    for k, c in enumerate(contact):
        who = f"punch {k} ({c.get('shape', '')}): " if len(contact) > 1 else ""
        rows.append([f"{who}total normal force", c["total_normal_force"], u("force"), "Σ Λᵢ |∇Z|"])
        mark(f"contact.{k}.total_normal_force")
        rows.append([f"{who}resultant force", c["force_magnitude"], u("force"), f"[Fx, Fy, Fz] = {fmt(c['force'])}"])
        mark(f"contact.{k}.force_magnitude")
        control = {"indentation": "indentation control", "force": "force control (the travel is computed)",
                   "fixed": "fixed position"}
        rows.append([f"{who}punch travel", c["punch_travel"], u("length"), control.get(c.get("mode"), "")])
        mark(f"contact.{k}.punch_travel")
        zone = c.get("zone")
        if isinstance(zone, Mapping):
            note = f"where the gap is below {with_unit(_g(zone['gap_tolerance']), 'length', system)}"
            if zone.get("x") and zone.get("phi"):
                (x0, x1), (p0, p1) = zone["x"], zone["phi"]
                note += f": x from {_g(x0)} to {with_unit(_g(x1), 'length', system)}, φ from {_g(p0)}° to {_g(p1)}°"
            if zone.get("state") == "point":
                note = "a point contact: the punch carries force, no sampled point is within the gap tolerance"
            rows.append([f"{who}contact zone area", zone["area"], u("area"), note])
            mark(f"contact.{k}.zone.area")
        rim = c.get("rim")
        if isinstance(rim, Mapping):
            share = rim["force"] / c["total_normal_force"] if c["total_normal_force"] else 0.0
            for j, pf in enumerate(rim.get("point_forces", [])):  # where the zone is a point (point_forces.py)
                rows.append([f"{who}point force", pf["force"], u("force"),
                             f"at x = {with_unit(_g(pf['x']), 'length', system)}, φ = {_g(pf['phi'])}°: carrying "
                             "points within the elements round one vertex (a zone the mesh sees as a point: refine "
                             "to tell a point from a small area), left out of the line/interior split"])
                mark(f"contact.{k}.rim.point_forces.{j}.force")
            if rim.get("kind") == "unresolved":  # carrying rows round which no zone is drawn (rim.py)
                rows.append([f"{who}force at scattered points", rim["interior_force"], u("force"),
                             "carrying points that form neither a zone nor a point force on this mesh: its split "
                             "into rim, line loads and interior is not resolved; refine"])
            loads = rim.get("line_loads") or {}
            if loads.get("force"):  # line contacts (a plate on a pipe, a saddle's horn): apart from the area rim
                rows.append([f"{who}line load", loads["mean_line_force"], u("force/length"),
                             f"force / length of the contact lines ({with_unit(_g(loads['length']), 'length', system)}"
                             f", carrying {loads['force'] / c['total_normal_force']:.0%} of the normal force"
                             + (f", {with_unit(_g(loads['end_force']), 'force', system)} of it as end forces at "
                                "the lines' ends: corner forces" if loads.get("end_force") else "") + ")"])
                mark(f"contact.{k}.rim.line_loads.mean_line_force")
            if rim.get("force"):
                rows.append([f"{who}rim line force (mean)", rim["mean_line_force"], u("force/length"),
                             f"along {with_unit(_g(rim['length']), 'length', system)} of rim, carrying "
                             f"{share:.0%} of the normal force; peak (mesh-dependent) "
                             f"{with_unit(_g(rim['peak_line_force']), 'force/length', system)}"])
                mark(f"contact.{k}.rim.mean_line_force")
                if rim.get("interior_area"):
                    rows.append([f"{who}interior force (mean pressure)", rim["mean_interior_pressure"], u("pressure"),
                                 f"{with_unit(_g(rim['interior_force']), 'force', system)} "
                                 f"({rim['interior_force'] / c['total_normal_force']:.1%} of the normal force) over "
                                 f"{with_unit(_g(rim['interior_area']), 'area', system)} inside the rim"])
                if rim.get("interior_force") and "interior_pressure" in rim:
                    resolved = rim.get("interior_resolved", True)
                    name = "interior pressure" + ("" if resolved else " (mesh-dependent)")
                    note = (f"where the shell carries inside the rim, over "
                            f"{with_unit(_g(rim['carrying_area']), 'area', system)}; "
                            f"{with_unit(_g(rim['interior_edge_force']), 'force', system)} on the edges of that "
                            "region (line forces where the contact ends inside the zone)")
                    if not resolved:
                        note = ("a faint contact inside the rim that this mesh does not resolve (its carrying points "
                                "are scattered): refine to resolve it; " + note)
                    rows.append([f"{who}{name}", rim["interior_pressure"], u("pressure"), note])
        rows.append([f"{who}peak nodal pressure (mesh-dependent)", c["peak_pressure"], u("pressure"),
                     "the map's nodal pressure: exact on a uniform load, but grows like 1/h at a line force"])
    rows.append(["max deflection |w|", s["max_abs_w"], u("length"), ""])
    mark("max_abs_w")
    st = s.get("stresses") or {}
    if st:
        name, worst = max(st.items(), key=lambda kv: kv[1]["von_mises_max"])
        at = f"{name} surface, x = {with_unit(fmt(worst['at']['x']), 'length', system)}, φ = {fmt(worst['at']['phi'])}°"
        rows.append(["max von Mises stress", worst["von_mises_max"], u("pressure"), at.strip()])
        mark(f"stresses.{name}.von_mises_max")
        if "utilisation_max" in worst:
            util = max(v.get("utilisation_max", 0.0) for v in st.values())
            rows.append(["utilisation σ_v / yield", util, _Unit("–"), "beyond yield" if util > 1 else ""])
    if not contact and s.get("reaction_resultant") is not None:
        rows.append(["support reaction", fmt(s["reaction_resultant"]), u("force"), "resultant [Fx, Fy, Fz]"])
    eq = s.get("equilibrium")
    if eq:
        rows.append(["equilibrium residual", eq["relative_residual"], _Unit("–"),
                     "relative to the largest gross force (moment) balance"])
    scaled = s.get("kkt_scaled") or {}
    if scaled:
        worst_k = max(scaled, key=lambda k: scaled[k])
        tol = s.get("tolerance")
        rows.append(["KKT residual (largest scaled)", scaled[worst_k], _Unit("–"),
                     f"{worst_k}; tolerance {fmt(tol)}" if tol is not None else worst_k])
    head: tuple[str, ...] = ("quantity", "value", "unit", "where / note")
    acc = s.get("accuracy") or {}
    if acc:  # the estimate next to the number (the Accuracy section has every headline, with what to refine)
        head = (*head[:3], "estimated error", head[3])
        for i, row in enumerate(rows):
            row.insert(3, _estimate(acc.get(paths.get(i, ""))))
    return table(rows, head, cls="headline")


def _estimate(entry: Mapping[str, Any] | None) -> str:
    """An accuracy entry's estimated relative error as shown ("–" where none)."""
    if not entry or entry.get("estimate") is None:
        return "–"
    e = float(entry["estimate"])
    return f"{100 * e:.2g} %" + (" (above 1 %)" if e > 0.01 else "")


def _accuracy(s: Mapping[str, Any]) -> str:
    """``run --estimate`` / ``--accuracy``: every headline beside its estimated relative discretisation error."""
    acc, ref = s.get("accuracy"), s.get("refinement") or {}
    if not acc:
        return ""
    units, tol, levels = s.get("units", {}), ref.get("tolerance"), ref.get("levels", [])
    advised = any("refine" in e for e in acc.values())  # accuracy.refine_advice, for estimates above 1 %
    rows = [[path, e["value"], _Unit(units.get(f"accuracy.{path}.value", "–")),
             "not estimated" if e["estimate"] is None else _estimate(e),
             "1 (assumed)" if e["order"] is None else f"{e['order']:.2g}",
             *([] if tol is None else ["met" if e.get("met") else "not met"]),
             *([e.get("refine", "")] if advised else [])] for path, e in acc.items()]
    meshes = ", ".join(f"{lv['dofs']} dofs" for lv in levels)
    intro = (f"<p>From {len(levels)} meshes, finest first ({meshes}), each coarser one with twice the element size: "
             "Richardson extrapolation with the observed order, or order 1 where none is observed "
             "(docs/outputs.md)." + (f" Tolerance {tol:g}: {html.escape(ref.get('stopped') or 'met')}." if tol else "")
             + "</p>")
    head = ("summary path", "value", "unit", "estimated relative error", "order", *(() if tol is None else ("",)),
            *(("what to refine",) if advised else ()))
    return intro + table(rows, head, cls="headline accuracy")


# -- details ----------------------------------------------------------------------------------------------------
def _stresses(s: Mapping[str, Any]) -> str:
    st = s.get("stresses") or {}
    if not st:
        return ""
    system = s.get("unit_system", "SI")
    P, L = bracket("pressure", system), bracket("length", system)
    util = any("utilisation_max" in v for v in st.values())
    rows = [[name, v["von_mises_max"], v["at"]["x"], v["at"]["phi"], v["max_principal"], v["min_principal"],
             *([v["utilisation_max"]] if util else [])] for name, v in st.items()]
    return table(rows, ["surface", f"max von Mises{P}", f"at x{L}", "at φ [deg]", f"max principal{P}",
                        f"min principal{P}", *(["utilisation"] if util else [])])


def _reactions(s: Mapping[str, Any]) -> str:
    r = s.get("reactions") or {}
    if not r:
        return ""
    system = s.get("unit_system", "SI")
    rows = [[edge, fmt(v["force"]), fmt(v["moment"]), fmt(v["about"])] for edge, v in r.items()]
    return table(rows, ("edge", f"force [Fx, Fy, Fz]{bracket('force', system)}",
                        f"moment [Mx, My, Mz]{bracket('moment', system)}",
                        f"about the point{bracket('length', system)}"))


def _equilibrium(s: Mapping[str, Any]) -> str:
    eq = s.get("equilibrium")
    if not eq:
        return ""
    system = s.get("unit_system", "SI")
    rows = [[k, fmt(eq[k]["force"]), fmt(eq[k]["moment"])]
            for k in ("applied", "contact", "reactions", "residual") if k in eq]
    return table(rows, ("", f"force [Fx, Fy, Fz]{bracket('force', system)}",
                        f"moment about the origin [Mx, My, Mz]{bracket('moment', system)}")) + (
        f"<p>relative residual {eq['relative_residual']:.2e} (of the largest gross force balance, and moment "
        "balance, Σ |f r|)</p>")


def _probes(s: Mapping[str, Any]) -> str:
    pr = s.get("probes") or []
    if not pr:
        return ""
    system = s.get("unit_system", "SI")
    L, P = bracket("length", system), bracket("pressure", system)
    out = table(
        [(i, p["x"], p["phi"], p["u"], p["v"], p["w"], fmt(p["displacement"])) for i, p in enumerate(pr)],
        ("probe", f"x{L}", "φ [deg]", f"u{L}", f"v{L}", f"w{L}", f"displacement [ux, uy, uz]{L}"),
    )
    rows = [(i, surface, v["s11"], v["s22"], v["s12"], v["von_mises"])
            for i, p in enumerate(pr) for surface, v in (p.get("stress") or {}).items()]
    if rows:
        out += "\n" + table(rows, ("probe", "surface", f"σ11{P}", f"σ22{P}", f"σ12{P}", f"von Mises{P}"))
    return out


def _contact(s: Mapping[str, Any]) -> str:
    """One column per punch, one row per quantity (with its unit): a table that stays narrow."""
    c = s.get("contact")
    if not c:
        return ""
    entries = c if isinstance(c, list) else [c]
    units = s.get("units") or {}
    keys: list[str] = []
    for e in entries:
        for k, v in e.items():
            sub = [f"{k}.{j}" for j in v] if isinstance(v, Mapping) else [k]
            lists = ("rim.samples", "rim.per_line", "rim.point_forces")  # in summary.json
            keys += [x for x in sub if x not in keys and x not in lists]

    def value(e: Mapping[str, Any], key: str) -> Any:
        head, _, tail = key.partition(".")
        v = e.get(head)
        return v.get(tail) if tail and isinstance(v, Mapping) else v

    show_units = s.get("unit_system", "SI") != "none"
    rows = [[k, _Unit(units.get(f"contact.{k}", "") if show_units else ""), *(value(e, k) for e in entries)]
            for k in keys]
    return table(rows, ["quantity", "unit", *(f"punch {i}" for i in range(len(entries)))])


def _kkt(s: Mapping[str, Any]) -> str:
    kkt = s.get("kkt")
    if not isinstance(kkt, Mapping) or not kkt:
        return ""
    units = s.get("units") or {}
    scaled = s.get("kkt_scaled") or {}
    show_units = s.get("unit_system", "SI") != "none"
    rows = [[k, v, _Unit(units.get(f"kkt.{k}", "–") if show_units else ""), scaled.get(k)] for k, v in kkt.items()]
    out = table(rows, ("residual", "value", "unit", "scaled (compared with the tolerance)"))
    if s.get("tolerance") is not None:
        out += f"<p>tolerance {fmt(s['tolerance'])}</p>"
    return out


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
    case: Any = None,
) -> str:
    """The HTML text of a run report (``case``: the ``Case``, for the opening paragraph)."""
    set_keys = {o.partition("=")[0].strip() for o in overrides}
    input_rows = [
        (_Raw(f'<span class="set">{html.escape(k)}</span> (--set)') if k in set_keys else k, v)
        for k, v in flatten(inputs or {})
    ]
    solver = summary.get("solver")
    source = summary.get("case_file") or (str(case.source) if getattr(case, "source", None) else "—")
    run_rows = [
        ("date (UTC)", _dt.datetime.now(_dt.UTC).strftime("%Y-%m-%d %H:%M:%S")),
        ("case file", source),
        ("unit system", summary.get("unit_system", "SI")),
        ("solver", solver if isinstance(solver, str) else "—"),
        ("iterations", summary.get("iterations", "—")),
        ("backend", summary.get("backend", "—")),
        *((k, summary[k]) for k in ("dofs", "unknowns", "elements", "vertices") if k in summary),
        ("energy" + bracket("energy", summary.get("unit_system", "SI")), summary.get("energy")),
    ]
    sections = [
        ("Warnings", _warnings(summary)),  # first: they change what every number below means
        ("The case", _describe_case(case, summary) if case is not None else ""),
        ("Results", _headline(summary)),
        ("Accuracy", _accuracy(summary)),
        ("Figures", "\n".join(image(n, b) for n, b in (figures or {}).items())),
        ("Details", "<p>Every number of the run, by topic; the full summary.json at the end.</p>"),
        ("Stresses (extremes per surface)", _stresses(summary), 3),
        ("Support reactions (on the shell, per edge)", _reactions(summary), 3),
        ("Equilibrium", _equilibrium(summary), 3),
        ("Probes", _probes(summary), 3),
        ("Contact", _contact(summary), 3),
        ("KKT residuals", _kkt(summary), 3),
        ("Solver", _mapping(summary, "solver") if isinstance(solver, Mapping) else "", 3),
        ("Iterations", _mapping(summary, "iterations"), 3),
        ("Timings (seconds)", _mapping(summary, "timings"), 3),
        ("Run", table(run_rows), 3),
        ("Inputs", table(input_rows, ("key", "value")) if input_rows else "", 3),
        ("Versions", table(list(versions().items()), ("package", "version")), 3),
        ("summary.json", f"<details><summary>show</summary><pre>{html.escape(json_text(summary))}</pre></details>",
         3),
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
    atomic_write_text(path, render(summary, getattr(result.case, "raw", {}), overrides, figures, title,
                                   case=result.case))
    return Path(path)


def write_study_report(
    path: str | Path,
    title: str,
    rows: list[Mapping[str, Any]],
    figures: Mapping[str, bytes] | None = None,
    about: Mapping[str, Any] | None = None,
    inputs: Mapping[str, Any] | None = None,
    heads: Mapping[str, str] | None = None,
) -> Path:
    """A self-contained page for a sweep or a convergence study: what was run, the table (``heads``: each
    column's title with its unit), the figures. The page is 1360 px wide; a table wider still scrolls in its box."""
    cols: list[str] = []
    for r in rows:
        cols += [c for c in r if c not in cols]
    titles = [(heads or {}).get(c, c).replace(".", ".\u200b").replace("_", "_\u200b") for c in cols]  # break points
    results = table([[r.get(c) for c in cols] for r in rows], titles, "study")
    sections = [
        ("Study", table(list((about or {}).items()), ("", "value"))),
        ("Results", f'<div class="scroll">{results}</div>'),
        ("Figures", "\n".join(image(n, b) for n, b in (figures or {}).items())),
        ("Inputs", table(flatten(inputs or {}), ("key", "value"))),
        ("Versions", table(list(versions().items()), ("package", "version"))),
    ]
    atomic_write_text(path, page(title, sections).replace("<body>", '<body class="wide">', 1))
    return Path(path)
