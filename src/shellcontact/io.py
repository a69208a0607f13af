"""Writing results: atomic files (temporary name, then rename) so nothing is half-written.

Public API (each takes a ``Result`` of ``shellcontact.solve``):

* ``vertex_fields(result)`` — every per-vertex array written to files (see docs/outputs.md);
* ``write_vtu(result, path)`` — the 3D shell surface for ParaView (meshio, VTU);
* ``write_npz(result, path)`` — raw vectors (U, F, mesh p and t, contact arrays when present);
* ``write_outputs(result, directory, ...)`` — the whole run directory.
"""

from __future__ import annotations

import io as _io
import json
import os
import tempfile
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from .errors import InputError

#: files a run directory may contain; ``--force`` removes exactly these before writing
RUN_FILES = (
    "summary.json",
    "fields.vtu",
    "results.npz",
    "deflection.png",
    "deformed.png",
    "pressure.png",
    "pressure_profiles.png",
    "report.html",
)

#: per-vertex contact arrays, in the order they are written
CONTACT_FIELDS = ("contact_status", "contact_pressure", "gap", "contact_force", "contact_force_vector")


# -- atomic writes --------------------------------------------------------------------------------
def _file_mode() -> int:
    """0o666 minus the process umask: what a plain ``open(path, "w")`` would give."""
    mask = os.umask(0)
    os.umask(mask)
    return 0o666 & ~mask


_MODE = _file_mode()


def atomic_write_bytes(path: str | Path, data: bytes) -> None:
    """Write ``data`` to a temporary file beside ``path``, then rename it into place."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        with os.fdopen(fd, "wb") as fh:
            fh.write(data)
        os.chmod(tmp, _MODE)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def atomic_write_text(path: str | Path, text: str) -> None:
    atomic_write_bytes(path, text.encode())


def atomic_write_with(path: str | Path, writer: Callable[[str], None]) -> None:
    """Let ``writer(tmp_path)`` write a file by name (e.g. meshio), then rename it to ``path``."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    os.close(fd)
    try:
        writer(tmp)
        os.chmod(tmp, _MODE)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def _json_default(obj: Any) -> Any:
    if isinstance(obj, np.generic):
        return obj.item()
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, Path):
        return str(obj)
    return str(obj)


def json_text(data: Any) -> str:
    return json.dumps(data, indent=2, sort_keys=False, default=_json_default) + "\n"


def write_json(path: str | Path, data: Any) -> None:
    atomic_write_bytes(path, json_text(data).encode())


def check_output_dir(path: str | Path, force: bool, option: str = "--output") -> Path:
    """Refuse an existing non-empty directory unless ``force``; a file in the way is an error."""
    path = Path(path)
    if path.exists() and not path.is_dir():
        raise InputError(option, f"{str(path)!r} exists and is not a directory")
    if path.is_dir() and any(path.iterdir()) and not force:
        raise InputError(option, f"{str(path)!r} exists and is not empty; use --force to overwrite")
    return path


def clear_run_files(path: str | Path) -> None:
    """Remove the files a previous run wrote (only those named in RUN_FILES)."""
    for name in RUN_FILES:
        (Path(path) / name).unlink(missing_ok=True)


# -- contact adapter --------------------------------------------------------------------------------
def _contact(result) -> Any:
    return getattr(result, "contact", None)


def contact_vertex_arrays(
    op, Lam: np.ndarray, active: np.ndarray | None = None, gap: np.ndarray | None = None
) -> dict[str, np.ndarray]:
    """Per-vertex contact arrays from a ``contact.ContactOperator`` and the row values of a solve.

    Rows of all punches are gathered on their mesh vertex (edge-midpoint rows are left out):
    ``contact_status`` 1 if any row at the vertex is active, 0 if it is only a candidate, −1 if
    no row; ``contact_pressure`` = ``op.vertex_pressure(Lam)``; ``contact_force`` = Σ Λ_i;
    ``contact_force_vector`` (nv, 3) = Σ Λ_i ∇Z(M_i); ``gap`` = min over the rows of G + BU (NaN
    where no row). On a full cylinder the φ = β copies take the values of their φ = α twins.
    """
    nv = int(op.nvertices)
    Lam = np.asarray(Lam, float)
    r = np.nonzero(np.asarray(op.vertex) >= 0)[0]
    v = np.asarray(op.vertex)[r]
    act = (op.active(Lam) if active is None else np.asarray(active, bool))[r]
    status = np.full(nv, -1, dtype=np.int64)
    np.maximum.at(status, v, act.astype(np.int64))
    force = np.zeros(nv)
    np.add.at(force, v, Lam[r])
    fvec = np.zeros((nv, 3))
    np.add.at(fvec, v, (np.asarray(op.grad)[:, r] * Lam[r]).T)
    out = {
        "contact_status": status,
        "contact_pressure": np.asarray(op.vertex_pressure(Lam), float),
        "contact_force": force,
        "contact_force_vector": fvec,
    }
    if gap is not None:
        g = np.full(nv, np.inf)
        np.minimum.at(g, v, np.asarray(gap, float)[r])
        out["gap"] = np.where(np.isfinite(g), g, np.nan)
    twins = getattr(op, "twins", None)
    if twins is not None:
        slave, master = twins
        for k in ("contact_status", "contact_force", "contact_force_vector", "gap"):
            if k in out:
                out[k][slave] = out[k][master]
    return out


def contact_vertex_fields(result) -> dict[str, np.ndarray]:
    """Per-vertex contact arrays of ``result.contact`` (empty dict without contact).

    Contract (docs/outputs.md): ``result.contact.vertex_fields()`` returns arrays of length
    nv (mesh vertices) named in CONTACT_FIELDS — ``contact_status`` (1 active, 0 inactive
    candidate, −1 not a candidate), ``contact_pressure`` (Λ_i/ω_i, 0 off contact), ``gap``
    (G + BU, NaN off the candidate set), ``contact_force`` (nodal Λ_i), optionally
    ``contact_force_vector`` (nv, 3). ``contact_vertex_arrays(op, Lam, active, gap)`` builds exactly
    these from a ContactOperator; it is used directly when the object has ``operator`` and
    ``Lambda`` (and optionally ``active``, ``gap``) attributes. Otherwise,
    attributes ``status``/``active``, ``pressure``, ``gap``, ``forces``/``Lambda`` are used, scattered
    to all vertices through ``vertices`` (candidate vertex indices) when they are shorter than nv.
    Missing fields are skipped, never invented.
    """
    c = _contact(result)
    if c is None:
        return {}
    nv = result.solution.space.mesh.nvertices
    if hasattr(c, "vertex_fields"):
        raw = dict(c.vertex_fields())
    elif getattr(c, "operator", None) is not None and getattr(c, "Lambda", None) is not None:
        gap = getattr(c, "gap", None)
        gap = gap() if callable(gap) else gap
        return contact_vertex_arrays(c.operator, c.Lambda, getattr(c, "active", None), gap)
    else:
        raw = {}
        for name, attrs in (
            ("contact_status", ("status", "active")),
            ("contact_pressure", ("pressure",)),
            ("gap", ("gap",)),
            ("contact_force", ("forces", "nodal_forces", "Lambda")),
        ):
            for a in attrs:
                v = getattr(c, a, None)
                if callable(v):
                    v = v()  # e.g. ContactSolution.gap()
                if v is not None:
                    raw[name] = v
                    break
    idx = getattr(c, "vertices", None)
    out: dict[str, np.ndarray] = {}
    for name, arr in raw.items():
        arr = np.asarray(arr)
        if arr.dtype == bool:
            arr = arr.astype(np.int8)
        if arr.shape[:1] != (nv,):
            if idx is None or arr.shape[:1] != np.shape(idx):
                continue  # cannot place it on the mesh: skip rather than guess
            fill = {"contact_status": -1, "contact_pressure": 0.0, "contact_force": 0.0}.get(name, np.nan)
            full = np.full((nv, *arr.shape[1:]), fill, dtype=np.result_type(arr.dtype, type(fill)))
            full[np.asarray(idx)] = arr
            arr = full
        out[name] = arr
    return out


# -- fields on the vertices --------------------------------------------------------------------------
def vertex_fields(result) -> dict[str, np.ndarray]:
    """Arrays at the mesh vertices: x, phi_deg, u, v, w, displacement (nv, 3), deformed (nv, 3),
    resultants N11 … M12 and the contact fields when present."""
    sol = result.solution
    mesh = sol.space.mesh
    x, s = mesh.p
    phi = s / sol.shell.radius
    d = sol.evaluate(x, phi)  # every quantity at once: one point location for all fields below
    disp = sol.displacement(x, phi, values=d)
    out: dict[str, np.ndarray] = {
        "x": x.copy(),
        "phi_deg": np.degrees(phi),
        "u": d["u"],
        "v": d["v"],
        "w": d["w"],
        "displacement": disp.T.copy(),
        "deformed": (sol.shell.point(x, phi) + disp).T.copy(),
        "thickness": sol.shell.t(x, phi),
    }
    out.update({k: np.asarray(val, float) for k, val in sol.resultants(x, phi, values=d).items()})
    out.update(contact_vertex_fields(result))
    return out


def reference_points(result) -> np.ndarray:
    sol = result.solution
    x, s = sol.space.mesh.p
    return sol.shell.point(x, s / sol.shell.radius).T.copy()


def write_vtu(result, path: str | Path, fields: dict[str, np.ndarray] | None = None) -> Path:
    """The shell's middle surface in 3D as a VTU file (points: reference coordinates)."""
    import meshio

    fields = vertex_fields(result) if fields is None else fields
    mesh = meshio.Mesh(
        reference_points(result),
        [("triangle", result.solution.space.mesh.t.T.astype(np.int64))],
        point_data={k: np.ascontiguousarray(v, dtype=float) for k, v in fields.items()},
    )
    atomic_write_with(path, lambda tmp: meshio.write(tmp, mesh, file_format="vtu"))
    return Path(path)


def write_npz(result, path: str | Path, fields: dict[str, np.ndarray] | None = None) -> Path:
    """Raw arrays: U (full dof vector), F, mesh p (x, s) and t, and the per-vertex fields."""
    sol = result.solution
    fields = vertex_fields(result) if fields is None else fields
    arrays: dict[str, np.ndarray] = {
        "U": sol.U,
        "F": sol.F,
        "p": sol.space.mesh.p,
        "t": sol.space.mesh.t,
        "radius": np.array(sol.shell.radius),
    }
    for k, v in fields.items():
        arrays.setdefault(k, np.asarray(v))
    c = _contact(result)
    if c is not None:
        for a in ("Lambda", "vertices", "omega", "G", "active"):
            v = getattr(c, a, None)
            if isinstance(v, np.ndarray):
                arrays.setdefault(f"contact_{a}", v)
    buf = _io.BytesIO()
    np.savez_compressed(buf, **arrays)
    atomic_write_bytes(path, buf.getvalue())
    return Path(path)


def write_outputs(
    result,
    directory: str | Path,
    summary: dict[str, Any] | None = None,
    *,
    figures: bool = True,
    report: bool = True,
    log: Callable[[str], None] | None = None,
    profile_x: float | None = None,
    profile_phi: float | None = None,
) -> dict[str, Path]:
    """Write the run directory: summary.json, fields.vtu, results.npz, PNG figures, report.html.

    ``profile_x``/``profile_phi`` (degrees) choose the pressure-profile lines.
    Returns the written files by name. ``summary`` defaults to ``result.summary()``; the time
    spent here is added to ``summary["timings"]["output"]`` (and ``total``).
    """
    import time

    t0 = time.perf_counter()
    directory = Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    summary = result.summary() if summary is None else summary
    written: dict[str, Path] = {}
    fields = vertex_fields(result)
    written["fields.vtu"] = write_vtu(result, directory / "fields.vtu", fields)
    written["results.npz"] = write_npz(result, directory / "results.npz", fields)
    pngs: dict[str, bytes] = {}
    if figures:
        from . import plots

        pngs = plots.run_figures(result, fields, profile_x, profile_phi)
        for name, data in pngs.items():
            atomic_write_bytes(directory / name, data)
            written[name] = directory / name
    timings = summary.setdefault("timings", {})
    timings["output"] = timings.get("output", 0.0) + time.perf_counter() - t0
    timings["total"] = timings.get("total", 0.0) + timings["output"]
    write_json(directory / "summary.json", summary)
    written["summary.json"] = directory / "summary.json"
    if report:
        from .report import write_report

        written["report.html"] = write_report(result, directory / "report.html", summary=summary, figures=pngs)
    if log:
        for name in written:
            log(f"wrote {directory / name}")
    return written
