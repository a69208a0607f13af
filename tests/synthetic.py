"""Synthetic contact QPs that mimic the shell problem (fourth order, conditioning ~h⁻⁴, rows of
B with up to five entries mixing deflection and slopes), for the solver tests.

* ``beam_qp``: clamped Euler–Bernoulli beam (Hermite cubics, dofs w, w'), pressed on its top
  fibre (ζ = half thickness) by a rigid cylinder — signed distance Z, full kinematics
  U(M) = (−ζw', w) as in MODEL.md §5.
* ``plate_qp``: Kirchhoff plate, finite-difference biharmonic h²LᵀL (L the Dirichlet 5-point
  Laplacian), pressed by a sphere; B rows use w and central-difference slopes (five entries).
* ``random_qp``: small random SPD problem with random sparse B.
* ``interpolate_active``: a coarse ``plate_qp`` active set carried to a finer one (nested start).
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from shellcontact.solvers.qp import ContactQP


def beam_qp(
    n_el: int = 64,
    radius: float = 0.3,
    indentation: float = 0.01,
    half_thickness: float = 0.02,
    load: float = 0.0,
    force: float | None = None,
    zone: float = 0.8,
) -> ContactQP:
    """Clamped beam on [0, 1], EI = 1, cylinder of ``radius`` above x = 0.5 overlapping the top
    fibre by ``indentation``; uniform load ``load`` (positive up). With ``force`` the punch is
    force-controlled along −z (one column D, P = [force]). Candidate vertices |x − ½| < zone·radius."""
    h = 1.0 / n_el
    ke = np.array([[12, 6 * h, -12, 6 * h], [6 * h, 4 * h * h, -6 * h, 2 * h * h],
                   [-12, -6 * h, 12, -6 * h], [6 * h, 2 * h * h, -6 * h, 4 * h * h]]) / h**3
    fe = load * np.array([h / 2, h * h / 12, h / 2, -h * h / 12])
    nd = 2 * (n_el + 1)
    rows, cols, vals = [], [], []
    Ff = np.zeros(nd)
    for e in range(n_el):
        dofs = np.arange(2 * e, 2 * e + 4)
        rows.append(np.repeat(dofs, 4))
        cols.append(np.tile(dofs, 4))
        vals.append(ke.ravel())
        Ff[dofs] += fe
    Af = sp.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))), shape=(nd, nd))
    keep = np.arange(2, nd - 2)  # clamped ends
    A = Af[keep][:, keep]
    F = Ff[keep]
    x = np.linspace(0, 1, n_el + 1)
    zeta = half_thickness
    cz = zeta + radius - indentation
    cand = np.flatnonzero((np.abs(x - 0.5) < zone * radius) & (x > 0) & (x < 1))
    dx, dz = x[cand] - 0.5, zeta - cz
    dist = np.hypot(dx, dz)
    G = dist - radius
    nx, nz = dx / dist, dz / dist
    m = cand.size
    # reduced dof index of node j: w -> 2j - 2, w' -> 2j - 1
    Bi = np.repeat(np.arange(m), 2)
    Bj = np.column_stack([2 * cand - 2, 2 * cand - 1]).ravel()
    Bv = np.column_stack([nz, -zeta * nx]).ravel()
    B = sp.csr_matrix((Bv, (Bi, Bj)), shape=(m, A.shape[0]))
    w = np.full(m, h)
    if force is None:
        return ContactQP(A, F, B, G, w)
    return ContactQP(A, F, B, G, w, D=nz[:, None].copy(), P=np.array([float(force)]))


def plate_qp(
    N: int = 24,
    radius: float = 0.5,
    indentation: float = 0.002,
    half_thickness: float = 0.01,
    zone: float = 0.35,
    load: float = 0.0,
) -> ContactQP:
    """Unit square plate, N×N interior grid, A = h²LᵀL; sphere of ``radius`` over the centre
    overlapping the top surface by ``indentation``. Candidates: grid points within ``zone`` of the
    centre (away from the edge, so all five stencil entries are unknowns)."""
    h = 1.0 / (N + 1)
    e = np.ones(N)
    T = sp.diags([e[:-1], -2 * e, e[:-1]], [-1, 0, 1])
    Id = sp.identity(N)
    L = (sp.kron(Id, T) + sp.kron(T, Id)) / h**2
    A = (h * h * (L.T @ L)).tocsr()
    n = N * N
    F = np.full(n, load * h * h)
    xs = (np.arange(N) + 1) * h
    X, Y = np.meshgrid(xs, xs, indexing="ij")
    X, Y = X.ravel(), Y.ravel()
    zeta = half_thickness
    cz = zeta + radius - indentation
    r2 = np.hypot(X - 0.5, Y - 0.5)
    cand = np.flatnonzero(r2 < zone)
    d = np.column_stack([X[cand] - 0.5, Y[cand] - 0.5, np.full(cand.size, zeta - cz)])
    dist = np.linalg.norm(d, axis=1)
    G = dist - radius
    nrm = d / dist[:, None]
    ii, jj = cand // N, cand % N
    m = cand.size
    # Π = Z + ∇Z·(−ζ w_x, −ζ w_y, w), slopes by central differences (index = i*N + j, x ~ i)
    Bi = np.repeat(np.arange(m), 5)
    Bj = np.column_stack([cand, (ii + 1) * N + jj, (ii - 1) * N + jj, ii * N + jj + 1, ii * N + jj - 1]).ravel()
    c = zeta / (2 * h)
    Bv = np.column_stack([nrm[:, 2], -c * nrm[:, 0], c * nrm[:, 0], -c * nrm[:, 1], c * nrm[:, 1]]).ravel()
    B = sp.csr_matrix((Bv, (Bi, Bj)), shape=(m, n))
    return ContactQP(A, F, B, G, np.full(m, h * h))


def random_qp(n: int = 30, m: int = 10, seed: int = 0, force: bool = False) -> ContactQP:
    """Random SPD A (cond ~1e3), random sparse B (≤3 entries per row), G with overlaps."""
    rng = np.random.default_rng(seed)
    Q, _ = np.linalg.qr(rng.standard_normal((n, n)))
    A = Q @ np.diag(np.logspace(0, 3, n)) @ Q.T
    A = sp.csr_matrix(0.5 * (A + A.T))
    B = np.zeros((m, n))
    for i in range(m):
        B[i, rng.choice(n, size=3, replace=False)] = rng.standard_normal(3)
    F = rng.standard_normal(n)
    G = rng.standard_normal(m) * 0.5 - 0.2
    w = rng.uniform(0.5, 1.5, m)
    if not force:
        return ContactQP(A, F, sp.csr_matrix(B), G, w)
    D = -np.abs(rng.standard_normal((m, 1)))
    return ContactQP(A, F, sp.csr_matrix(B), G, w, D=D, P=np.array([2.0]))


def interpolate_active(qpc: ContactQP, act_c: np.ndarray, Nc: int, qpf: ContactQP, Nf: int) -> np.ndarray:
    """Nearest coarse vertex's active flag for each fine candidate (plate_qp grids)."""
    def coords(qp: ContactQP, N: int) -> np.ndarray:
        idx = qp.B.indices.reshape(-1, 5)[:, 2]  # sorted row: the centre is the middle entry
        h = 1.0 / (N + 1)
        return np.column_stack([(idx // N + 1) * h, (idx % N + 1) * h])

    pc, pf = coords(qpc, Nc), coords(qpf, Nf)
    d = np.linalg.norm(pf[:, None, :] - pc[None, :, :], axis=2)
    return act_c[np.argmin(d, axis=1)]
