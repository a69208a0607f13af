"""The memory a case will need, estimated before anything is built, and the guard that refuses it.

From the ``MeshSpec`` alone (and the placed punches' zones) the counts follow exactly: the node
lines of the structured mesh (``mesh.node_lines``; a formula when there are too many to list),
nested red refinement (each level: a vertex per edge, four triangles per triangle), the dofs
2(nv + nf) + 6nv + nf of P2 × P2 × Argyris P5 (MODEL.md §7) and the nonzeros of the stiffness
(``model.StiffnessPattern``: a vertex carries a = 8 dofs, an edge b = 3, and two dofs couple when
their entities share a triangle):

    nnz(A) = a²(nv + 2nf) + 2ab(2nf + 3ne) + b²(nf + 6ne)

(vertex–vertex: itself and its edge neighbours; vertex–edge: the incident edges and the opposite
edge of each triangle; edge–edge: itself and the other two edges of each triangle). The
factorisation's fill is fitted on measured factors, nnz(L) ≈ c·n·log₂n (nested dissection on a 2D
mesh; c per backend in ``FILL``), the contact rows are the vertices (and with
``vertices+midpoints`` the edges) inside the candidate zones, and the dense blocks are those of
``solvers.schur``/``solvers.substructure``. The peak is the larger of two stages:

* assembly: the stiffness and the element matrices being scattered (``ASSEMBLY_BYTES`` per triangle);
* factorisation and solve: A, its reduced copy, |A|, the equilibrated triangle the backend reads, the
  factors, and the contact blocks (columns of S = B A⁻¹ Bᵀ, m × m at most; the substructured
  method's T and its Cholesky factor, 2 m_s² with m_s ≤ ``substructure.MAX_ROWS``, and its columns of S
  on the screened rows, m_s² at most).

The accuracy against measured peak resident sets is in docs/solvers.md ("Memory estimate").
"""

from __future__ import annotations

import math
import os
import re
from collections.abc import Sequence
from dataclasses import dataclass, field

from ..errors import InputError
from ..shell.mesh import MeshSpec, read_mesh_file

#: bytes the interpreter, NumPy, SciPy, scikit-fem and the backend take before the first array
BASE_BYTES = 150e6
#: transient bytes per triangle while the stiffness is assembled (element matrices 33 × 33, their
#: scatter positions; measured peak 21 KB per triangle, benchmarks/RESULTS.md, target 1)
ASSEMBLY_BYTES = 21e3
#: bytes per stored nonzero of a CSR matrix (value + column index)
CSR_BYTES = 12.0
#: factor nonzeros nnz(L) ≈ c · n · log₂ n by backend (SuperLU: L + U), fitted in benchmarks/memory.py
#: (MUMPS with PORD, its INFOG(29): 74.9 M at 276k unknowns, 369.4 M at 1.11M: c = 15.0, 16.6)
FILL = {"pardiso": 13.0, "cholmod": 10.0, "superlu": 20.0, "mumps": 16.6}
#: bytes per factor nonzero: the value and the backend's own structures (PARDISO 2.84 GB of factor
#: memory for 251 M nonzeros at 984k unknowns: 11.3)
FACTOR_BYTES = 11.5
#: a factorisation bordered by the contact rows (PARDISO's Schur mode) has more fill: 382 M against
#: 288 M nonzeros at 1.12M dofs (benchmarks/RESULTS.md, target 5)
BORDERED_FILL = 1.33
#: the refinement level from which the counts are only bounded (4^60 triangles is beyond any machine)
MAX_LEVELS = 60
#: node lines listed exactly up to this many intervals per direction
MAX_LISTED = 1_000_000
#: bytes per sweep step kept in memory (the case dictionary, the summary and the CSV row)
STEP_BYTES = 20e3

_UNITS = {"": 1.0, "b": 1.0, "k": 1e3, "kb": 1e3, "m": 1e6, "mb": 1e6, "g": 1e9, "gb": 1e9, "t": 1e12, "tb": 1e12,
          "kib": 2.0**10, "mib": 2.0**20, "gib": 2.0**30, "tib": 2.0**40}


@dataclass(frozen=True)
class SizeEstimate:
    """Counts and bytes of a case before it is built (floats: they may be astronomically large)."""

    vertices: float
    elements: float
    facets: float
    dofs: float
    nnz: float  # of the stiffness matrix
    factor_nnz: float
    contact_rows: float
    parts: dict[str, float] = field(default_factory=dict)  # bytes by stage and part

    @property
    def bytes(self) -> float:
        """The estimated peak resident set."""
        return max(self.parts.get("assembly stage", 0.0), self.parts.get("solve stage", 0.0))


def gigabytes(n: float) -> str:
    return f"about {n / 1e9:.3g} GB" if n < 1e39 else "more than 1e30 GB"


def _count(n: float) -> str:
    return f"{n:.3g}" if n < 1e30 else "more than 1e30"


def parse_memory(value: str | float | int, where: str = "--max-memory") -> float:
    """Bytes from ``8G``, ``512MB``, ``1.5GiB``, ``2e9`` or a number of bytes."""
    if isinstance(value, bool):
        raise InputError(where, f"must be a size such as 8G, 512M or a number of bytes, got {value!r}")
    if isinstance(value, (int, float)):
        size = float(value)
    else:
        m = re.fullmatch(r"\s*([0-9.]+(?:[eE][+-]?[0-9]+)?)\s*([A-Za-z]*)\s*", str(value))
        unit = m.group(2).lower() if m else None
        if m is None or unit not in _UNITS:
            raise InputError(where, f"must be a size such as 8G, 512M, 1.5GiB or a number of bytes, got {value!r}")
        try:
            size = float(m.group(1)) * _UNITS[unit]
        except ValueError:
            raise InputError(where, f"must be a size such as 8G, 512M or a number of bytes, got {value!r}") from None
    if not (math.isfinite(size) and size > 0):
        raise InputError(where, f"must be a positive, finite size, got {value!r}")
    return size


def available_memory() -> float:
    """MemAvailable of /proc/meminfo (bytes the kernel can give without swapping); the physical
    memory where there is no /proc; infinity if neither is known."""
    available = _proc_bytes("/proc/meminfo", "MemAvailable:")
    if available is not None:
        return available
    try:
        return float(os.sysconf("SC_PHYS_PAGES") * os.sysconf("SC_PAGE_SIZE"))
    except (ValueError, OSError, AttributeError):
        return math.inf


def mesh_lines(case, punches: Sequence = ()) -> tuple[list[float], list[float], list[float], list[float]]:
    """The node lines a case asks of its mesh (``mesh.build_mesh``'s x, φ lines and grading foci): the
    punches' fitted lines (zone edges, first contact), the point loads and the line loads."""
    from ..contact.punches import fitted_lines, focus_lines

    xs, ps = fitted_lines(punches, case.shell)
    fx, fp = focus_lines(punches)
    loads = case.loads
    xs += [p.x for p in loads.points] + [ln.x for ln in loads.lines if ln.x is not None]
    ps += [p.phi for p in loads.points] + [ln.phi for ln in loads.lines if ln.phi is not None]
    return xs, ps, fx, fp


def _refined(nv: float, ne: float, nf: float, levels: int) -> tuple[float, float, float]:
    """Counts after ``levels`` red refinements (a new vertex per edge, 4 triangles per triangle)."""
    if levels > MAX_LEVELS:
        return math.inf, math.inf, math.inf
    for _ in range(levels):
        nv, nf, ne = nv + nf, 2.0 * nf + 3.0 * ne, 4.0 * ne
    return nv, ne, nf


def _grid(spec: MeshSpec, ncx: float, ncs: float) -> tuple[float, float, float]:
    """Vertices, triangles, edges of a structured ncx × ncs cell grid (Euler: E = V + T − 1)."""
    cells = ncx * ncs
    nv = (ncx + 1.0) * (ncs + 1.0) + (cells if spec.pattern == "crossed" else 0.0)
    ne = (4.0 if spec.pattern == "crossed" else 2.0) * cells
    return nv, ne, nv + ne - 1.0


def _file_counts(path: str) -> tuple[float, float, float]:
    """Vertices, triangles, edges of a mesh file (read here: the file is the input)."""
    m = read_mesh_file(path)
    ne = float(sum(len(c.data) for c in m.cells if c.type == "triangle"))
    nv = float(len(m.points))
    return nv, ne, nv + ne - 1.0


def estimate(case, punches: Sequence = (), method: str | None = None, backend: str | None = None) -> SizeEstimate:
    """The counts and the peak memory of solving ``case`` (module docstring); ``punches`` are the
    placed punches (their zones give the contact rows; without them the rows are not counted)."""
    spec, shell, opts = case.mesh, case.shell, case.solver
    levels = int(spec.refine)
    zone_fraction = 0.0
    if spec.file:
        nv0, ne0, nf0 = _file_counts(spec.file)
        area = shell.length * (shell.s_max - shell.s_min)
        zone_fraction = sum((p.zone.x[1] - p.zone.x[0]) * sum(b - a for a, b in p.zone.phi) * shell.radius
                            for p in punches) / area
    else:
        lines = mesh_lines(case, punches)
        cuts_x = len(spec.x_lines) + len(spec.grading_x) + len(lines[0]) + len(lines[2])
        cuts_s = len(spec.phi_lines) + len(spec.grading_phi) + len(lines[1]) + len(lines[3])
        if spec.nx + cuts_x <= MAX_LISTED and spec.nphi + cuts_s <= MAX_LISTED:
            from ..shell.mesh import node_lines

            xs, ss = node_lines(shell, spec, *lines)
            ncx, ncs = float(len(xs) - 1), float(len(ss) - 1)
            zone_rows = sum(_zone_rows(p, shell, spec, xs, ss, levels, opts.contact_points) for p in punches)
        else:  # too many to list: each cut adds at most one interval
            ncx, ncs = float(spec.nx + cuts_x), float(spec.nphi + cuts_s)
            zone_rows = math.inf if punches else 0.0
        nv0, ne0, nf0 = _grid(spec, ncx, ncs)
    nv, ne, nf = _refined(nv0, ne0, nf0, levels)
    midpoints = opts.contact_points == "vertices+midpoints"
    if spec.file:
        zone_rows = zone_fraction * (nv + (nf if midpoints else 0.0))
    a, b = 8.0, 3.0
    dofs = a * nv + b * nf
    nnz = a * a * (nv + 2 * nf) + 2 * a * b * (2 * nf + 3 * ne) + b * b * (nf + 6 * ne)
    rows = min(zone_rows, nv + nf)
    return _bytes(case, nv, ne, nf, dofs, nnz, rows, method or opts.method, backend or opts.backend)


def _zone_rows(punch, shell, spec: MeshSpec, xs, ss, levels: int, points: str) -> float:
    """Contact rows of a punch: the vertices (and edges, with midpoints) of the refined mesh inside its
    candidate zone, whose edges are node lines."""
    import numpy as np

    tol = 1e-9 * max(shell.length, shell.s_max - shell.s_min)  # as ShellMesh: lines within it coincide
    x0, x1 = punch.zone.x
    cx = max(int(np.count_nonzero((xs >= x0 - tol) & (xs <= x1 + tol))) - 1, 0)
    a = shell.radius
    cs = sum(max(int(np.count_nonzero((ss >= a * p0 - tol) & (ss <= a * p1 + tol))) - 1, 0)
             for p0, p1 in punch.zone.phi)
    nv, ne, nf = _refined(*_grid(spec, float(cx), float(cs)), levels)
    return nv + (nf if points == "vertices+midpoints" else 0.0)


def _bytes(case, nv, ne, nf, dofs, nnz, rows, method: str, backend: str) -> SizeEstimate:
    from ..linalg import BACKENDS, resolve_backend
    from ..solvers.methods import METHODS
    from ..solvers.substructure import MAX_ROWS, MIN_UNKNOWNS

    name = resolve_backend(backend)
    n = dofs
    fill = FILL.get(name, max(FILL.values()))
    factor_nnz = fill * n * math.log2(max(n, 2.0)) if math.isfinite(n) else math.inf
    opts = case.solver
    exact = METHODS[method].exact if method in METHODS else True
    substructured = bool(rows) and exact and opts.substructure is not False and BACKENDS[name].supports_schur and (
        opts.substructure is True or n >= MIN_UNKNOWNS)
    schur_rows = min(rows, MAX_ROWS) if substructured else 0.0
    matrix = CSR_BYTES * nnz
    parts = {
        "stiffness": matrix,
        "reduced stiffness, |A| and the backend's copy": (1.0 + (0.7 if rows else 0.0) + 0.5) * matrix,
        "factor": FACTOR_BYTES * factor_nnz * (BORDERED_FILL if substructured else 1.0),
        # the columns of S (m × m at most; screened: those of the bordered rows), then T and its Cholesky factor
        "contact blocks": 8.0 * (schur_rows if substructured else rows) ** 2 + 16.0 * schur_rows * schur_rows,
        "vectors": 8.0 * 30 * dofs,
    }
    parts["assembly stage"] = BASE_BYTES + matrix + ASSEMBLY_BYTES * ne
    parts["solve stage"] = BASE_BYTES + sum(v for k, v in parts.items() if k != "assembly stage")
    return SizeEstimate(vertices=nv, elements=ne, facets=nf, dofs=dofs, nnz=nnz, factor_nnz=factor_nnz,
                        contact_rows=rows, parts=parts)


def _key(case) -> str:
    """The case-file key that sizes the mesh the most directly."""
    spec = case.mesh
    if spec.refine > 0:
        return "mesh.refine"
    if spec.file:
        return "mesh.file"
    return "mesh.nx" if spec.nx >= spec.nphi else "mesh.nphi"


def resident_memory() -> float:
    """The process's resident set now (VmRSS of /proc/self/status; 0 where unknown): memory the
    estimate counts (``BASE_BYTES``, earlier arrays) that is not asked of the machine again."""
    rss = _proc_bytes("/proc/self/status", "VmRSS:")
    return 0.0 if rss is None else rss


def _proc_bytes(path: str, key: str) -> float | None:
    """The ``key: N kB`` line of a /proc file in bytes (None where there is no such file or line)."""
    try:
        with open(path) as fh:
            for line in fh:
                if line.startswith(key):
                    return float(line.split()[1]) * 1024.0
    except OSError:
        pass
    return None


def check_size(case, punches: Sequence = (), max_memory: float | str | None = None, method: str | None = None,
               backend: str | None = None, what: str = "this case") -> SizeEstimate:
    """Refuse (InputError naming the mesh key to change) a case whose estimated peak memory exceeds
    ``max_memory`` (bytes or a size such as ``8G``), or by default whose growth beyond the process's
    present resident set exceeds the memory available now."""
    est = estimate(case, punches, method, backend)
    if max_memory is None:
        need, limit, source = est.bytes - resident_memory(), available_memory(), "the memory available"
    else:
        need, limit, source = est.bytes, parse_memory(max_memory), "--max-memory / max_memory"
    if not need <= limit:
        raise InputError(
            _key(case),
            f"{what} needs {gigabytes(est.bytes)} (estimated before building: {_count(est.dofs)} dofs, "
            f"{_count(est.nnz)} stiffness entries, {_count(est.factor_nnz)} factor entries, "
            f"{_count(est.contact_rows)} contact rows) but {source} is {gigabytes(limit)}; use a coarser "
            "mesh (mesh.nx, mesh.nphi, mesh.refine), or raise the limit with --max-memory (Python: "
            "solve(..., max_memory=...))",
        )
    return est


def check_steps(count: int, max_memory: float | str | None = None, where: str = "--values") -> None:
    """Refuse a sweep of more steps than the memory can record (``STEP_BYTES`` each), before any list
    of them is built."""
    limit = available_memory() if max_memory is None else parse_memory(max_memory)
    need = BASE_BYTES + STEP_BYTES * float(count)
    if not need <= limit:
        raise InputError(where, f"{count:.3g} steps need {gigabytes(need)} to record but "
                         f"{'the memory available' if max_memory is None else '--max-memory'} is {gigabytes(limit)}; "
                         "give fewer steps")
