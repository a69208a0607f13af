"""Target 4: shellcontact's contact solvers against generic QP solvers on the same discrete QP.

    python benchmarks/qp_peers.py             # demo case (src/shellcontact/cases/paper_panel.toml), 32 × 32 mesh
    python benchmarks/qp_peers.py --quick     # 16 × 16
    python benchmarks/qp_peers.py --n 48 --peers osqp,clarabel

The QP  min ½UᵀAU − FᵀU  s.t.  G + BU ≥ 0  is exported once per process from the demo case by
``common.export_qp`` (exactly the reduced QP that ``shellcontact.analysis.pipeline.solve`` solves) and given
to every solver, each in a fresh subprocess, at the tolerance settings 1e-4, 1e-6, 1e-8, 1e-10:

* shellcontact ``solve_active_set`` and ``solve_dual`` (tol = the setting; time = factorisation
  of A + contact solve);
* OSQP (ADMM, its own Ruiz scaling on, direct QDLDL KKT solver): eps_abs = eps_rel = setting,
  max_iter 10⁶, time limit, no warm start; once without and once with solution polishing;
* Clarabel (interior point, its equilibration on): tol_gap_abs = tol_gap_rel = tol_feas = setting,
  tol_ktratio = min(1e-6, setting), max_iter 500, max_threads 1;
* SciPy L-BFGS-B on the dual  max_{Λ≥0} −½(F+BᵀΛ)ᵀA⁻¹(F+BᵀΛ) − ΛᵀG  (gradient = the gap, one
  solve per evaluation with shellcontact's factorisation of A, which is timed): pgtol =
  setting × max|G|, ftol = 0, maxiter = maxfun = 10⁵;
* PETSc SNES VI (vinewtonrsls): only when petsc4py imports (it is not installed here: no binary
  wheel; building PETSc from source is out of scope) — the table says so.

Every run (ours and the peers') is repeated up to 3 times while one run takes under 10 s, and the
fastest is kept. The peers' input formats (upper triangle of A in CSC) are prepared outside the
timing, as is their equilibration. The peers get the QP after a symmetric Jacobi
equilibration (U = D x, D = diag(A)^-½; constraint rows scaled to unit norm), and their
solutions are mapped back. Every solution (U, Λ) is then
judged by the same yardstick, ``shellcontact.solvers.kkt`` (``kkt_residuals`` = raw residuals and
the scaled residuals that shellcontact's stopping test compares with its tolerance): "achieved" is
the largest scaled residual; "rel. error U" = ‖U − U_sc‖/‖U_sc‖ and "rel. error force" = relative
error of the punch force, against shellcontact's active-set solution at 1e-10. For each target
tolerance τ the time of a solver is its fastest run whose achieved residual is ≤ τ; the speedup at
τ is (fastest generic solver) / (faster of the shellcontact solvers). The headline value is at
τ = 1e-10 if a generic solver reaches it, else at
the tightest τ that one reaches (the JSON says which).
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import common  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
CASE = ROOT / "src" / "shellcontact" / "cases" / "paper_panel.toml"
GOAL = 20.0
TOLS = (1e-4, 1e-6, 1e-8, 1e-10)
PEERS = ("shellcontact-active-set", "shellcontact-dual", "osqp", "osqp-polish", "clarabel", "scipy-lbfgsb-dual",
         "petsc-vinewtonrsls")
OURS = ("shellcontact-active-set", "shellcontact-dual")
TIME_LIMIT = 120.0  # seconds per peer run


def equilibrate(qp):
    """Scaled data (A', F', B', G') with U = d·x, Λ = r·λ: A' = DAD, F' = DF, B' = RBD, G' = RG."""
    import scipy.sparse as sp

    d = 1.0 / np.sqrt(qp.A.diagonal())
    D = sp.diags(d)
    As = (D @ qp.A @ D).tocsc()
    Bd = (qp.B @ D).tocsr()
    r = 1.0 / np.sqrt(np.asarray(Bd.multiply(Bd).sum(axis=1)).ravel())
    Bs = (sp.diags(r) @ Bd).tocsc()
    return As, d * qp.F, Bs, r * qp.G, d, r


#: every solver's run is repeated up to REPEAT times while one run takes less than REPEAT_BELOW seconds, and
#: the fastest is kept: the same rule for shellcontact and the peers (single runs of this VM vary by 20-50 %)
REPEAT, REPEAT_BELOW = 3, 10.0


def _time(fn):
    """(result, wall s, CPU s) of the fastest of up to REPEAT runs of fn (one run if it takes ≥ REPEAT_BELOW s)."""
    best = None
    for _ in range(REPEAT):
        t0, c0 = time.perf_counter(), time.process_time()
        out = fn()
        run = (out, time.perf_counter() - t0, time.process_time() - c0)
        if best is None or run[1] < best[1]:
            best = run
        if run[1] >= REPEAT_BELOW:
            break
    return best


def run_ours(qp, method: str, tol: float):
    """The package's own path (as ``analysis.solve``): from 40k unknowns the substructured, screened
    factorisation (``solvers.screening``), below it a plain one with solved Schur columns. Also returns
    where the time of the kept run went (``breakdown``: seconds)."""
    from shellcontact.solvers import solve_active_set, solve_dual
    from shellcontact.solvers.screening import factorize_screened, solve_screened

    solver = solve_active_set if method == "shellcontact-active-set" else solve_dual

    def go():
        t0 = time.perf_counter()
        fac, rows = factorize_screened(qp)
        t1 = time.perf_counter()
        return solve_screened(qp, rows, solver, fac, tol=tol), fac.seconds, t1 - t0

    (cs, backend_s, factorize_s), wall, cpu = _time(go)
    breakdown = {"factorize": factorize_s, "backend_factorization": backend_s,
                 "preparation": factorize_s - backend_s, "schur_columns": cs.timings.get("schur", 0.0),
                 "n_schur_columns": int(cs.timings.get("schur_columns", 0)), "rest": wall - factorize_s
                 - cs.timings.get("schur", 0.0)}
    return cs.U, cs.Lambda, wall, cpu, cs.iterations, "converged", breakdown


def run_osqp(qp, tol: float, polish: bool):
    import osqp
    import scipy.sparse as sp

    As, Fs, Bs, Gs, d, r = equilibrate(qp)
    P = sp.triu(As, format="csc")  # the input format OSQP asks for: prepared outside the timing, like the scaling

    def go():
        prob = osqp.OSQP()
        prob.setup(P, -Fs, Bs, -Gs, np.full(Gs.size, np.inf), eps_abs=tol, eps_rel=tol,
                   max_iter=1_000_000, polishing=polish, time_limit=TIME_LIMIT, verbose=False)
        return prob.solve()

    res, wall, cpu = _time(go)
    # OSQP: P x + q + Aᵀy = 0 with y ≤ 0 on active lower bounds → λ = −y
    U = d * np.asarray(res.x)
    Lam = -r * np.asarray(res.y)
    return U, Lam, wall, cpu, int(res.info.iter), str(res.info.status)


def run_clarabel(qp, tol: float):
    import clarabel
    import scipy.sparse as sp

    As, Fs, Bs, Gs, d, r = equilibrate(qp)
    P, Ac = sp.triu(As, format="csc"), (-Bs).tocsc()  # Clarabel's input format, prepared outside the timing

    def go():
        s = clarabel.DefaultSettings()
        s.verbose = False
        s.tol_gap_abs = s.tol_gap_rel = s.tol_feas = tol
        s.tol_ktratio = min(1e-6, tol)
        s.max_iter = 500
        s.max_threads = 1
        s.time_limit = TIME_LIMIT
        # −B'x + s = G', s ≥ 0
        solver = clarabel.DefaultSolver(P, -Fs, Ac, Gs,
                                        [clarabel.NonnegativeConeT(Gs.size)], s)
        return solver.solve()

    sol, wall, cpu = _time(go)
    U = d * np.asarray(sol.x)
    Lam = r * np.asarray(sol.z)
    return U, Lam, wall, cpu, int(sol.iterations), str(sol.status)


def run_lbfgsb(qp, tol: float):
    from scipy.optimize import minimize

    from shellcontact.linalg import factorize

    As, Fs, Bs, Gs, d, r = equilibrate(qp)
    Bt = Bs.T.tocsr()
    state = {}

    def go():
        fac = factorize(As)

        def f(mu):
            w = Fs + Bt @ mu
            x = fac.solve(w)
            state["x"] = x
            return 0.5 * float(w @ x) + float(mu @ Gs), Gs + Bs @ x

        res = minimize(f, np.zeros(Gs.size), jac=True, method="L-BFGS-B", bounds=[(0.0, None)] * Gs.size,
                       options={"maxiter": 100_000, "maxfun": 100_000, "ftol": 0.0,
                                "gtol": tol * float(np.abs(Gs).max())})
        mu = res.x
        x = fac.solve(Fs + Bt @ mu)
        return res, x, mu

    (res, x, mu), wall, cpu = _time(go)
    return d * x, r * mu, wall, cpu, int(res.nit), str(res.message)


def worker(n: int, peer: str) -> dict:
    from shellcontact import linalg
    from shellcontact.linalg import factorize
    from shellcontact.problem.case import load_case
    from shellcontact.solvers import kkt, kkt_residuals, solve_active_set

    case = load_case(CASE, [f"mesh.nx={n}", f"mesh.nphi={n}"])
    qp, op, red, space = common.export_qp_parts(case)
    linalg.factorize(qp.A).solve(qp.F)  # load the libraries outside the timings
    fac = factorize(qp.A)
    ref = solve_active_set(qp, tol=1e-10, factorization=fac)
    f_ref = float(op.total_normal_force(ref.Lambda).sum())
    out = {"n": n, "peer": peer, "dofs": int(space.ndofs), "unknowns": qp.n, "constraints": qp.m,
           "nnz_A": int(qp.A.nnz), "runs": []}
    if peer == "petsc-vinewtonrsls":
        try:
            import petsc4py  # noqa: F401
        except ImportError:
            out["skipped"] = ("petsc4py is not installed: the package index has no binary wheel for it (the sdist "
                              "builds PETSc from source), so SNES VI was not run")
            return out
        out["skipped"] = "petsc4py imports, but its SNES VI driver is not written yet"
        return out
    for tol in TOLS:
        try:
            breakdown = None
            if peer in OURS:
                U, Lam, wall, cpu, it, status, breakdown = run_ours(qp, peer, tol)
            elif peer.startswith("osqp"):
                U, Lam, wall, cpu, it, status = run_osqp(qp, tol, polish=peer == "osqp-polish")
            elif peer == "clarabel":
                U, Lam, wall, cpu, it, status = run_clarabel(qp, tol)
            elif peer == "scipy-lbfgsb-dual":
                U, Lam, wall, cpu, it, status = run_lbfgsb(qp, tol)
            else:
                raise ValueError(f"unknown peer {peer!r}")
        except Exception as exc:  # a failed peer run is a row of the table, not a crash
            out["runs"].append({"tol": tol, "error": f"{type(exc).__name__}: {exc}"[:300]})
            continue
        rep = kkt.evaluate(qp, U, Lam, factorization=fac)
        raw = kkt_residuals(qp, U, Lam, factorization=fac)
        force = float(op.total_normal_force(Lam).sum())
        out["runs"].append({
            "tol": tol, "wall": wall, "cpu": cpu, "iterations": it, "status": status,
            "achieved": max(rep.scaled.values()), "worst": rep.worst(), "scaled": rep.scaled, "raw": raw,
            "force": force, "force_error": abs(force - f_ref) / abs(f_ref),
            "U_error": float(np.linalg.norm(U - ref.U) / np.linalg.norm(ref.U)),
            **({"breakdown": breakdown} if breakdown else {}),
        })
    return out


def time_at(res: dict, tau: float, key: str = "wall") -> float | None:
    ok = [r[key] for r in res.get("runs", []) if "achieved" in r and r["achieved"] <= tau]
    return min(ok) if ok else None


def summarize(results: dict[str, dict], key: str = "wall") -> dict:
    """Per target tolerance τ: fastest shellcontact, fastest generic peer, speedup."""
    out = {}
    for tau in TOLS:
        ours = {p: time_at(r, tau, key) for p, r in results.items() if p in OURS}
        peers = {p: time_at(r, tau, key) for p, r in results.items() if p not in OURS}
        ours = {p: t for p, t in ours.items() if t is not None}
        peers = {p: t for p, t in peers.items() if t is not None}
        best_ours = min(ours.items(), key=lambda kv: kv[1]) if ours else None
        best_peer = min(peers.items(), key=lambda kv: kv[1]) if peers else None
        out[tau] = {"ours": best_ours, "peer": best_peer,
                    "speedup": best_peer[1] / best_ours[1] if best_ours and best_peer else None}
    return out


def where_the_time_goes(results: dict, tau: float, s: dict) -> str:
    """The kept runs at τ split up: shellcontact's factorisation (preparation = equilibration and upper
    triangle; the backend's analysis + numeric phases), its Schur columns and the rest (face solves, the
    verifying solve and KKT check); the peer's seconds per iteration."""
    lines = [f"Where the time goes at τ = {tau:g} (the kept runs):"]
    for peer in OURS:
        runs = [r for r in results.get(peer, {}).get("runs", []) if "breakdown" in r and r["achieved"] <= tau]
        if not runs:
            continue
        r = min(runs, key=lambda r: r["wall"])
        b = r["breakdown"]
        per = b["schur_columns"] / b["n_schur_columns"] if b["n_schur_columns"] else float("nan")
        lines.append(f"* {peer}: {r['wall'] * 1e3:.1f} ms = preparation {b['preparation'] * 1e3:.1f} + backend "
                     f"factorisation {b['backend_factorization'] * 1e3:.1f} + {b['n_schur_columns']} Schur columns "
                     f"{b['schur_columns'] * 1e3:.1f} ({per * 1e3:.2f} each) + rest {b['rest'] * 1e3:.1f} ms")
    peer, t = s["peer"]
    runs = [r for r in results.get(peer, {}).get("runs", []) if r.get("wall") == t]
    if runs and runs[0].get("iterations"):
        it = runs[0]["iterations"]
        lines.append(f"* {peer}: {t:.3g} s in {it} iterations = {t / it * 1e3:.1f} ms per iteration")
    return "\n".join(lines)


def main(argv=None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--n", type=int, help="mesh n × n (default 32, quick 16)")
    ap.add_argument("--peers", default=",".join(PEERS))
    ap.add_argument("--worker", nargs="*")
    args = ap.parse_args(argv)
    if args.worker:
        res = worker(int(args.worker[0]), args.worker[1])
        common.emit(res)
        return res
    n = args.n or (16 if args.quick else 32)
    info = common.machine()
    try:
        import clarabel
        import osqp

        info["osqp"], info["clarabel"] = osqp.__version__, clarabel.__version__
    except ImportError as exc:
        info["peer_import_error"] = str(exc)
    results: dict[str, dict] = {}
    for peer in args.peers.split(","):
        try:
            results[peer] = common.run_worker(Path(__file__), [str(n), peer], timeout=4 * len(TOLS) * TIME_LIMIT + 300)
        except Exception as exc:
            results[peer] = {"peer": peer, "runs": [], "skipped": f"failed: {str(exc)[-400:]}"}
    meta = next((r for r in results.values() if "dofs" in r), {})
    print(f"# Generic QP solvers vs shellcontact on the same QP ({CASE.name}, mesh {n}×{n}: {meta.get('dofs')} dofs, "
          f"{meta.get('unknowns')} unknowns, {meta.get('constraints')} constraints, nnz(A) {meta.get('nnz_A')})")
    print(common.machine_line(info) + f"; osqp {info.get('osqp')}, clarabel {info.get('clarabel')}")
    rows = []
    for peer, res in results.items():
        if res.get("skipped"):
            rows.append([peer, "-", "-", "-", "-", "-", "-", "-", "-", "-", "-", "skipped (below)"])
            continue
        for r in res["runs"]:
            if "error" in r:
                rows.append([peer, r["tol"], "-", "-", "-", "-", "-", "-", "-", "-", "-", r["error"]])
                continue
            raw = r["raw"]
            rows.append([peer, r["tol"], r["wall"], r["cpu"], r["iterations"], r["achieved"], r["worst"],
                         raw["stationarity"], raw["penetration"], r["U_error"], r["force_error"], r["status"][:40]])
    print(common.table(["solver", "tol setting", "wall s", "CPU s", "iterations", "achieved (max scaled KKT)",
                        "worst residual", "stationarity", "penetration m", "rel. error U",
                        "rel. error force", "status"], rows))
    for peer, res in results.items():
        if res.get("skipped"):
            print(f"{peer}: {res['skipped']}")
    summ = {k: summarize(results, k) for k in ("wall", "cpu")}
    rows = []
    for tau in TOLS:
        sw, sc = summ["wall"][tau], summ["cpu"][tau]
        rows.append([tau, f"{sw['ours'][0]} {sw['ours'][1]:.3g}" if sw["ours"] else "-",
                     f"{sw['peer'][0]} {sw['peer'][1]:.3g}" if sw["peer"] else "none reaches it",
                     sw["speedup"] if sw["speedup"] else "-", sc["speedup"] if sc["speedup"] else "-"])
    print("\nTime to reach a tolerance (fastest run whose largest scaled KKT residual is ≤ τ); "
          "ratio = peer / shellcontact")
    print(common.table(["tolerance τ", "fastest shellcontact (wall s)", "fastest generic peer (wall s)",
                        "wall ratio", "CPU ratio"], rows))
    reached = [t for t in TOLS if summ["wall"][t]["speedup"] is not None]
    tau = 1e-10 if 1e-10 in reached else (min(reached) if reached else None)
    if tau is not None:
        s = summ["wall"][tau]
        note = "" if tau == 1e-10 else (f"no generic solver reached the scaled KKT tolerance 1e-10 (tightest reached: "
                                         f"{tau:g}); ratio at {tau:g}")
        tgt = common.target(round(s["speedup"], 2), GOAL, "x: fastest generic QP solver seconds / shellcontact "
                            "seconds to the same KKT tolerance", s["peer"][0], tolerance=tau, method=s["ours"][0],
                            cpu_ratio=round(summ["cpu"][tau]["speedup"], 2) if summ["cpu"][tau]["speedup"] else None,
                            dofs=meta.get("dofs"), **({"note": note} if note else {}))
        print(f"\nspeedup vs the fastest generic QP solver at τ = {tau:g}: {s['speedup']:.3g}× wall "
              f"({s['peer'][0]} {s['peer'][1]:.3g} s vs {s['ours'][0]} {s['ours'][1]:.3g} s); goal ≥ {GOAL:g}×")
        print(where_the_time_goes(results, tau, s))
    else:
        tgt = common.target(None, GOAL, "x over the fastest generic QP solver", None,
                            reason="no generic solver reached any of the tolerances " + ", ".join(map(str, TOLS)))
    out = {"targets": {"speedup_vs_qp_peer": tgt}, "results": results, "machine": info,
           "summary": {k: {str(t): v for t, v in s.items()} for k, s in summ.items()}}
    print(json.dumps(out, default=lambda o: None if isinstance(o, float) and math.isnan(o) else str(o)))
    return out


if __name__ == "__main__":
    main()
