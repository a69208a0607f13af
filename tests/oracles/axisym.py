"""An independent 1D axisymmetric solver of the shell model of MODEL.md, used as a test oracle.

Written from scratch with numpy/scipy only: it shares no code with ``shellcontact`` (no spaces,
no model, no contact layer), so agreement between the two is evidence, not tautology.

Model (MODEL.md §2–3 restricted to v = 0 and nothing depending on φ, w positive outward):

    ε11 = u',  ε22 = w/a,  κ11 = −w'',  κ22 = −w/a²

    energy per unit circumferential length of the mid-surface (multiply by 2πa for the total)
    Π(u, w) = ∫ ½ [B(ε11² + 2μ ε11 ε22 + ε22²) + D(κ11² + 2μ κ11 κ22 + κ22²)] dx − ∫ q w dx − Σ P_k w(x_k)

    B = E t/(1 − μ²), D = E t³/(12(1 − μ²)). The Euler–Lagrange equations are N11' = 0 (N11 = N is
    constant) and
        D w'''' + 2μ D w''/a² + k w = q − μ N/a,     k = D/a⁴ + E t/a²,
    with the natural boundary terms  N11 δu,  D(w'' + μ w/a²) δw',  −D(w''' + μ w'/a²) δw.

The characteristic roots of the homogeneous equation are ±α ± iβ with

    β_m⁴ = k/(4D) = 3(1 − μ²)/(a² t²) + 1/(4a⁴),   α = √(β_m² − μ/(2a²)),   β = √(β_m² + μ/(2a²)),

and a ring load P (force per unit circumferential length, outward) on an infinite cylinder deflects
it under the load by  w(0) = P / (8 D β_m² α)  (Fourier integral ∫dξ/(ξ⁴ − 2cξ² + m⁴) = π/(m²√(2(m² − c)))
with c = μ/a², m² = 2β_m²). The classical thin-shell value P/(8β_c³D), β_c⁴ = 3(1 − μ²)/(a²t²), drops
the model's κ22 = −w/a² term; the relative difference is −μ t/(4a√(3(1 − μ²))) + O(t²/a²), i.e. O(t/a)
(the 2μD w''/a² coupling changes α, β at first order, k/D only at second order).

Discretisation: u in C0 piecewise polynomials of degree ``pu`` (end values + Legendre bubbles), w in C1
piecewise polynomials of degree ``pw`` ≥ 3 (Hermite cubic end values and slopes + bubbles
ξ²(1−ξ)² L_k). Contact with a rigid axisymmetric punch (signed distance Z in the meridian plane
(x, ρ), ρ = distance from the axis) is imposed at the mesh nodes of the candidate zone:

    Π_i = Z(M_i) + Z_x(M_i) (u − ζ w')_i + Z_ρ(M_i) w_i ≥ 0,   M_i = (x_i, a + ζ),  ζ = ±e,

and the QP  min ½UᵀAU − FᵀU  s.t.  G + BU ≥ 0  is solved exactly: an active-set guess from the dense dual
(S = B A⁻¹ Bᵀ, Lawson–Hanson NNLS), then the Lawson–Hanson active-set method on the dual whose every
subproblem is solved exactly by eliminating w at the active nodes (Π_i = 0) from the sparse SPD system
(S itself is never trusted: its condition number grows like h⁻⁴), and a KKT check that raises on failure.
The multipliers Λ_i are ring forces per unit circumferential length of the mid-surface; the total force on
the whole circumference is 2πa Σ Λ_i |∇Z_i|.

Round-off: the stiffness has cond ~ (βh)⁻⁴, so it is assembled in extended precision (np.longdouble) and
every solve is refined with longdouble residuals against a float64 LU; this keeps ~1e-10 relative accuracy
down to βh ≈ 5e-3 (float64 assembly lost it already at βh ≈ 1e-2). Do not refine below βh ~ 1e-3.

API: Shell1D, graded_nodes / bisect (meshes), solve(...) -> AxisymSolution (w, u, N11, M11, contact_zone,
force_per_length, total_normal_force, radial/axial force, edge_forces, kkt), CylinderPunch / TorusPunch,
closed forms model_roots, ring_stiffness(_classical), ring_green, closed_form_pressure, and
sleeve_free_boundary (contact band + edge ring with the band end found exactly).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np
import scipy.optimize as sopt
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from numpy.polynomial import Polynomial
from numpy.polynomial import legendre as leg

SUPPORTS = ("clamped", "simply_supported", "symmetry", "free")


# --------------------------------------------------------------------------------------------
# shell data and closed forms
# --------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class Shell1D:
    """An axisymmetric cylinder x ∈ [x0, x1] of radius a, thickness t, Young E, Poisson μ."""

    radius: float
    thickness: float
    young: float
    poisson: float
    x0: float
    x1: float

    @property
    def B(self) -> float:
        return self.young * self.thickness / (1.0 - self.poisson**2)

    @property
    def D(self) -> float:
        return self.young * self.thickness**3 / (12.0 * (1.0 - self.poisson**2))

    @property
    def k(self) -> float:
        """Foundation modulus of the w-equation: D/a⁴ + E t/a²."""
        a = self.radius
        return self.D / a**4 + self.young * self.thickness / a**2


def beta_classical(a: float, t: float, mu: float) -> float:
    """Classical thin-shell decay rate β_c = (3(1 − μ²)/(a²t²))^(1/4)."""
    return (3.0 * (1.0 - mu**2) / (a * a * t * t)) ** 0.25


def model_roots(shell: Shell1D) -> tuple[float, float, float]:
    """(β_m, α, β): roots ±α ± iβ of D r⁴ + 2μD r²/a² + k = 0, β_m⁴ = k/(4D)."""
    a, mu = shell.radius, shell.poisson
    bm = (shell.k / (4.0 * shell.D)) ** 0.25
    return bm, math.sqrt(bm * bm - mu / (2 * a * a)), math.sqrt(bm * bm + mu / (2 * a * a))


def ring_stiffness(shell: Shell1D) -> float:
    """P / w(0) for a ring load on an infinite cylinder of this model: 8 D β_m² α."""
    bm, alpha, _ = model_roots(shell)
    return 8.0 * shell.D * bm * bm * alpha


def ring_stiffness_classical(shell: Shell1D) -> float:
    """The thin-shell limit 8 β_c³ D."""
    return 8.0 * beta_classical(shell.radius, shell.thickness, shell.poisson) ** 3 * shell.D


def ring_green(shell: Shell1D, P: float, x: np.ndarray) -> np.ndarray:
    """w(x) of an infinite cylinder under an outward ring load P at x = 0 (Re C e^{λ|x|}, λ = −α + iβ,
    with w'(0+) = 0 and D w'''(0+) = P/2)."""
    _, alpha, beta = model_roots(shell)
    lam = complex(-alpha, beta)
    # C = cr + i ci:  Re(C λ) = 0,  Re(C λ³) = P/(2D)
    M = np.array([[lam.real, -lam.imag], [(lam**3).real, -(lam**3).imag]])
    cr, ci = np.linalg.solve(M, [0.0, P / (2.0 * shell.D)])
    return np.real(complex(cr, ci) * np.exp(lam * np.abs(np.asarray(x, dtype=float))))


@dataclass
class ClosedForm:
    """Exact solution of the axisymmetric ODE under a uniform pressure q with any supports."""

    shell: Shell1D
    coef: np.ndarray  # c1..c4, N, u0
    q: float

    def _rows(self, x: np.ndarray, n: int) -> np.ndarray:
        sh = self.shell
        _, alpha, beta = model_roots(sh)
        lam, nu = complex(-alpha, beta), complex(alpha, beta)
        x = np.asarray(x, dtype=float)
        e0 = lam**n * np.exp(lam * (x - sh.x0))
        e1 = nu**n * np.exp(nu * (x - sh.x1))
        z = np.zeros_like(x)
        wp = 1.0 if n == 0 else 0.0
        # w_p = (q − μN/a)/k: the N column
        return np.stack([e0.real, e0.imag, e1.real, e1.imag, z - wp * sh.poisson / (sh.radius * sh.k), z], -1)

    def _const(self, x, n):
        return (self.q / self.shell.k if n == 0 else 0.0) + 0 * np.asarray(x, dtype=float)

    def w(self, x, n: int = 0) -> np.ndarray:
        return self._rows(x, n) @ self.coef + self._const(x, n)

    def _urow(self, x):
        sh = self.shell
        _, alpha, beta = model_roots(sh)
        lam, nu = complex(-alpha, beta), complex(alpha, beta)
        x = np.asarray(x, dtype=float)
        i0 = (np.exp(lam * (x - sh.x0)) - 1.0) / lam
        i1 = (np.exp(nu * (x - sh.x1)) - np.exp(nu * (sh.x0 - sh.x1))) / nu
        s = x - sh.x0
        ma = sh.poisson / sh.radius
        nc = s / sh.B + ma * s * sh.poisson / (sh.radius * sh.k)  # N enters through u' and through w_p
        rows = np.stack([-ma * i0.real, -ma * i0.imag, -ma * i1.real, -ma * i1.imag, nc, np.ones_like(s)], -1)
        const = -ma * s * self.q / sh.k
        return rows, const

    def u(self, x) -> np.ndarray:
        rows, const = self._urow(x)
        return rows @ self.coef + const

    @property
    def N(self) -> float:
        return float(self.coef[4])


def closed_form_pressure(shell: Shell1D, bc0: str, bc1: str, q: float) -> ClosedForm:
    """Solve the ODE exactly (homogeneous exponentials + particular solution, N and u(x0) unknown)."""
    cf = ClosedForm(shell, np.zeros(6), q)
    mu, a = shell.poisson, shell.radius
    rows, rhs = [], []

    def cond(kind, x):
        x = np.array([x])
        if kind == "u":
            r, c = cf._urow(x)
            return r[0], -c[0]
        if kind == "N":
            return np.eye(6)[4], 0.0
        if kind == "w":
            return cf._rows(x, 0)[0], -cf._const(x, 0)[0]
        if kind == "w1":
            return cf._rows(x, 1)[0], 0.0
        if kind == "M":  # w'' + μ w/a²
            return cf._rows(x, 2)[0] + mu / a**2 * cf._rows(x, 0)[0], -mu / a**2 * cf._const(x, 0)[0]
        if kind == "Q":  # w''' + μ w'/a²
            return cf._rows(x, 3)[0] + mu / a**2 * cf._rows(x, 1)[0], 0.0
        raise ValueError(kind)

    table = {
        "clamped": ("u", "w", "w1"),
        "simply_supported": ("N", "w", "M"),
        "symmetry": ("u", "w1", "Q"),
        "free": ("N", "M", "Q"),
    }
    kinds0, kinds1 = list(table[bc0]), list(table[bc1])
    if "u" not in kinds0 and "u" not in kinds1:  # axial rigid motion: pin u(x0) = 0, N = 0 once
        kinds1[kinds1.index("N")] = "pin"
    for kinds, x in ((kinds0, shell.x0), (kinds1, shell.x1)):
        for kind in kinds:
            if kind == "pin":
                r, c = np.eye(6)[5], 0.0
            else:
                r, c = cond(kind, x)
            rows.append(r)
            rhs.append(c)
    cf.coef = np.linalg.solve(np.array(rows), np.array(rhs))
    return cf


# --------------------------------------------------------------------------------------------
# meshes
# --------------------------------------------------------------------------------------------
def graded_nodes(
    x0: float, x1: float, points: Sequence[float] = (), h_min: float = 0.01, h_max: float = 0.1, ratio: float = 1.2
) -> np.ndarray:
    """Nodes on [x0, x1] containing ``points``, element sizes growing geometrically (``ratio``)
    from ``h_min`` at every break point (ends and ``points``) up to ``h_max``."""
    bps = sorted({float(x0), float(x1), *(float(p) for p in points if x0 < p < x1)})
    out = [bps[0]]
    for p, q in zip(bps[:-1], bps[1:]):
        length = q - p
        sizes, total = [], 0.0
        h = h_min
        while total + min(h, h_max) <= length / 2 + 1e-14 * length:
            sizes.append(min(h, h_max))
            total += sizes[-1]
            h *= ratio
        rest = length / 2 - total
        if rest > 0.5 * min(h, h_max) or not sizes:
            sizes.append(rest)
        else:
            sizes[-1] += rest
        half = np.array(sizes)
        seg = np.concatenate([half, half[::-1]])
        seg *= length / seg.sum()
        out.extend(p + np.cumsum(seg)[:-1])
        out.append(q)
    return np.array(out)


def bisect(nodes: np.ndarray, times: int = 1) -> np.ndarray:
    """Nested refinement: insert the midpoint of every element ``times`` times."""
    x = np.asarray(nodes, dtype=float)
    for _ in range(times):
        x = np.sort(np.concatenate([x, 0.5 * (x[1:] + x[:-1])]))
    return x


# --------------------------------------------------------------------------------------------
# reference shape functions
# --------------------------------------------------------------------------------------------
def _gauss01(n: int) -> tuple[np.ndarray, np.ndarray]:
    """Gauss–Legendre points and weights on [0, 1] in extended precision (Newton-polished)."""
    x = leg.leggauss(n)[0].astype(np.longdouble)
    for _ in range(3):
        p0, p1 = np.ones_like(x), x.copy()
        for k in range(2, n + 1):
            p0, p1 = p1, ((2 * k - 1) * x * p1 - (k - 1) * p0) / k
        dp = n * (x * p1 - p0) / (x * x - 1)
        x -= p1 / dp
    p0, p1 = np.ones_like(x), x.copy()
    for k in range(2, n + 1):
        p0, p1 = p1, ((2 * k - 1) * x * p1 - (k - 1) * p0) / k
    dp = n * (x * p1 - p0) / (x * x - 1)
    w = 2 / ((1 - x * x) * dp * dp)
    return (x + 1) / 2, w / 2


def _shape_polys(pw: int, pu: int) -> tuple[list[Polynomial], list[Polynomial]]:
    xi = Polynomial([0.0, 1.0])
    one = Polynomial([1.0])
    herm = [1 - 3 * xi**2 + 2 * xi**3, xi - 2 * xi**2 + xi**3, 3 * xi**2 - 2 * xi**3, -(xi**2) + xi**3]

    def lk(k):  # Legendre L_k(2ξ − 1) as a Polynomial in ξ
        c = np.zeros(k + 1)
        c[k] = 1.0
        return Polynomial(leg.leg2poly(c))(2 * xi - 1)

    wb = [xi**2 * (one - xi) ** 2 * lk(k) for k in range(pw - 3)]
    ub = [xi * (one - xi) * lk(k) for k in range(pu - 1)]
    return herm + wb, [one - xi, xi, *ub]


# --------------------------------------------------------------------------------------------
# punches (rigid, axisymmetric; Z is a signed distance in the meridian plane (x, ρ))
# --------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class CylinderPunch:
    """A coaxial cylinder of radius R; ``inverted`` (a sleeve around the shell): Z = R − ρ,
    otherwise a solid plug inside it: Z = ρ − R. Acts on the nodes with x in ``zone``."""

    radius: float
    zone: tuple[float, float]
    inverted: bool = True

    def gap(self, x: np.ndarray, rho: np.ndarray):
        s = 1.0 if self.inverted else -1.0
        return s * (self.radius - rho), np.zeros_like(x), -s * np.ones_like(rho)


@dataclass(frozen=True)
class TorusPunch:
    """A solid coaxial torus (ring) centred at x = ``center`` with major radius R and minor radius r:
    Z = √((x − xc)² + (ρ − R)²) − r. Default zone: x ∈ [xc − r, xc + r]."""

    center: float
    major_radius: float
    minor_radius: float
    zone: tuple[float, float] | None = None

    def gap(self, x: np.ndarray, rho: np.ndarray):
        dx, dr = x - self.center, rho - self.major_radius
        d = np.hypot(dx, dr)
        return d - self.minor_radius, dx / d, dr / d

    @property
    def candidate_zone(self) -> tuple[float, float]:
        if self.zone is not None:
            return self.zone
        return (self.center - self.minor_radius, self.center + self.minor_radius)


def _zone(p) -> tuple[float, float]:
    return p.candidate_zone if isinstance(p, TorusPunch) else p.zone


# --------------------------------------------------------------------------------------------
# solution
# --------------------------------------------------------------------------------------------
@dataclass
class AxisymSolution:
    shell: Shell1D
    nodes: np.ndarray
    U: np.ndarray
    energy: float
    dofmap: np.ndarray  # (ne, nloc) global dof numbers, local order [u: pu+1 | w: pw+1]
    scale: np.ndarray  # (ne, nloc) shape-function scaling (h on slope dofs)
    pw: int
    pu: int
    # contact
    cx: np.ndarray = field(default_factory=lambda: np.zeros(0))  # x of the constraint nodes
    cpunch: np.ndarray = field(default_factory=lambda: np.zeros(0, int))  # punch index per constraint
    lam: np.ndarray = field(default_factory=lambda: np.zeros(0))  # multipliers (force / circ. length)
    gap: np.ndarray = field(default_factory=lambda: np.zeros(0))  # Π_i at the solution
    gradZ: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))  # (Z_x, Z_ρ) at M_i
    active: np.ndarray = field(default_factory=lambda: np.zeros(0, bool))
    kkt: dict = field(default_factory=dict)
    iterations: int = 0
    method: str = ""
    band_force: float = 0.0  # reaction of a prescribed band w_band (force per unit circumferential length)

    # ---- fields
    def _eval(self, x, which: str, n: int) -> np.ndarray:
        x = np.atleast_1d(np.asarray(x, dtype=float))
        e = np.clip(np.searchsorted(self.nodes, x, side="right") - 1, 0, len(self.nodes) - 2)
        h = self.nodes[e + 1] - self.nodes[e]
        xi = (x - self.nodes[e]) / h
        pw_polys, pu_polys = _shape_polys(self.pw, self.pu)
        nu = self.pu + 1
        if which == "u":
            polys, cols = pu_polys, slice(0, nu)
        else:
            polys, cols = pw_polys, slice(nu, nu + self.pw + 1)
        vals = np.stack([p.deriv(n)(xi) if n else p(xi) for p in polys], -1) / h[:, None] ** n
        coef = self.U[self.dofmap[e, cols]] * self.scale[e, cols]
        return np.sum(vals * coef, axis=-1)

    def w(self, x, n: int = 0) -> np.ndarray:
        """w or its n-th x-derivative."""
        return self._eval(x, "w", n)

    def u(self, x, n: int = 0) -> np.ndarray:
        return self._eval(x, "u", n)

    def N11(self, x) -> np.ndarray:
        sh = self.shell
        return sh.B * (self.u(x, 1) + sh.poisson * self.w(x) / sh.radius)

    def M11(self, x) -> np.ndarray:
        sh = self.shell
        return -sh.D * (self.w(x, 2) + sh.poisson * self.w(x) / sh.radius**2)

    # ---- contact results
    def _sel(self, punch: int | None):
        return np.ones(len(self.cx), bool) if punch is None else self.cpunch == punch

    def contact_zone(self, punch: int | None = None) -> tuple[float, float] | None:
        """[x_a, x_b]: the extreme active constraint nodes."""
        m = self.active & self._sel(punch)
        if not m.any():
            return None
        return float(self.cx[m].min()), float(self.cx[m].max())

    def force_per_length(self, punch: int | None = None) -> float:
        """Σ Λ_i |∇Z_i|: normal force per unit circumferential length (mid-surface measure)."""
        m = self._sel(punch)
        return float(np.sum(self.lam[m] * np.hypot(self.gradZ[m, 0], self.gradZ[m, 1])))

    def total_normal_force(self, punch: int | None = None) -> float:
        """The normal force on the whole circumference: 2πa Σ Λ_i |∇Z_i|."""
        return 2.0 * math.pi * self.shell.radius * self.force_per_length(punch)

    def radial_force_per_length(self, punch: int | None = None) -> float:
        """Σ Λ_i Z_ρ,i: the radial (outward positive) force on the shell per unit circumferential length."""
        m = self._sel(punch)
        return float(np.sum(self.lam[m] * self.gradZ[m, 1]))

    def axial_force_per_length(self, punch: int | None = None) -> float:
        m = self._sel(punch)
        return float(np.sum(self.lam[m] * self.gradZ[m, 0]))

    def edge_forces(self, punch: int | None = None) -> tuple[float, float]:
        """Nodal forces Λ (per unit circumferential length) at the two ends of the contact zone."""
        m = self.active & self._sel(punch)
        if not m.any():
            return 0.0, 0.0
        idx = np.flatnonzero(m)
        i0, i1 = idx[np.argmin(self.cx[idx])], idx[np.argmax(self.cx[idx])]
        return float(self.lam[i0]), float(self.lam[i1])

    def continuous_gap(self, punches: Sequence, x: np.ndarray, side: str = "outer") -> np.ndarray:
        """Π(x) of the first punch in ``punches`` at arbitrary x (to check penetration between nodes)."""
        sh = self.shell
        zeta = (1.0 if side == "outer" else -1.0) * sh.thickness / 2
        p = punches[0]
        Z, Zx, Zr = p.gap(x, np.full_like(x, sh.radius + zeta))
        return Z + Zx * (self.u(x) - zeta * self.w(x, 1)) + Zr * self.w(x)


# --------------------------------------------------------------------------------------------
# the solver
# --------------------------------------------------------------------------------------------
@dataclass
class Assembly:
    """The stiffness A (extended precision, full dof numbering) and load F of the 1D model on ``nodes``, with
    the dof map ([u nodal | w, w' nodal | u bubbles | w bubbles]), the slope scaling and the supported dofs."""

    A: sp.csr_matrix
    F: np.ndarray
    dofmap: np.ndarray
    scale: np.ndarray
    fixed: list
    nn: int
    nu: int
    ndof: int


def assemble(
    shell: Shell1D,
    nodes: np.ndarray,
    bc0: str,
    bc1: str,
    *,
    pressure: float | Callable[[np.ndarray], np.ndarray] = 0.0,
    rings: Sequence[tuple[float, float]] = (),
    pw: int = 5,
    pu: int = 5,
) -> Assembly:
    """The 1D model's stiffness and loads (module docstring); ``solve`` and the friction oracle build on it."""
    a, mu = shell.radius, shell.poisson
    ne, nn = len(nodes) - 1, len(nodes)
    nbu, nbw = pu - 1, pw - 3
    nu, nw = pu + 1, pw + 1
    # ---- dof map: [u nodal | w, w' nodal | u bubbles | w bubbles]
    e = np.arange(ne)
    ucols = [e, e + 1] + [3 * nn + e * nbu + k for k in range(nbu)]
    wcols = [nn + 2 * e, nn + 2 * e + 1, nn + 2 * e + 2, nn + 2 * e + 3]
    wcols += [3 * nn + ne * nbu + e * nbw + k for k in range(nbw)]
    dofmap = np.stack(ucols + wcols, -1)
    ndof = 3 * nn + ne * (nbu + nbw)
    h = np.diff(nodes)
    scale = np.ones((ne, nu + nw))
    scale[:, nu + 1] = h
    scale[:, nu + 3] = h
    # ---- reference values at Gauss points
    wpoly, upoly = _shape_polys(pw, pu)
    nq = pw + 3
    xi, wq = _gauss01(nq)  # extended precision: the stiffness must be accurate to eps·(βh)⁴ (see _Refined)
    hl = np.diff(nodes.astype(np.longdouble))
    sl = scale.astype(np.longdouble)
    sl[:, nu + 1] = hl
    sl[:, nu + 3] = hl
    W0 = np.stack([p(xi) for p in wpoly], -1)  # (nq, nw)
    W2 = np.stack([p.deriv(2)(xi) for p in wpoly], -1)
    U1 = np.stack([p.deriv(1)(xi) for p in upoly], -1)
    # strain operator S (ne, nq, 4, nu+nw): rows ε11, ε22, κ11, κ22
    S = np.zeros((ne, nq, 4, nu + nw), dtype=np.longdouble)
    sw = sl[:, None, nu:]
    S[:, :, 0, :nu] = U1[None] / hl[:, None, None]
    S[:, :, 1, nu:] = W0[None] * sw / a
    S[:, :, 2, nu:] = -W2[None] * sw / hl[:, None, None] ** 2
    S[:, :, 3, nu:] = -W0[None] * sw / a**2
    C = np.zeros((4, 4), dtype=np.longdouble)
    C[:2, :2] = shell.B * np.array([[1, mu], [mu, 1]])
    C[2:, 2:] = shell.D * np.array([[1, mu], [mu, 1]])
    CS = np.einsum("ij,eqjb->eqib", C, S)
    Ke = np.einsum("eq,eqia,eqib->eab", hl[:, None] * wq[None], S, CS)
    rows = np.repeat(dofmap, nu + nw, axis=1).ravel()
    cols = np.tile(dofmap, (1, nu + nw)).ravel()
    A = sp.csr_matrix((Ke.ravel(), (rows, cols)), shape=(ndof, ndof))
    # ---- loads
    F = np.zeros(ndof, dtype=np.longdouble)
    xq = nodes[:-1, None] + hl[:, None] * xi[None]
    qv = pressure(xq) if callable(pressure) else np.full_like(xq, float(pressure))
    Fe = np.einsum("eq,eq,qa,ea->ea", hl[:, None] * wq[None], qv, W0, sl[:, nu:])
    np.add.at(F, dofmap[:, nu:], Fe)
    for xr, P in rings:
        i = int(np.argmin(np.abs(nodes - xr)))
        if abs(nodes[i] - xr) > 1e-12 * max(1.0, abs(xr)):
            raise ValueError(f"ring load at x = {xr} is not on a mesh node")
        F[nn + 2 * i] += P
    # ---- supports
    fixed = []
    for bc, i in ((bc0, 0), (bc1, nn - 1)):
        if bc == "clamped":
            fixed += [i, nn + 2 * i, nn + 2 * i + 1]
        elif bc == "simply_supported":
            fixed += [nn + 2 * i]
        elif bc == "symmetry":
            fixed += [i, nn + 2 * i + 1]
    if 0 not in fixed and nn - 1 not in fixed:
        fixed.append(0)  # axial rigid motion: pin u(x0)
    return Assembly(A, F, dofmap, scale, fixed, nn, nu, ndof)


def solve(
    shell: Shell1D,
    nodes: np.ndarray,
    bc0: str = "clamped",
    bc1: str = "clamped",
    *,
    pressure: float | Callable[[np.ndarray], np.ndarray] = 0.0,
    rings: Sequence[tuple[float, float]] = (),
    punches: Sequence = (),
    side: str = "outer",
    pw: int = 5,
    pu: int = 5,
    tol: float = 1e-9,
    initial_active: Callable[[np.ndarray], np.ndarray] | None = None,
    w_band: tuple[float, float, float] | None = None,
    debug: bool = False,
) -> AxisymSolution:
    """Solve the axisymmetric problem on the mesh ``nodes`` (x0 = nodes[0], x1 = nodes[-1]).

    ``pressure`` q (outward, per unit area) is a number or a function of x; ``rings`` are
    (x, P) outward ring loads per unit circumferential length at mesh nodes; ``punches`` are
    CylinderPunch / TorusPunch acting on the ``side`` ("outer": ζ = +e, "inner": ζ = −e), with the
    constraint at every mesh node of their zones. ``initial_active(x) -> bool array`` overrides the
    NNLS starting guess; ``w_band = (x_lo, x_hi, w)`` prescribes w ≡ w on whole elements (a bilateral
    band, used by sleeve_free_boundary; its radial reaction is ``band_force``). Raises RuntimeError if the
    KKT residuals exceed ``tol``.
    """
    if bc0 not in SUPPORTS or bc1 not in SUPPORTS:
        raise ValueError(f"supports must be among {SUPPORTS}")
    if pw < 3 or pu < 1:
        raise ValueError("need pw >= 3 and pu >= 1")
    nodes = np.asarray(nodes, dtype=float)
    ok_ends = abs(nodes[0] - shell.x0) < 1e-12 and abs(nodes[-1] - shell.x1) < 1e-12
    if not (ok_ends and np.all(np.diff(nodes) > 1e-9 * (nodes[-1] - nodes[0]))):
        raise ValueError("nodes must increase from shell.x0 to shell.x1 (no duplicate nodes)")
    asm = assemble(shell, nodes, bc0, bc1, pressure=pressure, rings=rings, pw=pw, pu=pu)
    A, F, dofmap, scale, fixed = asm.A, asm.F, asm.dofmap, asm.scale, asm.fixed
    a, nn, nu, ndof = shell.radius, asm.nn, asm.nu, asm.ndof
    g0 = np.zeros(ndof, dtype=np.longdouble)
    band_values = np.zeros(0, int)
    if w_band is not None:  # w ≡ value on [x_lo, x_hi] (a continuous bilateral contact band)
        xlo, xhi, wval = w_band
        ib = np.flatnonzero((nodes >= xlo - 1e-12) & (nodes <= xhi + 1e-12))
        eb = np.flatnonzero((nodes[:-1] >= xlo - 1e-12) & (nodes[1:] <= xhi + 1e-12))
        if len(eb) == 0 or abs(nodes[ib[0]] - xlo) > 1e-12 or abs(nodes[ib[-1]] - xhi) > 1e-12:
            raise ValueError("w_band must span whole elements between mesh nodes")
        band_values = nn + 2 * ib
        bdofs = np.concatenate([band_values, band_values + 1, dofmap[eb, nu + 4 :].ravel()])
        g0[band_values] = wval
        fixed = sorted(set(fixed) | set(bdofs.tolist()))
    free = np.setdiff1d(np.arange(ndof), fixed)
    F0 = F - A @ g0
    Fr = F0[free]
    lu = _Refined(A[free][:, free])
    # ---- contact operator (sparse rows in the full dof numbering)
    zeta = (1.0 if side == "outer" else -1.0) * shell.thickness / 2
    cx, cp, G, grad, cnode = [], [], [], [], []
    for ip, p in enumerate(punches):
        z0, z1 = _zone(p)
        idx = np.flatnonzero((nodes >= z0 - 1e-12) & (nodes <= z1 + 1e-12))
        xs = nodes[idx]
        Z, Zx, Zr = p.gap(xs, np.full_like(xs, a + zeta))
        cx += list(xs)
        cp += [ip] * len(idx)
        G += list(Z)
        grad += list(zip(Zx, Zr))
        cnode += list(idx)
    m = len(G)
    cx, cp, G, cnode = np.array(cx), np.array(cp, int), np.array(G), np.array(cnode, int)
    grad = np.array(grad).reshape(-1, 2)
    if len(set(cnode.tolist())) != m:
        raise ValueError("candidate zones of different punches overlap")
    wdof = nn + 2 * cnode
    rows = np.repeat(np.arange(m), 3)
    cols = np.stack([cnode, wdof + 1, wdof], -1).ravel()
    vals = np.stack([grad[:, 0], -zeta * grad[:, 0], grad[:, 1]], -1).ravel() if m else np.zeros(0)
    Bfull = sp.csr_matrix((vals, (rows, cols)), shape=(m, ndof))
    fixed_mask = np.zeros(ndof, bool)
    fixed_mask[fixed] = True
    if m and np.any(fixed_mask[wdof]):
        raise ValueError("a support fixes w inside a candidate contact zone; shorten the zone")
    if m and np.any(np.abs(grad[:, 1]) < 0.05):
        raise ValueError("|Z_rho| too small at a constraint node: the punch touches the shell edge-on")

    def solve_active(act: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Eliminate w at the active nodes (Π_i = 0), solve the SPD reduced system; return U, Λ."""
        slaves = wdof[act]
        master = free[~np.isin(free, slaves)]
        T = sp.lil_matrix((ndof, len(master)))
        pos = -np.ones(ndof, int)
        pos[master] = np.arange(len(master))
        T[master, np.arange(len(master))] = 1.0
        g = g0.copy()
        for i in np.flatnonzero(act):
            zx, zr = grad[i]
            g[wdof[i]] = -G[i] / zr
            for d, cval in ((cnode[i], -zx / zr), (wdof[i] + 1, zeta * zx / zr)):
                if pos[d] >= 0 and cval != 0.0:
                    T[wdof[i], pos[d]] = cval
        T = T.tocsr().astype(np.longdouble)
        K = T.T @ A @ T
        Um = _Refined(K).solve(T.T @ (F - A @ g))
        U = T @ Um + g
        r = A @ U - F
        lam = np.zeros(m)
        lam[act] = (r[wdof[act]] / grad[act, 1]).astype(float)
        return U, lam

    iterations, method = 0, "linear"
    if m:
        if initial_active is None:
            act = _dual_nnls_guess(lu, Bfull[:, free], G, Fr)
        else:
            act = np.asarray(initial_active(cx), bool)
        gtol = 1e-13 * max(np.max(np.abs(G)), 1e-300)
        # Lawson–Hanson active-set method on the dual (finite, monotone), every subproblem solved exactly by
        # elimination; S = B A⁻¹ Bᵀ is never used. Start: the guess, pruned until its multipliers are positive.
        method = "lawson-hanson"
        while True:
            U, lam = solve_active(act)
            bad = act & (lam <= 0)
            if not bad.any():
                break
            act &= ~bad
        x = lam.copy()
        it = 0
        while True:
            gap = (G + Bfull @ U).astype(float)
            cand = ~act & (gap < -gtol)
            if not cand.any():
                break
            it += 1
            if it > 20 * m + 50:
                raise RuntimeError(f"axisymmetric oracle: active set did not settle in {it} iterations")
            act[np.argmin(np.where(cand, gap, np.inf))] = True
            while True:
                Uz, z = solve_active(act)
                neg = act & (z <= 0)
                if not neg.any():
                    U, x = Uz, z
                    break
                ratio = np.where(neg, x / np.where(neg, x - z, 1.0), np.inf)
                al = float(np.min(ratio))
                x = x + al * (z - x)
                U = U + al * (Uz - U)
                act &= ~(neg & (ratio <= al * (1 + 1e-12)))
                x[~act] = 0.0
            if debug:
                print(it, int(act.sum()))
        lam = x
        iterations = it
    else:
        U = g0.copy()
        U[free] = lu.solve(Fr)
        lam, gap = np.zeros(0), np.zeros(0)
    kkt: dict = {}
    if m:
        r = (A @ U - F - Bfull.T @ lam)[free]
        # normwise backward error: the residual against the size of the terms that cancel in it
        absA = abs(A)
        fs = np.linalg.norm((absA @ np.abs(U) + np.abs(F) + abs(Bfull).T @ np.abs(lam))[free])
        fs = max(fs, 1e-300)
        gscale = max(np.max(np.abs(G)), 1e-300)
        lscale = max(np.max(np.abs(lam)), 1e-300)
        kkt = {
            "stationarity": float(np.linalg.norm(r) / fs),
            "penetration": float(max(0.0, -gap.min()) / gscale),
            "dual_feasibility": float(max(0.0, -lam.min()) / lscale),
            "complementarity": float(np.max(np.abs(lam * gap)) / (lscale * gscale)),
        }
    energy = float(0.5 * U @ (A @ U) - F @ U)
    U = U.astype(float)
    sol = AxisymSolution(shell, nodes, U, energy, dofmap, scale, pw, pu, iterations=iterations, method=method)
    # reaction of the band: the work of the residual on a unit radial translation of the band
    sol.band_force = float(np.sum((A @ U - F)[band_values]))
    if m:
        sol.cx, sol.cpunch, sol.lam, sol.gap, sol.gradZ = cx, cp, lam, gap, grad
        sol.active = lam > 0
        sol.kkt = kkt
        bad = {k: v for k, v in kkt.items() if v > tol}
        if bad:
            raise RuntimeError(f"axisymmetric oracle: KKT not satisfied: {kkt}")
    return sol


def _dual_nnls_guess(lu: _Refined, Bf: sp.csr_matrix, G: np.ndarray, Fr: np.ndarray) -> np.ndarray:
    """Active-set guess from the dual QP  min ½ΛᵀSΛ − hᵀΛ, Λ ≥ 0  (S = B A⁻¹ Bᵀ, h = −(G + B A⁻¹F)) solved by
    Lawson–Hanson NNLS: finite and robust where a primal–dual active set creeps one node per iteration
    (fourth-order obstacle problems). The exact solution is then polished by the active-set loop."""
    X = lu.solve(np.asarray(Bf.T.todense(), dtype=np.longdouble))
    S = np.asarray(Bf @ X, dtype=float)
    S = 0.5 * (S + S.T)
    h = -np.asarray(G + Bf @ lu.solve(Fr), dtype=float)
    w, V = np.linalg.eigh(S)
    w = np.maximum(w, w.max() * 1e-15)
    R = (V * np.sqrt(w)).T  # S ≈ RᵀR
    lam, _ = sopt.nnls(R, V.T @ h / np.sqrt(w), maxiter=20 * len(h))
    return lam > 0


class _Refined:
    """Sparse LU of an SPD stiffness (cond ~ (βh)⁻⁴) with mixed-precision iterative refinement: the
    residual is accumulated in extended precision (np.longdouble), so the forward error is ~ eps_64 as long
    as cond · eps_64 < 1, instead of cond · eps_64."""

    def __init__(self, A: sp.spmatrix) -> None:
        self.A = sp.csr_matrix(A, dtype=np.longdouble)
        self.lu = spla.splu(sp.csc_matrix(self.A, dtype=float))

    def solve(self, b: np.ndarray) -> np.ndarray:
        bl = np.asarray(b, dtype=np.longdouble)
        x = self.lu.solve(np.asarray(b, dtype=float)).astype(np.longdouble)
        for _ in range(4):
            x += self.lu.solve(np.asarray(bl - self.A @ x, dtype=float))
        return x


# --------------------------------------------------------------------------------------------
# a sharper reference for the sleeve: the free boundary located exactly
# --------------------------------------------------------------------------------------------
@dataclass
class SleeveSolution:
    """Half model (symmetry at x0) pressed by a sleeve on [x0, c]: contact on the band [x0, x_t] and on the
    ring x = c, found with x_t as an unknown (moment continuity w''(x_t+) = 0), not at mesh nodes."""

    x_t: float  # end of the contact band
    band_pressure: float  # p = k δ' + μ N/a inside the band (force per unit area)
    ring_band: float  # ring force at x_t (per unit circumferential length)
    ring_edge: float  # ring force at the sleeve edge x = c
    force_per_length: float  # Σ: band reaction (incl. the ring at x_t) + ring at c
    total_normal_force: float  # 2πa × force_per_length
    N: float  # axial force N11 (constant)
    solution: AxisymSolution


def sleeve_free_boundary(
    shell: Shell1D,
    radius: float,
    c: float,
    bc1: str = "clamped",
    side: str = "outer",
    h_min: float = 0.002,
    h_max: float = 0.02,
    pw: int = 5,
    bracket: tuple[float, float] | None = None,
) -> SleeveSolution:
    """Exact contact topology [x0, x_t] ∪ {c} for a sleeve of inner ``radius`` (``side`` = "outer") or a
    plug of outer ``radius`` ("inner") on [x0, c], symmetry at x0. Inside the band w ≡ w_b = ±(radius − a ∓ e);
    x_t solves w''(x_t+) = 0 (no concentrated moment). All sign conditions are verified (KKT), else ValueError."""
    from scipy.optimize import brentq

    a, e, mu = shell.radius, shell.thickness / 2, shell.poisson
    sgn = 1.0 if side == "outer" else -1.0
    wb = radius - (a + sgn * e)  # prescribed w in the band (negative for an interference sleeve)
    punch = [CylinderPunch(radius, (c, c), inverted=side == "outer")]

    def run(xt: float) -> AxisymSolution:
        nodes = graded_nodes(shell.x0, shell.x1, [xt, c], h_min=h_min, h_max=h_max, ratio=1.3)
        return solve(shell, nodes, "symmetry", bc1, punches=punch, side=side, w_band=(shell.x0, xt, wb), pw=pw, pu=pw)

    lo, hi = bracket if bracket is not None else (shell.x0 + 0.02 * (c - shell.x0), c - 0.02 * (c - shell.x0))
    xs = np.linspace(lo, hi, 12)
    vals = np.array([run(x).w(x + 1e-13, 2)[0] for x in xs])
    k = np.flatnonzero(np.sign(vals[:-1]) != np.sign(vals[1:]))
    if len(k) == 0:
        raise ValueError("sleeve_free_boundary: no band end with w''(x_t+) = 0 in the bracket")
    xt = brentq(lambda x: run(x).w(x + 1e-13, 2)[0], xs[k[0]], xs[k[0] + 1], xtol=1e-14, rtol=1e-15)
    s = run(xt)
    N = float(s.N11(0.5 * (shell.x0 + xt))[0])
    p = -sgn * (shell.k * wb + mu * N / a)  # contact pressure in the band (q_contact = k w + μN/a, inward)
    band = -sgn * s.band_force  # magnitude of the band reaction (per unit circumferential length)
    ring_band = band - p * (xt - shell.x0)
    ring_edge = float(s.lam[0]) if len(s.lam) else 0.0
    x = np.linspace(xt, c, 400)
    gap = sgn * (wb - s.w(x))
    if p < 0 or ring_band < -1e-9 * band or ring_edge < 0 or gap.min() < -1e-12 * abs(wb):
        raise ValueError(
            f"sleeve_free_boundary: topology [x0, x_t] + ring at c violates KKT (p={p}, ring_band={ring_band}, "
            f"ring_edge={ring_edge}, min gap={gap.min()})"
        )
    fpl = band + ring_edge
    return SleeveSolution(xt, p, ring_band, ring_edge, fpl, 2 * math.pi * a * fpl, N, s)
