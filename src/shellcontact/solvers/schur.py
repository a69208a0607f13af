"""One factorisation of A, reused: the Schur complement S = B A⁻¹ Bᵀ column by column.

Every solver here works in the multiplier space. With U0 = A⁻¹F and c0 = G + B U0 (the gap
with no contact force), any U = A⁻¹(F + BᵀΛ) has the gap g(Λ, δ) = c0 + SΛ + Dδ and the
energy 𝓔 = −½FᵀU0 + ½ΛᵀSΛ (− Pᵀδ). The columns S[:, J] = B (A⁻¹ B_Jᵀ) are computed lazily —
only for constraints that ever carry force — by blocked solves with the single factorisation
(blocks of at most 64 right-hand sides, without iterative refinement), and cached. A final
fresh solve U = A⁻¹(F + BᵀΛ) and the KKT check on that U guard against round-off in S; if
the check fails, a few refinement steps with the true gaps as right-hand side follow
(iterative refinement of the face system).

When the factorisation carries the dense Schur complement of the QP's rows
(``Factorization.schur``, from ``substructure.factorize_contact``: one factorisation of A bordered
by B), a column of S costs two dense triangular solves of order m instead of a sparse solve, and
``finish_exact`` always does one face refinement on the true gaps (kept only if the point stays
converged).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import cast

import numpy as np

from ..errors import SolverError
from ..linalg import Factorization, SchurComplement, factorize
from ..linalg.sparse import same_entries
from .face import solve_face
from .kkt import TINY, KKTReport, evaluate, length_scale
from .qp import ContactQP, ContactSolution, check_feasibility
from .substructure import factorize_contact


def default_growth(ws: Workspace) -> float:
    """The working-set growth θ of the active-set and dual methods: 0.9 (add only the deepest
    violations: fewer columns of S, each a sparse solve) or, when the columns come from the dense
    Schur complement and cost little, 0 (add all: fewer iterations; paper panel at 281k dofs,
    active set 29 → 17 iterations, dual 63 → 12, for the same time)."""
    return 0.0 if ws.dense_schur is not None else 0.9


#: the fewest rows a working set may gain in one step; above it, at most as many as it holds (doubling)
MIN_BATCH = 64
#: and at least 1/FLOOR_SHARE of the rows it holds (when that many are violated), however few lie within θ
#: of the deepest: a uniform overlap (a sleeve on a pipe) leaves only a few rows near the deepest at every
#: step, and the set then crept by 3 rows an iteration (active set: no convergence in 100 iterations)
FLOOR_SHARE = 4


def deepest_violations(g: np.ndarray, candidates: np.ndarray, growth: float, size: int,
                       limit: int | None = None) -> np.ndarray:
    """The rows that join a working set of ``size`` rows: among ``candidates`` (bool) with g < 0, the deepest
    k, where k is the number of them with g ≤ θ·min g (θ = ``growth``), raised to at least
    max(``MIN_BATCH``, size/``FLOOR_SHARE``) and cut to at most max(``MIN_BATCH``, size) (and to ``limit``,
    when given), and never more than are violated.

    The cap lets the set at most double per step: when a seed face leaves a whole band of rows penetrating
    (a floating pipe held at two points), the band would otherwise join at once, each row a column of S
    (4260 instead of 844 columns for the same 249 active rows, ring-stiffness example at 213k unknowns).
    The floor guarantees progress: while rows are violated, the set grows by at least a quarter per step
    (or by all violated rows, or by ``MIN_BATCH``), so a zone of N active rows fills in O(log N) steps and
    not in N / (rows within θ of the deepest) steps."""
    v = candidates & (g < 0)
    n_violated = int(v.sum())
    if n_violated == 0:
        return v
    count = n_violated
    if growth > 0:
        count = int((v & (g <= growth * g[v].min())).sum())
        count = max(count, MIN_BATCH, size // FLOOR_SHARE)
    cap = max(MIN_BATCH, size) if limit is None else min(max(MIN_BATCH, size), limit)
    count = min(count, cap, n_violated)
    if count < n_violated:
        cand = np.flatnonzero(v)
        v = np.zeros_like(v)
        v[cand[np.argsort(g[cand], kind="stable")[:count]]] = True
    return v


class Workspace:
    """Factorisation, U0, c0 and the cache of Schur-complement columns for one QP."""

    def __init__(self, qp: ContactQP, factorization: Factorization | None = None,
                 substructure: bool | None = None, extended: bool = False, finish: bool = True) -> None:
        """``substructure``: use the dense Schur complement of the contact rows
        (``substructure.factorize_contact``) for the columns of S. None (default): use it when the
        factorisation carries one for the QP's first rows (all of them, or a prefix: the remaining
        rows' columns S[:, m0:] are then solved for once, in blocks, and kept with the Schur
        complement so that a QP extending those rows again (``screening``) solves only for its newest
        rows); True: also factorise that way when no factorisation is given; False: never (one sparse
        solve per column). ``extended``: the final solves U = A⁻¹(F + BᵀΛ) of ``finish_exact`` with
        mixed-precision refinement (``Factorization.solve(extended=True)``, right-hand side formed in
        extended precision too), so that the gaps, and the face refinement of Λ on them, are not
        limited by cond(A)·ε. ``finish`` False: ``finish_exact`` returns an ``Unfinished`` (the converged
        multipliers before their final check), whose check its caller runs later, with the solves of several
        points in one block (``screening.solve_screened_curve``)."""
        self.qp = qp
        self.extended = extended
        self.finish = finish
        self.t0 = time.perf_counter()
        self.timings = {"feasibility": 0.0, "factorization": 0.0, "schur": 0.0, "solve": 0.0, "dense": 0.0}
        self.n_solves = 0
        self.dependent_faces = 0  # face solves that dropped dependent rows or columns of D (``face``)
        t = time.perf_counter()
        self.live = check_feasibility(qp)
        self.timings["feasibility"] = time.perf_counter() - t
        t = time.perf_counter()
        if factorization is None:
            factorization = (factorize_contact(qp.A, qp.B, min_unknowns=0, flexibility=qp.flexibility)
                             if substructure else factorize(qp.A))
        self.fact = factorization
        self.timings["factorization"] = time.perf_counter() - t
        sch = self.fact.schur if substructure is not False else None
        prefix = sch is not None and sch.m <= qp.m and sch.matches(qp.B[: sch.m])
        self.dense_schur: SchurComplement | None = sch if prefix else None
        #: S[:, m0:] for the rows after the dense Schur complement's m0 rows (None: there are none)
        self.extra: np.ndarray | None = None
        #: one face refinement on the true gaps after convergence (finish_exact); on with the dense S
        #: unless its owner turned it off (``SchurComplement.refine_converged``)
        self.extra_refinement = self.dense_schur is not None and self.dense_schur.refine_converged
        self.U0 = self.solve(qp.F) if np.any(qp.F) else np.zeros(qp.n)  # no load but the punch: U0 = 0
        self.BU0 = qp.B @ self.U0
        self.c0 = qp.G + self.BU0
        self.BT = qp.B.T.tocsc()
        if self.dense_schur is not None and sch.m < qp.m:
            t = time.perf_counter()
            self.extra = self._extra_columns(sch)
            sch.extra = (qp.B[sch.m :], self.extra)
            self.timings["schur"] += time.perf_counter() - t
        m = qp.m
        self._store = np.empty((m, min(m, 16)))
        self._ncol = 0
        self._pos = np.full(m, -1, dtype=np.int64)
        #: the length scale before contact (``kkt.length_scale`` at Λ = 0): the largest prescribed
        #: overlap and the largest displacement of a constraint point under the load alone
        self.lscale = length_scale(qp, self.c0)

    # -- linear algebra -------------------------------------------------------------------
    def solve(self, b: np.ndarray) -> np.ndarray:
        t = time.perf_counter()
        x = self.fact.solve(b)
        self.timings["solve"] += time.perf_counter() - t
        self.n_solves += 1
        return x

    def solve_equilibrium(self, lam: np.ndarray) -> np.ndarray:
        """U = A⁻¹(F + BᵀΛ); with ``extended`` the right-hand side and the refinement's residuals in
        extended precision."""
        qp = self.qp
        if not self.extended:
            return self.solve(qp.F + qp.B.T @ lam)
        t = time.perf_counter()
        ld = np.longdouble
        rhs = qp.F.astype(ld) + qp.B.T.astype(ld) @ lam.astype(ld)
        x = self.fact.solve(rhs, extended=True)
        self.timings["solve"] += time.perf_counter() - t
        self.n_solves += 1 + self.fact.refinements
        return x

    def ensure(self, idx: np.ndarray) -> None:
        idx = np.asarray(idx, dtype=np.int64)
        miss = np.unique(idx[self._pos[idx] < 0])
        if miss.size == 0:
            return
        t = time.perf_counter()
        need = self._ncol + miss.size
        if need > self._store.shape[1]:
            new = np.empty((self.qp.m, min(self.qp.m, max(need, 2 * self._store.shape[1]))))
            new[:, : self._ncol] = self._store[:, : self._ncol]
            self._store = new
        # dense Schur complement: S[:, J] = T⁻¹[:, J] − ρ⁻¹I[:, J], dense triangular solves in one go
        chunk = miss.size if self.dense_schur is not None else self._block_size()
        for s in range(0, miss.size, chunk):
            cols = miss[s : s + chunk]
            if self.dense_schur is not None:
                self._store[:, self._ncol : self._ncol + cols.size] = self._dense_columns(cols)
            else:
                self._store[:, self._ncol : self._ncol + cols.size] = self._solved_columns(cols)
            self._pos[cols] = np.arange(self._ncol, self._ncol + cols.size)
            self._ncol += cols.size
        # keep the computed block exactly symmetric: S_KK is used both in face solves
        # (Cholesky needs symmetry) and in gap updates; an O(cond·ε_mach) asymmetry between
        # them would be amplified by ω/ε in the penalty method. The block of the earlier columns is
        # symmetric already: only the new rows and columns are averaged (the same values as averaging
        # the whole block, in O(|K|·|J|) instead of O(|K|²))
        known = np.flatnonzero(self._pos >= 0)
        pos, pos_new = self._pos[known], self._pos[miss]
        avg = 0.5 * (self._store[np.ix_(known, pos_new)] + self._store[np.ix_(miss, pos)].T)
        self._store[np.ix_(known, pos_new)] = avg
        self._store[np.ix_(miss, pos)] = avg.T
        self.timings["schur"] += time.perf_counter() - t

    def _block_size(self) -> int:
        """Right-hand sides per blocked solve: PARDISO, 211k unknowns, ms per column for blocks of
        1, 16, 64, 128, 256: 90, 31, 23, 34, 34 (n = 40k: 3-4 ms for 8-128)."""
        return int(max(1, min(64, 2e8 // self.qp.n)))

    def _solved_columns(self, cols: np.ndarray) -> np.ndarray:
        """S[:, cols] = B (A⁻¹ B_colsᵀ): one blocked sparse solve."""
        # without iterative refinement: it would triple the cost of the columns, and round-off in S
        # is corrected by the refinement on the true gaps at the end
        Z = self.fact.solve_many(self.BT[:, cols].toarray(), refine=False)
        self.n_solves += cols.size
        return self.qp.B @ Z

    def _extra_columns(self, sch: SchurComplement) -> np.ndarray:
        """S[:, m0:] for the rows after the m0 Schur rows: the block an earlier Workspace solved for
        (``sch.extra``, when this QP's rows extend its rows) is reused, the new columns are solved
        for, and S[new, old] = S[old, new]ᵀ."""
        m, m0 = self.qp.m, sch.m
        out = np.empty((m, m - m0))
        e = 0
        if sch.extra is not None:
            rows, known = sch.extra
            e = rows.shape[0]
            if m0 + e <= m and same_entries(self.qp.B[m0 : m0 + e], rows):
                out[: m0 + e, :e] = known
            else:
                e = 0
        chunk = self._block_size()
        for s in range(m0 + e, m, chunk):
            cols = np.arange(s, min(m, s + chunk))
            out[:, cols - m0] = self._solved_columns(cols)
        out[m0 + e :, :e] = out[m0 : m0 + e, e:].T
        return out

    def _dense_columns(self, cols: np.ndarray) -> np.ndarray:
        """S[:, cols] from the dense Schur complement of the first m0 rows and ``extra`` = S[:, m0:]."""
        sch = self.dense_schur
        m0 = sch.m
        if self.extra is None:
            return sch.columns(cols)
        X = np.empty((self.qp.m, cols.size))
        first = cols < m0
        if first.any():  # S[m0:, j] = S[j, m0:]ᵀ (symmetry)
            X[:m0, first] = sch.columns(cols[first])
            X[m0:, first] = self.extra[cols[first]].T
        if (~first).any():
            X[:, ~first] = self.extra[:, cols[~first] - m0]
        return X

    def columns(self, idx: np.ndarray) -> np.ndarray:
        """S[:, idx] (m × len(idx))."""
        idx = np.asarray(idx, dtype=np.int64)
        self.ensure(idx)
        return self._store[:, self._pos[idx]]

    def block(self, idx: np.ndarray) -> np.ndarray:
        """S[idx][:, idx], symmetrised (gathered directly: not through the m × |idx| columns)."""
        idx = np.asarray(idx, dtype=np.int64)
        self.ensure(idx)
        return self._store[np.ix_(idx, self._pos[idx])]

    def Sx(self, x: np.ndarray) -> np.ndarray:
        supp = np.flatnonzero(x)
        if supp.size == 0:
            return np.zeros(self.qp.m)
        self.ensure(supp)
        if 4 * supp.size < self._ncol:  # few columns: gather them
            return self._store[:, self._pos[supp]] @ x[supp]
        z = np.zeros(self._ncol)  # many: one product with every stored column, no gathered copy
        z[self._pos[supp]] = x[supp]
        return self._store[:, : self._ncol] @ z

    def known_diagonal(self) -> np.ndarray:
        """Diagonal entries S_ii of the columns computed so far."""
        idx = np.flatnonzero(self._pos >= 0)
        return self._store[idx, self._pos[idx]]

    def length_scale(self, g: np.ndarray) -> float:
        """``kkt.length_scale`` at the gaps g (≥ the scale before contact): the scale of the
        penetration in the solvers' stopping tests; it grows with the contact displacement (under
        force control it starts near 0: the punch just touches and the travel is unknown)."""
        return max(self.lscale, float(np.abs(g - self.qp.G).max(initial=0.0)))

    def force_scale(self, g: np.ndarray) -> float:
        """Λ_ref = length scale / max S_ii over the columns computed so far (``kkt`` module docstring): the
        force that closes the length scale at the most flexible row; a force below tol·Λ_ref moves no gap
        by more than tol·length scale. TINY before any column is known (then every Λ is still 0)."""
        smax = self.max_flexibility()
        return self.length_scale(g) / smax if smax > 0.0 else TINY

    def max_flexibility(self) -> float:
        """max S_ii over the columns computed so far (0 before any)."""
        diag = self.known_diagonal()
        return float(diag.max()) if diag.size else 0.0

    @property
    def n_columns(self) -> int:
        return self._ncol

    def gap(self, lam: np.ndarray, delta: np.ndarray | None) -> np.ndarray:
        """Predicted gap c0 + SΛ + Dδ."""
        g = self.c0 + self.Sx(lam)
        if self.qp.k and delta is not None:
            g = g + self.qp.D @ delta
        return g

    def face_solve(
        self,
        idx: np.ndarray,
        rhs: np.ndarray,
        rhs2: np.ndarray | None = None,
        shift: np.ndarray | None = None,
        H: np.ndarray | None = None,
        use_D: bool = True,
    ) -> tuple[np.ndarray, np.ndarray | None, bool]:
        """Solve (S_II + diag(shift)) x + D_I δ = rhs, D_Iᵀ x = rhs2 (the last only under force
        control) by Cholesky of the dense block (``face.solve_face``): rows of the face that depend on the
        others, and columns of D the face does not determine, are found by a rank check on the pivots and
        dropped (x = 0 there, δ = 0 along them). Returns x, δ, and whether the face was singular (also counted
        in ``dependent_faces``, which the solution's info reports)."""
        qp = self.qp
        if H is None:
            H = self.block(idx)
            if shift is not None:
                H[np.diag_indices_from(H)] += shift
        t = time.perf_counter()
        with_D = qp.k > 0 and use_D
        sol = solve_face(H, np.asarray(rhs, float), qp.D[idx] if with_D else None, rhs2 if with_D else None)
        self.timings["dense"] += time.perf_counter() - t
        if sol.singular:
            self.dependent_faces += 1
        return sol.x, sol.delta, sol.singular

    def first_contact(self, mask: np.ndarray, g: np.ndarray) -> np.ndarray:
        """Force control: add to ``mask`` the first vertex each loaded punch would touch if it
        has none in the set (else δ_j is undetermined on the face)."""
        qp = self.qp
        mask = mask.copy()
        for j in range(qp.k):
            if qp.P[j] == 0:
                continue
            s = np.sign(qp.P[j])
            ahead = self.live & (s * qp.D[:, j] < 0)
            if np.any(mask & ahead):
                continue
            cand = np.flatnonzero(ahead)
            t = g[cand] / (-s * qp.D[cand, j])
            mask[cand[np.argmin(t)]] = True
        return self._hold_every_column(mask, g)

    def _hold_every_column(self, mask: np.ndarray, g: np.ndarray) -> np.ndarray:
        """While the columns of D on ``mask`` are dependent (e.g. a floating shell's translation and the
        travel of the punch that pushes it: only the other punch's rows tell them apart), add the row
        nearest to contact among those that see a direction y with D_I y = 0."""
        D = self.qp.D
        for _ in range(self.qp.k):
            DI = D[mask]
            _, sv, vt = np.linalg.svd(DI, full_matrices=True)
            rank = int(np.sum(sv > 1e-10 * max(float(sv[0]) if sv.size else 0.0, 1e-300)))
            if rank == self.qp.k:
                break
            seen = np.abs(D @ vt[rank:].T).max(axis=1)
            cand = np.flatnonzero(self.live & ~mask & (seen > 1e-10 * np.abs(D).max()))
            if cand.size == 0:
                break
            mask[cand[np.argmin(g[cand])]] = True
        return mask

    # -- result ---------------------------------------------------------------------------
    def result(
        self,
        U: np.ndarray,
        lam: np.ndarray,
        delta: np.ndarray | None,
        active: np.ndarray,
        rep: KKTReport,
        method: str,
        iterations: int,
        history: list,
        info: dict | None = None,
    ) -> ContactSolution:
        tim = dict(self.timings)
        tim["total"] = time.perf_counter() - self.t0
        tim["n_solves"] = float(self.n_solves)
        tim["schur_columns"] = float(self._ncol)
        inf = {"gap": rep.gap, "scaled_residuals": rep.scaled, "dependent_faces": self.dependent_faces}
        inf.update(info or {})
        return ContactSolution(
            U=U,
            Lambda=lam,
            pressure=lam / self.qp.weights,
            active=active,
            delta=delta,
            iterations=iterations,
            residuals=rep.residuals,
            method=method,
            history=history,
            timings=tim,
            energy=rep.energy,
            dual_value=rep.dual_value,
            info=inf,
        )

    def finish_exact(
        self,
        lam: np.ndarray,
        delta: np.ndarray | None,
        tol: float,
        method: str,
        iterations: int,
        history: list,
        refine: int = 3,
        info: dict | None = None,
        first: tuple[np.ndarray, ...] | None = None,
    ) -> ContactSolution | Unfinished:
        """Fresh U = A⁻¹(F + BᵀΛ), KKT check at ``tol``; refine on the face if round-off in S
        spoils it; raise SolverError with the residuals if it still fails. ``first`` = (U, A U, A⁻¹r, |A||U|):
        the first check's solves and products, made already (``Unfinished.finish``). With ``finish`` off
        (``Workspace``), the ``Unfinished`` point instead."""
        if not self.finish:
            return Unfinished(self, lam, delta, tol, method, iterations, history, refine, info,
                              spent=time.perf_counter() - self.t0)
        qp = self.qp
        # a force below tol·Λ_ref (``force_scale``) moves no gap by more than tol × the length scale: below what
        # the method resolves, it is round-off (±6e-14 N of a zero answer: a shell pushed rigidly by its only punch)
        lam = np.maximum(lam, 0.0)
        lam[lam <= tol * self.force_scale(self.gap(lam, delta))] = 0.0
        # S from the dense Schur complement differs from the solves' S by ~1e-10 relative: one face
        # refinement on the true gaps even when converged, kept only if it stays converged
        # with extended-precision solves the true gaps are accurate beyond cond(A)·ε: two face
        # refinements on them bring Λ (and the force) to that accuracy
        extra = 2 if self.extended else (1 if self.extra_refinement else 0)
        left = extra
        accepted = None
        for step in range(refine + 1 + extra):
            if step == 0 and first is not None:
                U, AU, Ainv_r, absA_absU = first
                rep = evaluate(qp, U, lam, delta, self.fact, AU=AU, Ainv_r=Ainv_r, absA_absU=absA_absU,
                               max_flexibility=self.max_flexibility())
            else:
                U = self.solve_equilibrium(lam)
                rep = evaluate(qp, U, lam, delta, self.fact, max_flexibility=self.max_flexibility())
                self.n_solves += 1
            if rep.converged(tol):
                if left == 0 or not np.any(lam > 0) or step == refine + extra:
                    break
                left -= 1
                accepted = (U, lam, delta, rep)
            elif accepted is not None:  # the extra step spoiled a converged point: keep that one
                U, lam, delta, rep = accepted
                break
            if step == refine + extra:
                raise SolverError(
                    f"{method}: KKT residuals above tolerance {tol:g} after refinement "
                    f"(worst: {rep.worst()})",
                    residuals=rep.residuals,
                    iterations=iterations,
                )
            # rows that penetrate beyond the tolerance on the true gaps join the face (not those within
            # it: a round-off sign must not decide whether a row carries force), but only while their
            # multiplier comes out ≥ 0: a row that penetrates only because the active rows' gaps are
            # off by round-off would pull, and clipping its pull would spoil the step for all rows
            rhs2 = None if qp.k == 0 else -(qp.D.T @ lam + qp.P)
            joining = (rep.gap < -tol * rep.lscale) & self.live & (lam <= 0)
            while True:
                idx = np.flatnonzero((lam > 0) | joining)
                dx, dd, _ = self.face_solve(idx, -rep.gap[idx], rhs2)
                pulling = joining[idx] & (dx < 0)
                if not pulling.any():
                    break
                joining[idx[pulling]] = False
            lam = lam.copy()
            lam[idx] = np.maximum(lam[idx] + dx, 0.0)
            if dd is not None:
                delta = delta + dd
            history.append({"iteration": iterations, "refinement": step + 1, "worst": rep.worst(),
                            "worst_value": rep.scaled[rep.worst()]})
        return self.result(U, lam, delta, lam > 0, rep, method, iterations, history, info)


@dataclass
class Unfinished:
    """An exact method's converged multipliers before the final check (``Workspace(finish=False)``):
    ``finish`` makes it, from U = A⁻¹(F + BᵀΛ), A U, A⁻¹r and |A||U| when given (solved together with other
    points'), else solving for them; then as ``Workspace.finish_exact``."""

    ws: Workspace
    lam: np.ndarray
    delta: np.ndarray | None
    tol: float
    method: str
    iterations: int
    history: list
    refine: int
    info: dict | None
    #: seconds the method took to get here
    spent: float = 0.0
    #: when the method stopped: the time until ``finish`` is not the point's (``Workspace.result``'s total)
    stopped: float = field(default_factory=time.perf_counter)

    @property
    def Lambda(self) -> np.ndarray:
        """The multipliers the check starts from (≥ 0)."""
        return np.maximum(self.lam, 0.0)

    @property
    def active(self) -> np.ndarray:
        return self.lam > 0

    def finish(self, first: tuple[np.ndarray, ...] | None = None) -> ContactSolution:
        ws = self.ws
        ws.finish = True
        ws.t0 += time.perf_counter() - self.stopped
        if first is not None:
            ws.n_solves += 2
        return cast(ContactSolution, ws.finish_exact(self.lam, self.delta, self.tol, self.method, self.iterations,
                                                     self.history, self.refine, self.info, first=first))
