"""KKT residuals and duality gap of the contact QP (MODEL.md §8), shared by every solver.

Residuals (``kkt_residuals``), with g = G + BU (+ Dδ) and r = AU − F − BᵀΛ:

* stationarity      ‖r‖ / ‖F + BᵀΛ‖                             (dimensionless)
* penetration       max_i [g_i]₋                                   (length, absolute)
* dual_feasibility  max_i |min(Λ_i, 0)|                            (force, absolute)
* complementarity   max_i |Λ_i g_i| / W,  W = max(½UᵀAU, |FᵀU|, |Pᵀδ|): the largest work
                    done by one nodal force across its gap, relative to the energy scale
* duality_gap       |𝓔(U) − q(Λ)| / |𝓔(U)|, q(Λ) = −½(F+BᵀΛ)ᵀA⁻¹(F+BᵀΛ) − ΛᵀG
* force_balance     ‖DᵀΛ + P‖ / max(‖P‖, ‖|D|ᵀΛ‖, Λ_ref)   (force control and floating shells)

Λ_ref (``schur.Workspace.force_scale``; here from ``max_flexibility`` = max S_ii) is the problem's own force
scale: the force that closes the length scale at the most flexible row, length scale / max S_ii. Without it a zero
answer (a shell pushed rigidly by its only punch: P = 0, Λ = 0) measured its round-off (Λ ≈ 6e-14 N)
against itself and never converged; a force below tol·Λ_ref changes no gap by more than tol·length scale.
The floor also bounds the dual feasibility's scale (max(‖Λ‖∞, Λ_ref)), the energy scale of
complementarity and the duality gap (½ Λ_ref × length scale) and the stationarity's (Λ_ref max_i ‖B_i‖).

The gap is evaluated through the exact identity 𝓔(U) − q(Λ) = Λᵀg + ½ rᵀA⁻¹r − (P + DᵀΛ)ᵀδ,
which avoids subtracting two nearly equal energies (``dual_value`` computes q directly; the
tests check both agree). Convergence (``KKTReport.converged``) asks every *scaled* residual
to be ≤ tol: penetration relative to the length scale max(max(−G)₊, ‖BU + Dδ‖∞) (``length_scale``), dual
feasibility relative to ‖Λ‖∞, stationarity as the normwise backward error
‖r‖ / ‖ |A||U| + |F| + |Bᵀ||Λ| ‖ (the forward form ‖r‖/‖F + BᵀΛ‖ has a round-off floor
ε_mach·‖|A||U|‖/‖F + BᵀΛ‖, which reaches 1e-10 already for a 128-element clamped beam:
conditioning ~h⁻⁴), the others as above. The dict ``residuals`` always holds the forms above.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..linalg import Factorization, factorize
from .qp import ContactQP

TINY = 1e-300


@dataclass
class KKTReport:
    residuals: dict[str, float]
    scaled: dict[str, float]
    gap: np.ndarray
    energy: float
    dual_value: float
    lscale: float  # the length scale of the scaled penetration (``length_scale``)

    def converged(self, tol: float) -> bool:
        return all(v <= tol for v in self.scaled.values())

    def worst(self) -> str:
        return max(self.scaled, key=self.scaled.get)


def evaluate(
    qp: ContactQP,
    U: np.ndarray,
    Lambda: np.ndarray,
    delta: np.ndarray | None = None,
    factorization: Factorization | None = None,
    AU: np.ndarray | None = None,
    Ainv_r: np.ndarray | None = None,
    absA_absU: np.ndarray | None = None,
    max_flexibility: float = 0.0,
) -> KKTReport:
    """All residuals, their scaled forms, the energy and the dual value (see module doc). ``AU`` (= A U),
    ``Ainv_r`` (= A⁻¹r for r = AU − F − BᵀΛ) and ``absA_absU`` (= |A||U|) may be given when computed already,
    for several points at once (``screening.solve_screened_curve``: block products and one block solve for
    every point of a curve). ``max_flexibility``: the largest S_ii
    known, for Λ_ref of the module docstring (0: no floor)."""
    if qp.k and delta is None:
        delta = np.zeros(qp.k)
    BtL = qp.B.T @ Lambda
    AU = qp.A @ U if AU is None else AU
    rhs = qp.F + BtL
    r = AU - rhs
    g = qp.gap(U, delta)
    stat = float(np.linalg.norm(r) / max(np.linalg.norm(rhs), np.linalg.norm(AU), TINY))
    pen = float(max(0.0, -g.min())) if g.size else 0.0
    dfeas = float(max(0.0, -Lambda.min())) if Lambda.size else 0.0
    uau = float(U @ AU)
    fu = float(qp.F @ U)
    pd = float(qp.P @ delta) if qp.k else 0.0
    energy = 0.5 * uau - fu - pd
    lscale = length_scale(qp, g)
    force_floor = lscale / max_flexibility if max_flexibility > 0.0 else TINY
    wfloor = max(0.5 * force_floor * lscale, TINY)  # the work of Λ_ref across the length scale
    wscale = max(0.5 * abs(uau), abs(fu), abs(pd), wfloor)
    comp = float(np.max(np.abs(Lambda * g)) / wscale) if g.size else 0.0
    if Ainv_r is None and np.any(r):
        Ainv_r = (factorization if factorization is not None else factorize(qp.A)).solve(r)
    corr = 0.5 * float(r @ Ainv_r) if np.any(r) else 0.0
    gap_value = float(Lambda @ g) + corr
    res = {
        "stationarity": stat,
        "penetration": pen,
        "dual_feasibility": dfeas,
        "complementarity": comp,
    }
    if qp.k:
        fb = qp.D.T @ Lambda + qp.P
        gap_value -= float(fb @ delta)
        res["duality_gap"] = abs(gap_value) / max(abs(energy), wfloor)
        # gross, not net: the net DᵀΛ of a floating shell's rigid mode without load (P = 0) is round-off
        fscale = max(np.linalg.norm(qp.P), np.linalg.norm(abs(qp.D).T @ np.abs(Lambda)), force_floor, TINY)
        res["force_balance"] = float(np.linalg.norm(fb) / fscale)
    else:
        res["duality_gap"] = abs(gap_value) / max(abs(energy), wfloor)
    lam_scale = max(float(np.abs(Lambda).max()) if qp.m else 0.0, force_floor, TINY)
    scaled = dict(res)
    mag = (qp.abs_A @ np.abs(U) if absA_absU is None else absA_absU) + np.abs(qp.F) + abs(qp.B).T @ np.abs(Lambda)
    sfloor = force_floor * largest_row_norm(qp.B) if max_flexibility > 0.0 else TINY
    scaled["stationarity"] = float(np.linalg.norm(r) / max(np.linalg.norm(mag), sfloor, TINY))
    scaled["penetration"] = pen / lscale
    scaled["dual_feasibility"] = dfeas / lam_scale
    return KKTReport(residuals=res, scaled=scaled, gap=g, energy=energy, dual_value=energy - gap_value,
                     lscale=lscale)


def largest_row_norm(B) -> float:
    """max_i ‖B_i‖: the most one row's unit force exerts on the dofs (Λ_ref times it: the stationarity's floor)."""
    return float(np.sqrt(np.asarray(B.multiply(B).sum(axis=1)).max(initial=0.0))) if B.shape[0] else 0.0


def length_scale(qp: ContactQP, g: np.ndarray) -> float:
    """max(max(−G)₊, ‖g − G‖∞): the largest prescribed overlap and the largest displacement of a
    constraint point towards its punch (B U + D δ); the scaled penetration is relative to it.

    Positive gaps are not a scale of the contact: with max|G| (the far rows of a zone) an
    indentation of 1e-12 on a zone 0.02 deep passed as "penetration 5e-11 relative" at Λ = 0. Every
    penetrating row has |G_i| ≤ this scale (G_i > 0 needs (BU)_i < −G_i), so the round-off of its
    gap G_i + (BU)_i is a few ε times the scale."""
    if not qp.m:
        return TINY
    return max(float(max(-qp.G.min(), 0.0)), float(np.abs(g - qp.G).max()), TINY)


def kkt_residuals(
    qp: ContactQP,
    U: np.ndarray,
    Lambda: np.ndarray,
    delta: np.ndarray | None = None,
    factorization: Factorization | None = None,
) -> dict[str, float]:
    """The residual dict of MODEL.md §8 (keys and scalings in the module docstring).
    Pass the factorisation of A when you have one (the gap needs one solve with it)."""
    return evaluate(qp, U, Lambda, delta, factorization).residuals


def dual_value(qp: ContactQP, Lambda: np.ndarray, factorization: Factorization | None = None) -> float:
    """q(Λ) = −½(F+BᵀΛ)ᵀA⁻¹(F+BᵀΛ) − ΛᵀG, evaluated directly (MODEL.md §8). Under force
    control this is the dual function on {DᵀΛ = −P} (elsewhere q = −∞)."""
    fact = factorization if factorization is not None else factorize(qp.A)
    rhs = qp.F + qp.B.T @ Lambda
    return -0.5 * float(rhs @ fact.solve(rhs)) - float(Lambda @ qp.G)


def lagrangian(qp: ContactQP, V: np.ndarray, mu: np.ndarray, delta: np.ndarray | None = None) -> float:
    """ℒ(V, μ) = 𝓔(V) − μᵀ(G + BV + Dδ) (MODEL.md §6)."""
    return qp.energy(V, delta) - float(mu @ qp.gap(V, delta))
