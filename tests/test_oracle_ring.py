"""The closed-form ring of this model (tests/oracles/ring.py): its own checks, the thin-ring limit, and the FE model.

(1) The closed forms are the sums of their Fourier series, satisfy the model's equations (M22 = −D(w'' + w)/a²,
    N22 = B(v' + w)/a constant, M22'' + M22 = a N22 between the loads, the jump a P of M22' under a load)
    and give δ = −2 w(0).
(2) Thin-ring limit: δ → (π/4 − 2/π) P R³/EI, EI = E t³/(12(1 − ν²)), with the membrane correction
    ≈ 0.357 (t/a)².
(3) The FE model (no contact): a quarter of a long pipe with symmetry supports on all four edges (plane strain:
    the ends keep the section plane) under the given line load P/2 on the edge φ = 90° (half of P: the load
    line lies in the symmetry plane). w and v around the quarter and δ converge to the closed form under
    refinement in φ; at the finest mesh the error is far below the membrane contribution, which is
    thereby verified too.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from oracles.ring import SERIES_SUM, Ring, classical_diametral_change

import shellcontact
from shellcontact.problem.case import case_from_dict

A, T, E, MU = 0.1, 0.005, 2.1e11, 0.3  # a steel pipe, a/t = 20
P = 1000.0  # N per metre of generator


# ---------------------------------------------------------------------------------------------------------------
# (1) the closed forms
# ---------------------------------------------------------------------------------------------------------------
def test_series_sum():
    n = 2.0 * np.arange(1, 200001)
    assert SERIES_SUM == pytest.approx(np.sum(1.0 / (n**2 - 1) ** 2), rel=1e-14)


def test_closed_form_is_the_fourier_series():
    ring = Ring(A, T, E, MU)
    th = np.linspace(-np.pi, 2 * np.pi, 181)
    w, v = ring.w(th, P), ring.v(th, P)
    assert np.max(np.abs(w - ring.w_series(th, P, 20000))) <= 1e-12 * np.max(np.abs(w))
    assert np.max(np.abs(v - ring.v_series(th, P, 20000))) <= 1e-12 * np.max(np.abs(v))
    assert ring.diametral_change(P) == pytest.approx(-2 * ring.w(0.0, P), rel=1e-14)
    assert ring.diametral_change(P) == pytest.approx(-(ring.w(0.0, P) + ring.w(np.pi, P)), rel=1e-14)
    assert ring.lateral_change(P) == pytest.approx(2 * ring.w(np.pi / 2, P), rel=1e-14)
    assert ring.stiffness() * ring.diametral_change(P) == pytest.approx(P, rel=1e-14)


def test_closed_form_solves_the_model_equations():
    ring = Ring(A, T, E, MU)
    a, h = A, 1e-3
    th = np.linspace(0.2, np.pi - 0.2, 9)  # between the loads

    def d(f, k):  # central differences of order h⁴
        if k == 1:
            return (-f(th + 2 * h) + 8 * f(th + h) - 8 * f(th - h) + f(th - 2 * h)) / (12 * h)
        return (-f(th + 2 * h) + 16 * f(th + h) - 30 * f(th) + 16 * f(th - h) - f(th - 2 * h)) / (12 * h**2)

    w = lambda t: ring.w(t, P)  # noqa: E731
    v = lambda t: ring.v(t, P)  # noqa: E731
    M = lambda t: ring.moment(t, P)  # noqa: E731
    m_scale = P * a
    # constitutive: M22 = D κ22 = −D (w'' + w)/a², N22 = B ε22 = B (v' + w)/a, constant
    assert np.max(np.abs(-ring.D * (d(w, 2) + w(th)) / a**2 - M(th))) <= 1e-7 * m_scale
    assert np.max(np.abs(ring.B * (d(v, 1) + w(th)) / a - ring.hoop_force(P))) <= 1e-7 * P
    # equilibrium between the loads: M'' + M = a N; under a load M' jumps by a P
    assert np.max(np.abs(d(M, 2) + M(th) - a * ring.hoop_force(P))) <= 1e-7 * m_scale
    e = 1e-6  # M is continuous with a kink under the load
    jump = (ring.moment(e, P) - ring.moment(0.0, P)) / e - (ring.moment(0.0, P) - ring.moment(-e, P)) / e
    assert jump == pytest.approx(a * P, rel=1e-6)
    # symmetry: w even about the load line and about the perpendicular one, v odd
    assert ring.w(0.3, P) == pytest.approx(ring.w(-0.3, P), rel=1e-14)
    assert ring.w(0.3, P) == pytest.approx(ring.w(np.pi - 0.3, P), rel=1e-14)
    assert ring.v(0.3, P) == pytest.approx(-ring.v(-0.3, P), rel=1e-14)
    for node in (0.0, np.pi / 2):  # v vanishes on both symmetry lines
        assert abs(ring.v(node, P)) <= 1e-15 * abs(ring.v(0.3, P))


# ---------------------------------------------------------------------------------------------------------------
# (2) the thin-ring limit
# ---------------------------------------------------------------------------------------------------------------
def test_thin_ring_limit_is_the_classical_formula():
    """δ/δ_classic − 1 = 2D/(π(Ba² + D)(π/4 − 2/π)) → (t/a)²/(6π(π/4 − 2/π)) ≈ 0.357 (t/a)²."""
    c0 = 1.0 / (6 * math.pi * (math.pi / 4 - 2 / math.pi))
    print(f"\n  a/t      delta/delta_classic - 1   / (t/a)^2   (limit {c0:.6f})")
    previous = math.inf
    for ratio in (10.0, 100.0, 1000.0, 10000.0):
        t = A / ratio
        ring = Ring(A, t, E, MU)
        EI = E * t**3 / (12 * (1 - MU**2))
        classic = classical_diametral_change(P, A, EI)
        assert ring.bending_part(P) == pytest.approx(classic, rel=1e-14)
        excess = ring.membrane_part(P) / classic  # = δ/δ_classic − 1, without the cancellation
        assert ring.diametral_change(P) / classic - 1 == pytest.approx(excess, rel=1e-6, abs=1e-15)
        scaled = excess / (t / A) ** 2
        print(f"  {ratio:7.0f}   {excess:.6e}              {scaled:.8f}")
        assert excess > 0.0
        # the scaled excess tends to c0, with an error O((t/a)²)
        assert abs(scaled - c0) <= c0 * (t / A) ** 2 / 12
        assert abs(scaled - c0) < previous
        previous = abs(scaled - c0)


# ---------------------------------------------------------------------------------------------------------------
# (3) the FE model against the closed form
# ---------------------------------------------------------------------------------------------------------------
def _quarter(nphi: int) -> dict:
    return {
        "shell": {"radius": A, "length": 0.05, "x_start": 0.0, "angle": [0.0, 90.0], "thickness": T, "young": E,
                  "poisson": MU},
        "supports": {"x_min": "symmetry", "x_max": "symmetry", "phi_min": "symmetry", "phi_max": "symmetry"},
        "mesh": {"nx": 1, "nphi": nphi},
        "loads": {"line": [{"phi": 90.0, "normal": -P / 2}]},  # inward, half of P on the symmetry plane
    }


def test_fe_quarter_converges_to_the_closed_form():
    ring = Ring(A, T, E, MU)
    phi = np.radians(np.linspace(0.0, 90.0, 91))
    theta = phi - np.pi / 2  # the load line is φ = 90°
    w_ref, v_ref = ring.w(theta, P), ring.v(theta, P)
    rows = []
    for nphi in (8, 16, 32, 64):
        res = shellcontact.solve(case_from_dict(_quarter(nphi)))
        sol = res.solution
        errs = []
        for x in (0.0, 0.025, 0.05):  # the state does not depend on x
            f = sol.evaluate(np.full_like(phi, x), phi, ("u", "v", "w"))
            errs.append((np.max(np.abs(f["w"] - w_ref)) / np.max(np.abs(w_ref)),
                         np.max(np.abs(f["v"] - v_ref)) / np.max(np.abs(v_ref)),
                         np.max(np.abs(f["u"])) / np.max(np.abs(w_ref))))
        ew, ev, eu = np.max(errs, axis=0)
        delta = -2 * sol.evaluate(np.array([0.025]), np.array([np.pi / 2]), ("w",))["w"][0]
        ed = abs(delta / ring.diametral_change(P) - 1)
        rows.append((nphi, sol.space.ndofs, ed, ew, ev, eu))
    print(f"\n ring quarter, a/t = {A / T:g}: delta = {ring.diametral_change(P):.10e} m "
          f"(membrane part {ring.membrane_part(P) / ring.diametral_change(P):.3e} of it)")
    print("  nphi  dofs   |delta err|   rate   max|w err|   rate   max|v err|   rate   max|u|/max|w|")
    for k, (n, dofs, ed, ew, ev, eu) in enumerate(rows):
        rates = ["" if k == 0 else f"{math.log2(rows[k - 1][j] / rows[k][j]):5.2f}" for j in (2, 3, 4)]
        print(f"  {n:4d} {dofs:5d}  {ed:.3e}  {rates[0]:>5}  {ew:.3e}  {rates[1]:>5}  {ev:.3e}  {rates[2]:>5}  "
              f"{eu:.1e}")
    for j in (2, 3, 4):
        errs = [r[j] for r in rows]
        assert all(e1 < e0 for e0, e1 in zip(errs, errs[1:], strict=False)), "errors decrease under refinement"
        # observed order about 4 (Argyris w, P2 v); at least 3 between the two finest meshes
        assert math.log2(errs[-2] / errs[-1]) >= 3.0
    n, _, ed, ew, ev, eu = rows[-1]
    assert ed < 1e-5 and ew < 1e-5 and ev < 1e-5
    assert eu < 1e-6  # plane strain: u = 0 up to the discretisation
    # the membrane part is resolved: the error is below 1 % of it (the inextensible ring is off by all of it)
    assert ed * ring.diametral_change(P) < 0.01 * ring.membrane_part(P)
