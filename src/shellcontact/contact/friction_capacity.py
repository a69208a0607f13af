"""The friction's capacity along the rigid motions only friction holds (docs/theory.md §9a, "A shell held by contact
alone, with friction").

The forces the friction can give along k motions are the set 𝒞 = {E_Hᵀ T : |T_i| ≤ g_i} (E_H: the slips' change
per unit of each motion, pairs E_i of 2 × k rows; each disc |T_i| ≤ g_i maps to an ellipse, 𝒞 is their sum: convex
and symmetric). A load P_H of those motions has a static solution only if −P_H ∈ 𝒞, i.e. s* ≥ 1 for

    s* = max{s : s P_H ∈ 𝒞} = min{h(d) : P_H·d = 1},   h(d) = Σ_i g_i |E_i d|   (h: the support function of 𝒞).

For one motion s* = h(1)/|P|, exactly (the per-motion check of μ × the normal force). For several, the minimum is
an LP on the discs' inscribed polygons (|x| ≥ max_v u_v·x ≥ cos(π/N)|x|, u_v the N vertex directions), whose value
is a lower bound of s* and whose minimiser d gives the upper bound h(d) ≤ s*/cos(π/N): the two bracket s* to
0.12 % (N = 64).
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

#: the inscribed polygons' number of sides: the capacity is bracketed to 1/cos(π/N) − 1 = 0.12 %
SIDES = 64


def support(E: np.ndarray, g: np.ndarray, d: np.ndarray) -> float:
    """h(d) = Σ_i g_i |E_i d| (N): the most the friction gives along the combination d of the motions."""
    return float(g @ np.linalg.norm((E @ d).reshape(-1, 2), axis=1))


def capacity_ratio(E: np.ndarray, g: np.ndarray, P: np.ndarray) -> tuple[float, float]:
    """(lower, upper) bounds of s* (module docstring) for the slip columns E (2m × k), the bounds g (m, N) and the
    load P (k, N); (inf, inf) for P = 0. Equal (and exact) for k = 1."""
    P = np.asarray(P, float)
    size = float(np.linalg.norm(P))
    if size == 0.0:
        return np.inf, np.inf
    if P.size == 1:
        s = support(E, g, np.array([1.0 / float(P[0])]))
        return s, s
    from scipy.optimize import linprog

    pairs = E.reshape(-1, 2, P.size)
    keep = (g > 0) & np.any(pairs != 0.0, axis=(1, 2))
    pairs, gk = pairs[keep], g[keep]
    m, k = len(gk), P.size
    theta = 2.0 * np.pi * np.arange(SIDES) / SIDES
    u = np.stack([np.cos(theta), np.sin(theta)], axis=1)  # (N, 2)
    rows = np.einsum("vc,ick->ivk", u, pairs).reshape(m * SIDES, k)  # u_v·E_i d
    # variables (d (k), r (m)): min Σ g_i r_i, u_v·E_i d ≤ r_i, P·d = 1; d scaled by |P| for conditioning
    A_ub = sp.hstack([sp.csr_matrix(rows / size),
                      -sp.csr_matrix((np.ones(m * SIDES), (np.arange(m * SIDES), np.repeat(np.arange(m), SIDES))),
                                     shape=(m * SIDES, m))], format="csr")
    res = linprog(np.concatenate([np.zeros(k), gk]), A_ub=A_ub, b_ub=np.zeros(m * SIDES),
                  A_eq=np.concatenate([P / size, np.zeros(m)])[None], b_eq=[1.0],
                  bounds=[(None, None)] * k + [(0.0, None)] * m, method="highs")
    if res.status != 0:  # unbounded below cannot happen (h ≥ 0); a solver failure: no joint verdict
        return 0.0, np.inf
    d = res.x[:k] / size
    return float(res.fun), support(E[np.repeat(keep, 2)], gk, d)
