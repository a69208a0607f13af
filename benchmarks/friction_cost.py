"""Issue 26 item 6: the cost of friction against the frictionless solve of the same case.

examples/panel_pushed_sideways.toml at ``mesh.refine`` r (r = 1: 16.8k unknowns), three variants of its punch:
frictionless (friction 0, no slide), Tresca (``--tresca-bound``, default 1e7 Pa, on the points in contact, 1 mm
axial slide; ``--tresca-fixed g`` instead: the bound g on the points in contact of the frictionless solution, held
fixed — the case key ``friction.surface = "frictionless-contact"``, one convex Tresca problem) and Coulomb
(μ = 0.3, the same slide); each by ``--methods`` (default active-set and dual). Every run is a fresh
subprocess (its peak RSS its own); reported: the whole ``shellcontact.solve`` (wall, CPU s), its solve stage,
the fixed-point iterations and the solver's iterations, the peak RSS.

    .venv/bin/python benchmarks/friction_cost.py --refine 1 2 [--methods active-set dual] [--tresca-bound 1e6]
    .venv/bin/python benchmarks/friction_cost.py --refine 1 2 --methods active-set --tresca-fixed 1e6
    flock /work/wt/big.lock .venv/bin/python benchmarks/friction_cost.py --refine 112 --methods active-set

(``--refine 112``: the mesh nx = nphi = 112, 216k unknowns, the issue's size; refine 3 is 276k.)

Runs with refine ≥ 3 take more than 4 GB: run them under ``flock /work/wt/big.lock``.
"""

from __future__ import annotations

import argparse
import json
import resource
import subprocess
import sys
import time
import tomllib
from pathlib import Path

from common import machine, machine_line, single_thread_env

CASE = Path(__file__).resolve().parents[1] / "examples" / "panel_pushed_sideways.toml"
VARIANTS = {
    "frictionless": {"friction": 0.0},
    "tresca": {"friction": {"model": "tresca", "bound": 1e7}, "slide": [1e-3, 0.0, 0.0]},
    "coulomb": {"friction": 0.3, "slide": [1e-3, 0.0, 0.0]},
}


def one(refine: int, variant: str, method: str, tresca_bound: float, fixed: bool) -> dict:
    """One run, in this process: the numbers of the table's row."""
    from shellcontact import solve
    from shellcontact.problem.case import case_from_dict

    data = tomllib.loads(CASE.read_text())
    if refine > 3:  # not a refine level: the mesh nx = nphi = refine at refine 0 (112: 216k unknowns)
        data["mesh"].update(nx=refine, nphi=refine, refine=0)
    else:
        data["mesh"]["refine"] = refine
    punch = data["punch"][0]
    punch.pop("slide", None)
    punch.update(VARIANTS[variant])
    if variant == "tresca":
        punch["friction"] = {"model": "tresca", "bound": tresca_bound}
        if fixed:
            punch["friction"]["surface"] = "frictionless-contact"
    case = case_from_dict(data)
    wall, cpu = time.perf_counter(), time.process_time()
    result = solve(case, method=method)
    wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
    contact = result.summary()["contact"][0]
    friction = contact.get("friction", {})
    return {"refine": refine, "variant": variant, "method": method, "unknowns": result.info["unknowns"],
            "rows": int(result.contact.Lambda.size), "wall_s": wall, "cpu_s": cpu,
            "solve_s": result.timings.get("solve", float("nan")),
            "fixed_point_iterations": _fixed_point_text(friction.get("fixed_point")),
            "newton": _newton_text(friction.get("fixed_point", {}).get("newton")),
            "iterations": int(result.contact.solution.iterations),
            "friction_force_N": friction.get("force", [0.0])[0], "normal_force_N": contact["total_normal_force"],
            "peak_rss_MB": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024}


def _fixed_point_text(record: dict | None) -> str:
    """The fixed point's iterations in a table cell, and "(not converged)" where it did not converge."""
    if record is None:
        return "0"
    return f"{record['iterations']}" + ("" if record["converged"] else " (not converged)")


def _newton_text(record: dict | None) -> str:
    """The whole-law Newton's record (``fixed_point.newton``) in a table cell: its iterations, why it stopped,
    and the Newton iterations of each polish of the fixed point's iterate."""
    if record is None:
        return "-"
    text = f"{record['iterations']}" + ("" if record["converged"] else f" ({record['fallback']})")
    if record["polish_iterations"]:
        text += f"; polish {'+'.join(str(i) for i in record['polish_iterations'])}"
    return text


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--refine", type=int, nargs="+", default=[1],
                    help="refine levels 0-3 of the example's 16 x 16 mesh, or above 3 the mesh nx = nphi = that number")
    ap.add_argument("--methods", nargs="+", default=["active-set", "dual"])
    ap.add_argument("--tresca-bound", type=float, default=1e7, help="the Tresca variant's bound (Pa)")
    ap.add_argument("--tresca-fixed", type=float, default=None, metavar="G",
                    help="the Tresca variant: the bound G (Pa) on the frictionless solution's contact set, held fixed")
    ap.add_argument("--variants", nargs="+", default=list(VARIANTS), choices=list(VARIANTS))
    ap.add_argument("--one", nargs=3, metavar=("REFINE", "VARIANT", "METHOD"), help=argparse.SUPPRESS)
    args = ap.parse_args()
    fixed = args.tresca_fixed is not None
    bound = args.tresca_fixed if fixed else args.tresca_bound
    if args.one:
        print(json.dumps(one(int(args.one[0]), args.one[1], args.one[2], bound, fixed)))
        return
    print(machine_line(machine()))
    print("| refine | unknowns | rows | variant | method | wall s | CPU s | solve stage s | fixed-point its | "
          "newton its | solver its | friction force N | peak RSS MB |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    for refine in args.refine:
        for method in args.methods:
            for variant in args.variants:
                out = subprocess.run([sys.executable, __file__, "--one", str(refine), variant, method,
                                      "--tresca-fixed" if fixed else "--tresca-bound", str(bound)],
                                     capture_output=True, text=True, env=single_thread_env())
                if out.returncode:
                    print(f"| {refine} | | | {variant} | {method} | failed: {out.stderr.strip()[-200:]} |")
                    continue
                r = json.loads(out.stdout.strip().splitlines()[-1])
                print(f"| {refine} | {r['unknowns']} | {r['rows']} | {variant} | {method} | {r['wall_s']:.2f} | "
                      f"{r['cpu_s']:.2f} | {r['solve_s']:.2f} | {r['fixed_point_iterations']} | {r['newton']} | "
                      f"{r['iterations']} | "
                      f"{r['friction_force_N']:.4g} | {r['peak_rss_MB']:.0f} |", flush=True)


if __name__ == "__main__":
    main()
