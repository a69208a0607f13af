"""Values on the mesh vertices of a ``Result``: displacements, resultants, contact arrays.

Pure functions of a result (no files, no figures); every writer and figure takes its per-vertex
arrays from here. The arrays are listed in docs/outputs.md.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from .results import SURFACES

#: per-vertex contact arrays, in the order they are written
CONTACT_FIELDS = ("contact_status", "contact_pressure", "gap", "contact_force", "contact_force_vector")
#: per-vertex friction arrays (only when a punch has friction or a slide)
FRICTION_FIELDS = ("friction_state", "friction_traction", "friction_slip")
#: the values of ``friction_state``
FRICTION_STATES = {-1: "no contact row", 0: "open", 1: "stick", 2: "slip"}


def contact_vertex_arrays(
    op, Lam: np.ndarray, spread: Callable[[np.ndarray], np.ndarray], active: np.ndarray | None = None,
    gap: np.ndarray | None = None, pressure: np.ndarray | None = None,
) -> dict[str, np.ndarray]:
    """Per-vertex contact arrays from a ``contact.ContactOperator`` and the row values of a solve.

    Rows of all punches are gathered on their mesh vertex: ``contact_status`` 1 if any row at the
    vertex is active, 0 if it is only a candidate, −1 if no row; ``contact_pressure`` = the punches'
    ``pressure`` (npunch, nv) summed (``contact.nodal_pressure``; without it the vertex rows' Λ/ω,
    ``op.vertex_pressure``, which zig-zags on a uniform load); ``gap`` = min over the rows of G + BU
    (NaN where no row) — these from the vertex rows; ``contact_force`` = Σ Λ_i and ``contact_force_vector``
    (nv, 3) = Σ Λ_i ∇Z(M_i) on the vertices' value dofs, ``spread`` (row values (m, …) → (npunch, nv, …):
    ``contact.nodal_pressure.on_vertices``, the vertex's rows plus half of each edge-midpoint row on its edges),
    summed over the punches, so that they sum to the punches' forces. On a full cylinder the φ = β copies take
    the values of their φ = α twins.
    """
    nv = int(op.nvertices)
    Lam = np.asarray(Lam, float)
    r = np.nonzero(np.asarray(op.vertex) >= 0)[0]
    v = np.asarray(op.vertex)[r]
    act = (op.active(Lam) if active is None else np.asarray(active, bool))[r]
    status = np.full(nv, -1, dtype=np.int64)
    np.maximum.at(status, v, act.astype(np.int64))
    force = spread(Lam).sum(axis=0)
    fvec = spread((np.asarray(op.grad) * Lam).T).sum(axis=0)
    out = {
        "contact_status": status,
        "contact_pressure": (np.asarray(op.vertex_pressure(Lam), float) if pressure is None
                             else np.asarray(pressure, float).sum(axis=0)),
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
    candidate, −1 not a candidate), ``contact_pressure`` (Pa, the nodal pressure, 0 off contact), ``gap``
    (G + BU, NaN off the candidate set), ``contact_force`` (nodal Λ_i), optionally
    ``contact_force_vector`` (nv, 3). ``contact_vertex_arrays(op, Lam, spread, active, gap, pressure)`` builds exactly
    these from a ContactOperator; it is used directly when the object has ``operator``,
    ``Lambda`` and ``on_vertices`` (and optionally ``active``, ``gap``, ``nodal_pressure``) attributes. Otherwise,
    attributes ``status``/``active``, ``pressure``, ``gap``, ``forces``/``Lambda`` are used, scattered
    to all vertices through ``vertices`` (candidate vertex indices) when they are shorter than nv.
    Missing fields are skipped, never invented.
    """
    c = getattr(result, "contact", None)
    if c is None:
        return {}
    nv = result.solution.space.mesh.nvertices
    if hasattr(c, "vertex_fields"):
        raw = dict(c.vertex_fields())
    elif all(getattr(c, a, None) is not None for a in ("operator", "Lambda", "on_vertices")):
        gap = getattr(c, "gap", None)
        gap = gap() if callable(gap) else gap
        return contact_vertex_arrays(c.operator, c.Lambda, c.on_vertices, getattr(c, "active", None), gap,
                                     getattr(c, "nodal_pressure", None))
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


def friction_vertex_fields(result) -> dict[str, np.ndarray]:
    """Per-vertex friction arrays of a result with friction (empty dict without): ``friction_state`` (−1 no
    row, 0 open, 1 stick, 2 slip: the largest over the vertex's rows), ``friction_traction`` (nv, 3; Pa: the
    tangential traction on the shell, the rows' forces T_i τ_i on the vertex's value dof over a unit pressure's, as
    ``contact_pressure``: |traction| ≤ μ × contact_pressure, = where all of it slips one way) and ``friction_slip``
    (nv, 3; m: the slip of the shell relative to the punch, σ_i1 τ_i1 + σ_i2 τ_i2, the total of a load path;
    vertex rows only). On a full cylinder the φ = β copies take their φ = α twins' values."""
    c = getattr(result, "contact", None)
    info = getattr(getattr(c, "solution", None), "info", None) or {}
    top = info.get("tangential")
    if top is None:
        return {}
    op = c.operator
    nv = int(op.nvertices)
    r = np.nonzero(np.asarray(op.vertex) >= 0)[0]
    v = np.asarray(op.vertex)[r]
    state = np.full(nv, -1, dtype=np.int64)
    np.maximum.at(state, v, top.states(info["T"], info["bounds"], c.Lambda)[r])
    slip = np.zeros((nv, 3))
    np.add.at(slip, v, top.vectors(info["slip"])[:, r].T)
    count = np.bincount(v, minlength=nv)
    loads, spread = getattr(c, "unit_loads", None), getattr(c, "on_vertices", None)
    if loads is None or spread is None:  # without the space: the vertex rows' weights (Σ ω_i)
        loads = np.zeros((1, nv))
        np.add.at(loads[0], v, np.asarray(op.weights)[r])
        force = np.zeros((1, nv, 3))
        np.add.at(force[0], v, top.vectors(info["T"])[:, r].T)
    else:  # the tangential forces on the value dofs over a unit pressure's, as contact_pressure
        force = spread(top.vectors(info["T"]).T)
    with np.errstate(divide="ignore", invalid="ignore"):
        traction = np.where(loads[:, :, None] > 0, force / np.where(loads > 0, loads, 1.0)[:, :, None], 0.0).sum(0)
        slip = np.where(count[:, None] > 0, slip / np.maximum(count, 1)[:, None], 0.0)
    out = {"friction_state": state, "friction_traction": traction, "friction_slip": slip}
    twins = getattr(op, "twins", None)
    if twins is not None:
        for arr in out.values():
            arr[twins[0]] = arr[twins[1]]
    return out


# -- fields on the vertices --------------------------------------------------------------------------
def surface_vertex_fields(sol, x: np.ndarray, phi: np.ndarray, values: dict, yield_stress: float | None = None
                          ) -> dict[str, np.ndarray]:
    """Strains and stresses on each surface (bottom, middle, top) at the points (x, φ): ``strain_<s>``
    (n, 3: ε11, ε22, γ12), ``stress_<s>`` (n, 3: σ11, σ22, σ12), ``von_mises_<s>``, ``principal_<s>``
    (n, 2: σ_1 ≥ σ_2), ``principal_angle_<s>`` (degrees from x) and, with a yield stress,
    ``utilisation_<s>`` = σ_v / yield_stress. ``values``: ``sol.evaluate(x, phi)``."""
    out: dict[str, np.ndarray] = {}
    for name in SURFACES:
        st = sol.surface(x, phi, name, values)
        out[f"strain_{name}"] = st.strain.T.copy()
        out[f"stress_{name}"] = st.stress.T.copy()
        out[f"von_mises_{name}"] = st.von_mises
        out[f"principal_{name}"] = st.principal.T.copy()
        out[f"principal_angle_{name}"] = st.principal_angle
        if yield_stress is not None:
            out[f"utilisation_{name}"] = st.von_mises / yield_stress
    return out


def vertex_fields(result) -> dict[str, np.ndarray]:
    """Arrays at the mesh vertices: x, phi_deg, u, v, w, displacement (nv, 3), deformed (nv, 3),
    resultants N11 … M12, strains and stresses on the three surfaces (``surface_vertex_fields``) and
    the contact fields when present."""
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
    out.update(surface_vertex_fields(sol, x, phi, d, result.case.yield_stress))
    out.update(contact_vertex_fields(result))
    out.update(friction_vertex_fields(result))
    return out


def reference_points(result) -> np.ndarray:
    sol = result.solution
    x, s = sol.space.mesh.p
    return sol.shell.point(x, s / sol.shell.radius).T.copy()
