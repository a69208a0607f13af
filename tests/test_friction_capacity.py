"""The joint capacity of friction along several rigid motions (contact/friction_capacity.py): the LP bracket of
s* = min{h(d) : P·d = 1}, h(d) = Σ g_i |E_i d|, against a brute-force scan of d over the circle (k = 2: the exact
minimum of a convex function of the angle) and against the closed form for discs that all see the motions alike."""

from __future__ import annotations

import numpy as np
import pytest

from shellcontact.contact.friction_capacity import SIDES, capacity_ratio, support


def scan(E: np.ndarray, g: np.ndarray, P: np.ndarray, n: int = 200_001) -> float:
    """min over unit d with P·d > 0 of h(d)/(P·d): s* by brute force (k = 2)."""
    theta = np.linspace(0.0, 2.0 * np.pi, n)
    best = np.inf
    for t in theta:
        d = np.array([np.cos(t), np.sin(t)])
        if P @ d > 1e-12:
            best = min(best, support(E, g, d) / float(P @ d))
    return best


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_bracket_contains_the_scanned_ratio(seed):
    """Random slip columns (40 points, 2 motions) and bounds: lower ≤ s*(scan) ≤ upper ≤ lower / cos(π/N)."""
    rng = np.random.default_rng(seed)
    E, g, P = rng.normal(size=(80, 2)), rng.uniform(0.0, 2.0, 40), rng.normal(size=2)
    lower, upper = capacity_ratio(E, g, P)
    exact = scan(E, g, P, 20_001)
    assert lower <= exact * (1 + 1e-9) and exact <= upper * (1 + 1e-6)  # the scan's grid: 1e-8 relative
    assert upper <= lower / np.cos(np.pi / SIDES) * (1 + 1e-9)


def test_identical_discs_give_a_disc():
    """Every point slides along either motion alike (E_i = I): 𝒞 is the disc of radius Σ g_i, so s* = Σ g/|P|; one
    motion alone gives Σ g exactly."""
    m = 30
    E = np.tile(np.eye(2), (m, 1))
    g = np.linspace(1.0, 2.0, m)
    P = np.array([3.0, 4.0])
    lower, upper = capacity_ratio(E, g, P)
    assert lower <= g.sum() / 5.0 <= upper <= lower / np.cos(np.pi / SIDES) * (1 + 1e-9)  # the worst case: equal
    assert capacity_ratio(E[:, :1], g, np.array([-2.0])) == pytest.approx((g.sum() / 2.0,) * 2, rel=1e-14)
    assert capacity_ratio(E, g, np.zeros(2)) == (np.inf, np.inf)
