"""The discrete space V_h = P2 × P2 × Argyris on one mesh (MODEL.md §7, (8.5)).

Global vector layout U = [u (P2) | v (P2) | w (Argyris)]. P2 dofs: vertex i → i, facet f →
nv + f (scikit-fem's order). Argyris dofs: vertex i, kind k → 6 i + k with k ∈ (w, w_x,
w_s, w_xx, w_xs, w_ss), facet f → 6 nv + f (normal derivative). All derivatives are with
respect to the arc-length chart (x, s).
"""

from __future__ import annotations

import hashlib
import threading
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import scipy.sparse as sp
from skfem import ElementTriP2
from skfem.quadrature import get_quadrature
from skfem.refdom import RefTri

from ..errors import InputError
from .argyris import ArgyrisBasis, edge_normals
from .mesh import ShellMesh

W_KINDS = ("w", "w_x", "w_s", "w_xx", "w_xs", "w_ss")
QUANTITIES = ("u", "u_x", "u_s", "v", "v_x", "v_s", "w", "w_x", "w_s", "w_xx", "w_xs", "w_ss")
#: evaluations a memo keeps (the least recently used goes first: a curve's points evaluate the same zone
#: basis at every point and new rim points at each, which must not push the zone basis out)
MEMO_ENTRIES = 16
_MEMO_LOCK = threading.Lock()


@dataclass
class ShellSpace:
    """Dof numbering, element dofs and basis evaluation for V_h on ``mesh``."""

    mesh: ShellMesh
    _argyris: ArgyrisBasis | None = field(default=None, repr=False)
    _finder: object = field(default=None, repr=False)
    _affine: np.ndarray | None = field(default=None, repr=False)  # (7, nel): ``physical_to_reference``'s maps
    #: memoised basis evaluations and point operators (None: off). ``curves.solve_family`` turns it on for
    #: the space its points share: their post-processing evaluates the same points again and again
    memo: dict | None = field(default=None, repr=False)

    def __post_init__(self) -> None:
        m = self.mesh.mesh
        self.nv, self.nf = m.p.shape[1], m.facets.shape[1]
        self.n_p2 = self.nv + self.nf
        self.n_w = 6 * self.nv + self.nf
        self.ndofs = 2 * self.n_p2 + self.n_w
        self.u_slice = slice(0, self.n_p2)
        self.v_slice = slice(self.n_p2, 2 * self.n_p2)
        self.w_slice = slice(2 * self.n_p2, self.ndofs)
        t, t2f = m.t, m.t2f
        p2 = np.vstack([t, self.nv + t2f])  # (6, nel)
        arg = np.vstack([6 * t[v] + k for v in range(3) for k in range(6)] + [6 * self.nv + t2f])
        self.element_dofs = np.vstack([p2, self.n_p2 + p2, 2 * self.n_p2 + arg])  # (33, nel)

    # -- dof lookup -----------------------------------------------------------------------
    def u_dofs(self, vertices=(), facets=()) -> np.ndarray:
        return np.concatenate([np.asarray(vertices, int), self.nv + np.asarray(facets, int)])

    def v_dofs(self, vertices=(), facets=()) -> np.ndarray:
        return self.n_p2 + self.u_dofs(vertices, facets)

    def w_vertex_dofs(self, vertices, kinds) -> np.ndarray:
        idx = [W_KINDS.index(k) for k in kinds]
        return (2 * self.n_p2 + 6 * np.asarray(vertices, int)[:, None] + np.asarray(idx)[None, :]).ravel()

    def w_facet_dofs(self, facets) -> np.ndarray:
        return 2 * self.n_p2 + 6 * self.nv + np.asarray(facets, int)

    @property
    def argyris(self) -> ArgyrisBasis:
        if self._argyris is None:
            m = self.mesh.mesh
            normals = edge_normals(m.p, m.t, m.t2f, m.boundary_facets())
            self._argyris = ArgyrisBasis.build(m.p, m.t, normals)
        return self._argyris

    def facet_normals(self) -> np.ndarray:
        """The normal (2, nf) that defines each facet's Argyris dof."""
        m = self.mesh.mesh
        normals = edge_normals(m.p, m.t, m.t2f, m.boundary_facets())
        out = np.empty((2, self.nf))
        for k in range(3):
            out[:, m.t2f[k]] = normals[:, k, :].T
        return out

    # -- basis evaluation ------------------------------------------------------------------
    def quadrature(self, order: int = 10) -> tuple[np.ndarray, np.ndarray]:
        """Reference points (2, nq) and weights (nq,) on the unit triangle."""
        return get_quadrature(RefTri, order)

    def reference_to_physical(self, elements: np.ndarray, X: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Physical points x, s (n, nq) of reference points X (2, nq), and |det J| (n,)."""
        p, t = self.mesh.p, self.mesh.t[:, elements]
        p0, d1, d2 = p[:, t[0]], p[:, t[1]] - p[:, t[0]], p[:, t[2]] - p[:, t[0]]
        x = p0[0][:, None] + d1[0][:, None] * X[0] + d2[0][:, None] * X[1]
        s = p0[1][:, None] + d1[1][:, None] * X[0] + d2[1][:, None] * X[1]
        return x, s, np.abs(d1[0] * d2[1] - d1[1] * d2[0])

    def physical_to_reference(self, elements: np.ndarray, x: np.ndarray, s: np.ndarray) -> np.ndarray:
        """Reference coordinates (2, n) of physical points in the given elements."""
        if self._affine is None:  # every element's first vertex, edges and det, once: ``locate`` asks 24× per point
            p, t = self.mesh.p, self.mesh.t
            p0, d1, d2 = p[:, t[0]], p[:, t[1]] - p[:, t[0]], p[:, t[2]] - p[:, t[0]]
            self._affine = np.vstack([p0, d1, d2, d1[0] * d2[1] - d1[1] * d2[0]])
        a = self._affine[:, elements]  # rows: p0 x, s; d1 x, s; d2 x, s; det
        rx, ry = x - a[0], s - a[1]
        return np.array([(a[5] * rx - a[4] * ry) / a[6], (-a[3] * rx + a[2] * ry) / a[6]])

    def memoized(self, key: tuple, compute: Callable[[], Any]) -> Any:
        """``compute()``, kept in ``memo`` under ``key`` when the memo is on (its values are read only)."""
        memo = self.memo
        if memo is None:
            return compute()
        with _MEMO_LOCK:  # points of a family may be post-processed in threads (``curves``)
            if key in memo:
                memo[key] = value = memo.pop(key)  # the most recently used goes last
                return value
        value = compute()
        with _MEMO_LOCK:
            memo[key] = value
            while len(memo) > MEMO_ENTRIES:
                memo.pop(next(iter(memo)))
        return value

    def element_basis(self, elements: np.ndarray, X: np.ndarray) -> dict[str, np.ndarray]:
        """All 33 element basis functions of V_h at reference points.

        ``X`` is (2, nq) (same points in every element) or (2, n, nq) (per element).
        Returns the QUANTITIES, each of shape (33, n, nq): rows 0–5 the u-functions,
        6–11 the v-functions, 12–32 the w-functions (zero where a field is absent).
        """
        elements = np.asarray(elements, dtype=int)
        X = np.asarray(X, dtype=float)
        return self.memoized(("basis", _digest(elements), _digest(X)), lambda: self._element_basis(elements, X))

    def _element_basis(self, elements: np.ndarray, X: np.ndarray) -> dict[str, np.ndarray]:
        n = elements.size
        X_given = X
        X = np.broadcast_to(X[:, None, :], (2, n, X.shape[-1])) if X.ndim == 2 else X
        nq = X.shape[-1]
        p, t = self.mesh.p, self.mesh.t[:, elements]
        d1, d2 = p[:, t[1]] - p[:, t[0]], p[:, t[2]] - p[:, t[0]]
        det = d1[0] * d2[1] - d1[1] * d2[0]
        # inverse Jacobian rows: ∇_x = J^{-T} ∇_X
        ix = np.array([[d2[1], -d1[1]], [-d2[0], d1[0]]]) / det  # ix[a, b]: dX_b/dx_a
        elem = ElementTriP2()
        val = np.empty((6, n, nq))
        grad = np.empty((2, 6, n, nq))
        flatX = X.reshape(2, -1)
        for i in range(6):
            phi, dphi = elem.lbasis(flatX, i)
            phi, dphi = phi.reshape(n, nq), dphi.reshape(2, n, nq)
            val[i] = phi
            for a in range(2):
                grad[a, i] = ix[a, 0][:, None] * dphi[0] + ix[a, 1][:, None] * dphi[1]
        # reference basis + explicit transformation (argyris.evaluate_reference): no monomials per element
        wb = self.argyris.evaluate_reference(elements, X_given, order=2)

        def block(rows: slice, values: np.ndarray) -> np.ndarray:
            out = np.zeros((33, n, nq))  # zero pages are mapped lazily: only the field's rows are written
            out[rows] = values
            return out

        out = {
            "u": block(slice(0, 6), val),
            "u_x": block(slice(0, 6), grad[0]),
            "u_s": block(slice(0, 6), grad[1]),
            "v": block(slice(6, 12), val),
            "v_x": block(slice(6, 12), grad[0]),
            "v_s": block(slice(6, 12), grad[1]),
        }
        for k in ("w", "w_x", "w_s", "w_xx", "w_xs", "w_ss"):
            out[k] = block(slice(12, 33), wb[k.replace("s", "y")])
        return out

    # -- point evaluation ------------------------------------------------------------------
    def locate(self, x: np.ndarray, s: np.ndarray) -> np.ndarray:
        """Element containing each point (x, s); raises InputError for points outside Ω."""
        x, s = np.atleast_1d(np.asarray(x, float)), np.atleast_1d(np.asarray(s, float))
        if self._finder is None:
            from scipy.spatial import cKDTree

            m = self.mesh.mesh
            self._finder = cKDTree(m.p[:, m.t].mean(axis=1).T)
        best = np.full(x.size, -1)
        best_val = np.full(x.size, -np.inf)
        todo = np.arange(x.size)
        k = min(24, self.mesh.nelements)
        while True:
            # nearest centroids first; on strongly graded (slender) elements the containing one can
            # lie farther away, so points not found are retried with more candidates
            _, cand = self._finder.query(np.c_[x[todo], s[todo]], k=k)
            cand = cand.reshape(todo.size, k)
            for j in range(k):
                e = cand[:, j]
                X = self.physical_to_reference(e, x[todo], s[todo])
                lam = np.min(np.vstack([X[0], X[1], 1 - X[0] - X[1]]), axis=0)
                better = lam > best_val[todo]
                best[todo[better]], best_val[todo[better]] = e[better], lam[better]
            todo = todo[best_val[todo] < -1e-8]
            if todo.size == 0 or k == self.mesh.nelements:
                break
            k = min(8 * k, self.mesh.nelements)
        bad = best_val < -1e-8
        if np.any(bad):
            i = int(np.nonzero(bad)[0][0])
            sh = self.mesh.shell
            raise InputError(
                "point",
                f"(x={x[i]:.6g}, phi={np.degrees(s[i] / sh.radius):.6g} deg) lies outside the shell "
                f"x in [{sh.x_min:.6g}, {sh.x_max:.6g}], phi in [{np.degrees(sh.alpha):.6g}, "
                f"{np.degrees(sh.beta):.6g}] deg",
            )
        return best

    def point_operators(self, x, s, quantities=QUANTITIES) -> dict[str, sp.csr_matrix]:
        """Sparse matrices E_q (npoints × ndofs) with E_q U = quantity q at the points."""
        x, s = np.atleast_1d(np.asarray(x, float)), np.atleast_1d(np.asarray(s, float))
        quantities = tuple(quantities)
        return self.memoized(("points", _digest(x), _digest(s), quantities),
                             lambda: self._point_operators(x, s, quantities))

    def _point_operators(self, x: np.ndarray, s: np.ndarray, quantities: tuple[str, ...]) -> dict[str, sp.csr_matrix]:
        e = self.locate(x, s)
        X = self.physical_to_reference(e, x, s)[:, :, None]  # (2, n, 1)
        basis = self.element_basis(e, X)
        dofs = self.element_dofs[:, e]  # (33, n)
        rows = np.broadcast_to(np.arange(x.size), dofs.shape)
        out = {}
        for q in quantities:
            vals = basis[q][:, :, 0]
            nz = vals != 0.0
            out[q] = sp.csr_matrix((vals[nz], (rows[nz], dofs[nz])), shape=(x.size, self.ndofs))
        return out

    def vertex_coordinates(self) -> tuple[np.ndarray, np.ndarray]:
        return self.mesh.p[0], self.mesh.p[1]

    def interpolate(self, fields) -> np.ndarray:
        """Nodal interpolant of an exact field: fields(x, s) → dict of QUANTITIES."""
        m = self.mesh.mesh
        U = np.zeros(self.ndofs)
        mid = 0.5 * (m.p[:, m.facets[0]] + m.p[:, m.facets[1]])
        pts = np.hstack([m.p, mid])  # P2 nodes: vertices then facet midpoints
        f = fields(pts[0], pts[1])  # once: a coarse solution's evaluation is most of a nested start's prolongation
        U[self.u_slice] = f["u"]
        U[self.v_slice] = f["v"]
        nv = m.p.shape[1]
        wv = np.stack([f[k][:nv] for k in W_KINDS], axis=1).ravel()
        fm = {k: f[k][nv:] for k in ("w_x", "w_s")}
        nrm = self.facet_normals()
        wn = nrm[0] * fm["w_x"] + nrm[1] * fm["w_s"]
        U[self.w_slice] = np.concatenate([wv, wn])
        return U

    def check_points(self, name: str, x, s) -> None:
        try:
            self.locate(x, s)
        except InputError as exc:
            raise InputError(name, exc.message) from None


def _digest(a: np.ndarray) -> tuple:
    """A memo key of an array: its shape, type and a hash of its bytes."""
    a = np.ascontiguousarray(a)
    return a.shape, a.dtype.str, hashlib.sha1(a.tobytes()).hexdigest()
