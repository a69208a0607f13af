"""Screening: the Schur complement of the rows likely to touch only, the other rows verified.

The dense Schur complement of ``substructure.factorize_contact`` costs more the more rows it has
(demo case, 211k unknowns, PARDISO, 1 thread: plain factorisation 3.1 s; with the Schur
complement of 10 rows 4.2 s, 300 rows 4.8 s, all 2025 candidate rows 7.4-8.4 s), while only
about 4 % of the candidate rows end up active. So every method works on a growing row set W:

1. W = the rows predicted to touch (``initial_rows``): for each punch the fraction ``fraction``
   of its candidate rows with the smallest G (the deepest overlap of the undeformed shell), at
   least ``min_rows`` of them, and the rows whose G ties with the last one taken (a uniform
   overlap ranks nothing); the factorisation carries the Schur complement of B_W;
2. solve the QP restricted to W (active set or dual; warm-started from the previous round);
3. evaluate g = G + BU (+ Dδ) at every row. If no row outside W penetrates by more than the
   tolerance, (U, Λ with Λ_i = 0 outside W) is a KKT point of the whole QP: the outside rows are
   feasible and carry no force, and every other residual is that of the restricted QP. Otherwise
   the penetrating rows join W (their columns of S: blocked solves with the same factors, kept
   for later rounds) and step 2 repeats.

W only grows, so the loop ends, at the latest with W = all rows.

The penalty method runs the same loop (``exact=False``), with one difference: an outside row joins W as soon
as it penetrates at all, since every penetrating row carries a penalty force; the screened solution is
then the penalty solution of the whole QP. Paper panel at 216k dofs with the midpoints' 7 921 rows: 4 881
Schur columns by sparse solves and 79 s of contact solve on A alone, 2.8 s after the factorisation bordered
by the 2 641 screened rows (4.3 s against 1.8 s for A alone), the same 675 penetrating rows.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterator, Sequence

import numpy as np

from ..errors import InputError, SolverError
from ..linalg import Factorization
from ..linalg.sparse import same_entries
from .kkt import length_scale
from .qp import ContactQP, ContactSolution
from .schur import Unfinished
from .substructure import MIN_UNKNOWNS, factorize_contact

#: share of each punch's candidate rows in the first Schur complement. On the demo case every
#: active row is among the deepest 21-28 % (70k, 211k, 281k dofs: 58 of 625 rows active, the
#: shallowest of them at rank 172; 84 of 2025, rank 428; 191 of 2401, rank 648); at 1.12M dofs a
#: first set of 25 % missed 154 of the 1181 active rows, whose columns then cost 27 s of solves
FRACTION = 1 / 3
#: fewest rows per punch in the first Schur complement
MIN_ROWS = 64
#: predicted by a coarser level's solution (``predicted_rows``), the rows whose predicted gap is at most this
#: share of the length scale. Paper panel at 281k dofs (9 409 rows, 1 189 active) from the 71k level: 431 rows
#: penetrate, 1 805 / 1 957 / 2 253 lie within 1e-5 / 1e-4 / 1e-3 (the coarse zone: its fine rows' gaps are
#: ~0), and the active rows reach rank 1 799 in that gap (in G: rank 2 673 of the G rule's 3 137)
MARGIN = 1e-4
#: a coarser level predicts the first Schur complement (``solver.nested = "auto"``) when the G rule would
#: border more rows than this: each row costs ~5 ms of the bordered factorisation at 1.12M dofs
NESTED_ROWS = 4000


def initial_rows(G: np.ndarray, groups: np.ndarray | None = None, fraction: float = FRACTION,
                 min_rows: int = MIN_ROWS) -> np.ndarray:
    """Indices (sorted) of the rows predicted to touch: per group (punch) the ⌈fraction·m_k⌉ rows
    with the smallest G, at least ``min_rows`` (or all of the group's rows), and every row whose G
    ties with the last one taken (to 1e-9 of the group's range of |G|): G cannot tell those apart,
    so a uniform overlap (an interference fit) selects all rows instead of an arbitrary third."""
    if not 0 < fraction <= 1:
        raise InputError("screening.fraction", f"must lie in (0, 1], got {fraction!r}")
    G = np.asarray(G, dtype=float)
    groups = np.zeros(G.size, dtype=np.int64) if groups is None else np.asarray(groups)
    keep = []
    for k in np.unique(groups):
        idx = np.flatnonzero(groups == k)
        count = min(idx.size, max(min_rows, int(np.ceil(fraction * idx.size))))
        order = idx[np.argsort(G[idx], kind="stable")]
        cut = G[order[count - 1]] + 1e-9 * float(np.abs(G[idx]).max())
        keep.append(order[G[order] <= cut])
    return np.sort(np.concatenate(keep)) if keep else np.zeros(0, dtype=np.int64)


def predicted_rows(g: np.ndarray, scale: float, groups: np.ndarray | None = None, margin: float = MARGIN,
                   min_rows: int = MIN_ROWS) -> np.ndarray:
    """Indices (sorted) of the rows predicted to touch by predicted gaps g (a coarser level's solution on this
    mesh): per group (punch) the rows with g ≤ ``margin``·``scale``, at least the ``min_rows`` smallest."""
    g = np.asarray(g, dtype=float)
    groups = np.zeros(g.size, dtype=np.int64) if groups is None else np.asarray(groups)
    keep = []
    for k in np.unique(groups):
        idx = np.flatnonzero(groups == k)
        order = idx[np.argsort(g[idx], kind="stable")]
        keep.append(np.union1d(order[: min(min_rows, idx.size)], idx[g[idx] <= margin * scale]))
    return np.sort(np.concatenate(keep)) if keep else np.zeros(0, dtype=np.int64)


def coarse_start_pays(m: int, fraction: float = FRACTION) -> bool:
    """Whether a start from the coarser level (``solver.nested = "auto"``) pays for m candidate rows: when the
    share ``fraction`` of them, the first Schur complement without a prediction, exceeds ``NESTED_ROWS``."""
    return fraction * m > NESTED_ROWS


def factorize_screened(qp: ContactQP, groups: np.ndarray | None = None, initial_active: np.ndarray | None = None,
                       backend: str = "auto", min_unknowns: int = MIN_UNKNOWNS,
                       predicted_gap: np.ndarray | None = None) -> tuple[Factorization, np.ndarray | None]:
    """The factorisation for the contact methods: A with the dense Schur complement of the rows
    ``initial_rows(qp.G, groups)`` — or, given ``predicted_gap`` (the gaps of a coarser level's solution),
    ``predicted_rows`` of it — plus the rows of ``initial_active`` (e.g. a warm start), when
    ``substructure.factorize_contact`` takes that path (from ``min_unknowns`` on), else plain. Returns
    it and the screened rows (None when there is no Schur complement: then solve the whole QP
    directly)."""
    if predicted_gap is None:
        rows = initial_rows(qp.G, groups)
    else:
        rows = predicted_rows(predicted_gap, length_scale(qp, predicted_gap), groups)
    if initial_active is not None:
        rows = np.union1d(rows, np.flatnonzero(np.asarray(initial_active, dtype=bool)))
    flex = None if qp.flexibility is None else qp.flexibility[rows]
    fac = factorize_contact(qp.A, qp.B[rows], backend, min_unknowns=min_unknowns, flexibility=flex)
    return fac, (rows if fac.schur is not None else None)


def solve_screened(
    qp: ContactQP,
    rows: np.ndarray | None,
    solver: Callable[..., ContactSolution],
    factorization: Factorization,
    tol: float = 1e-10,
    initial_active: np.ndarray | None = None,
    max_rounds: int = 50,
    exact: bool = True,
    **kw,
) -> ContactSolution:
    """Solve ``qp`` by ``solver`` on a growing row set, starting from ``rows`` (module docstring).
    ``factorization`` should carry the Schur complement of ``qp.B[rows]`` (``factorize_contact``);
    ``kw`` go to the solver. The result is the solution of the whole QP; ``info["screening"]`` lists
    the rows per round. Without screening (``rows`` None, as ``factorize_screened`` returns it for a
    plain factorisation, or every row) this is ``solver`` on the whole QP.

    ``exact``: ``solver`` is an exact method (``solve_active_set``, ``solve_dual``: warm-started by an
    active set; an outside row may penetrate by the tolerance, as any row of the KKT point may) or,
    False, the penalty method (``solve_penalty``: warm-started by the previous round's U; an outside
    row joins as soon as it penetrates at all, since every penetrating row carries a penalty force, so
    the screened penalty solution is that of the whole penalised problem)."""
    if rows is None or np.asarray(rows).size == qp.m:
        start_kw = {"initial_active": initial_active} if exact else {}
        return solver(qp, tol=tol, factorization=factorization, **start_kw, **kw)
    t0 = time.perf_counter()
    m = qp.m
    order = np.asarray(rows, dtype=np.int64)
    inside = np.zeros(m, dtype=bool)
    inside[order] = True
    if initial_active is not None:
        initial_active = np.asarray(initial_active, dtype=bool)
    history: list = []
    timings: dict[str, float] = {}
    iterations = 0
    sizes = []
    for rnd in range(1, max_rounds + 1):
        sizes.append(int(order.size))
        sub = qp.restrict(order)
        if exact:
            kw["initial_active"] = None if initial_active is None else initial_active[order]
        sol = solver(sub, tol=tol, factorization=factorization, **kw)
        iterations += sol.iterations
        for rec in sol.history:
            history.append({**rec, "screening_round": rnd})
        for key, val in sol.timings.items():
            timings[key] = timings.get(key, 0.0) + val
        g, lscale, pen_out = _outside_penetration(qp, sol, inside)
        if pen_out <= (tol * lscale if exact else 0.0):
            return _whole(qp, sol, order, g, lscale, iterations, history, timings, sizes, t0)
        new = np.flatnonzero(~inside & (g < 0))
        active = np.zeros(m, dtype=bool)
        active[order[sol.active]] = True
        active[new] = True  # PDAS: the penetrating rows start active
        initial_active = active
        if not exact:  # the penalty restarts from this round's displacements
            kw["initial_U"] = sol.U
        order = np.concatenate([order, new[np.argsort(g[new], kind="stable")]])
        inside[new] = True
    raise SolverError(f"{sol.method}: screening did not settle in {max_rounds} rounds",
                      residuals={"penetration_outside": pen_out}, iterations=iterations)


def solve_screened_curve(
    qps: Sequence[ContactQP],
    rows: np.ndarray | None,
    solver: Callable[..., ContactSolution | Unfinished],
    factorization: Factorization,
    tol: float = 1e-10,
    initial_active: np.ndarray | None = None,
    callbacks: Sequence[Callable[[dict], None] | None] | None = None,
    **kw,
) -> Iterator[ContactSolution]:
    """The points of a curve: QPs with the same A, F and B (a force-controlled punch at several forces: only
    P differs), each the solution of ``solve_screened(qp, rows, solver, factorization, tol)`` to the tolerance.

    1. Each QP restricted to ``rows`` is solved in the multiplier space (``solver``, an exact method, with
       ``finish=False``), warm-started from its predecessor's active set (the first from ``initial_active``).
    2. The final checks of all points share their solves: one block solve for U_k = A⁻¹(F + BᵀΛ_k), block
       products A U_k and |A||U_k|, and one block solve for the duality-gap terms A⁻¹r_k (``kkt.evaluate``),
       where one point alone makes two solves and three products (68 ms per solve at 211k unknowns against
       25 ms per column of a block of 20).
    3. A point whose check passes and whose outside rows do not penetrate is the whole QP's solution, as in
       ``solve_screened``; any other point (round-off in S, an outside row that touches) runs
       ``solve_screened`` alone, from its active set.

    ``callbacks[k]``: the solver's ``callback`` for point k. ``kw`` go to the solver. Yields the points'
    solutions in order; when a point's solve fails (SolverError, or any other error), the points before it are
    yielded, then its error is raised, as a loop of ``solve_screened`` would. Points of another stiffness,
    load or rows than the first: InputError, at once."""
    qps = list(qps)
    first = qps[0] if qps else None
    for k, qp in enumerate(qps[1:], 1):
        same_A = qp.A is first.A or same_entries(qp.A, first.A)  # one object for the points of a curve
        if not same_A or not np.array_equal(qp.F, first.F) or not same_entries(qp.B, first.B):
            raise InputError("qps", f"point {k} has another stiffness, load or contact rows than point 0: "
                             "solve it with solve_screened")
    return _solve_curve(qps, rows, solver, factorization, tol, initial_active,
                        list(callbacks) if callbacks is not None else [None] * len(qps), kw)


def _solve_curve(qps: list[ContactQP], rows: np.ndarray | None, solver: Callable, factorization: Factorization,
                 tol: float, initial_active: np.ndarray | None, callbacks: list, kw: dict) -> Iterator[ContactSolution]:
    if not qps:
        return
    m = qps[0].m
    order = np.arange(m) if rows is None else np.asarray(rows, dtype=np.int64)
    inside = np.zeros(m, dtype=bool)
    inside[order] = True
    active = None if initial_active is None else np.asarray(initial_active, dtype=bool)
    pending: list[Unfinished | ContactSolution] = []
    failure: Exception | None = None
    for qp, callback in zip(qps, callbacks):
        sub = qp if rows is None else qp.restrict(order)
        try:
            u = solver(sub, tol=tol, factorization=factorization, finish=False, callback=callback,
                       initial_active=None if active is None else active[order], **kw)
        except Exception as exc:  # noqa: BLE001 — the points before it are finished first, then it is raised
            failure = exc
            break
        pending.append(u)
        active = np.zeros(m, dtype=bool)
        active[order[u.active]] = True
    t0 = time.perf_counter()
    waiting = [k for k, u in enumerate(pending) if isinstance(u, Unfinished)]
    shared: dict[int, tuple[np.ndarray, ...]] = {}
    if waiting:
        ws = pending[waiting[0]].ws  # type: ignore[union-attr]
        lam = np.stack([pending[k].Lambda for k in waiting], axis=1)
        rhs = ws.qp.F[:, None] + ws.qp.B.T @ lam
        # without refinement: the KKT check is the judge (its stationarity is U's backward error), and a point
        # that fails it refines on its own (``Workspace.finish_exact``)
        U = factorization.solve_many(rhs, refine=False)
        AU = ws.qp.A @ U
        Ainv_r = factorization.solve_many(AU - rhs, refine=False)
        absA_absU = ws.qp.abs_A @ np.abs(U)
        shared = {k: (U[:, j], AU[:, j], Ainv_r[:, j], absA_absU[:, j]) for j, k in enumerate(waiting)}
    share = (time.perf_counter() - t0) / max(len(waiting), 1)
    for k, (qp, u) in enumerate(zip(qps, pending)):
        try:
            sol = u.finish(shared[k]) if isinstance(u, Unfinished) else u
        except SolverError:
            sol = None  # the check failed even after refinement on the face: the point alone
        if sol is not None:
            sol.timings["solve"] = sol.timings.get("solve", 0.0) + share
            sol.timings["total"] = sol.timings.get("total", 0.0) + share
            g, lscale, pen_out = _outside_penetration(qp, sol, inside)
            if pen_out <= tol * lscale:  # (no row is outside without screening)
                # _whole's total runs from its start argument: the point's own seconds before this check
                began = time.perf_counter() - sol.timings["total"]
                whole = sol if rows is None else _whole(qp, sol, order, g, lscale, sol.iterations,
                                                         list(sol.history), sol.timings, [int(order.size)], began)
                whole.info["curve"] = {"shared_final_solves": True}
                yield whole
                continue
        start = np.zeros(m, dtype=bool)
        start[order[u.active]] = True
        alone = solve_screened(qp, rows, solver, factorization, tol=tol, initial_active=start,
                               callback=callbacks[k], **kw)
        if isinstance(u, Unfinished):  # its first attempt counts too
            alone.timings["total"] += u.spent + share
        alone.info["curve"] = {"shared_final_solves": False}
        yield alone
    if failure is not None:
        raise failure


def _outside_penetration(qp: ContactQP, sol: ContactSolution, inside: np.ndarray) -> tuple[np.ndarray, float, float]:
    """The whole QP's gaps g at ``sol``, their length scale (``kkt.length_scale``) and the deepest penetration
    of a row not ``inside`` the restricted QP (0 if none)."""
    g = qp.gap(sol.U, sol.delta)
    outside = ~inside & (g < 0)
    return g, length_scale(qp, g), float(-g[outside].min()) if outside.any() else 0.0


def _whole(qp: ContactQP, sol: ContactSolution, order: np.ndarray, g: np.ndarray, lscale: float,
           iterations: int, history: list, timings: dict, sizes: list, t0: float) -> ContactSolution:
    """The restricted solution as a solution of the whole QP (Λ = 0 and g ≥ −tol outside)."""
    m = qp.m
    lam = np.zeros(m)
    lam[order] = sol.Lambda
    active = np.zeros(m, dtype=bool)
    active[order] = sol.active
    pen = float(max(0.0, -g.min())) if m else 0.0
    residuals = {**sol.residuals, "penetration": pen}
    scaled = {**sol.info.get("scaled_residuals", {}), "penetration": pen / lscale}
    timings = {**timings, "total": time.perf_counter() - t0}
    info = {**sol.info, "gap": g, "scaled_residuals": scaled,
            "screening": {"rows": sizes, "rounds": len(sizes), "candidates": m}}
    return ContactSolution(U=sol.U, Lambda=lam, pressure=lam / qp.weights, active=active, delta=sol.delta,
                           iterations=iterations, residuals=residuals, method=sol.method, history=history,
                           timings=timings, energy=sol.energy, dual_value=sol.dual_value, info=info)
