"""Friction on the contact face: the tangential operator C, slides and the Tresca / Coulomb bounds
(MODEL.md §11; docs/theory.md "Friction").

At every constraint row i of the contact operator (``contact.ContactOperator``) the punch's unit normal
is ν_i = ∇Z(M_i)/|∇Z(M_i)| and (τ_i1, τ_i2) an orthonormal basis of its tangent plane: τ_i1 is the shell's
axis e_x projected on the plane (e2(φ_i) where the axis is within 25° of ν_i), τ_i2 = ν_i × τ_i1. The two
tangential rows of point i give τ_ik·U(M_i), U(M) the Kirchhoff displacement of the face point with the
±(t/2)·∇w offset terms (``contact.surface_rows``, the same kinematics as B). Rows are interleaved: row
2i + k of C is τ_ik·U(M_i), so that point i's pair is C[2i:2i+2].

A slide s (a rigid translation of the punch tangent to its surface) makes the shell's slip relative to
the punch σ_i = C_i U − c_i with c_i = (τ_i1·s, τ_i2·s). The law on the nodal tangential force T_i (N, on
the shell): |T_i| ≤ g_i, stick σ_i = 0 where |T_i| < g_i, slip σ_i = −β_i T_i (β_i ≥ 0) where |T_i| = g_i.
Tresca: g_i = ω_i g (g in Pa); Coulomb: g_i = μ Λ_i |∇Z(M_i)|.

API::

    top = tangential_operator(space, op)        # TangentialOperator: C (2m × ndofs), tau (2, 3, m)
    top.offsets(slides)                         # c (2m,) from one slide (3,) per punch (m)
    top.tresca_bounds(op.weights, bound)        # g_i = ω_i g (N)
    top.coulomb_bounds(op, Lam, mu)             # g_i = μ Λ_i |∇Z_i| (N)
    top.force(T), top.states(T, slip, g), top.summary(op, T, slip, g)
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import scipy.sparse as sp

from ..errors import InputError
from ..shell.spaces import ShellSpace
from .operator import ContactOperator, surface_rows

#: below this |e_x × ν| the axis is (nearly) normal to the punch and τ1 comes from the circumferential e2
AXIS_NEAR_NORMAL = np.sin(np.radians(25.0))


def tangent_basis(grad: np.ndarray, phi: np.ndarray) -> np.ndarray:
    """(2, 3, m): the orthonormal tangent vectors (τ1, τ2) of the punch at rows with gradient ``grad`` (3, m)."""
    nu = grad / np.linalg.norm(grad, axis=0)
    ex = np.zeros_like(nu)
    ex[0] = 1.0
    e2 = np.stack([np.zeros_like(phi), -np.sin(phi), np.cos(phi)])
    ref = np.where(np.linalg.norm(np.cross(ex.T, nu.T).T, axis=0) > AXIS_NEAR_NORMAL, ex, e2)
    t1 = ref - np.sum(ref * nu, axis=0) * nu
    t1 /= np.linalg.norm(t1, axis=0)
    t2 = np.cross(nu.T, t1.T).T
    return np.stack([t1, t2])


@dataclass
class TangentialOperator:
    """The tangential rows of every contact row (module docstring)."""

    C: sp.csr_matrix  # (2m, ndofs), full dof vector; rows 2i, 2i+1 = τ_i1, τ_i2 · U(M_i)
    tau: np.ndarray  # (2, 3, m) tangent vectors
    punch: np.ndarray  # (m,) punch of each row

    @property
    def m(self) -> int:
        return int(self.tau.shape[2])

    def offsets(self, slides: Sequence[np.ndarray | None]) -> np.ndarray:
        """c (2m,): the punches' slides (one (3,) vector per punch, m; None = no slide) on the tangent pairs."""
        c = np.zeros((self.m, 2))
        for k, s in enumerate(slides):
            if s is None:
                continue
            r = self.punch == k
            c[r] = np.einsum("kdi,d->ik", self.tau[:, :, r], np.asarray(s, float))
        return c.ravel()

    def tresca_bounds(self, weights: np.ndarray, bound: np.ndarray | float) -> np.ndarray:
        """g_i = ω_i g (N) for a Tresca bound g (Pa; a scalar or one per row)."""
        g = np.broadcast_to(np.asarray(bound, float), (self.m,))
        if np.any(~np.isfinite(g)) or np.any(g < 0):
            raise InputError("friction.bound", "must be a finite number ≥ 0 (Pa)")
        return np.asarray(weights, float) * g

    @staticmethod
    def coulomb_bounds(op: ContactOperator, Lam: np.ndarray, mu: np.ndarray | float) -> np.ndarray:
        """g_i = μ Λ_i |∇Z(M_i)| (N): μ × the normal nodal force (μ a scalar or one per row)."""
        return np.asarray(mu, float) * np.maximum(Lam, 0.0) * np.linalg.norm(op.grad, axis=0)

    def vectors(self, T: np.ndarray) -> np.ndarray:
        """(3, m): the tangential nodal forces T_i1 τ_i1 + T_i2 τ_i2 (N) as global vectors."""
        T = np.asarray(T, float).reshape(self.m, 2)
        return self.tau[0] * T[:, 0] + self.tau[1] * T[:, 1]

    def force(self, T: np.ndarray) -> np.ndarray:
        """(npunch, 3): the friction force on the shell per punch, Σ_i T_i (N)."""
        V = self.vectors(T)
        npunch = int(self.punch.max(initial=-1)) + 1
        return np.array([V[:, self.punch == k].sum(axis=1) for k in range(npunch)]).reshape(npunch, 3)

    def states(self, T: np.ndarray, g: np.ndarray, Lam: np.ndarray | None = None, rtol: float = 1e-6) -> np.ndarray:
        """Per row: 0 open (Λ_i = 0 where Λ is given, or no bound), 1 stick (|T_i| < g_i), 2 slip (|T_i| = g_i)."""
        t = np.linalg.norm(np.asarray(T, float).reshape(self.m, 2), axis=1)
        g = np.asarray(g, float)
        out = np.where(t >= (1.0 - rtol) * g, 2, 1)
        closed = g > 0 if Lam is None else (np.asarray(Lam) > 0) & (g > 0)
        return np.where(closed, out, 0)

    def summary(self, weights: np.ndarray, T: np.ndarray, slip: np.ndarray, g: np.ndarray,
                Lam: np.ndarray | None = None) -> list[dict]:
        """Per punch: ``force`` (N, vector on the shell), ``stick_area``, ``slip_area`` (m², Σ ω_i of the rows)
        and ``max_slip`` (m, the largest |σ_i|)."""
        state = self.states(T, g, Lam)
        s = np.linalg.norm(np.asarray(slip, float).reshape(self.m, 2), axis=1)
        out = []
        for k, f in enumerate(self.force(T)):
            r = self.punch == k
            out.append({"force": [float(v) for v in f],
                        "stick_area": float(weights[r & (state == 1)].sum()),
                        "slip_area": float(weights[r & (state == 2)].sum()),
                        "max_slip": float(s[r].max(initial=0.0))})
        return out


def tangential_operator(space: ShellSpace, op: ContactOperator) -> TangentialOperator:
    """The tangential rows of the contact operator ``op`` on ``space`` (module docstring)."""
    tau = tangent_basis(op.grad, op.phi)
    s = op.phi * space.mesh.shell.radius
    C1, C2 = (surface_rows(space, op.x, s, op.zeta, op.vertex, tau[k]) for k in range(2))
    m = op.m
    order = np.arange(2 * m).reshape(2, m).T.ravel()  # interleave: row 2i + k ← block k, row i
    C = sp.vstack([C1, C2], format="csr")[order]
    return TangentialOperator(C=C, tau=tau, punch=op.punch.copy())


#: the Coulomb fixed point stops when the bounds change by less than this, relative to the largest bound
COULOMB_TOL = 1e-9
#: a measured contraction factor above this gets the ``friction_contraction`` warning: the fixed point (and the
#: static Coulomb problem's uniqueness, which it proves when below 1) is then in doubt
COULOMB_CONTRACTION = 0.9


@dataclass
class CoulombRecord:
    """The fixed point g^{k+1} = μ Λ(g^k) |∇Z| of Tresca problems (MODEL.md §11): per iteration the change
    ‖g^{k+1} − g^k‖∞ (N), and the contraction factor q, the geometric mean ratio of successive changes."""

    iterations: int
    changes: list[float]
    #: where the semismooth Newton on the whole law converged (no fixed point ran: ``newton``), that of the map at
    #: its solution from two probing Tresca solves (``probed_contraction``); None where nothing measured it
    contraction: float | None
    converged: bool
    #: the bounds returned to an earlier iterate's exactly (a cycle of contact sets: the Tresca bound on the
    #: contact set then has no solution among them, docs/theory.md §9a); the fixed point stopped there
    cycle: bool = False
    #: "none" (g^{k+1} = G(g^k)) or "anderson" (``anderson_step``)
    acceleration: str = "none"
    #: the semismooth Newton on the whole law tried first (``solvers.coulomb_newton``): its iterations, whether it
    #: converged, and why not (``fallback``: then the fixed point above ran); None where it was not tried
    newton: dict | None = None

    def summary(self) -> dict:
        out = {"iterations": self.iterations, "contraction": self.contraction, "converged": self.converged,
               "cycle": self.cycle, "changes_N": self.changes, "acceleration": self.acceleration}
        if self.newton is not None:
            out["newton"] = self.newton
        return out


#: the fixed point's change (relative to the largest bound) below which ``solve_coulomb`` tries its ``polish``
POLISH_BELOW = 1e-2
#: iterates Anderson's mixing remembers
ANDERSON_DEPTH = 5


def anderson_step(gs: list[np.ndarray], Gs: list[np.ndarray]) -> np.ndarray:
    """The next bounds by Anderson's mixing (type II, Walker & Ni, SIAM J. Numer. Anal. 49 (2011) 1715) of the
    last iterates g_k and their images G(g_k): G_k − ΔG γ with γ the least-squares fit of the residual
    f_k = G_k − g_k by the residuals' differences Δf; clipped at 0 (a bound is ≥ 0). One iterate: G_k."""
    if len(gs) < 2:
        return Gs[-1]
    f = [G - g for g, G in zip(gs, Gs)]
    dF = np.stack([f[i + 1] - f[i] for i in range(len(f) - 1)], axis=1)
    dG = np.stack([Gs[i + 1] - Gs[i] for i in range(len(Gs) - 1)], axis=1)
    gamma = np.linalg.lstsq(dF, f[-1], rcond=1e-12)[0]
    return np.maximum(Gs[-1] - dG @ gamma, 0.0)


def solve_coulomb(qp, C: sp.csr_matrix, c: np.ndarray, bounds: Callable[[np.ndarray], np.ndarray],
                  tresca: Callable, max_iterations: int = 50, fixed_point_tol: float = COULOMB_TOL,
                  warm: Callable[[Any], dict] | None = None, start: Any = None, accelerate: bool = False,
                  polish: Callable[[Any], Any] | None = None, **solver_options):
    """Friction whose bounds depend on the normal forces, g = bounds(Λ), by the fixed point on Tresca problems:
    g^0 = bounds(Λ) of the frictionless solution (``tresca`` with g = 0), g^{k+1} = bounds(Λ^k), until
    ‖g^{k+1} − g^k‖∞ ≤ fixed_point_tol·‖g^{k+1}‖∞. Coulomb: bounds(Λ) = μ |∇Z| Λ
    (``TangentialOperator.coulomb_bounds``).
    ``tresca`` is ``solvers.tresca.solve_tresca_dual`` or ``solve_tresca_penalty`` (its keyword options in
    ``solver_options``); ``warm(solution)`` gives the options that start the next solve from the last one. The
    contraction factor (geometric mean) is measured on the changes above 1000·fixed_point_tol (below, the
    solver's round-off decides).
    ``start``: the frictionless solution, when the caller has it (then not solved again), or another start (the
    whole-law Newton's best iterate: g^0 = bounds of its Λ). ``accelerate``: the
    next bounds by ``anderson_step`` of the last ``ANDERSON_DEPTH`` iterates (the plain iteration alternated and
    contracted by 0.72 only, 50 iterations without converging, Coulomb μ = 0.3 at 16.8k unknowns); the
    contraction is then that of the map G itself, the largest |G(g_k) − G(g_{k−1})|∞ / |g_k − g_{k−1}|∞ above the
    floor (``_contraction``). ``polish(solution)``: once a change is below ``POLISH_BELOW``·‖G‖∞, a solver of the
    whole law from that iterate (``solvers.coulomb_newton``), returning its solution or None where it did not
    converge; a solution ends the fixed point (converged: it satisfies the law itself).
    Returns the last Tresca solution and a ``CoulombRecord``."""
    sol = start if start is not None else tresca(qp, C, c, np.zeros(qp.m), **solver_options)
    G = bounds(sol.Lambda)
    g = G
    changes: list[float] = []
    gs: list[np.ndarray] = []
    Gs: list[np.ndarray] = []
    converged = cycle = False
    tried = np.inf  # the change at the last polish
    seen = {g.tobytes()}
    for _ in range(max_iterations):
        sol = tresca(qp, C, c, g, **solver_options, **(warm(sol) if warm is not None else {}))
        G = bounds(sol.Lambda)
        changes.append(float(np.abs(G - g).max(initial=0.0)))
        gs.append(g)
        Gs.append(G)
        if changes[-1] <= fixed_point_tol * max(float(G.max(initial=0.0)), 1e-300):
            g, converged = G, True
            break
        if (polish is not None and changes[-1] <= POLISH_BELOW * max(float(G.max(initial=0.0)), 1e-300)
                and changes[-1] <= 0.5 * tried):  # again only once the change has halved since the last try
            tried = changes[-1]  # (216k unknowns: a try at each of 31 iterations, 6 failed steps each)
            polished = polish(sol)
            if polished is not None:
                sol, converged = polished, True
                G = bounds(sol.Lambda)
                break
        g = anderson_step(gs[-ANDERSON_DEPTH - 1:], Gs[-ANDERSON_DEPTH - 1:]) if accelerate else G
        if g.tobytes() in seen:  # back to earlier bounds: the same solves again (a cycle of contact sets)
            cycle = True
            break
        seen.add(g.tobytes())
    record = CoulombRecord(len(changes), changes, _contraction(changes, gs, Gs, fixed_point_tol, g, accelerate),
                           converged, cycle, "anderson" if accelerate else "none")
    sol.info["bounds_used"] = sol.info["bounds"]
    sol.info["bounds"] = G  # the bounds of the final multipliers (equal to those used, to tol, when converged)
    return sol, record


def _contraction(changes: list[float], gs: list[np.ndarray], Gs: list[np.ndarray], tol: float, g: np.ndarray,
                 accelerate: bool) -> float:
    """The fixed point's contraction factor q (``solve_coulomb``), from the changes above 1000·tol·max g."""
    floor = 1e3 * tol * max(float(g.max(initial=0.0)), 1e-300)
    if not accelerate:
        above = [d for d in changes if d > floor]  # the geometric mean ratio: the changes oscillate (×1.7 in
        # one step, ×0.75 on average over 46 iterations on the 32 × 32 panel), the largest ratio would mislead
        return float((above[-1] / above[0]) ** (1.0 / (len(above) - 1))) if len(above) > 1 else 0.0
    ratios = [float(np.abs(Gs[i + 1] - Gs[i]).max() / np.abs(gs[i + 1] - gs[i]).max())
              for i in range(len(gs) - 1) if np.abs(gs[i + 1] - gs[i]).max() > floor]
    # the largest: Anderson's iterates probe G along few directions, and a mean of them hid a 2-cycle of the
    # plain iteration (μ = 5 on the 8 × 8 panel: ratios 0.24–1.75, geometric mean 0.48)
    return max(ratios, default=0.0)


#: the probes' relative size: the ratios agree to 3 digits for 1e-2 … 1e-6 of the largest bound, every probe
#: keeping the closed set (8 × 8 panel, 1 mm slide, μ = 0.3 and 5)
PROBE_SIZE = 1e-4
PROBE_SOLVES = 2  # ``probed_contraction``'s Tresca solves: its two probe directions


def probed_contraction(qp, C: sp.csr_matrix, c: np.ndarray, bounds: Callable[[np.ndarray], np.ndarray],
                       tresca: Callable, solution: Any, warm: Callable[[Any], dict], **solver_options) -> float:
    """The contraction q of the fixed-point map G(g) = bounds(Λ(Tresca with g)) at a solution of the whole law
    (where the semismooth Newton converged, no fixed point ran to measure it): g* = bounds(Λ*) = G(g*), and
    q = max ‖G(g* + δ) − g*‖∞ / ‖δ‖∞ over two probes δ = ``PROBE_SIZE``·g*·s, s = 1 (every bound up) and
    s = ±1 alternating by row (half of them down: a 2-cycle's direction), each a Tresca solve warm-started from
    the solution (2–3 iterations of the Tresca Newton). A lower bound of ‖DG‖∞ as the fixed point's is, the same
    test (q > ``COULOMB_CONTRACTION``) applies; 8 × 8 panel, 1 mm slide: 0.081 at μ = 0.3, 2.34 at μ = 5."""
    g = bounds(solution.Lambda)
    signs = np.where(np.arange(g.size) % 2, -1.0, 1.0)
    ratios = []
    for s in (np.ones_like(g), signs):
        probe = np.maximum(g * (1.0 + PROBE_SIZE * s), 0.0)
        step = float(np.abs(probe - g).max(initial=0.0))
        if step == 0.0:  # no friction bound anywhere
            return 0.0
        out = tresca(qp, C, c, probe, **solver_options, **warm(solution))
        ratios.append(float(np.abs(bounds(out.Lambda) - g).max()) / step)
    return max(ratios)
