"""Face solves S_II x = r of a working set I that changes a little per iteration, without refactorising S_II.

The active set's late iterations move a few rows in and out of a face of thousands (demo case at 281k dofs:
~1 200 rows, 1–100 moved per iteration; at 1.12M dofs ~5 000), and a Cholesky factor of S_II costs |I|³/3 flops
each time. ``UpdatedFace`` keeps the factor L of one base set b and solves for I = (b ∖ R) ∪ N by bordering it:
with C = [S_bN, E_R] (E_R: the unit columns of the rows R that left, times the mean S_ii) and v = [x_N; μ],

    [S_bb  C] [x_b]   [r̃_b]        Z v = [r_N; 0] − Wᵀz,   Z = diag(S_NN, 0) − WᵀW,   W = L⁻¹C,  z = L⁻¹r̃_b,
    [Cᵀ    D] [ v ] = [r_N; 0]       x_b = L⁻ᵀ(z − W v),

where r̃_b is r on b ∩ I and 0 on R, and D = diag(S_NN, 0). The constraint E_Rᵀx_b = 0 holds the rows that left
at zero (their own equations take the multiplier μ), so x_I solves S_II x_I = r_I exactly: the same system as a
refactorised face, to round-off. A column of W costs |b|² flops once (kept while the base stays), Z is q × q
(q = |N| + |R|), symmetric indefinite. The base is refactorised (b ← I) when q exceeds ``REBASE_SHARE`` of |I|,
or when the bordered system is singular.
"""

from __future__ import annotations

import time
import warnings

import numpy as np
import scipy.linalg as sla

from .schur import Workspace

#: refactorise the base when the rows that joined or left since exceed this share of the working set: the
#: bordered solve then costs |b|²q + |b|q² + q³/3 flops against |I|³/3 for a new factor
REBASE_SHARE = 0.25
#: a factor whose smallest diagonal entry is below this share of its largest is singular (as ``face_solve``)
SINGULAR = 1e-7
#: the largest relative residual ‖S_II x − r‖ / (‖S_II x‖ + ‖r‖) of a bordered answer that is kept
ACCURACY = 1e-10


class UpdatedFace:
    """Face solves (S_II x = r, no force control) of one ``Workspace`` for a sequence of working sets."""

    def __init__(self, ws: Workspace, rebase_share: float = REBASE_SHARE) -> None:
        self.ws = ws
        self.rebase_share = rebase_share
        self.base: np.ndarray | None = None  # the base rows b (indices of the QP's rows)
        self.factor: np.ndarray | None = None  # lower Cholesky factor of S_bb
        self.where = np.full(ws.qp.m, -1, dtype=np.int64)  # position of a row in b, −1 outside
        self.W: dict[int, np.ndarray] = {}  # row → column of W = L⁻¹C for that row
        self.scale = 1.0  # mean diagonal of S_bb: E_R's columns are scaled by it so that Z is not ill-scaled
        #: how many face solves refactorised and how many bordered the base (benchmarks, tests)
        self.counts = {"refactorised": 0, "bordered": 0}

    def solve(self, idx: np.ndarray, rhs: np.ndarray) -> tuple[np.ndarray, bool]:
        """x with S_II x = ``rhs`` for I = ``idx``, and whether S_II was singular (then x is
        ``Workspace.face_solve``'s least-squares answer)."""
        idx = np.asarray(idx, dtype=np.int64)
        if self.base is not None:
            inside = self.where[idx] >= 0
            new = idx[~inside]
            keep = np.zeros(self.base.size, dtype=bool)
            keep[self.where[idx[inside]]] = True
            left = self.base[~keep]
            if new.size + left.size <= self.rebase_share * max(idx.size, 1):
                x = self._bordered(idx, rhs, inside, new, left)
                if x is not None and self._accurate(idx, rhs, x):
                    self.counts["bordered"] += 1
                    return x, False
        return self._refactorise(idx, rhs)

    def _refactorise(self, idx: np.ndarray, rhs: np.ndarray) -> tuple[np.ndarray, bool]:
        ws = self.ws
        self.base, self.factor, self.W = None, None, {}
        self.where[:] = -1
        self.counts["refactorised"] += 1
        H = ws.block(idx)
        t = time.perf_counter()
        try:
            if idx.size == 0:
                raise np.linalg.LinAlgError
            self.scale = float(np.mean(np.diag(H)))
            L = sla.cholesky(H, lower=True, overwrite_a=True, check_finite=False)
            d = np.diag(L)
            if d.min() <= SINGULAR * d.max():
                raise np.linalg.LinAlgError
        except (np.linalg.LinAlgError, sla.LinAlgError):
            ws.timings["dense"] += time.perf_counter() - t
            x, _, singular = ws.face_solve(idx, rhs)
            return x, singular
        self.base, self.factor = idx.copy(), L
        self.where[idx] = np.arange(idx.size)
        x = sla.cho_solve((L, True), rhs, check_finite=False)
        ws.timings["dense"] += time.perf_counter() - t
        return x, False

    def _accurate(self, idx: np.ndarray, rhs: np.ndarray, x: np.ndarray) -> bool:
        """Whether the bordered answer solves S_II x = r to ``ACCURACY`` (its residual: one product with the stored
        columns of S, not a gathered S_II); else the face is refactorised."""
        full = np.zeros(self.ws.qp.m)
        full[idx] = x
        Sx = self.ws.Sx(full)[idx]
        return float(np.linalg.norm(Sx - rhs)) <= ACCURACY * (float(np.linalg.norm(Sx)) + float(np.linalg.norm(rhs)))

    def _bordered(self, idx: np.ndarray, rhs: np.ndarray, inside: np.ndarray, new: np.ndarray,
                  left: np.ndarray) -> np.ndarray | None:
        ws, L, b = self.ws, self.factor, self.base
        border = np.concatenate([new, left])
        missing = [int(j) for j in border if int(j) not in self.W]
        S_bN = ws.cross(b, new) if new.size else np.zeros((b.size, 0))
        t = time.perf_counter()
        if missing:
            C = np.zeros((b.size, len(missing)))
            for c, j in enumerate(missing):
                if self.where[j] >= 0:  # a row of b that left: its unit column, of S's size (Z's blocks alike)
                    C[self.where[j], c] = self.scale
                else:
                    C[:, c] = S_bN[:, int(np.flatnonzero(new == j)[0])]
            Wn = sla.solve_triangular(L, C, lower=True, check_finite=False)
            for c, j in enumerate(missing):
                self.W[j] = Wn[:, c]
        W = np.column_stack([self.W[int(j)] for j in border]) if border.size else np.zeros((b.size, 0))
        r_b = np.zeros(b.size)
        r_b[self.where[idx[inside]]] = rhs[inside]
        z = sla.solve_triangular(L, r_b, lower=True, check_finite=False)
        Z = -(W.T @ W)
        q_new = new.size
        if q_new:
            Z[:q_new, :q_new] += ws.block(new)
        rv = -(W.T @ z)
        rv[:q_new] += rhs[~inside]
        try:
            with warnings.catch_warnings():  # an ill-conditioned Z shows in the residual check (``_accurate``)
                warnings.simplefilter("ignore", sla.LinAlgWarning)
                v = sla.solve(Z, rv, assume_a="sym", check_finite=False) if border.size else np.zeros(0)
        except (np.linalg.LinAlgError, sla.LinAlgError):
            ws.timings["dense"] += time.perf_counter() - t
            return None
        if not np.all(np.isfinite(v)):
            ws.timings["dense"] += time.perf_counter() - t
            return None
        x_b = sla.solve_triangular(L, z - W @ v, lower=True, trans="T", check_finite=False)
        x = np.empty(idx.size)
        x[inside] = x_b[self.where[idx[inside]]]
        x[~inside] = v[:q_new]
        ws.timings["dense"] += time.perf_counter() - t
        return x
