"""A case's friction (``punch.<i>.friction``, ``punch.<i>.slide``; MODEL.md §11) in ``analysis.solve``.

``has_friction(case)`` says whether any punch has friction or a slide; then ``solve_friction`` replaces the
frictionless contact solve: Tresca (a bound g in Pa, acting on the rows in contact: the bound of row i is
ω_i g where Λ_i > 0) or Coulomb (μ, the fixed point g = μ|∇Z|Λ), each Tresca problem of the fixed point
solved by the semismooth Newton of ``solvers.tresca_newton`` (method "active-set"), the dual with disc
constraints (method "dual") or the penalty (method "penalty", its ε). The fixed point is needed for the
case's Tresca too: its bound on the contact set is not a convex problem (docs/theory.md §9a).
``[solver] steps``/``path`` make it a load path whose steps carry the slip (``solve_path``), and a punch's
``tangential_force`` makes it force-controlled along the surface (``solve_pushed``, an outer iteration on the
slide). ``attach_friction`` adds the friction force to the shell's balance and the per-punch ``friction`` entry of
summary.json. Frictionless cases never come here: their results are today's, bit for bit.
"""

from __future__ import annotations

import dataclasses
import sys
from typing import Any

import numpy as np

from ..contact.floating import friction_columns
from ..contact.friction import (
    COULOMB_CONTRACTION,
    COULOMB_TOL,
    PROBE_SOLVES,
    CoulombRecord,
    TangentialOperator,
    probed_contraction,
    solve_coulomb,
    tangential_operator,
)
from ..contact.friction_capacity import capacity_ratio, support
from ..contact.operator import contact_operator
from ..contact.punches import place_punches
from ..errors import InputError, SolverError
from ..linalg import factorize
from ..problem.case import Case
from ..problem.options import SolverOptions
from ..solvers.active_set import solve_active_set
from ..solvers.coulomb_newton import solve_friction_newton
from ..solvers.pair_block import border_rows, factorize_pairs
from ..solvers.qp import ContactSolution
from ..solvers.screening import solve_screened
from ..solvers.tresca import normal_part, solve_tresca_dual, solve_tresca_penalty
from ..solvers.tresca_newton import solve_tresca_newton
from ..solvers.tresca_screened import solve_tresca_screened
from .validity import ResultWarning

#: the penalty's normal forces carry Newton's round-off (changes of ~3e-9 of the largest bound between
#: iterations on the paper panel at its default ε), so its fixed point stops at this relative change
PENALTY_FIXED_POINT_TOL = 1e-7
#: the Newton iterations of a polish of the fixed point's iterate (``solve_coulomb``'s ``polish``): from a
#: near-solution it converges in 1–2 (32 × 32 panel, μ = 0.3, from the fixed point's solution: 2)
POLISH_ITERATIONS = 6
#: the whole-law Newton's iterations before the fixed point takes over: where it converges it takes 4–5 (8 × 8
#: panel, μ ≤ 3), 10–12 (32 × 32, μ ≤ 1); where it does not, its sets wander (19 iterations before it stalled at
#: 68k unknowns, μ = 0.3, each adding pairs to solve for: 22 of 48 s of the run, the fixed point that then
#: converged 11 s); with the join limit growing with the closed set (``coulomb_newton.JOIN_SHARE``) and the step's
#: offsets right where pairs leave (branch coul15) it converges at 68k in 6 (each call counts its own), at 211k
#: it stops after 19 at 1e-7 (one edge row that pulls when a step joins it) and the fixed point finishes
NEWTON_ITERATIONS = 25


def has_friction(case: Case) -> bool:
    """Whether any punch of ``case`` has friction or a slide (else the frictionless path, unchanged)."""
    return any(p.drags for p in case.punches)


def load_stages(case: Case) -> list[tuple[float, float]]:
    """The load path (``[solver] steps``, ``path``): per step the fractions of the indentations and of the slides."""
    n = case.solver.steps
    if case.solver.path == "indent-then-slide":
        return [(k / n, 0.0) for k in range(1, n + 1)] + [(1.0, k / n) for k in range(1, n + 1)]
    return [(k / n, k / n) for k in range(1, n + 1)]


def _staged(case: Case, indentation: float, slide: float) -> Case:
    """``case`` with every punch's indentation (a force-controlled punch's force) and slide scaled (a punch in a
    fixed position stays where it is)."""
    punches = tuple(dataclasses.replace(p, indentation=p.indentation * indentation, force=p.force * indentation,
                                        slide=None if p.slide is None else p.slide * slide) for p in case.punches)
    return dataclasses.replace(case, punches=punches)


def solve_friction(case: Case, d: Any, setup: Any, opts: SolverOptions) -> tuple[ContactSolution, dict]:
    """The contact solve with friction (``solve_path``); with a punch's ``tangential_force``, the slide along that
    force which makes the friction force on the shell equal to it (``solve_pushed``)."""
    pushed = [p for p in case.punches if p.tangential_force is not None]
    return solve_pushed(case, pushed[0], d, setup, opts) if pushed else solve_path(case, d, setup, opts)


def solve_pushed(case: Case, spec: Any, d: Any, setup: Any, opts: SolverOptions) -> tuple[ContactSolution, dict]:
    """Force control along the surface: the slide s = α e (e = F/|F|) of punch ``spec`` with e·f(α) = |F|, f the
    friction force on the shell from that punch. f is linear in α where the punch sticks and saturates at the
    friction's capacity (μ × the normal force) where it slides: a secant step from the responses at α = 0 and
    at a probe, then bracketing (×4) and the Illinois method to 1e-8 |F|. A force at or above the capacity (f stops
    growing before reaching it) is refused: the punch would slide without bound."""
    force = np.asarray(spec.tangential_force, float)
    target = float(np.linalg.norm(force))
    e = force / target
    runs: list[tuple[float, float]] = []

    def run(alpha: float) -> tuple[float, float, tuple[ContactSolution, dict]]:
        punches = tuple(dataclasses.replace(p, slide=alpha * e, tangential_force=None) if p is spec else p
                        for p in case.punches)
        out = solve_path(dataclasses.replace(case, punches=punches), d, setup, opts)
        f = float(e @ out[1]["operator"].force(out[0].info["T"])[spec.index])
        runs.append((alpha, f))
        return alpha, f, out

    def done(alpha: float, out: tuple[ContactSolution, dict]) -> tuple[ContactSolution, dict]:
        out[1]["pushed"] = {"punch": spec.index, "slide": [float(v) for v in alpha * e], "evaluations": len(runs),
                            "tangential_force": [float(v) for v in force]}
        return out

    tol = 1e-8 * target
    _, f0, _ = run(0.0)
    probe = 1e-3 * case.shell.thickness
    probe, f1, out = run(probe)
    if f1 - f0 <= 0.0:
        raise InputError(f"{spec.where}.tangential_force", "the punch holds no force along it (it does not touch "
                                                             "the shell, or its friction is 0 where it touches)")
    lo, rlo, hi, rhi = 0.0, f0 - target, None, 0.0  # the bracket and its residuals f − |F|
    if f1 > target:
        hi, rhi = probe, f1 - target
    else:
        lo, rlo = probe, f1 - target
    alpha, side = probe * (target - f0) / (f1 - f0), 0  # the secant: exact where the punch sticks
    for _ in range(60):
        alpha, f, out = run(alpha)
        r = f - target
        if abs(r) <= tol:
            return done(alpha, out)
        if r < 0:
            # no longer growing (the punch slides at f), or growing only by the normal force's change past any
            # slide a shell of this length can take
            if hi is None and (r - rlo <= 1e-6 * target or alpha > case.shell.length):
                raise InputError(f"{spec.where}.tangential_force",
                                 f"{target:.6g} N is more than the friction holds: the punch slides without bound at "
                                 f"{f:.6g} N (μ × the normal force; allowed: below it)")
            lo, rlo = alpha, r
            rhi = 0.5 * rhi if side == -1 else rhi  # Illinois: halve the stale end's residual
            side = -1
        else:
            hi, rhi = alpha, r
            rlo = 0.5 * rlo if side == 1 else rlo
            side = 1
        alpha = 4.0 * alpha if hi is None else lo + (hi - lo) * rlo / (rlo - rhi)
    raise SolverError(f"{spec.where}.tangential_force: the slide that holds {target:.6g} N was not found in "
                      f"{len(runs)} solves (last {runs[-1][1]:.6g} N at {runs[-1][0]:.4g} m)")


def solve_path(case: Case, d: Any, setup: Any, opts: SolverOptions) -> tuple[ContactSolution, dict]:
    """The contact solve with friction on the discretisation ``d`` (``analysis.Discretization``) from the
    ``analysis.ContactSetup`` ``setup``, along the load path of ``[solver] steps`` and ``path``: each step's law
    acts on the slip since the last step (σ carried per row as a global vector, 0 for a row new to the step).
    Returns the last step's solution of the reduced QP (``info`` holds T, the total slip, bounds) and the friction
    record for ``attach_friction``."""
    stages = load_stages(case)
    carried: dict[tuple[int, int, int], np.ndarray] = {}
    steps: list[dict] = []
    for k, (fi, fs) in enumerate(stages):
        last = k == len(stages) - 1
        if last and fi == 1.0 and fs == 1.0:
            case_k, dk, qp = case, d, setup.qp  # the case itself (one step: exactly the one-shot solve)
        else:
            case_k = _staged(case, fi, fs)
            op = contact_operator(d.space, place_punches(case_k.punches, case.shell, case.units), opts.contact_points)
            dk = dataclasses.replace(d, operator=op, Br=op.B @ d.reduction.P, punches=op.punches)
            qp = dk.qp()
        sol, record, top = _solve_step(case_k, dk, setup, qp, opts, carried)
        keys = _row_keys(dk.operator)
        total = top.vectors(sol.info["slip"])  # (3, m) the slip of this step, global
        carried = {key: carried.get(key, np.zeros(3)) + total[:, i] for i, key in enumerate(keys)}
        if len(stages) > 1:
            normal = sol.Lambda * np.linalg.norm(dk.operator.grad, axis=0)
            punch_of = dk.operator.punch
            steps.append({"indentation_fraction": fi, "slide_fraction": fs,
                          "force": [[float(v) for v in f] for f in top.force(sol.info["T"])],
                          "normal_force": [float(normal[punch_of == j].sum()) for j in range(len(case.punches))],
                          "iterations": record.iterations, "converged": record.converged})
    if len(stages) > 1:  # the reported slip is the total since the first step
        slip_total = np.stack([carried[key] for key in _row_keys(d.operator)], axis=1)
        sol.info["slip_increment"] = sol.info["slip"]
        sol.info["slip"] = np.einsum("kdi,di->ik", top.tau, slip_total).ravel()
    return sol, {"operator": top, "record": record, "method": sol.method, "steps": steps}


def _row_keys(op: Any) -> list[tuple[int, int, int]]:
    """A row's identity across the steps' operators on one mesh: (punch, vertex, facet)."""
    return list(zip(op.punch.tolist(), op.vertex.tolist(), op.facet.tolist()))


def _solve_step(case: Case, d: Any, setup: Any, qp: Any, opts: SolverOptions, carried: dict
                ) -> tuple[ContactSolution, Any, TangentialOperator]:
    """One step of the path: Tresca or Coulomb with the slides of ``case`` plus the slip carried from the last
    step (``carried``: row key → global slip vector), so that the law acts on this step's slip."""
    op = d.operator
    top = tangential_operator(d.space, op)
    C = (top.C @ d.reduction.P).tocsr()
    before = np.stack([carried.get(key, np.zeros(3)) for key in _row_keys(op)], axis=1) if op.m else np.zeros((3, 0))
    c = top.offsets([p.slide for p in case.punches]) + np.einsum("kdi,di->ik", top.tau, before).ravel()
    specs = [case.punches[k].friction for k in op.punch]
    mu = np.array([s.coefficient if s.model == "coulomb" else 0.0 for s in specs])
    tresca_g = top.tresca_bounds(op.weights, np.array([s.bound if s.model == "tresca" else 0.0 for s in specs]))
    scale = np.linalg.norm(op.grad, axis=0)

    given = np.array([s.model == "tresca" and s.surface == "frictionless-contact" for s in specs], bool)
    surface: list[np.ndarray] = []  # the given surface of those rows: the frictionless solution's contact set

    def bounds(Lam: np.ndarray) -> np.ndarray:
        on = np.where(given, surface[0], Lam > 0) if surface else Lam > 0
        return mu * scale * np.maximum(Lam, 0.0) + np.where(on, tresca_g, 0.0)

    E = _slip_columns(d, qp, top)
    held = not np.all(normal_part(qp)[1])  # rigid motions only friction holds (``_frictionless_start``)
    start, newton, polish = None, None, None

    def warm(sol: ContactSolution) -> dict:
        return {"initial": _warm_start(sol)}

    def probe(sol: ContactSolution) -> float:  # the fixed-point map's contraction at a solution of the whole law
        if newton is not None:
            newton["contraction_solves"] = PROBE_SOLVES
        return probed_contraction(qp, C, c, bounds, tresca, sol, warm, **options)

    if opts.method == "active-set":
        # the pipeline's factorisation solves A whether or not it is bordered by the screened rows
        options: dict[str, Any] = {"factorization": setup.factorization, "tol": opts.tolerance, "cache": {}}
        tresca, fixed_tol = solve_tresca_newton, COULOMB_TOL
        # the frictionless solve of the pipeline, screened, is the start; every Tresca solve runs on the screened
        # rows with its dense Schur complement (not with motions only friction holds: ``_frictionless_start``)
        if setup.screen is not None and qp is setup.qp and not held:
            start = _frictionless(solve_screened(qp, setup.screen, solve_active_set, setup.factorization,
                                                 tol=opts.tolerance, initial_active=setup.initial_active))
            options["screen"], options["solver"] = setup.screen, solve_tresca_newton
            tresca = solve_tresca_screened
            # A bordered by the normal and tangential rows of the frictionless contact set (``pair_block``): the
            # pairs' products from its Schur complement, no solve per pair; those rows are the screen
            rows = border_rows(start.Lambda, qp.gap(start.U, start.delta)) if np.any(start.Lambda > 0) else []
            joint = factorize_pairs(qp, C, rows, opts.backend) if len(rows) else None
            if joint is not None:
                options["factorization"], options["screen"] = joint, rows

        law = np.stack([mu * scale, tresca_g], axis=1)
        if np.any(mu > 0) and E is None and not given.any():  # the whole law by Newton (Coulomb without δ; the
            # case's Tresca keeps the fixed point: its bound jumps with the closed set, docs/theory.md §9a)
            if start is None:
                start = _frictionless(solve_active_set(qp, tol=opts.tolerance, factorization=setup.factorization))
            sol, fallback = _newton(qp, C, c, law, options, _warm_start(start), NEWTON_ITERATIONS)
            newton = {"iterations": int(sol.iterations), "converged": fallback is None, "fallback": fallback,
                      "polish_iterations": []}
            if fallback is None:  # no fixed point ran: its map's contraction, for the uniqueness warning, probed
                return sol, CoulombRecord(0, [], probe(sol), True, newton=newton), top
            print(f"note: friction: the semismooth Newton on the friction law stopped ({fallback}) after "
                  f"{sol.iterations} iterations; the fixed point of Tresca problems follows from its best iterate "
                  f"(residual {sol.info['residual']:.2g})", file=sys.stderr)
            # the fixed point from the Newton's best iterate, not from the frictionless solution: at 211k unknowns
            # the Newton stops at 1.0e-7 on one edge row (benchmarks/RESULTS.md, "Branch coul15"), from where the
            # fixed point needs 4 iterations, from the frictionless solution it did not converge in 50
            start = sol

            def polish(s: ContactSolution) -> ContactSolution | None:
                out, failed = _newton(qp, C, c, law, options, _warm_start(s), POLISH_ITERATIONS)
                newton["polish_iterations"].append(int(out.iterations))
                return out if failed is None else None
    elif opts.method == "penalty":
        options = {"epsilon": setup.eps, "tol": opts.tolerance}
        tresca, fixed_tol = solve_tresca_penalty, PENALTY_FIXED_POINT_TOL

        def warm(sol: ContactSolution) -> dict:  # from the last solve's (U, δ): from the stuck state each time the
            # Newton took 25 steps per Tresca solve on the vessel on saddles (20 × 24), from the last (U, δ) 1–4
            # once the bounds settle (74 → 20 CPU s); the paper panel, μ = 0.3: 6.9 → 6.0 CPU s
            return {"initial_U": np.concatenate([sol.U] + ([sol.delta] if sol.delta is not None else []))}
    else:
        fac = setup.factorization if setup.screen is None else factorize(qp.A)
        options = {"factorization": fac, "tol": opts.tolerance, "cache": {}}
        tresca, fixed_tol = solve_tresca_dual, COULOMB_TOL
    if E is not None:
        options["E"] = E
        tresca = _held(tresca, qp, E, d, case)
        if start is None and held:  # the frictionless start without the motions only friction holds (amounts 0)
            start = _frictionless_start(qp, C, c, E, tresca, options)
    if given.any():  # the given surface, from the frictionless solution (the fixed point's start, as it solves it)
        if start is None:
            start = tresca(qp, C, c, np.zeros(qp.m), **options)
        surface.append(start.Lambda > 0)
    sol, record = solve_coulomb(qp, C, c, bounds, tresca, fixed_point_tol=fixed_tol, warm=warm, start=start,
                                accelerate=bool(np.any(mu > 0)), polish=polish, **options)  # Coulomb: Anderson's mixing
    if record.acceleration == "anderson" and record.converged and record.iterations < 2:  # no ratio of the map
        # measured (one iteration, then a polish or the tolerance: 8 × 8, μ = 5, the Newton held to 3 steps gave
        # q 0 and no warning): probed at the solution as where the Newton converged alone
        record.contraction = probe(sol)
    record.newton = newton
    return sol, record, top


def _frictionless(sol: ContactSolution) -> ContactSolution:
    """A frictionless contact solution as a friction solve's start: T = 0 and bounds 0 on every row."""
    sol.info.update(T=np.zeros(2 * sol.Lambda.size), bounds=np.zeros(sol.Lambda.size))
    return sol


def _warm_start(sol: ContactSolution) -> np.ndarray:
    """The next Tresca solve's start: (Λ, T) and the travels and rigid motions δ."""
    return np.concatenate([sol.Lambda, sol.info["T"]] + ([sol.delta] if sol.delta is not None else []))


def _slip_columns(d: Any, qp: Any, top: TangentialOperator) -> np.ndarray | None:
    """E (2m × k): the slips' change per unit δ. A force-controlled punch's travel along its direction drags
    nothing (0: as an indentation, it places the punch; the slip counts from the placed punch), a rigid motion R
    of a shell held by contact moves every point by R (C R, ``floating.friction_columns``)."""
    if not qp.k:
        return None
    E = np.zeros((2 * qp.m, qp.k))
    fl = d.floating
    if fl is not None and fl.P.size:
        E[:, qp.k - fl.D.shape[1]:] = friction_columns(fl, top.C)
    return E


def _frictionless_start(qp: Any, C: Any, c: np.ndarray, E: np.ndarray, tresca: Any, options: dict
                        ) -> ContactSolution:
    """The frictionless solve (g = 0) on the QP without the δ columns no gap sees (``normal_part``: the rigid
    motions only friction holds, undetermined without it), their amounts set to 0."""
    qp0, keep = normal_part(qp)
    own = {**options, "E": E[:, keep] if keep.any() else None}
    if "cache" in own:  # a cache of its own: the Workspace it keeps belongs to qp0
        own["cache"] = {}
    sol = tresca(qp0, C, c, np.zeros(qp.m), **own)
    delta = np.zeros(qp.k)
    if sol.delta is not None:
        delta[keep] = sol.delta
    sol.delta = delta
    return sol


def _held(tresca: Any, qp: Any, E: np.ndarray, d: Any, case: Case) -> Any:
    """``tresca`` after a check that the friction can hold the rigid motions that only friction holds: their loads
    P_H in the set of forces the bounds' discs can give (``friction_capacity``): each P_j at most Σ_i g_i |E_ij|,
    and jointly (friction is isotropic: two motions' loads each within their capacity may together exceed it);
    else there is no solution, the shell slides away (InputError naming the motions, the punches and the forces)."""
    fl = d.floating
    if fl is None or not fl.by_friction:
        return tresca
    kr = len(fl.restrained)
    first = qp.k - fl.D.shape[1] + kr - fl.by_friction
    held = np.arange(first, first + fl.by_friction)
    punch_of = d.operator.punch

    def names(g: np.ndarray, columns: np.ndarray) -> str:
        reach = np.linalg.norm(E[:, columns].reshape(-1, 2, len(columns)), axis=1).max(axis=1)
        return ", ".join(f"punch.{k}" for k in np.unique(punch_of[(reach > 0) & (g > 0)])) or "no punch"

    def motion(j: int) -> str:
        return qp.force_label(j).split(": ")[-1]

    def checked(qp_: Any, C: Any, c: np.ndarray, g: np.ndarray, **options: Any) -> ContactSolution:
        if qp_ is qp and np.any(g > 0):
            alone = {}
            for j in held:
                capacity = support(E[:, [j]], g, np.ones(1))
                if abs(qp.P[j]) > capacity:
                    per = " (a moment / the radius)" if motion(j).startswith("rotation") else ""
                    raise InputError("loads", f"the shell slides away along the {motion(j)}: the loads push it with "
                                     f"{abs(qp.P[j]):.6g} N{per} but the friction of {names(g, [j])} holds at "
                                     f"most {capacity:.6g} N there (everything slides; no static solution): lower the "
                                     "load or raise the friction")
                alone[j] = capacity
            loaded = [j for j in held if qp.P[j] != 0.0]
            if len(loaded) > 1:
                _, upper = capacity_ratio(E[:, loaded], g, qp.P[loaded])
                if upper < 1.0:  # certainly beyond (``upper`` ≥ the exact ratio)
                    size = float(np.linalg.norm(qp.P[loaded]))
                    parts = ", ".join(f"{qp.P[j]:.6g} N along the {motion(j)} (alone it holds {alone[j]:.6g} N)"
                                      for j in loaded)
                    which = " and the ".join(map(motion, loaded))
                    raise InputError("loads", f"the shell slides away along a combination of the {which}: the loads "
                                     f"push it with {parts}, together {size:.6g} N, but the friction of "
                                     f"{names(g, loaded)} holds at most {upper * size:.6g} N in that direction "
                                     "(friction is isotropic: each point's force is bounded in size, not per "
                                     "direction; a rotation's force is a moment / the radius; everything slides; no "
                                     "static solution): lower the load or raise the friction")
        return tresca(qp_, C, c, g, **options)

    return checked


def _newton(qp: Any, C: Any, c: np.ndarray, law: np.ndarray, options: dict, initial: np.ndarray,
            max_iterations: int = 50) -> tuple[ContactSolution, str | None]:
    """The semismooth Newton on the whole law (``solvers.coulomb_newton``) from y = ``initial``, on the screened
    rows where ``options`` has them, sharing the fixed point's cache (its Workspace and pair solves). Returns its
    solution and why it stopped without converging (None where it converged)."""
    tol, fac = options["tol"], options["factorization"]
    if "screen" in options:
        sol = solve_tresca_screened(qp, C, c, law, solve_friction_newton, options["screen"], fac, options["cache"],
                                    initial=initial, tol=tol, max_iterations=max_iterations)
    else:
        sol = solve_friction_newton(qp, C, c, law, tol=tol, factorization=fac, initial=initial, cache=options["cache"],
                                    max_iterations=max_iterations)
    return sol, sol.info["fallback"]


def attach_friction(result: Any, friction: dict) -> None:
    """Put the friction force Cᵀ T into the shell's balance, the per-punch friction entries into the contact
    summary (``ContactResult.friction``) and a coded warning where the fixed point did not contract."""
    top: TangentialOperator = friction["operator"]
    sol = result.contact.solution
    T, slip, g = sol.info["T"], sol.info["slip"], sol.info["bounds"]
    result.solution.extra_forces = result.solution.extra_forces + top.C.T @ T
    sol.info["tangential"] = top  # the fields and the figure of friction (outputs.fields) read it
    record = friction["record"]
    entries = top.summary(result.contact.operator.weights, T, slip, g, result.contact.Lambda)
    for entry in entries:
        entry["units"] = {"force": "N", "stick_area": "m²", "slip_area": "m²", "max_slip": "m"}
        entry["fixed_point"] = record.summary()
        entry["method"] = friction["method"]
    for j, entry in enumerate(entries):
        if friction["steps"]:  # the load path: per step this punch's friction and normal force (N)
            entry["steps"] = [{**{k: v for k, v in st.items() if k not in ("force", "normal_force")},
                               "force": st["force"][j], "normal_force": st["normal_force"][j]}
                              for st in friction["steps"]]
            entry["units"]["steps"] = {"force": "N", "normal_force": "N"}
    pushed = friction.get("pushed")
    if pushed is not None:  # force control along the surface: the slide found and the solves it took
        entries[pushed["punch"]].update(slide=pushed["slide"], tangential_force=pushed["tangential_force"],
                                        force_control_solves=pushed["evaluations"])
        entries[pushed["punch"]]["units"].update(slide="m", tangential_force="N")
    result.contact.friction = entries
    unconverged = [i + 1 for i, st in enumerate(friction["steps"]) if not st["converged"]]
    if unconverged and record.converged:
        text = (f"friction: the fixed point of the friction bounds did not converge in steps {unconverged} of the "
                "load path; the slip carried from them is not a solution's")
        result.info.setdefault("warnings", []).append(ResultWarning("friction_contraction", text))
    if record.cycle:
        text = ("friction: the contact set alternates between sets that each, with the Tresca bound on its rows, "
                "close different rows: the Tresca law on the contact set has no solution among them (the bound "
                "exceeds what the contact pressure can hold without lifting the shell; docs/theory.md §9a) and "
                "this result is not one; lower the Tresca bound or the slide, or use Coulomb friction")
        result.info.setdefault("warnings", []).append(ResultWarning("friction_no_solution", text))
    elif not record.converged or (record.contraction is not None and record.contraction > COULOMB_CONTRACTION):
        state = (f"did not converge in {record.iterations} iterations" if not record.converged
                 else f"has the contraction factor {record.contraction:.3g} (above {COULOMB_CONTRACTION})")
        which = "of which this result is one" if record.converged else "and this result is none of them"
        text = (f"friction: the fixed point of the friction bounds on the normal forces {state}: the static friction "
                f"problem may have several solutions, {which}; lower the friction coefficient or the Tresca bound, or "
                "the slide")
        result.info.setdefault("warnings", []).append(ResultWarning("friction_contraction", text))
