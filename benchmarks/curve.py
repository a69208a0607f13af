"""Issue 15: a force–indentation curve at the price of one solve (``curves.solve_family``).

    python benchmarks/curve.py             # demo case (paper panel), 112 × 112 mesh (~216k dofs), 20 points
    python benchmarks/curve.py --quick     # 40 × 40, 5 points
    python benchmarks/curve.py --n 80 --points 10
    python benchmarks/curve.py --control indentation   # indentations 0.5 … 10 mm instead of forces
    python benchmarks/curve.py --contact-points vertices   # [solver] contact_points (default: the case's)
    python benchmarks/curve.py --borders 1457,1981,2641    # also: A bordered by the k deepest rows (by G)

In one fresh subprocess, side by side on the demo case with its punch force-controlled (forces P/k …
P, P = 2.5e5 N, about the demo's 10 mm indentation; the travel δ at each force is the indentation):

* **linear**: one linear solve of the same mesh: factorise the reduced stiffness + solve one right-hand
  side (best of ``--repeat``);
* **curve**: ``solve_family`` of the points (one mesh, assembly and factorisation; warm-started; a force
  curve's final checks in block solves, ``screening.solve_screened_curve``);
* **curve + summaries**: the same, then every point's ``summary()`` (stresses at every vertex, reactions,
  equilibrium, contact zone, rim: what a curve's points make only when asked for);
* **naive**: ``analysis.solve`` of each point on its own (which makes all of it).

The target ratio is curve / linear with the curve's cost counted after its one-time mesh and assembly
(which a linear analysis needs as well): factorisation, every point's contact rows, contact solve and
checks (the whole QP's KKT residuals, the penetration outside the zone); the ratio with every point's
summary is printed beside it. The naive loop is counted the same way (each of its solves minus its
mesh and assembly), and both are also given end to end. Every point of the curve is compared with the
naive solve of the same case (force, travel, displacements). The machine is shared: wall times move
by tens of percent between runs; the process CPU time is printed beside them.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import common  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
CASE = ROOT / "examples" / "paper_panel.toml"
GOAL = 3.0
FORCE = 2.5e5  # N: about the demo's 10 mm indentation
INDENTATION = 1e-2  # m: the demo's indentation (``--control indentation``)


def curve_cases(n: int, points: int, control: str = "force", contact_points: str = "default"):
    """The curve's cases: forces P/k … P, or (``control="indentation"``) indentations d/k … d."""
    from shellcontact.inputs.overrides import apply_overrides
    from shellcontact.problem.case import case_from_dict, load_case

    sets = [f"mesh.nx={n}", f"mesh.nphi={n}"]
    base = load_case(CASE, sets + ([] if contact_points == "default" else [f"solver.contact_points={contact_points}"]))
    if control == "indentation":
        return [case_from_dict(apply_overrides(base.raw, {"punch.0.indentation": INDENTATION * (i + 1) / points}),
                               source=CASE) for i in range(points)]
    punch = {k: v for k, v in base.raw["punch"][0].items() if k != "indentation"}
    raw = {**base.raw, "punch": [punch]}
    forces = [FORCE * (i + 1) / points for i in range(points)]
    return [case_from_dict(apply_overrides(raw, {"punch.0.force": f}), source=CASE) for f in forces]


def _travel(case, contact: dict) -> float:
    """The indentation of a point: the force-controlled travel, or the prescribed indentation."""
    t = contact.get("punch_travel")
    return float(t) if t is not None else float(case.punches[0].indentation)


def _stages(result) -> float:
    return result.timings.get("mesh", 0.0) + result.timings.get("assembly", 0.0)


def border_costs(d, borders: list[int], repeat: int) -> list[dict]:
    """Seconds to factorise the reduced stiffness bordered by the k rows of smallest G (the screening's
    order, ``solvers.screening``), best of ``repeat``, for each k in ``borders``."""
    from shellcontact.solvers.substructure import factorize_contact

    qp = d.qp()
    order = np.argsort(qp.G, kind="stable")
    out = []
    for k in borders:
        rows = np.sort(order[:k])
        best = np.inf
        for _ in range(max(1, repeat)):
            t0 = time.perf_counter()
            fac = factorize_contact(qp.A, qp.B[rows], flexibility=qp.flexibility[rows], min_unknowns=0)
            best = min(best, time.perf_counter() - t0)
            del fac
        out.append({"rows": k, "seconds": best})
    return out


def worker(n: int, points: int, repeat: int, control: str = "force", contact_points: str = "default",
           borders: str = "") -> dict:
    import scipy.sparse as sp

    from shellcontact import linalg
    from shellcontact.analysis.pipeline import solve
    from shellcontact.studies.curves import solve_family

    linalg.factorize(sp.identity(4, format="csr")).solve(np.ones(4))  # load the libraries outside the timings
    for r in solve_family(curve_cases(8, 2, control, contact_points)):  # every module a solve imports on first use
        r.summary()
    cases = curve_cases(n, points, control, contact_points)

    # the curve
    wall0, cpu0 = time.perf_counter(), time.process_time()
    curve = list(solve_family(cases))
    curve_wall, curve_cpu = time.perf_counter() - wall0, time.process_time() - cpu0
    t0 = time.perf_counter()
    for r in curve:  # what the points make when asked for: stresses, reactions, zone, rim
        r.summary()
    summaries = time.perf_counter() - t0
    shared = _stages(curve[0])
    d = curve[0].discretization

    # one linear solve of the same mesh
    rhs = d.Fr if np.any(d.Fr) else np.asarray(d.Br.T @ np.ones(d.Br.shape[0]))  # no load: the punch's pattern
    linear = []
    for _ in range(max(1, repeat)):
        t0, c0 = time.perf_counter(), time.process_time()
        fac = linalg.factorize(d.Ar, curve[0].info.get("backend", "auto"))
        t1 = time.perf_counter()
        fac.solve(rhs)
        linear.append((t1 - t0, time.perf_counter() - t1, time.process_time() - c0))
        del fac
    t_fact, t_solve, linear_cpu = min(linear, key=lambda x: x[0] + x[1])
    linear_cost = t_fact + t_solve

    # the naive loop
    naive, naive_walls, naive_stages = [], [], 0.0
    cpu0 = time.process_time()
    for c in cases:
        t0 = time.perf_counter()
        r = solve(c)
        naive_walls.append(time.perf_counter() - t0)
        naive_stages += _stages(r)
        # what the comparison needs: a Result keeps its own stiffness (20 of them would take 8 GB here)
        naive.append((r.solution.U, r.summary()["contact"][0], int(r.contact.active.sum()),
                      r.contact.solution.iterations))
        del r
    naive_cpu = time.process_time() - cpu0
    naive_wall = sum(naive_walls)
    naive_cost = naive_wall - naive_stages

    rows = []
    worst = {"force": 0.0, "travel": 0.0, "U": 0.0}
    for k, (a, (U, cb, active, iterations)) in enumerate(zip(curve, naive)):
        ca = a.summary()["contact"][0]
        du = float(np.abs(a.solution.U - U).max() / np.abs(U).max())
        df = abs(ca["force_magnitude"] - cb["force_magnitude"]) / cb["force_magnitude"]
        dt = abs(_travel(cases[k], ca) - _travel(cases[k], cb)) / abs(_travel(cases[k], cb))
        worst = {"force": max(worst["force"], df), "travel": max(worst["travel"], dt), "U": max(worst["U"], du)}
        rows.append({"force": cb["force_magnitude"], "travel": _travel(cases[k], cb), "active": active,
                     "iterations_curve": a.contact.solution.iterations, "iterations_naive": iterations,
                     "seconds_curve": a.timings["total"], "seconds_naive": naive_walls[k]})
    ranks = np.argsort(np.argsort(d.operator.G, kind="stable"), kind="stable")
    deepest_needed = int(max((ranks[r.contact.active].max() + 1 for r in curve if r.contact.active.any()), default=0))
    borders_measured = border_costs(d, [int(k) for k in borders.split(",") if k], repeat)
    per_stage = {s: sum(r.timings.get(s, 0.0) for r in curve) for s in ("factorization", "solve", "postprocess")}
    per_stage["summary and rest"] = curve_wall - shared - sum(per_stage.values())
    return {
        "n": n, "points": points, "dofs": int(curve[0].solution.space.ndofs), "unknowns": int(d.Ar.shape[0]),
        "constraints": int(d.operator.m), "factorizations": curve[-1].info["family"]["factorizations"],
        "linear_factorize": t_fact, "linear_solve": t_solve, "linear_cpu": linear_cpu,
        "linear_samples": [a + b for a, b, _ in linear],
        "curve_wall": curve_wall, "curve_cpu": curve_cpu, "curve_shared_mesh_assembly": shared,
        "curve_cost": curve_wall - shared, "curve_stages": per_stage, "summaries": summaries,
        "active_rank": deepest_needed, "borders": borders_measured,
        "ratio_with_summaries": (curve_wall - shared + summaries) / linear_cost, "contact_points": contact_points,
        "shared_final_solves": sum(bool(r.contact.solution.info.get("curve", {}).get("shared_final_solves"))
                                   for r in curve),
        "naive_wall": naive_wall, "naive_cpu": naive_cpu, "naive_cost": naive_cost,
        "ratio": (curve_wall - shared) / linear_cost, "naive_ratio": naive_cost / linear_cost,
        "ratio_end_to_end": curve_wall / (linear_cost + shared), "worst_difference": worst, "rows": rows,
    }


def main(argv=None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--n", type=int, help="mesh n × n (default 112, quick 40)")
    ap.add_argument("--points", type=int, help="points on the curve (default 20, quick 5)")
    ap.add_argument("--repeat", type=int, default=3, help="timed linear solves (the best is kept)")
    ap.add_argument("--control", choices=("force", "indentation"), default="force",
                    help="the curve's points: forces (the target) or indentations")
    ap.add_argument("--contact-points", default="default", choices=["default", "vertices", "vertices+midpoints"],
                    help="[solver] contact_points (default: the case's, i.e. the package default vertices+midpoints)")
    ap.add_argument("--borders", default="", help="comma-separated row counts k: also time the factorisation "
                    "bordered by the k rows of smallest G")
    ap.add_argument("--worker", nargs="*")
    args = ap.parse_args(argv)
    if args.worker:
        res = worker(int(args.worker[0]), int(args.worker[1]), int(args.worker[2]), args.worker[3], args.worker[4],
                     args.worker[5] if len(args.worker) > 5 else "")
        common.emit(res)
        return res
    n = args.n or (40 if args.quick else 112)
    points = args.points or (5 if args.quick else 20)
    info = common.machine()
    r = common.run_worker(Path(__file__), [str(n), str(points), str(args.repeat), args.control, args.contact_points,
                                           args.borders], timeout=7200.0)
    print(f"# A {points}-point force–indentation curve ({args.control} control) vs one linear solve "
          f"({CASE.name}, mesh {n}×{n}, {r['dofs']} dofs, {r['constraints']} contact rows, contact points: "
          f"{args.contact_points})")
    print(common.machine_line(info))
    lin = r["linear_factorize"] + r["linear_solve"]
    print(common.table(
        ["run", "wall s", "after mesh+assembly s", "× linear", "CPU s", "factorisations"],
        [["linear (factorise + solve)", lin, lin, 1.0, r["linear_cpu"], 1],
         [f"curve ({points} points, solve_family)", r["curve_wall"], r["curve_cost"], r["ratio"], r["curve_cpu"],
          r["factorizations"]],
         ["curve + every point's summary", r["curve_wall"] + r["summaries"], r["curve_cost"] + r["summaries"],
          r["ratio_with_summaries"], "", r["factorizations"]],
         [f"naive loop ({points} × solve)", r["naive_wall"], r["naive_cost"], r["naive_ratio"], r["naive_cpu"],
          points]]))
    print("curve, after its mesh and assembly (s): " + ", ".join(f"{k} {v:.2f}" for k, v in r["curve_stages"].items())
          + f"; points whose final check ran on the block solves: {r['shared_final_solves']} of {points}")
    print("(curve s: a point's own stages; the first holds the mesh, assembly and factorisation, and a force curve's "
          "points share their final solves)")
    print(common.table(["force N", "travel m", "active", "iterations curve", "iterations naive", "curve s", "naive s"],
                       [[x["force"], x["travel"], x["active"], x["iterations_curve"], x["iterations_naive"],
                         x["seconds_curve"], x["seconds_naive"]] for x in r["rows"]]))
    print(f"the curve's active rows reach rank {r['active_rank']} of {r['constraints']} in the order of G (the "
          "screening's: above substructure.MIN_UNKNOWNS unknowns the factorisation is bordered by the first "
          "screening.FRACTION of them)")
    if r["borders"]:
        print(common.table(["border rows (smallest G)", "factorise s", "× linear"],
                           [[b["rows"], b["seconds"], b["seconds"] / lin] for b in r["borders"]]))
    print("largest relative difference curve vs naive: " + ", ".join(f"{k} {v:.1e}" for k, v in
                                                                      r["worst_difference"].items()))
    target = common.target(round(r["ratio"], 3), GOAL, f"seconds of a {points}-point curve (after its mesh and "
                           "assembly) / seconds of one linear factorise + solve", "one linear solve of the same mesh",
                           naive_ratio=round(r["naive_ratio"], 3), dofs=r["dofs"], points=points, control=args.control,
                           with_summaries=round(r["ratio_with_summaries"], 3), contact_points=args.contact_points,
                           end_to_end=round(r["ratio_end_to_end"], 3))
    out = {"targets": {"curve_vs_linear": target}, "run": r, "machine": info}
    print(json.dumps(out))
    return out


if __name__ == "__main__":
    main()
