"""The linear Kirchhoff–Love cylindrical shell: strains, resultants, stiffness (MODEL.md §2–3).

In the chart (x, s), s = a φ (so ∂/∂φ = a ∂/∂s and dΩ = a dx dφ = dx ds), the strain
measures of MODEL.md §2 (w positive outward) read

    ε11 = u_x            κ11 = −w_xx
    ε22 = v_s + w/a      κ22 = −(w_ss + w/a²)
    γ12 = u_s + v_x      κ12 = −w_xs + (v_x − u_s)/(2a)

and the strain energy density is N·ε + M·κ with N = C_m ε, M = C_b κ (MODEL.md (5.5)).
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from .geometry import Shell
from .spaces import ShellSpace

STRAINS = ("eps11", "eps22", "gam12", "kap11", "kap22", "kap12")
RESULTANTS = ("N11", "N22", "N12", "M11", "M22", "M12")


def strains(d: dict[str, np.ndarray], a: float) -> np.ndarray:
    """Strain vector (ε11, ε22, γ12, κ11, κ22, κ12) from the field derivatives (MODEL.md §2)."""
    return np.stack(
        [
            d["u_x"],
            d["v_s"] + d["w"] / a,
            d["u_s"] + d["v_x"],
            -d["w_xx"],
            -(d["w_ss"] + d["w"] / a**2),
            -d["w_xs"] + (d["v_x"] - d["u_s"]) / (2.0 * a),
        ]
    )


def constitutive(shell: Shell, t: np.ndarray) -> np.ndarray:
    """Energy matrix C (6, 6, ...) with energy density ½ eᵀ C e (MODEL.md §3).

    Membrane: N = B [[1, μ, 0], [μ, 1, 0], [0, 0, (1−μ)/2]] (ε11, ε22, γ12);
    bending: D [[1, μ, 0], [μ, 1, 0], [0, 0, 2(1−μ)]] (κ11, κ22, κ12), since 2 M12 κ12 = 2 D (1−μ) κ12².
    """
    mu = shell.poisson
    B, D = shell.membrane_stiffness(t), shell.bending_stiffness(t)
    C = np.zeros((6, 6) + np.shape(t))
    for off, S, shear in ((0, B, 0.5 * (1 - mu)), (3, D, 2.0 * (1 - mu))):
        C[off, off] = C[off + 1, off + 1] = S
        C[off, off + 1] = C[off + 1, off] = mu * S
        C[off + 2, off + 2] = shear * S
    return C


def resultants(shell: Shell, e: np.ndarray, t: np.ndarray) -> np.ndarray:
    """(N11, N22, N12, M11, M22, M12) from strains e (6, ...): N12 = B(1−μ)/2 γ12, M12 = D(1−μ) κ12."""
    C = constitutive(shell, t)
    r = np.einsum("ij...,j...->i...", C, e)
    r[5] *= 0.5  # the energy matrix carries 2 M12 κ12
    return r


def element_chunks(nel: int, size: int = 4096):
    for start in range(0, nel, size):
        yield np.arange(start, min(start + size, nel))


def stiffness(space: ShellSpace, order: int = 10, parts: tuple[str, ...] = ("membrane", "bending")) -> sp.csr_matrix:
    """Global stiffness matrix A of a(U, V) (MODEL.md §3), vectorised over elements.

    ``parts`` may drop the membrane or bending energy (used to verify each element alone).
    """
    shell = space.mesh.shell
    a = shell.radius
    X, W = space.quadrature(order)
    rows, cols, vals = [], [], []
    mask = np.zeros(6)
    if "membrane" in parts:
        mask[:3] = 1.0
    if "bending" in parts:
        mask[3:] = 1.0
    for e in element_chunks(space.mesh.nelements):
        basis = space.element_basis(e, X)
        x, s, detJ = space.reference_to_physical(e, X)
        S = strains(basis, a) * mask[:, None, None, None]  # (6, 33, n, nq)
        C = constitutive(shell, shell.t(x, s / a))  # (6, 6, n, nq)
        dx = W[None, :] * detJ[:, None]  # (n, nq)
        CS = np.einsum("klnq,ljnq->kjnq", C, S, optimize=True) * dx  # (6, 33, n, nq)
        # K_e = Σ_{k,q} S[k,i] (C S)[k,j] dx as one batched matrix product per element
        n = e.size
        Ke = np.matmul(S.transpose(2, 1, 0, 3).reshape(n, 33, -1), CS.transpose(2, 0, 3, 1).reshape(n, -1, 33))
        dofs = space.element_dofs[:, e]
        rows.append(np.broadcast_to(dofs[:, None, :], (33, 33, e.size)).transpose(2, 0, 1).ravel())
        cols.append(np.broadcast_to(dofs[None, :, :], (33, 33, e.size)).transpose(2, 0, 1).ravel())
        vals.append(Ke.ravel())
    A = sp.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))), shape=(space.ndofs,) * 2)
    A.sum_duplicates()
    return A


def field_derivatives(space: ShellSpace, U: np.ndarray, elements: np.ndarray, X: np.ndarray) -> dict[str, np.ndarray]:
    """The QUANTITIES of the discrete field U at reference points X in ``elements``."""
    basis = space.element_basis(elements, X)
    coeff = U[space.element_dofs[:, elements]]  # (33, n)
    return {k: np.einsum("bnq,bn->nq", v, coeff) for k, v in basis.items()}


def energy_norm_sq(space: ShellSpace, fields_error, order: int = 10) -> float:
    """a(E, E) for an error field given as a callable (elements, X) → derivative dict."""
    shell = space.mesh.shell
    X, W = space.quadrature(order)
    total = 0.0
    for e in element_chunks(space.mesh.nelements):
        d = fields_error(e, X)
        x, s, detJ = space.reference_to_physical(e, X)
        eps = strains(d, shell.radius)
        C = constitutive(shell, shell.t(x, s / shell.radius))
        total += float(np.einsum("knq,klnq,lnq,nq->", eps, C, eps, W[None, :] * detJ[:, None]))
    return total
