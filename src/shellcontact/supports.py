"""Edge supports and periodicity as one linear reduction U = P U_r (MODEL.md §4).

Only the Argyris dofs implied by a condition are constrained. On an edge x = const the
tangential direction is s: w = 0 along the edge kills w, w_s, w_ss; ∂w/∂n = w_x = 0 kills
w_x, w_xs and the edge-normal dofs; w_xx stays free (it carries the clamping moment).
On an edge φ = const the roles of x and s swap.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from .errors import InputError
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

    @classmethod
    def build(cls, space: ShellSpace, supports: Supports) -> Reduction:
        n = space.ndofs
        master = np.arange(n)
        sign = np.ones(n)
        if supports.periodic:
            s, mst, sg = periodic_pairs(space)
            master[s], sign[s] = mst, sg
        fixed_mask = np.zeros(n, dtype=bool)
        fixed_mask[constrained_dofs(space, supports)] = True
        fixed_mask |= fixed_mask[master]  # a slave of a fixed master is fixed
        is_unknown = (master == np.arange(n)) & ~fixed_mask
        free = np.nonzero(is_unknown)[0]
        col = np.full(n, -1)
        col[free] = np.arange(free.size)
        keep = ~fixed_mask
        rows = np.nonzero(keep)[0]
        P = sp.csr_matrix((sign[keep], (rows, col[master[keep]])), shape=(n, free.size))
        fixed = np.nonzero(fixed_mask)[0]
        check_rigid_motions(space, fixed)
        return cls(P=P, fixed=fixed, free=free)

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


def check_rigid_motions(space: ShellSpace, fixed: np.ndarray, tol: float = 1e-8) -> None:
    """Raise if a combination of the six rigid motions (MODEL.md §2) satisfies every support.

    Such a motion costs no energy, so the stiffness would be singular (coercivity (6.5) fails).
    """
    sh = space.mesh.shell
    cols = []
    for k in range(6):
        c, th = np.zeros(3), np.zeros(3)
        (c if k < 3 else th)[k % 3] = 1.0 if k < 3 else 1.0 / sh.radius
        r = space.interpolate(rigid_motion(sh, c, th))
        cols.append(r[fixed] / np.linalg.norm(r))
    R = np.array(cols).T
    if R.shape[0] == 0:
        raise InputError("supports", "no edge is supported: all six rigid-body motions are free")
    _, sv, vt = np.linalg.svd(R, full_matrices=False)
    if sv[-1] < tol * max(sv[0], 1e-300) or sv[-1] < tol:
        combo = vt[-1]
        names = [f"{c:+.2g} x {RIGID_MOTIONS[i]}" for i, c in enumerate(combo) if abs(c) > 1e-3]
        raise InputError(
            "supports",
            "the supports leave a rigid-body motion free (" + ", ".join(names) + "); "
            "clamp or support more edges, or add a symmetry plane",
        )
