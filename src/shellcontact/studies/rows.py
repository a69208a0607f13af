"""The rows of a study, one per point: the summary's headline columns (``summary_row``), their units and
kinds, CSV and Parquet files, and the console's fixed-width tables."""

from __future__ import annotations

import csv
import io as _io
import logging
from collections.abc import Sequence
from fnmatch import fnmatchcase
from pathlib import Path
from typing import Any

from ..outputs.files import atomic_write_text, atomic_write_with
from ..outputs.tables import text_table
from ..problem.case import key_kind

log = logging.getLogger("shellcontact")

CONTACT_COLUMNS = (
    ("force", "force_magnitude"),
    ("normal_force", "total_normal_force"),
    ("area", "area"),
    ("peak_pressure", "peak_pressure"),
    ("active_vertices", "active_vertices"),
    ("punch_travel", "punch_travel"),
)


#: the kind of quantity (units.KINDS) of each CSV column, by name pattern (None: a count or dimensionless)
COLUMN_KINDS = (("dofs", None), ("energy", "energy"), ("max_abs_w", "length"), ("probe*_[uvw]", "length"),
                ("normal_force*", "force"), ("force*", "force"), ("zone_area*", "area"), ("area*", "area"),
                ("line_force*", "force/length"), ("line_load*", "force/length"),
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
            # the area rim's mean line force and the line loads' (a plate on a pipe, a saddle's horn), apart; empty
            # where there is none (a point force: contact.<k>.rim.point_forces)
            rim = e.get("rim") if isinstance(e.get("rim"), dict) else {}
            loads = rim.get("line_loads") or {}
            row["line_force" + suffix] = rim["mean_line_force"] if rim.get("force") else None
            row["line_load" + suffix] = loads["mean_line_force"] if loads.get("force") else None
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
