"""The tangential operator of friction (MODEL.md §11, docs/theory.md "Friction"): its rows are the punch's
tangent components of the Kirchhoff face displacement, checked against exact motions."""

from __future__ import annotations

import numpy as np
import pytest
from test_contact_operator import BAR, ELL, SPHERE, SPHERE_IN, kirchhoff, polynomial, setup, smooth

from shellcontact.contact.friction import tangential_operator
from shellcontact.shell.geometry import rigid_motion


@pytest.mark.parametrize("punch", [[SPHERE], [SPHERE_IN], [BAR, ELL]])
def test_tangent_basis_is_orthonormal_and_tangent(punch):
    _, _, space, op = setup(punch)
    top = tangential_operator(space, op)
    assert top.C.shape == (2 * op.m, space.ndofs)
    nu = op.grad / np.linalg.norm(op.grad, axis=0)
    t1, t2 = top.tau
    for a, b, want in ((t1, t1, 1), (t2, t2, 1), (t1, t2, 0), (t1, nu, 0), (t2, nu, 0)):
        assert np.allclose(np.sum(a * b, axis=0), want, rtol=0, atol=1e-14)


@pytest.mark.parametrize("full", [False, True])
def test_rigid_motion_slides_contact_points_exactly(full):
    """A rigid motion c + θ × X moves the face point M by c + θ × M (no interpolation error at vertices):
    its tangential rows are the tangent components of that motion, computed here from the geometry alone."""
    punch = [SPHERE, SPHERE_IN] if not full else [{**SPHERE, "center": [0.1, 1.2, 0.3]}]
    case, _, space, op = setup(punch, full=full)
    top = tangential_operator(space, op)
    rng = np.random.default_rng(5)
    for _ in range(3):
        c, th = rng.normal(size=3) * 1e-3, rng.normal(size=3) * 1e-3
        U = space.interpolate(rigid_motion(case.shell, c, th))
        exact = c[:, None] + np.cross(th, op.points.T).T
        want = np.stack([np.sum(top.tau[k] * exact, axis=0) for k in range(2)], axis=1).ravel()
        assert np.allclose(top.C @ U, want, rtol=0, atol=1e-15)


@pytest.mark.parametrize("fields", [smooth, polynomial])
def test_rows_are_tangential_kirchhoff_displacement(fields):
    """Bending with w_x, w_s ≠ 0: the face slides by −ζ∇w (the offset terms) beside the mid-surface motion."""
    _, _, space, op = setup([SPHERE, BAR])
    top = tangential_operator(space, op)
    U = space.interpolate(fields)
    UM = kirchhoff(op, fields)
    want = np.stack([np.sum(top.tau[k] * UM, axis=0) for k in range(2)], axis=1).ravel()
    assert np.allclose(top.C @ U, want, rtol=0, atol=1e-12)
    # the offset matters: without it (ζ = 0) the rows would miss −ζ∇w, ~t/2 |∇w| (here ~0.025 × 1)
    mid = kirchhoff(type(op)(**{**op.__dict__, "zeta": 0 * op.zeta}), fields)
    moved = np.stack([np.sum(top.tau[k] * mid, axis=0) for k in range(2)], axis=1).ravel()
    assert np.max(np.abs(moved - want)) > 1e-3


def test_midpoint_rows_exact_for_polynomials():
    _, _, space, op = setup([SPHERE, BAR], points="vertices+midpoints")
    top = tangential_operator(space, op)
    U = space.interpolate(polynomial)
    UM = kirchhoff(op, polynomial)
    want = np.stack([np.sum(top.tau[k] * UM, axis=0) for k in range(2)], axis=1).ravel()
    assert np.allclose(top.C @ U, want, rtol=0, atol=1e-12)


def test_slide_offsets_and_force():
    _, _, space, op = setup([SPHERE, BAR])
    top = tangential_operator(space, op)
    s = np.array([0.0, 1e-3, -2e-3])
    c = top.offsets([s, None]).reshape(op.m, 2)
    r0, r1 = op.rows(0), op.rows(1)
    nu = op.grad / np.linalg.norm(op.grad, axis=0)
    # the slide's tangential part at each row is recovered from its pair
    tang = s[:, None] - np.sum(nu * s[:, None], axis=0) * nu
    assert np.allclose(top.vectors(c)[:, r0], tang[:, r0], rtol=0, atol=1e-15)
    assert np.all(c[r1] == 0.0)
    F = top.force(np.tile([1.0, 0.0], op.m))
    assert F.shape == (2, 3) and np.allclose(F[0], top.tau[0][:, r0].sum(axis=1))
