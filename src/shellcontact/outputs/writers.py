"""A result's vertex fields as files: ``fields.vtu`` (ParaView, via meshio) and ``results.npz`` (raw arrays)."""

from __future__ import annotations

import io as _io
from pathlib import Path

import numpy as np

from .fields import reference_points, vertex_fields
from .files import atomic_write_bytes, atomic_write_with


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
    c = getattr(result, "contact", None)
    if c is not None:
        for a in ("Lambda", "vertices", "omega", "G", "active"):
            v = getattr(c, a, None)
            if isinstance(v, np.ndarray):
                arrays.setdefault(f"contact_{a}", v)
    buf = _io.BytesIO()
    np.savez_compressed(buf, **arrays)
    atomic_write_bytes(path, buf.getvalue())
    return Path(path)
