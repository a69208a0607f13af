"""Checks of the independent 1D axisymmetric oracle (tests/oracles/axisym.py) against closed forms.

The oracle is itself verified here before it is used to judge the 2D package:
(1) uniform pressure, any supports, incl. the nonlocal axial force of axially fixed ends: exact ODE solution;
(2) ring load on a long cylinder: w(0) = P/(8 D β_m² α) of THIS model, and the classical 8β³D differs by
    −μ t/(4a√(3(1−μ²))) + O(t²/a²);
(3) sleeve contact: the nodal-constraint discretisation converges to the solution whose free boundary is found
    exactly (root of the moment condition), table and observed rates printed;
(4) torus ring: small interference gives one ring force P = 8 D β_m² α δ; larger interference a contact band
    with ring forces concentrated at its edges.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from oracles.axisym import (
    CylinderPunch,
    Shell1D,
    TorusPunch,
    bisect,
    closed_form_pressure,
    graded_nodes,
    model_roots,
    ring_green,
    ring_stiffness,
    ring_stiffness_classical,
    sleeve_free_boundary,
    solve,
)

A, T, E, MU = 1.0, 0.02, 2.0e5, 0.3


# ---------------------------------------------------------------------------------------------------------------
# (1) pressure: the ODE  D w'''' + 2μD w''/a² + (D/a⁴ + Et/a²) w = q − μN/a,  N11 = N constant
# ---------------------------------------------------------------------------------------------------------------
@pytest.mark.parametrize(
    "bcs",
    [("clamped", "clamped"), ("clamped", "free"), ("symmetry", "clamped"), ("symmetry", "simply_supported")],
)
def test_pressure_matches_closed_form(bcs):
    sh = Shell1D(A, T, E, MU, 0.0, 2.0)
    q = 1.0
    cf = closed_form_pressure(sh, *bcs, q=q)
    x = np.linspace(sh.x0, sh.x1, 1501)
    # the closed form satisfies the ODE (derivatives of the exact expression)
    ode = sh.D * cf.w(x, 4) + 2 * MU * sh.D / A**2 * cf.w(x, 2) + sh.k * cf.w(x) - (q - MU * cf.N / A)
    assert np.max(np.abs(ode)) <= 1e-9 * q
    if bcs[0] in ("clamped", "symmetry") and bcs[1] in ("clamped", "symmetry"):
        assert abs(cf.N) > 0.1 * q * A  # both ends axially fixed: the nonlocal axial force is really there
    else:
        assert cf.N == 0.0
    nodes = graded_nodes(sh.x0, sh.x1, [], h_min=0.005, h_max=0.02, ratio=1.3)
    s = solve(sh, nodes, *bcs, pressure=q)
    wmax, umax = np.max(np.abs(cf.w(x))), np.max(np.abs(cf.u(x)))
    assert np.max(np.abs(s.w(x) - cf.w(x))) <= 1e-8 * wmax
    assert np.max(np.abs(s.u(x) - cf.u(x))) <= 1e-8 * umax
    assert np.max(np.abs(s.N11(x) - cf.N)) <= 1e-8 * q * A + 1e-8 * abs(cf.N)


# ---------------------------------------------------------------------------------------------------------------
# (2) ring load: modified β of this model and the O(t/a) difference from the classical formula
# ---------------------------------------------------------------------------------------------------------------
def test_ring_load_modified_beta():
    P = 1.0
    rows = []
    for t in (0.02, 0.01, 0.002):
        sh0 = Shell1D(A, t, E, MU, 0.0, 1.0)
        bm, alpha, beta = model_roots(sh0)
        # the Fourier value P/(8Dβ_m²α) and the direct Green's function agree
        assert ring_green(sh0, P, 0.0) * ring_stiffness(sh0) == pytest.approx(P, rel=1e-13)
        L = 30.0 / alpha  # e^{-30}: the far ends do not matter; simply supported ends keep N11 = 0
        sh = Shell1D(A, t, E, MU, -L, L)
        nodes = graded_nodes(-L, L, [0.0], h_min=0.05 / alpha, h_max=0.25 / alpha, ratio=1.3)
        s = solve(sh, nodes, "simply_supported", "simply_supported", rings=[(0.0, P)])
        w0 = float(s.w(0.0)[0])
        assert w0 * ring_stiffness(sh) == pytest.approx(P, rel=1e-8)
        x = np.linspace(-L, L, 2001)
        assert np.max(np.abs(s.w(x) - ring_green(sh, P, x))) <= 1e-8 * w0
        # classical thin-shell limit: relative difference −με/4 + (3/16 − μ²/32) ε², ε = t/(a√(3(1−μ²)))
        eps = t / (A * math.sqrt(3 * (1 - MU**2)))
        diff = (P / w0) / ring_stiffness_classical(sh) - 1.0
        first = -MU * eps / 4
        second = first + (3 / 16 - MU**2 / 32) * eps**2
        rows.append((t, diff, first, second))
        assert abs(diff - second) <= eps**3
        assert abs(diff) >= 0.5 * MU * eps / 4  # O(t/a), far above the discretisation error (1e-8)
    print("\n t/a      (P/w0)/(8β_c³D) − 1    −με/4          two-term expansion")
    for t, d, f, s2 in rows:
        print(f" {t:<7g}  {d: .6e}        {f: .6e}   {s2: .6e}")


# ---------------------------------------------------------------------------------------------------------------
# (3) sleeve: convergence of the contact force of the nodal-constraint discretisation
# ---------------------------------------------------------------------------------------------------------------
def test_sleeve_contact_force_converges():
    sh = Shell1D(A, T, E, MU, 0.0, 1.0)
    delta, c = 1e-3, 0.3
    Rs = A + T / 2 - delta
    ref = sleeve_free_boundary(sh, Rs, c)
    ref2 = sleeve_free_boundary(sh, Rs, c, h_min=0.001, h_max=0.01, pw=7)
    assert ref2.total_normal_force == pytest.approx(ref.total_normal_force, rel=1e-8)
    assert ref2.x_t == pytest.approx(ref.x_t, abs=1e-9)
    # band pressure = k δ − μN/a from the ODE, ring forces positive at both band end and sleeve edge
    assert ref.band_pressure == pytest.approx(sh.k * delta - MU * ref.N / A, rel=1e-12)
    assert ref.ring_band > 0 and ref.ring_edge > 0
    punch = [CylinderPunch(Rs, (0.0, c))]
    base = graded_nodes(0.0, 1.0, [c], h_min=0.01, h_max=0.05, ratio=1.5)
    print(
        f"\n sleeve, free boundary resolved: F = {ref.total_normal_force:.10f}, x_t = {ref.x_t:.8f}, "
        f"rings {ref.ring_band:.6f} (x_t), {ref.ring_edge:.6f} (x = c)"
    )
    print(" level  nodes  active  total force       rel. error   rate   edge ring")
    errs, hs = [], []
    for lev in range(5):
        nodes = bisect(base, lev)
        s = solve(sh, nodes, "symmetry", "clamped", punches=punch)
        assert max(s.kkt.values()) <= 1e-9
        err = abs(s.total_normal_force() / ref.total_normal_force - 1)
        rate = "" if not errs else f"{math.log2(errs[-1] / err):5.2f}"
        errs.append(err)
        hs.append(np.max(np.diff(nodes)))
        print(
            f" {lev:5d}  {len(nodes):5d}  {int(s.active.sum()):6d}  {s.total_normal_force():.10f}  {err:.3e}  "
            f"{rate:>5}  {s.edge_forces()[1]:.6f}"
        )
        # the contact set is [0, x_t] ∪ {c}: a gap opens between the band and the sleeve edge
        za, zb = s.contact_zone()
        assert za == 0.0 and zb == pytest.approx(c)
        act = s.cx[s.active]
        gap_start = act[np.argmax(np.diff(act))]
        assert abs(gap_start - ref.x_t) <= 2.5 * hs[-1]
    assert errs[-1] <= 1e-6
    assert errs[-1] <= 1e-2 * errs[0]
    overall = math.log2(errs[0] / errs[-1]) / (len(errs) - 1)
    print(f" mean observed rate over the levels: {overall:.2f}")
    assert overall >= 2.0
    # the nodal force at the sleeve edge converges to the ring force of the exact solution
    assert s.edge_forces()[1] == pytest.approx(ref.ring_edge, rel=1e-4)


# ---------------------------------------------------------------------------------------------------------------
# (4) torus ring: one circle of contact, then a band with ring forces at its edges
# ---------------------------------------------------------------------------------------------------------------
def _torus_case(delta: float, r: float = 0.5, t: float = T):
    sh0 = Shell1D(A, t, E, MU, 0.0, 1.0)
    alpha = model_roots(sh0)[1]
    L = 30.0 / alpha
    sh = Shell1D(A, t, E, MU, 0.0, L)  # half model: symmetry at the ring plane x = 0
    punch = TorusPunch(0.0, A + t / 2 - delta + r, r, zone=(0.0, min(0.3, L)))
    return sh, punch, alpha


def test_torus_small_interference_single_ring():
    rows = []
    for t in (0.02, 0.005):
        delta = 0.05 * t
        sh, punch, alpha = _torus_case(delta, t=t)
        nodes = graded_nodes(0.0, sh.x1, [], h_min=0.05 / alpha, h_max=0.25 / alpha, ratio=1.3)
        s = solve(sh, nodes, "symmetry", "simply_supported", punches=[punch])
        assert s.contact_zone() == (0.0, 0.0) and int(s.active.sum()) == 1
        # no penetration between the nodes either (the exact solution is a single ring)
        x = np.linspace(0.0, 0.3, 3001)
        assert s.continuous_gap([punch], x).min() >= -1e-12 * delta
        P = 2.0 * s.lam[0]  # the half model carries half of the ring force
        assert P == pytest.approx(ring_stiffness(sh) * delta, rel=1e-8)
        eps = t / (A * math.sqrt(3 * (1 - MU**2)))
        diff = P / (ring_stiffness_classical(sh) * delta) - 1
        assert abs(diff - (-MU * eps / 4 + (3 / 16 - MU**2 / 32) * eps**2)) <= eps**3
        rows.append((t, P, ring_stiffness_classical(sh) * delta, diff))
    print("\n t/a     P (oracle)        8β_c³Dδ           relative difference (model vs thin-shell limit)")
    for t, P, Pc, d in rows:
        print(f" {t:<6g}  {P:.10e}  {Pc:.10e}  {d: .4e}")


def test_torus_large_interference_band_with_edge_rings():
    delta = 0.03
    sh, punch, alpha = _torus_case(delta)
    base = graded_nodes(0.0, sh.x1, [], h_min=0.005, h_max=0.05, ratio=1.3)
    forces, edge_sums, interior = [], [], []
    print("\n level  active  zone end   total force      edge-layer sum  max interior nodal force / h")
    for lev in range(4):
        nodes = bisect(base, lev)
        s = solve(sh, nodes, "symmetry", "simply_supported", punches=[punch])
        assert max(s.kkt.values()) <= 1e-9
        za, zb = s.contact_zone()
        assert za == 0.0 and zb > 0.04  # a band, not a single circle
        act = np.flatnonzero(s.active)
        assert np.all(np.diff(act) == 1)  # one connected band
        xb = s.cx[act[-1]]
        h = np.max(np.diff(nodes[nodes <= 0.1]))
        near = s.active & (s.cx >= xb - 0.006)  # the last ~6 mm of the band: the edge ring and its discrete spread
        inner = s.active & (s.cx <= 0.5 * xb)
        forces.append(s.force_per_length())
        edge_sums.append(s.lam[near].sum())
        interior.append(s.lam[inner].max() / h)
        print(f" {lev:5d}  {act.size:6d}  {zb:.5f}  {forces[-1]:.10f}  {edge_sums[-1]:.6f}        {interior[-1]:.4f}")
    forces = np.array(forces)
    d = np.abs(np.diff(forces))
    assert np.all(d[1:] < d[:-1])  # Cauchy differences shrink
    assert d[-1] <= 1e-4 * forces[-1]
    # a ring force: the edge layer keeps a finite force (≥ 40 % of the total) while the interior nodal forces
    # scale with h (a bounded pressure)
    assert min(edge_sums) >= 0.4 * forces[-1]
    assert max(edge_sums) <= 1.2 * min(edge_sums)
    assert max(interior) <= 1.5 * min(interior)


def test_oracle_is_independent_of_the_package():
    """The oracle must not share code with shellcontact (numpy/scipy only)."""
    import ast
    import inspect

    import oracles.axisym as mod

    tree = ast.parse(inspect.getsource(mod))
    names = {a.name for n in ast.walk(tree) if isinstance(n, ast.Import) for a in n.names}
    names |= {n.module or "" for n in ast.walk(tree) if isinstance(n, ast.ImportFrom)}
    assert not any(n.split(".")[0] == "shellcontact" for n in names)
    assert {n.split(".")[0] for n in names} <= {"__future__", "math", "collections", "dataclasses", "numpy", "scipy"}
