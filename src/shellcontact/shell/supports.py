"""Edge supports and periodicity as one linear reduction U = P U_r (MODEL.md §4).

Only the Argyris dofs implied by a condition are constrained. On an edge x = const the
tangential direction is s: w = 0 along the edge kills w, w_s, w_ss; ∂w/∂n = w_x = 0 kills
w_x, w_xs and the edge-normal dofs; w_xx stays free (it carries the clamping moment).
On an edge φ = const the roles of x and s swap.
"""

from __future__ import annotations

import contextlib
from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp

from ..errors import InputError
from .geometry import rigid_motion
from .mesh import EDGES
from .spaces import ShellSpace

SUPPORTS = ("clamped", "simply_supported", "symmetry", "free", "periodic")

# (fields of u/v constrained, Argyris vertex kinds constrained, edge-normal dofs constrained)
_RULES = {
    # edge x = const: normal x, tangent s
    ("x", "clamped"): ("uv", ("w", "w_x", "w_s", "w_xs", "w_ss"), True),
    ("x", "simply_supported"): ("v", ("w", "w_s", "w_ss"), False),
    ("x", "symmetry"): ("u", ("w_x", "w_xs"), True),
    ("x", "free"): ("", (), False),
    # edge φ = const: normal s, tangent x
    ("s", "clamped"): ("uv", ("w", "w_x", "w_s", "w_xx", "w_xs"), True),
    ("s", "simply_supported"): ("u", ("w", "w_x", "w_xx"), False),
    ("s", "symmetry"): ("v", ("w_s", "w_xs"), True),
    ("s", "free"): ("", (), False),
}


@dataclass(frozen=True)
class Supports:
    x_min: str = "clamped"
    x_max: str = "clamped"
    phi_min: str = "clamped"
    phi_max: str = "clamped"

    def __post_init__(self) -> None:
        for edge in EDGES:
            value = getattr(self, edge)
            if value not in SUPPORTS:
                raise InputError(f"supports.{edge}", f"must be one of {', '.join(SUPPORTS)}, got {value!r}")
        for edge in ("x_min", "x_max"):
            if getattr(self, edge) == "periodic":
                raise InputError(f"supports.{edge}", "'periodic' applies to the phi edges of a full cylinder only")
        if (self.phi_min == "periodic") != (self.phi_max == "periodic"):
            raise InputError("supports.phi_min", "'periodic' must be given for both phi_min and phi_max")

    @property
    def periodic(self) -> bool:
        return self.phi_min == "periodic"


def edge_constrained_dofs(space: ShellSpace, supports: Supports) -> dict[str, np.ndarray]:
    """Dofs fixed to zero by each edge's condition (edges with "free" or "periodic" are left out)."""
    m = space.mesh
    out = {}
    for edge in EDGES:
        kind = getattr(supports, edge)
        if kind in ("periodic", "free"):
            continue
        fields, kinds, normal = _RULES[("x" if edge.startswith("x") else "s", kind)]
        verts, facets = m.edge_vertices(edge), m.edge_facets(edge)
        fixed = []
        if "u" in fields:
            fixed.append(space.u_dofs(verts, facets))
        if "v" in fields:
            fixed.append(space.v_dofs(verts, facets))
        if kinds:
            fixed.append(space.w_vertex_dofs(verts, kinds))
        if normal:
            fixed.append(space.w_facet_dofs(facets))
        out[edge] = np.unique(np.concatenate(fixed)) if fixed else np.empty(0, dtype=int)
    return out


def constrained_dofs(space: ShellSpace, supports: Supports) -> np.ndarray:
    """Dofs fixed to zero by the edge conditions."""
    fixed = list(edge_constrained_dofs(space, supports).values())
    return np.unique(np.concatenate(fixed)) if fixed else np.empty(0, dtype=int)


def periodic_pairs(space: ShellSpace) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(slave, master, sign) dof triples identifying φ = β with φ = α."""
    m = space.mesh
    if not m.shell.full:
        raise InputError("supports.phi_min", "'periodic' needs a full cylinder (shell.full = true)")
    lo, hi = m.edge_vertices("phi_min"), m.edge_vertices("phi_max")
    if lo.size != hi.size or not np.allclose(m.p[0, lo], m.p[0, hi], atol=m._tol()):
        raise InputError("mesh", "a periodic mesh needs matching vertices on phi_min and phi_max")
    flo, fhi = m.edge_facets("phi_min"), m.edge_facets("phi_max")
    f = m.mesh.facets
    key = lambda fs: np.sort(m.p[0, f[:, fs]].mean(axis=0))  # noqa: E731
    order_lo = np.argsort(m.p[0, f[:, flo]].mean(axis=0))
    order_hi = np.argsort(m.p[0, f[:, fhi]].mean(axis=0))
    flo, fhi = flo[order_lo], fhi[order_hi]
    if flo.size != fhi.size or not np.allclose(key(flo), key(fhi), atol=m._tol()):
        raise InputError("mesh", "a periodic mesh needs matching edges on phi_min and phi_max")
    normals = space.facet_normals()
    sign_f = np.sign(np.sum(normals[:, flo] * normals[:, fhi], axis=0))
    slaves = [
        space.u_dofs(hi, fhi),
        space.v_dofs(hi, fhi),
        space.w_vertex_dofs(hi, ("w", "w_x", "w_s", "w_xx", "w_xs", "w_ss")),
        space.w_facet_dofs(fhi),
    ]
    masters = [
        space.u_dofs(lo, flo),
        space.v_dofs(lo, flo),
        space.w_vertex_dofs(lo, ("w", "w_x", "w_s", "w_xx", "w_xs", "w_ss")),
        space.w_facet_dofs(flo),
    ]
    signs = [np.ones(s.size) for s in slaves[:3]] + [sign_f]
    return np.concatenate(slaves), np.concatenate(masters), np.concatenate(signs)


@dataclass
class Reduction:
    """U = P U_r: fixed dofs removed, periodic slaves expressed by their masters."""

    P: sp.csr_matrix
    fixed: np.ndarray
    free: np.ndarray  # full-vector dofs that are unknowns (one per column of P)

    motions: np.ndarray = field(default_factory=lambda: np.zeros((0, 6)))  # free rigid motions (rows, mode basis)
    gauge: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=int))  # dofs fixed by the gauge only
    #: (ndofs, 6) the interpolated rigid motions (``rigid_modes``), kept when some are free (floating.analyse)
    modes: np.ndarray | None = None

    @classmethod
    def build(cls, space: ShellSpace, supports: Supports, floating: bool = False) -> Reduction:
        """The reduction of ``supports``. Rigid motions they leave free are refused, unless ``floating``
        (a contact problem, where punches may hold the shell): then they are kept in ``motions`` and
        the gauge fixes one dof per free motion (``gauge_dofs``)."""
        n = space.ndofs
        master = np.arange(n)
        sign = np.ones(n)
        if supports.periodic:
            s, mst, sg = periodic_pairs(space)
            master[s], sign[s] = mst, sg
        fixed_mask = np.zeros(n, dtype=bool)
        fixed_mask[constrained_dofs(space, supports)] = True
        fixed_mask |= fixed_mask[master]  # a slave of a fixed master is fixed
        modes = rigid_modes(space)
        motions = free_motions(space, np.nonzero(fixed_mask)[0], modes=modes)
        gauge = np.zeros(0, dtype=int)
        if motions.size and not floating:
            raise InputError("supports", free_motion_message(motions, space.mesh.shell))
        if motions.size:
            gauge = gauge_dofs(space, motions, fixed_mask | (master != np.arange(n)), modes=modes)
            fixed_mask[gauge] = True
            fixed_mask |= fixed_mask[master]
        is_unknown = (master == np.arange(n)) & ~fixed_mask
        free = np.nonzero(is_unknown)[0]
        col = np.full(n, -1)
        col[free] = np.arange(free.size)
        keep = ~fixed_mask
        rows = np.nonzero(keep)[0]
        P = sp.csr_matrix((sign[keep], (rows, col[master[keep]])), shape=(n, free.size))
        fixed = np.nonzero(fixed_mask)[0]
        return cls(P=P, fixed=fixed, free=free, motions=motions, gauge=gauge, modes=modes if motions.size else None)

    def reduce_matrix(self, A: sp.spmatrix) -> sp.csr_matrix:
        """Pᵀ A P; without periodic slaves P only selects the free dofs, so slice instead."""
        if self.P.nnz == self.free.size:
            return sp.csr_matrix(A)[self.free][:, self.free]
        return (self.P.T @ A @ self.P).tocsr()

    def reduce_vector(self, F: np.ndarray) -> np.ndarray:
        return self.P.T @ F

    def expand(self, Ur: np.ndarray) -> np.ndarray:
        return self.P @ Ur


RIGID_MOTIONS = (
    "translation along x",
    "translation along y",
    "translation along z",
    "rotation about x",
    "rotation about y",
    "rotation about z",
)


def rigid_modes(space: ShellSpace) -> np.ndarray:
    """(ndofs, 6): the interpolated rigid motions in the order of ``RIGID_MOTIONS``; rotations by 1/a, so that
    every motion displaces the shell by about 1."""
    sh = space.mesh.shell
    cols = []
    for k in range(6):
        c, th = np.zeros(3), np.zeros(3)
        (c if k < 3 else th)[k % 3] = 1.0 if k < 3 else 1.0 / sh.radius
        cols.append(space.interpolate(rigid_motion(sh, c, th)))
    return np.array(cols).T


def free_motions(space: ShellSpace, fixed: np.ndarray, tol: float = 1e-8,
                 modes: np.ndarray | None = None) -> np.ndarray:
    """A basis (k, 6) of the combinations of the six rigid motions (MODEL.md §2) that satisfy every support:
    the null space of the interpolated motions restricted to the fixed dofs, in reduced row echelon form so
    that a motion free by itself appears alone (e.g. "translation along y"). ``modes``: ``rigid_modes(space)``
    when the caller has it."""
    R = rigid_modes(space) if modes is None else modes
    R = R[fixed] / np.linalg.norm(R, axis=0)
    if R.shape[0] == 0:
        return np.eye(6)
    sv, vt = right_singular(R)
    rank = int(np.sum((sv >= tol * max(sv[0], 1e-300)) & (sv >= tol)))
    return _echelon(vt[rank:])


def right_singular(M: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The singular values and all k right singular vectors (k × k) of M (rows × k), without the rows × rows
    left factor that ``full_matrices=True`` would build (16 350 contact rows: 2 GB and most of a minute)."""
    _, sv, vt = np.linalg.svd(M, full_matrices=M.shape[0] < M.shape[1])
    return sv, vt


def _echelon(N: np.ndarray) -> np.ndarray:
    """Reduced row echelon form of the rows of N (a basis of the same space), tiny entries zeroed. A pivot
    below 1e-6 of the largest entry is round-off (a roller's normal across its axis, 1e-9), not a component:
    dividing by it would give a basis of 1e15-sized combinations."""
    N = N.copy()
    tiny = 1e-6 * max(float(np.abs(N).max()) if N.size else 0.0, 1e-300)
    row = 0
    for col in range(N.shape[1]):
        if row == N.shape[0]:
            break
        piv = row + int(np.argmax(np.abs(N[row:, col])))
        if abs(N[piv, col]) < tiny:
            continue
        N[[row, piv]] = N[[piv, row]]
        N[row] /= N[row, col]
        for r in range(N.shape[0]):
            if r != row:
                N[r] -= N[r, col] * N[row]
        row += 1
    N[np.abs(N) < 1e-12] = 0.0
    return N


def gauge_dofs(space: ShellSpace, motions: np.ndarray, excluded: np.ndarray,
               modes: np.ndarray | None = None) -> np.ndarray:
    """One dof per free motion, fixed to zero in the elastic part so that the reduced stiffness is regular
    (a few fixed dofs remove the kernel, as for FETI's floating subdomains). Only tangential dofs (u, v at
    the vertices) are candidates, never w. On a mesh that is its own mirror image in x (``x_mirror``, with
    supports alike at both ends) only the vertices on the mirror plane are, when they can carry the gauge: a
    dof there is its own mirror image, so the gauge is mirror-invariant and mirror-image problems get the
    same answer to round-off (the interpolated rigid motions are not exactly stress-free in V_h, so the
    choice shifts the solution by their interpolation error, O(h⁴): a gauge at one end, x = −5 m, made the
    mirror saddles of examples/vessel_saddles.toml differ by 1.3e-6 in their interior force at 48 × 48).
    For each motion in turn (those the elements represent exactly, the translation along and the rotation
    about x, first): among the candidates where it moves at least half as much as where it moves most and
    that keep the chosen rows of the motions well conditioned (a smallest singular value at least half the
    best one), the one where it moves most (then the best conditioned, then the first in mesh order). Two
    dofs a row apart would leave the reduced stiffness nearly singular (the ring's rotation about x and
    translation along z told apart by v at φ = 0 and 0.94°: cos φ − 1 ≈ 1e-4 there). On a ring between
    plates the choice is v at φ = 0 (rotation about x), 90° or 270° (translation along y) and the vertex
    nearest 180° (translation along z). The choice splits the displacement into elastic and rigid parts
    only: the contact does not depend on it beyond that interpolation error (floating.py)."""
    if motions.size == 0:
        return np.zeros(0, dtype=int)
    # the motions P2 holds exactly (u = const, v = const) first: they move every vertex alike
    motions = motions[np.argsort(np.any(motions[:, [1, 2, 4, 5]] != 0.0, axis=1), kind="stable")]
    R = (rigid_modes(space) if modes is None else modes) @ motions.T  # (ndofs, k)
    v = np.arange(space.mesh.nvertices)
    plane = _mirror_plane_vertices(space, excluded)
    if plane.size:
        with contextlib.suppress(InputError):  # the plane's dofs cannot tell the motions apart: anywhere
            return _choose_gauge(space, R, excluded, plane)
    return _choose_gauge(space, R, excluded, v)


def _mirror_plane_vertices(space: ShellSpace, excluded: np.ndarray) -> np.ndarray:
    """The vertices on the mesh's mirror plane x = (x_min + x_max)/2 when the mesh and the ``excluded`` u, v
    dofs are mirror images of themselves (``ShellMesh.x_mirror``), else none."""
    perm = space.mesh.x_mirror()
    if perm is None:
        return np.zeros(0, dtype=int)
    v = np.arange(space.mesh.nvertices)
    for dofs in (space.u_dofs, space.v_dofs):
        if not np.array_equal(excluded[dofs(v)], excluded[dofs(perm)]):
            return np.zeros(0, dtype=int)
    return np.flatnonzero(perm == v)


def _choose_gauge(space: ShellSpace, R: np.ndarray, excluded: np.ndarray, vertices: np.ndarray) -> np.ndarray:
    """``gauge_dofs``' choice among the u, v dofs of ``vertices``: R (ndofs, k) the free motions, in order."""
    cand = np.concatenate([space.u_dofs(vertices), space.v_dofs(vertices)])
    cand = np.sort(cand[~excluded[cand]])
    R = R[cand]  # (candidates, k)
    scale = float(np.abs(R).max()) if R.size else 0.0
    if scale == 0.0:
        raise InputError("supports", "no tangential dof can carry the gauge of the free rigid motions")
    chosen: list[int] = []
    for j in range(R.shape[1]):
        size = np.abs(R[:, j])
        group = np.flatnonzero(size >= 0.5 * size.max()) if size.max() > 0.0 else np.zeros(0, dtype=int)
        rows = np.concatenate([np.broadcast_to(R[chosen, : j + 1], (group.size, len(chosen), j + 1)),
                               R[group, None, : j + 1]], axis=1)
        sv = np.round(np.linalg.svd(rows, compute_uv=False)[:, -1] / scale, 10) if group.size else np.zeros(0)
        if not sv.size or sv.max() <= 1e-6:
            raise InputError("supports", "no tangential dof can carry the gauge of the free rigid motions")
        # well conditioned (at least half the best), then where the motion moves most, then the best conditioned
        good = np.flatnonzero(sv >= 0.5 * sv.max())
        order = np.lexsort((good, -sv[good], -np.round(size[group[good]] / scale, 10)))
        chosen.append(int(group[good[order[0]]]))
    return np.sort(cand[chosen])


def describe_motion(coefficients: np.ndarray, radius: float) -> str:
    """A combination of the six rigid motions in words: "translation along z", or
    "translation along y + 0.5 x rotation about x (by 1/a)" for a mixture."""
    c = np.asarray(coefficients, float)
    c = c / np.max(np.abs(c))
    parts = [(RIGID_MOTIONS[i], ci) for i, ci in enumerate(c) if abs(ci) > 1e-3]
    if len(parts) == 1:
        return parts[0][0]
    return " + ".join(f"{ci:.3g} x {name}" for name, ci in parts) + f" (rotations by 1/a, a = {radius:g})"


#: how to remove each rigid motion with a support or a plane of symmetry
REMEDIES = (
    "a symmetry plane x = const (supports.x_min = 'symmetry') or a clamped end",
    "a symmetry plane y = 0 (model the half phi in [-90, 90] deg with phi edges 'symmetry')",
    "a symmetry plane z = 0 (model the half phi in [0, 180] deg with phi edges 'symmetry')",
    "a symmetry plane through the axis (phi edges 'symmetry') or supported phi edges",
    "a symmetry plane x = const (supports.x_min = 'symmetry') or supported ends",
    "a symmetry plane x = const (supports.x_min = 'symmetry') or supported ends",
)


def remedy(coefficients: np.ndarray) -> str:
    """The supports that remove a rigid motion (that of its largest component)."""
    return REMEDIES[int(np.argmax(np.abs(coefficients)))]


def free_motion_message(motions: np.ndarray, shell) -> str:
    names = "; ".join(describe_motion(m, shell.radius) for m in motions)
    if motions.shape[0] == 6:
        return f"no edge is supported: all six rigid-body motions are free ({names})"
    return (f"the supports leave {motions.shape[0]} rigid-body motion{'s' if motions.shape[0] > 1 else ''} free "
            f"({names}); clamp or support more edges, or add a symmetry plane; a shell held by contact "
            "alone needs punches that restrain these motions")


def check_rigid_motions(space: ShellSpace, fixed: np.ndarray, tol: float = 1e-8) -> None:
    """Raise if a combination of the six rigid motions (MODEL.md §2) satisfies every support, naming every
    free motion. Such a motion costs no energy, so the stiffness would be singular (coercivity (6.5) fails)."""
    motions = free_motions(space, fixed, tol)
    if motions.size:
        raise InputError("supports", free_motion_message(motions, space.mesh.shell))
