"""The discrete contact operator B, gap G and weights ω (MODEL.md §5, §7 (8.6), §8).

For every punch and every constraint point a_i = (x_i, φ_i) of its candidate zone, the contact
point is M_i = Φ(x_i, φ_i) + ζ_c n(φ_i) with ζ_c = ±t/2 (outer/inner surface). The displacement
of M_i follows the Kirchhoff hypothesis (MODEL.md (4.9), written in the (x, s) chart, s = a φ):

    U(M) = (u − ζ w_x) e1 + (v (1 + ζ/a) − ζ w_s) e2 + w n,      w_s = (1/a) ∂w/∂φ,

so row i of B is ∇Z(M_i)·U(M_i): at a mesh vertex at most five entries (u, v, w, w_x, w_s of
the vertex). G_i = Z(M_i) of the placed punch (interference/indentation included), and the
linearised gap (MODEL.md §5) is Π = G + B U (+ D δ for force-controlled punches, with
D_ij = −∇Z(M_i)·d_j for the rows of force-controlled punch j and δ_j its unknown travel; the
energy then gains −Σ_j P_j δ_j).

A punch of finite extent (``Punch.extent``) constrains only the points opposite its body
(``Punch.on_body``): the vertices of the zone that face it (with the mesh tolerance, so the body's
edge counts) and the triangles whose centroid does; Ω_c below is then the part of the zone the body faces.

Weights: ω_i = ∫_{Ω_c,h} ψ_i dΩ (dΩ = dx ds, the mid-surface area), ψ_i the P1 hat function,
Ω_c,h the union of the triangles whose centroid lies in the zone Ω_c — i.e. row sums of the
lumped P1 surface mass matrix over the zone. When the zone edges are node lines (fitted_lines)
Ω_c,h = Ω_c and Σ ω_i = |Ω_c|. The rows are the vertices in the closed zone and the vertices of
the triangles of Ω_c,h. On a full cylinder the vertices on φ = β are the periodic images of those
on φ = α: their rows are merged into the φ = α ones (weights added), so no constraint appears twice.

Option ``points="vertices+midpoints"`` also constrains the edge midpoints of Ω_c,h (rows from
ShellSpace.point_operators; weights from P1 on the red-refined triangulation: |T|/12 to each
vertex and |T|/4 to each edge midpoint of a zone triangle).

API::

    op = contact_operator(space, punches)          # ContactOperator, B over the full dof vector
    Br = op.B @ reduction.P                        # reduced by the lead
    op.gap(U, delta), op.resultant(Lam), op.moment(Lam), op.total_normal_force(Lam),
    op.contact_area(active), op.pressure(Lam), op.vertex_pressure(Lam), op.summary(Lam, delta=...)
    op.blocked_rows(reduction.P)                   # violated rows no displacement can open (empty K)
    penetration_outside(space, punches, U, delta)  # after a solve: does contact leave the zones?

Multipliers Λ_i ≥ 0 are nodal forces (MODEL.md §8); with signed-distance Z they are in force
units, the pressure at row i is Λ_i/ω_i and the force of punch k on the shell is Σ Λ_i ∇Z_i.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp

from ..errors import InputError
from ..shell.geometry import frame
from ..shell.spaces import ShellSpace
from .punches import Punch
from .zone_points import ROUND_OFF_GAP, fill_idle_rows, nearest_point_class

POINTS = ("vertices", "vertices+midpoints")


@dataclass
class ContactOperator:
    """Constraint rows of all punches, stacked punch by punch (rows of punch k: ``rows(k)``)."""

    B: sp.csr_matrix  # (m, ndofs), full dof vector
    G: np.ndarray  # (m,) Z(M_i)
    weights: np.ndarray  # (m,) ω_i
    grad: np.ndarray  # (3, m) ∇Z(M_i)
    points: np.ndarray  # (3, m) M_i
    x: np.ndarray  # (m,) parameter coordinates of the rows
    phi: np.ndarray  # (m,) radians
    zeta: np.ndarray  # (m,) ζ_c
    vertex: np.ndarray  # (m,) mesh vertex of the row, −1 for an edge-midpoint row
    facet: np.ndarray  # (m,) mesh facet of an edge-midpoint row, −1 for a vertex row
    punch: np.ndarray  # (m,) punch index of the row
    punches: list[Punch]
    D: np.ndarray | None = None  # (m, k) force-control columns, k = len(force_punches)
    force_punches: list[int] = field(default_factory=list)  # punch indices with force control
    forces: np.ndarray = field(default_factory=lambda: np.zeros(0))  # (k,) prescribed forces P_j
    nvertices: int = 0
    twins: tuple[np.ndarray, np.ndarray] | None = None  # full cylinder: (vertices on φ = β, twins on φ = α)
    ends: np.ndarray | None = None  # (2, m) the two vertices of an edge-midpoint row's edge, −1 for a vertex row

    # -- sizes and slicing ------------------------------------------------------------------
    @property
    def m(self) -> int:
        return int(self.G.size)

    def rows(self, k: int) -> np.ndarray:
        """Row indices of punch k."""
        return np.nonzero(self.punch == k)[0]

    # -- gap -----------------------------------------------------------------------------------
    def gap(self, U: np.ndarray, delta: np.ndarray | None = None) -> np.ndarray:
        """Linearised gap Π = G + B U + D δ at every row (U the full dof vector)."""
        out = self.G + self.B @ U
        if self.D is not None:
            if delta is None:
                raise ValueError("force-controlled punches need their travel delta")
            out = out + self.D @ np.asarray(delta, float)
        return out

    def blocked_rows(self, P: sp.spmatrix | None = None, rtol: float = 1e-12) -> np.ndarray:
        """Rows violated (G_i < 0) that no admissible displacement can open: B_i P = 0 (and D_i = 0).

        E.g. a punch overlapping a clamped edge. Non-empty ⇒ the admissible set is empty.
        """
        Br = self.B if P is None else (self.B @ P).tocsr()
        scale = np.abs(self.B).max(axis=1).toarray().ravel() if self.m else np.zeros(0)
        rowmax = np.abs(Br).max(axis=1).toarray().ravel() if self.m else np.zeros(0)
        movable = rowmax > rtol * np.maximum(scale, 1e-300)
        if self.D is not None:
            movable |= np.any(self.D != 0.0, axis=1)
        return np.nonzero((self.G < 0.0) & ~movable)[0]

    # -- results ---------------------------------------------------------------------------
    def _per_punch(self, values: np.ndarray) -> np.ndarray:
        """Sum row values (…, m) per punch → (…, npunch)."""
        values = np.asarray(values, float)
        out = np.zeros(values.shape[:-1] + (len(self.punches),))
        for k in range(len(self.punches)):
            out[..., k] = values[..., self.punch == k].sum(axis=-1)
        return out

    def resultant(self, Lam: np.ndarray) -> np.ndarray:
        """Force of each punch on the shell, Σ Λ_i ∇Z(M_i): shape (npunch, 3)."""
        return self._per_punch(self.grad * Lam).T

    def moment(self, Lam: np.ndarray, about: np.ndarray | None = None) -> np.ndarray:
        """Moment of each punch's contact forces about its (placed) centre, or ``about`` (3,): (npunch, 3)."""
        out = np.zeros((len(self.punches), 3))
        F = self.grad * Lam
        for k, p in enumerate(self.punches):
            r = self.rows(k)
            c = np.asarray(p.center if about is None else about, float)
            out[k] = np.cross((self.points[:, r] - c[:, None]).T, F[:, r].T).sum(axis=0)
        return out

    def total_normal_force(self, Lam: np.ndarray) -> np.ndarray:
        """Σ Λ_i |∇Z_i| per punch (meaningful also for a ring whose resultant vanishes)."""
        return self._per_punch(np.linalg.norm(self.grad, axis=0) * Lam)

    def contact_area(self, active: np.ndarray) -> np.ndarray:
        """Σ ω_i over the active rows, per punch."""
        return self._per_punch(np.where(np.asarray(active, bool), self.weights, 0.0))

    def pressure(self, Lam: np.ndarray) -> np.ndarray:
        """Λ_i/ω_i (NaN at a row of zero weight)."""
        Lam = np.asarray(Lam, float)
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.where(self.weights > 0, Lam / np.where(self.weights > 0, self.weights, 1.0), np.nan)

    def vertex_pressure(self, Lam: np.ndarray) -> np.ndarray:
        """Contact pressure at every mesh vertex (sum over punches, 0 off the zones), for plotting.

        Vertex rows only; on a full cylinder the φ = β copies get the value of their φ = α twin.
        """
        out = np.zeros(self.nvertices)
        r = self.vertex >= 0
        Lam = np.asarray(Lam, float)
        np.add.at(out, self.vertex[r], Lam[r])
        wsum = np.zeros(self.nvertices)
        np.add.at(wsum, self.vertex[r], self.weights[r])
        with np.errstate(divide="ignore", invalid="ignore"):
            p = np.where(wsum > 0, out / np.where(wsum > 0, wsum, 1.0), 0.0)
        if self.twins is not None:
            slave, master = self.twins
            p[slave] = p[master]
        return p

    def active(self, Lam: np.ndarray, rtol: float = 1e-10) -> np.ndarray:
        """Rows with Λ_i > rtol·max Λ."""
        Lam = np.asarray(Lam, float)
        scale = float(np.max(np.abs(Lam))) if Lam.size else 0.0
        return Lam > rtol * scale if scale > 0 else np.zeros(Lam.shape, bool)

    def summary(self, Lam: np.ndarray, active: np.ndarray | None = None, delta: np.ndarray | None = None) -> list[dict]:
        """One dict per punch, the ``contact`` entry of summary.json (issue 3)."""
        Lam = np.asarray(Lam, float)
        active = self.active(Lam) if active is None else np.asarray(active, bool)
        F = self.resultant(Lam)
        N = self.total_normal_force(Lam)
        A = self.contact_area(active)
        M = self.moment(Lam)
        pr = self.pressure(Lam)
        out = []
        for k, p in enumerate(self.punches):
            r = self.rows(k)
            pk = pr[r][active[r]]
            pk = pk[np.isfinite(pk)]
            if p.mode == "force":
                j = self.force_punches.index(k)
                travel = float(np.asarray(delta, float)[j]) if delta is not None else float("nan")
            elif p.mode == "indentation":
                travel = float(p.indentation)
            else:
                travel = 0.0
            out.append(
                {
                    "shape": p.shape,
                    "side": p.side,
                    "mode": p.mode,
                    "constraints": int(r.size),
                    "active_vertices": int(np.count_nonzero(active[r] & (self.vertex[r] >= 0))),
                    "active_points": int(np.count_nonzero(active[r])),
                    "area": float(A[k]),
                    "force": [float(c) for c in F[k]],
                    "force_magnitude": float(np.linalg.norm(F[k])),
                    "total_normal_force": float(N[k]),
                    "moment": [float(c) for c in M[k]],
                    "peak_pressure": float(pk.max()) if pk.size else 0.0,
                    "punch_travel": travel,
                }
            )
        return out


def _seam_twins(space: ShellSpace) -> tuple[np.ndarray, np.ndarray] | None:
    """(vertices on φ = β, their twins on φ = α) for a full cylinder, else None."""
    m = space.mesh
    if not m.shell.full:
        return None
    lo, hi = m.edge_vertices("phi_min"), m.edge_vertices("phi_max")
    if lo.size != hi.size or not np.allclose(m.p[0, lo], m.p[0, hi], atol=m._tol()):
        raise InputError("mesh", "a full cylinder needs matching vertices on phi_min and phi_max")
    return hi, lo


def facing_body(space: ShellSpace, punch: Punch, x: np.ndarray, s: np.ndarray, tol: float = 0.0) -> np.ndarray:
    """Contact-surface points at (x, s) opposite a punch of finite extent (all True for an unbounded one)."""
    sh = space.mesh.shell
    if punch.extent is None:
        return np.ones(np.shape(x), dtype=bool)
    phi = s / sh.radius
    return punch.on_body(sh.point(x, phi, punch.zeta(sh, x, phi)), tol)


def _zone_elements(space: ShellSpace, punch: Punch) -> np.ndarray:
    m = space.mesh
    c = m.p[:, m.t].mean(axis=1)
    return np.nonzero(punch.zone.contains(c[0], c[1] / m.shell.radius) & facing_body(space, punch, c[0], c[1]))[0]


def _vertex_rows(space: ShellSpace, punch: Punch, twins) -> tuple[np.ndarray, np.ndarray]:
    """Vertices and weights ω_i of one punch (after merging periodic twins)."""
    m = space.mesh
    nv = m.nvertices
    elems = _zone_elements(space, punch)
    area = 0.5 * np.abs(m._det()[elems])
    w = np.zeros(nv)
    np.add.at(w, m.t[:, elems].ravel(), np.repeat(area[None, :] / 3.0, 3, axis=0).ravel())
    in_zone = punch.zone.contains(m.p[0], m.p[1] / m.shell.radius, tol=m._tol())
    in_zone &= facing_body(space, punch, m.p[0], m.p[1], tol=m._tol())
    in_zone[m.t[:, elems].ravel()] = True
    if twins is not None:
        slave, master = twins
        in_zone[master] |= in_zone[slave]
        in_zone[slave] = False
        w[master] += w[slave]
        w[slave] = 0.0
    if punch.extent is not None:  # a vertex that touches the body's part of the zone only at a point bears nothing
        in_zone &= w > 0.0
    verts = np.nonzero(in_zone)[0]
    return verts, w[verts]


def _midpoint_rows(space: ShellSpace, punch: Punch, twins) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Facets (edge midpoints) of the zone triangles with weights, and vertex weights |T|/12."""
    m = space.mesh
    elems = _zone_elements(space, punch)
    area = 0.5 * np.abs(m._det()[elems])
    wf = np.zeros(space.nf)
    np.add.at(wf, m.mesh.t2f[:, elems].ravel(), np.repeat(area[None, :] / 4.0, 3, axis=0).ravel())
    wv = np.zeros(m.nvertices)
    np.add.at(wv, m.t[:, elems].ravel(), np.repeat(area[None, :] / 12.0, 3, axis=0).ravel())
    if twins is not None:
        fhi, flo = m.edge_facets("phi_max"), m.edge_facets("phi_min")
        f = m.mesh.facets
        flo = flo[np.argsort(m.p[0, f[:, flo]].mean(axis=0))]
        fhi = fhi[np.argsort(m.p[0, f[:, fhi]].mean(axis=0))]
        wf[flo] += wf[fhi]
        wf[fhi] = 0.0
        slave, master = twins
        wv[master] += wv[slave]
        wv[slave] = 0.0
    facets = np.nonzero(wf > 0)[0]
    return facets, wf[facets], wv


def contact_operator(space: ShellSpace, punches: Sequence[Punch], points: str = "vertices") -> ContactOperator:
    """The contact operator of all punches on ``space`` (see the module docstring)."""
    if points not in POINTS:
        raise InputError("solver.contact_points", f"must be one of {', '.join(POINTS)}, got {points!r}")
    m = space.mesh
    sh = m.shell
    a = sh.radius
    twins = _seam_twins(space)
    blocks: dict[str, list[np.ndarray]] = {k: [] for k in ("x", "s", "w", "vert", "fac", "pun")}
    for k, p in enumerate(punches):
        verts, wv = _vertex_rows(space, p, twins)
        if points == "vertices+midpoints":
            facets, wf, wv_all = _midpoint_rows(space, p, twins)
            wv = wv_all[verts]
            mid = 0.5 * (m.p[:, m.mesh.facets[0, facets]] + m.p[:, m.mesh.facets[1, facets]])
        else:
            facets, wf, mid = np.zeros(0, int), np.zeros(0), np.zeros((2, 0))
        if verts.size == 0:
            raise InputError(
                f"{p.where}.zone", f"contains no mesh vertex ({p.zone.describe()}); refine the mesh or widen the zone"
            )
        blocks["x"] += [m.p[0, verts], mid[0]]
        blocks["s"] += [m.p[1, verts], mid[1]]
        blocks["w"] += [wv, wf]
        blocks["vert"] += [verts, -np.ones(facets.size, int)]
        blocks["fac"] += [-np.ones(verts.size, int), facets]
        blocks["pun"] += [np.full(verts.size + facets.size, k)]
    x, s = np.concatenate(blocks["x"]), np.concatenate(blocks["s"])
    weights = np.concatenate(blocks["w"])
    vertex, facet = np.concatenate(blocks["vert"]), np.concatenate(blocks["fac"])
    punch = np.concatenate(blocks["pun"]).astype(int)
    phi = s / a
    M = np.empty((3, x.size))
    zeta = np.empty(x.size)
    G = np.empty(x.size)
    grad = np.empty((3, x.size))
    for k, p in enumerate(punches):
        r = punch == k
        zeta[r] = p.zeta(sh, x[r], phi[r])
        M[:, r] = sh.point(x[r], phi[r], zeta[r])
        G[r], grad[:, r] = p.Z(M[:, r])
    if not (np.all(np.isfinite(G)) and np.all(np.isfinite(grad))):
        bad = int(np.nonzero(~(np.isfinite(G) & np.all(np.isfinite(grad), axis=0)))[0][0])
        raise InputError(f"punch.{punch[bad]}", "Z or its gradient is not finite at a contact point")
    B = surface_rows(space, x, s, zeta, vertex, grad)
    force_punches = [k for k, p in enumerate(punches) if p.force_controlled]
    D = None
    if force_punches:
        D = np.zeros((x.size, len(force_punches)))
        for j, k in enumerate(force_punches):
            r = punch == k
            D[r, j] = -(punches[k].direction @ grad[:, r])
    return ContactOperator(
        B=B,
        G=G,
        weights=weights,
        grad=grad,
        points=M,
        x=x,
        phi=phi,
        zeta=zeta,
        vertex=vertex,
        facet=facet,
        punch=punch,
        punches=list(punches),
        D=D,
        force_punches=force_punches,
        forces=np.array([punches[k].force for k in force_punches], dtype=float),
        nvertices=m.nvertices,
        twins=twins,
        ends=np.where(facet >= 0, m.mesh.facets[:, np.maximum(facet, 0)], -1),
    )


def surface_rows(space: ShellSpace, x: np.ndarray, s: np.ndarray, zeta: np.ndarray, vertex: np.ndarray,
                 directions: np.ndarray) -> sp.csr_matrix:
    """Rows (m, ndofs) giving directions[:, i]·U(M_i), U(M) the Kirchhoff displacement of the face point
    M_i = Φ(x_i, s_i/a) + ζ_i n (MODEL.md §5, (4.9)): five entries at a vertex row (vertex ≥ 0), the
    interpolation operators at an edge-midpoint row. B is these rows with directions ∇Z(M_i); friction's
    tangential rows (``friction``) are them with the punch's tangent vectors."""
    a = space.mesh.shell.radius
    e1, e2, n = frame(s / a)
    g1, g2, gn = (np.sum(directions * e, axis=0) for e in (e1, e2, n))
    cu, cv, cw, cwx, cws = g1, g2 * (1.0 + zeta / a), gn, -zeta * g1, -zeta * g2
    isv = vertex >= 0
    rv = np.nonzero(isv)[0]
    vv = vertex[rv]
    wd = space.w_vertex_dofs(vv, ("w", "w_x", "w_s")).reshape(-1, 3)
    cols = np.concatenate([space.u_dofs(vv), space.v_dofs(vv), wd[:, 0], wd[:, 1], wd[:, 2]])
    vals = np.concatenate([cu[rv], cv[rv], cw[rv], cwx[rv], cws[rv]])
    rows = np.tile(rv, 5)
    B = sp.csr_matrix((vals, (rows, cols)), shape=(x.size, space.ndofs))
    rf = np.nonzero(~isv)[0]
    if rf.size:
        E = space.point_operators(x[rf], s[rf], ("u", "v", "w", "w_x", "w_s"))
        Bf = (
            sp.diags(cu[rf]) @ E["u"]
            + sp.diags(cv[rf]) @ E["v"]
            + sp.diags(cw[rf]) @ E["w"]
            + sp.diags(cwx[rf]) @ E["w_x"]
            + sp.diags(cws[rf]) @ E["w_s"]
        )
        sel = sp.csr_matrix((np.ones(rf.size), (rf, np.arange(rf.size))), shape=(x.size, rf.size))
        B = (B + sel @ Bf).tocsr()
    B.eliminate_zeros()
    return B


def point_flexibility(shell, x: np.ndarray, phi: np.ndarray) -> np.ndarray:
    """An estimate of the shell's normal deflection under a unit normal point force at (x, φ) (m/N):
    1/(8√(kD)), the point load on a plate of bending stiffness D on an elastic foundation k = E₂t/a² (the
    hoop membrane of a cylinder). It only weighs the border of a bordered factorisation
    (``linalg.bordered``: ρ·S_ii near 1 keeps S to ~5e-10, where the mesh-dependent default loses digits
    as ρ·S_ii grows); measured B A⁻¹ Bᵀ / estimate: 2.2 on the paper panel, 9 on a ring between plates."""
    t = shell.t(np.asarray(x, float), np.asarray(phi, float))
    k = shell.material.hoop_modulus * t / shell.radius**2
    return 1.0 / (8.0 * np.sqrt(k * shell.material.bending_scale(t)))


def row_flexibility(shell, op: ContactOperator) -> np.ndarray:
    """Per contact row, an estimate of S_ii = B_i A⁻¹ B_iᵀ: |∇Z(M_i)|² × ``point_flexibility`` (row i
    measures the displacement along ∇Z)."""
    return np.sum(op.grad**2, axis=0) * point_flexibility(shell, op.x, op.phi)


def penetration_outside(
    space: ShellSpace, punches: Sequence[Punch], U: np.ndarray, delta: np.ndarray | None = None
) -> np.ndarray:
    """Largest penetration [Π]₋ at the mesh vertices OUTSIDE each punch's candidate zone, (npunch,).

    A check after a solve: a positive value means the contact would extend beyond Ω_c (e.g. an
    automatic zone of a force-controlled punch that travelled far), so the zone must be widened.
    """
    from dataclasses import replace

    from .punches import Zone

    sh = space.mesh.shell
    whole = Zone((sh.x_min, sh.x_max), ((sh.alpha, sh.beta),))
    everywhere = [replace(p, zone=whole) for p in punches]
    op = contact_operator(space, everywhere)
    gap = op.G + op.B @ U
    if op.D is not None:
        if delta is None:
            raise ValueError("force-controlled punches need their travel delta")
        gap = gap + op.D @ np.asarray(delta, float)
    out = np.zeros(len(punches))
    for k, p in enumerate(punches):
        r = op.rows(k)
        outside = ~p.zone.contains(op.x[r], op.phi[r], tol=space.mesh._tol())
        if np.any(outside):
            out[k] = max(0.0, float(-np.min(gap[r][outside])))
    return out


#: the gap below which a point counts as touching, relative to the punch's travel (``contact_zone``)
ZONE_GAP = 1e-3


#: the fields the linearised gap needs at a point
GAP_QUANTITIES = ("u", "v", "w", "w_x", "w_s")


def linearised_gap(shell, punch: Punch, x: np.ndarray, phi: np.ndarray, fields: dict[str, np.ndarray],
                   step: float = 0.0) -> np.ndarray:
    """Π = Z(M) + ∇Z·U(M) − δ ∇Z·d at middle-surface points (x, φ) (MODEL.md §5), from the values of
    GAP_QUANTITIES there; ``step`` is a force-controlled punch's travel δ."""
    from ..shell.geometry import to_global

    a = shell.radius
    zeta = punch.zeta(shell, x, phi)
    Z, g = punch.Z(shell.point(x, phi, zeta))
    local = np.stack([fields["u"] - zeta * fields["w_x"], fields["v"] * (1.0 + zeta / a) - zeta * fields["w_s"],
                      fields["w"]])
    gap = Z + np.sum(g * to_global(local, phi), axis=0)
    if step:
        gap -= step * (punch.direction @ g)
    return gap


def zone_tolerance(punch: Punch, step: float | None = None, rel_gap: float = ZONE_GAP) -> float:
    """The gap below which a point counts as touching: ``rel_gap`` × the punch's travel (its indentation,
    its force-control travel δ = ``step``, or else its overlap)."""
    if punch.mode == "force" and step is not None:
        travel = abs(step)
    else:
        travel = punch.indentation if punch.mode == "indentation" else punch.overlap
    return rel_gap * travel


def contact_zone(space: ShellSpace, punches: Sequence[Punch], U: np.ndarray, delta: np.ndarray | None = None,
                 rel_gap: float = ZONE_GAP, order: int = 10,
                 carrying: tuple[ContactOperator, np.ndarray, np.ndarray] | None = None) -> list[dict]:
    """Where each punch touches, as quantities that converge under refinement.

    The linearised gap Π = Z(M) + ∇Z·U(M) (− δ ∇Z·d under force control; MODEL.md §5) is evaluated at
    the quadrature points of the candidate zone's triangles, and a point counts as touching where
    Π ≤ ``rel_gap`` × the punch's travel (its indentation, its force-control travel δ, or else its
    overlap; for a fixed punch that only touches, the largest displacement toward it in its zone). A fixed
    punch's points are classified by their nearest constraint point instead when ``carrying`` = (the operator,
    Λ, the gap at its rows) is given: it touches when it carries force or its gap is at round-off,
    ``ROUND_OFF_GAP`` × that motion (zone_points.py: between the points the gap is an interpolation with no
    gap in its distribution, and points that carry nothing hover down to 10 nm above the punch), or when it is
    within one element between touching ones (``fill_idle_rows``: below the mesh's resolution).
    Returns per punch ``area`` (of the middle surface), ``x`` = [x0, x1] and ``phi`` = [φ0, φ1]
    (degrees) of the touching points, and the ``gap_tolerance`` used. Unlike the weights of the active
    constraint points — which shrink with h when a Kirchhoff shell carries the load in a line force at
    the rim while the inside of the zone lifts off by a fraction of a micrometre — these converge.
    """
    from ..shell.model import field_derivatives

    sh = space.mesh.shell
    a = sh.radius
    X, W = space.quadrature(order)
    out = []
    forced = [k for k, p in enumerate(punches) if p.mode == "force"]
    for k, p in enumerate(punches):
        els = _zone_elements(space, p)
        x, s, det = space.reference_to_physical(els, X)
        d = field_derivatives(space, U, els, X, GAP_QUANTITIES)
        x, phi = x.ravel(), (s / a).ravel()
        step = float(np.asarray(delta, float)[forced.index(k)]) if p.mode == "force" and delta is not None else None
        gap = linearised_gap(sh, p, x, phi, {q: d[q].ravel() for q in GAP_QUANTITIES}, step or 0.0)
        tol = zone_tolerance(p, step, rel_gap)
        inside = p.zone.contains(x, phi) & facing_body(space, p, x, s.ravel())
        fixed = tol == 0.0 and bool(inside.any())
        if fixed:  # a fixed punch just touching: no travel, scale by the motion toward it
            Z, _ = p.Z(sh.point(x, phi, p.zeta(sh, x, phi)))
            tol = rel_gap * float(np.max(np.abs(gap - Z)[inside]))
        if fixed and carrying is not None:  # contact = carrying force, or a gap at round-off (zone_points.py)
            op, lam, row_gap = carrying
            rows, tol = op.rows(k), tol * ROUND_OFF_GAP / ZONE_GAP
            period = 2.0 * np.pi * a if sh.full else None
            rows_touching = fill_idle_rows(space, op.x[rows], a * op.phi[rows],
                                           (lam[rows] > 0.0) | (row_gap[rows] <= tol), period)
            touching = inside & nearest_point_class(x, s.ravel(), op.x[rows], a * op.phi[rows], rows_touching,
                                                    period)
        else:
            touching = (gap <= tol) & inside
        area = float(((np.abs(det)[:, None] * W[None, :]).ravel())[touching].sum())
        entry: dict = {"area": area, "gap_tolerance": float(tol)}
        if touching.any():
            entry["x"] = [float(x[touching].min()), float(x[touching].max())]
            entry["phi"] = [float(np.degrees(phi[touching].min())), float(np.degrees(phi[touching].max()))]
        out.append(entry)
    return out
