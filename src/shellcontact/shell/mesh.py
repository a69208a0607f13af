"""Triangulations of the parameter domain in arc-length coordinates (x, s), s = a φ.

Structured meshes come from two 1D node distributions (uniform, graded toward points,
with required node lines), split into triangles by a diagonal pattern. Unstructured
meshes are read with meshio. Every mesh is a scikit-fem ``MeshTri`` whose element
columns are sorted (this fixes the orientation of the Argyris edge-normal dofs).
"""

from __future__ import annotations

import contextlib
import io
import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree
from skfem import MeshTri

from ..errors import InputError
from .geometry import Shell

EDGES = ("x_min", "x_max", "phi_min", "phi_max")
PATTERNS = ("alternate", "right", "left", "crossed")


@dataclass(frozen=True)
class MeshSpec:
    """The ``[mesh]`` table: a structured mesh (graded, with required node lines) or a mesh file."""

    nx: int = 16
    nphi: int = 16
    refine: int = 0
    pattern: str = "alternate"
    file: str | None = None
    grading_x: tuple[float, ...] = ()
    grading_phi: tuple[float, ...] = ()  # radians
    grading_ratio: float = 1.0
    x_lines: tuple[float, ...] = ()
    phi_lines: tuple[float, ...] = ()  # radians


#: node lines closer than this fraction of the mesh's mean interval are one line (``graded_nodes``)
LINE_MERGE = 1e-4


def graded_nodes(
    start: float,
    stop: float,
    n: int,
    focus: Sequence[float] = (),
    ratio: float = 1.0,
    required: Sequence[float] = (),
) -> np.ndarray:
    """About ``n`` intervals on [start, stop]; ``ratio`` > 1 shrinks elements toward ``focus``.

    ``ratio`` is the ratio of the largest to the smallest interval next to a focus point.
    Points in ``required`` (and the focus points) become nodes.
    """
    if n < 1:
        raise InputError("mesh.n", f"needs at least 1 interval, got {n}")
    if ratio < 1.0:
        raise InputError("mesh.grading", f"ratio must be >= 1, got {ratio}")
    length = stop - start
    cuts: list[float] = []
    # one node for lines closer than ``LINE_MERGE`` of an interval (a node line given in the case and found from a
    # punch; a first-contact line 1e-7 rad off a grading focus made a sliver 1e-5 of its neighbours wide: the
    # stiffness was not positive definite): the focus or the shell's edge is kept, else the first
    close = LINE_MERGE * abs(length) / n
    for c in sorted({start, stop, *[c for c in (*focus, *required) if start < c < stop]}):
        if not cuts or c - cuts[-1] > close:
            cuts.append(c)
        elif c in focus and cuts[-1] not in focus and cuts[-1] != start:
            cuts[-1] = c
    cuts[-1] = stop
    counts = [max(1, int(round(n * (hi - lo) / length))) for lo, hi in zip(cuts[:-1], cuts[1:])]
    if len(counts) > 1 and _mirrored(cuts, focus, length):
        counts = _mirror_counts(counts)
    nodes = [np.array([start])]
    for lo, hi, k in zip(cuts[:-1], cuts[1:], counts):
        t = np.linspace(0.0, 1.0, k + 1)
        near_lo, near_hi = _at_focus(lo, focus, length), _at_focus(hi, focus, length)
        if ratio > 1.0 and (near_lo or near_hi) and k >= 2:
            t = _graded_unit(k, ratio, near_lo, near_hi)
        nodes.append(lo + (hi - lo) * t[1:])
    return np.concatenate(nodes)


def _at_focus(c: float, focus: Sequence[float], length: float) -> bool:
    """The node ``c`` is one of the grading foci (to round-off of the interval's ``length``)."""
    return any(abs(c - f) < 1e-12 * max(1.0, abs(length)) for f in focus)


def _mirrored(cuts: list[float], focus: Sequence[float], length: float) -> bool:
    """The cuts (node lines and foci) are their own mirror image about the interval's middle."""
    tol = 1e-9 * abs(length)
    is_focus = [_at_focus(c, focus, length) for c in cuts]
    return all(abs((c - cuts[0]) - (cuts[-1] - m)) <= tol and a == b
               for c, m, a, b in zip(cuts, cuts[::-1], is_focus, is_focus[::-1]))


def _mirror_counts(counts: list[int]) -> list[int]:
    """Interval counts of mirrored cuts: equal in mirror segments (round-off in the segments' lengths could round
    them apart), and an even total, since the "alternate" pattern's diagonals are their own mirror image only on
    an even count (vessel_saddles' estimate meshes at nx = 40 and 20 had 39 and 21 columns: its mirror saddles'
    estimates differed, 5.2 % and 0.45 % for the same zone area)."""
    half, odd = divmod(len(counts), 2)
    first = counts[:half]
    middle = [counts[half] + counts[half] % 2] if odd else []
    return first + middle + first[::-1]


def _graded_unit(k: int, ratio: float, at_lo: bool, at_hi: bool) -> np.ndarray:
    """k intervals on [0, 1], power-law graded toward the flagged ends, largest/smallest = ratio."""
    from scipy.optimize import brentq  # here, not at the top: 0.25 s to import, only graded meshes need it

    t = np.linspace(0.0, 1.0, k + 1)

    def nodes(p: float) -> np.ndarray:
        if at_lo and at_hi:
            r = 2.0 * t - 1.0
            return 0.5 * (1.0 + np.sign(r) * (1.0 - (1.0 - np.abs(r)) ** p))
        return t**p if at_lo else 1.0 - (1.0 - t) ** p

    def excess(p: float) -> float:
        h = np.diff(nodes(p))
        return float(np.log(h.max() / h.min()) - np.log(ratio))

    hi = 2.0
    while excess(hi) < 0.0 and hi < 64.0:
        hi *= 2.0
    p = brentq(excess, 1.0, hi, xtol=1e-12) if excess(hi) > 0.0 else hi
    return nodes(p)


def _split(nx: int, ny: int, pattern: str) -> tuple[np.ndarray, np.ndarray]:
    """Triangles of an (nx × ny)-cell grid of nodes (i, j) → i + (nx+1) j; extra centres last."""
    i, j = np.meshgrid(np.arange(nx), np.arange(ny), indexing="ij")
    i, j = i.ravel(), j.ravel()
    n00 = i + (nx + 1) * j
    n10, n01, n11 = n00 + 1, n00 + nx + 1, n00 + nx + 2
    if pattern == "crossed":
        c = (nx + 1) * (ny + 1) + np.arange(nx * ny)
        t = np.hstack([[n00, n10, c], [n10, n11, c], [n11, n01, c], [n01, n00, c]])
        return t, c
    if pattern == "right":
        flip = np.zeros_like(i, dtype=bool)
    elif pattern == "left":
        flip = np.ones_like(i, dtype=bool)
    elif pattern == "alternate":
        flip = (i + j) % 2 == 1
    else:
        raise InputError("mesh.pattern", f"must be one of {PATTERNS}, got {pattern!r}")
    t1 = np.where(flip, [n00, n10, n01], [n00, n10, n11])
    t2 = np.where(flip, [n10, n11, n01], [n00, n11, n01])
    return np.hstack([t1, t2]), np.empty(0, dtype=int)


@dataclass
class ShellMesh:
    """A triangulation of Ω in (x, s) with the shell it belongs to."""

    shell: Shell
    mesh: MeshTri

    def __post_init__(self) -> None:
        p, t = self.mesh.p, np.sort(self.mesh.t, axis=0)
        self.mesh = MeshTri(np.ascontiguousarray(p, dtype=float), np.ascontiguousarray(t))
        self._check_domain()

    # -- basic data ------------------------------------------------------------------
    @property
    def p(self) -> np.ndarray:
        return self.mesh.p

    @property
    def t(self) -> np.ndarray:
        return self.mesh.t

    @property
    def nvertices(self) -> int:
        return self.mesh.p.shape[1]

    @property
    def nelements(self) -> int:
        return self.mesh.t.shape[1]

    @property
    def nfacets(self) -> int:
        return self.mesh.facets.shape[1]

    def h(self) -> float:
        """Largest edge length."""
        f = self.mesh.facets
        return float(np.max(np.linalg.norm(self.p[:, f[0]] - self.p[:, f[1]], axis=0)))

    def refined(self, times: int = 1) -> ShellMesh:
        """Nested uniform (red) refinement."""
        if times < 0:
            raise InputError("mesh.refine", f"must be >= 0, got {times}")
        return ShellMesh(self.shell, self.mesh.refined(times) if times else self.mesh)

    def x_mirror(self) -> np.ndarray | None:
        """The vertex permutation of the mirror x → x_min + x_max − x when it maps the mesh onto itself (every
        vertex onto a vertex, every triangle onto a triangle), else None."""
        p = self.p
        image = np.stack([self.shell.x_min + self.shell.x_max - p[0], p[1]])
        dist, perm = cKDTree(p.T).query(image.T)
        if np.any(dist > 10.0 * self._tol()):
            return None
        own = np.unique(np.sort(self.t, axis=0), axis=1)
        return perm if np.array_equal(own, np.unique(np.sort(perm[self.t], axis=0), axis=1)) else None

    def _tol(self) -> float:
        sh = self.shell
        return 1e-9 * max(sh.length, sh.s_max - sh.s_min, abs(sh.x_min), abs(sh.s_min), 1.0)

    def _check_domain(self) -> None:
        sh, p, tol = self.shell, self.mesh.p, self._tol()
        if np.any(p[0] < sh.x_min - tol) or np.any(p[0] > sh.x_max + tol):
            raise InputError("mesh", f"mesh x-coordinates leave [{sh.x_min}, {sh.x_max}]")
        if np.any(p[1] < sh.s_min - tol) or np.any(p[1] > sh.s_max + tol):
            raise InputError("mesh", f"mesh s-coordinates leave [{sh.s_min}, {sh.s_max}] (s = radius*phi)")
        area = 0.5 * np.abs(self._det())
        total = sh.length * (sh.s_max - sh.s_min)
        if np.any(area < 1e-14 * total):
            raise InputError("mesh", "mesh has degenerate (zero-area) triangles")
        if abs(area.sum() - total) > 1e-8 * total:
            raise InputError("mesh", f"mesh covers area {area.sum():.6g}, the domain has {total:.6g}")

    def _det(self) -> np.ndarray:
        p, t = self.mesh.p, self.mesh.t
        d1, d2 = p[:, t[1]] - p[:, t[0]], p[:, t[2]] - p[:, t[0]]
        return d1[0] * d2[1] - d1[1] * d2[0]

    # -- boundary --------------------------------------------------------------------
    def edge_vertices(self, edge: str) -> np.ndarray:
        """Vertices on one edge of the rectangle, ordered along the edge."""
        sh, p, tol = self.shell, self.mesh.p, self._tol()
        coord, value = {
            "x_min": (0, sh.x_min),
            "x_max": (0, sh.x_max),
            "phi_min": (1, sh.s_min),
            "phi_max": (1, sh.s_max),
        }[edge]
        ix = np.nonzero(np.abs(p[coord] - value) <= tol)[0]
        return ix[np.argsort(p[1 - coord, ix])]

    def edge_facets(self, edge: str) -> np.ndarray:
        on = np.zeros(self.nvertices, dtype=bool)
        on[self.edge_vertices(edge)] = True
        f = self.mesh.facets
        bf = self.mesh.boundary_facets()
        return bf[on[f[0, bf]] & on[f[1, bf]]]

    def line_facets(self, coord: int, value: float) -> np.ndarray:
        """Facets lying on the mesh line {x = value} (coord 0) or {s = value} (coord 1)."""
        p, f = self.mesh.p, self.mesh.facets
        on = np.abs(p[coord] - value) <= self._tol()
        return np.nonzero(on[f[0]] & on[f[1]])[0]


def structured(
    shell: Shell,
    nx: int,
    nphi: int,
    pattern: str = "alternate",
    x_nodes: np.ndarray | None = None,
    s_nodes: np.ndarray | None = None,
) -> ShellMesh:
    """Structured nx × nphi triangulation; explicit node arrays override the uniform ones."""
    for name, n in (("mesh.nx", nx), ("mesh.nphi", nphi)):
        if not isinstance(n, (int, np.integer)) or isinstance(n, bool) or n < 1:
            raise InputError(name, f"must be an integer >= 1, got {n!r}")
    if pattern not in PATTERNS:
        raise InputError("mesh.pattern", f"must be one of {', '.join(PATTERNS)}, got {pattern!r}")
    xs = np.linspace(shell.x_min, shell.x_max, nx + 1) if x_nodes is None else np.asarray(x_nodes, float)
    ss = np.linspace(shell.s_min, shell.s_max, nphi + 1) if s_nodes is None else np.asarray(s_nodes, float)
    if shell.full and nphi < 3 and s_nodes is None:
        raise InputError("mesh.nphi", "a full cylinder needs nphi >= 3")
    X, S = np.meshgrid(xs, ss, indexing="xy")
    p = np.vstack([X.ravel(), S.ravel()])
    t, centres = _split(len(xs) - 1, len(ss) - 1, pattern)
    if centres.size:
        q = p[:, t[0, : centres.size]] + p[:, t[1, centres.size : 2 * centres.size]]  # n00 + n11
        p = np.hstack([p, 0.5 * q])
    return ShellMesh(shell, MeshTri(p, t))


def read_mesh_file(path: str):
    """The meshio mesh of ``path``; any failure is an InputError on ``mesh.file``."""
    import meshio

    try:
        with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
            return meshio.read(path)
    except (Exception, SystemExit) as exc:  # meshio raises many types, and exits on a file no reader takes
        detail = str(exc) if not isinstance(exc, SystemExit) else "no reader of meshio recognises it"
        raise InputError("mesh.file", f"cannot read mesh file {path!r}: {detail}") from None


def from_file(shell: Shell, path: str) -> ShellMesh:
    """Read a triangulation of Ω in (x, s) coordinates (s = radius·φ, φ in radians) with meshio."""
    m = read_mesh_file(path)
    tris = [c.data for c in m.cells if c.type == "triangle"]
    if not tris:
        raise InputError("mesh.file", f"{path!r} contains no 'triangle' cells")
    t = np.vstack(tris).T
    used = np.unique(t)
    renumber = np.full(m.points.shape[0], -1)
    renumber[used] = np.arange(used.size)
    p = m.points[used, :2].T
    return ShellMesh(shell, MeshTri(np.ascontiguousarray(p, float), renumber[t]))


def node_lines(shell: Shell, spec: MeshSpec, lines_x: Sequence[float] = (), lines_phi: Sequence[float] = (),
               focus_x: Sequence[float] = (), focus_phi: Sequence[float] = ()) -> tuple[np.ndarray, np.ndarray]:
    """The node coordinates x and s = aφ of the structured mesh of ``spec`` before refinement
    (``build_mesh``'s arguments): cheap, so ``sizing`` counts vertices without building anything."""
    req_x = [*spec.x_lines, *lines_x]
    req_phi = [*spec.phi_lines, *lines_phi]
    for name, vals, lo, hi in (("x", req_x, shell.x_min, shell.x_max), ("phi", req_phi, shell.alpha, shell.beta)):
        for v in vals:
            if not lo - 1e-12 <= v <= hi + 1e-12:
                shown = v if name == "x" else math.degrees(v)
                rng = (lo, hi) if name == "x" else (math.degrees(lo), math.degrees(hi))
                raise InputError(
                    f"mesh.{name}", f"a required node line at {shown:.6g} lies outside [{rng[0]:.6g}, {rng[1]:.6g}]"
                )
    gx, gphi = spec.grading_x, spec.grading_phi
    if spec.grading_ratio > 1.0 and not gx and not gphi:
        gx, gphi = tuple(focus_x), tuple(focus_phi)
    xs = graded_nodes(shell.x_min, shell.x_max, spec.nx, gx, spec.grading_ratio, req_x)
    ss = shell.radius * graded_nodes(shell.alpha, shell.beta, spec.nphi, gphi, spec.grading_ratio, req_phi)
    return xs, ss


def build_mesh(shell: Shell, spec: MeshSpec, lines_x: Sequence[float] = (), lines_phi: Sequence[float] = (),
               focus_x: Sequence[float] = (), focus_phi: Sequence[float] = ()) -> ShellMesh:
    """The mesh of ``spec``: structured (graded, with node lines at ``spec``'s and the given ``lines``) or read.

    ``focus_x``/``focus_phi`` (e.g. a punch's first contact) are the grading foci when ``spec`` has a
    grading ratio > 1 but no focus of its own. φ values are in radians.
    """
    if spec.file:
        return from_file(shell, spec.file).refined(spec.refine)
    xs, ss = node_lines(shell, spec, lines_x, lines_phi, focus_x, focus_phi)
    return structured(shell, len(xs) - 1, len(ss) - 1, spec.pattern, x_nodes=xs, s_nodes=ss).refined(spec.refine)
