"""Issue 13, item 8: the default ``[solver] contact_points``, chosen by accuracy per second.

    python benchmarks/contact_points.py           # six cases, three meshes each
    python benchmarks/contact_points.py --quick   # two meshes each

For the cases sphere (examples/paper_panel.toml), ring (a torus round a full cylinder), sleeve (a full
cylinder in a rigid sleeve), band clamp (examples/band_clamp.toml), plane (a flat plate pressed onto a pipe)
and saddle (examples/saddle_support.toml, the saddle's force), each mesh is solved with
``contact_points = "vertices"`` (the paper's constraint at the mesh vertices, MODEL.md (8.6)) and with
``"vertices+midpoints"``. Measured: the total normal force and the largest |w| against a reference, and the
solve time (process CPU time of ``solve``, BLAS on one thread, best of ``--repeat`` runs after one warm-up
solve; the wall time is in the JSON).

References: the ring, the sleeve and the band clamp are axisymmetric and have an exact solution of this
shell model (tests/oracles/axisym.py, which shares no code with the package: the ring stiffness 8 D β_m² α
and the sleeve's free boundary located exactly); force and max |w| are compared with it. The sphere, the
plane and the saddle are compared with a mesh twice as fine in each direction as the finest measured one,
solved with BOTH choices: the table prints how far the two fine solutions lie apart ("ref. spread"), the
uncertainty of that reference; the errors are measured against the vertices+midpoints one.

"digits" = −log10(relative force error); "accuracy/s" = 1 / (relative force error × CPU seconds), the accuracy
bought per second. At each mesh the choice with the larger accuracy/s wins; on balance the geometric mean of
its ratio (vertices+midpoints / vertices) over all rows decides. The last line is JSON:
``{"cases": [...], "decision": {...}}``.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from dataclasses import dataclass
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import common  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "tests"))  # the independent axisymmetric oracle

POINTS = ("vertices", "vertices+midpoints")
REFERENCE_POINTS = "vertices+midpoints"

# ring and sleeve: a full cylinder a = 1, t = 0.02 with a symmetry plane at x = 0 (as tests/test_axisymmetric)
A, T, E, MU = 1.0, 0.02, 2.0e5, 0.3
DELTA, R_MINOR = 1e-3, 0.5
SLEEVE_RADIUS, SLEEVE_END = A + T / 2 - 1e-3, 0.3


@dataclass(frozen=True)
class Bench:
    """One case: how to build it on a mesh level (nx, nphi), which punch's force is measured, the exact solution."""

    name: str
    build: object  # (level, contact_points) -> Case
    punch: int
    levels: tuple[tuple[int, int], ...]
    quick_levels: tuple[tuple[int, int], ...]
    exact: object = None  # () -> {"force", "max_abs_w"} of this shell model, or None: a fine mesh is the reference

    def reference_level(self, quick: bool) -> tuple[int, int]:
        """Twice the finest measured mesh in each direction (four times its elements)."""
        nx, nphi = (self.quick_levels if quick else self.levels)[-1]
        return 2 * nx, 2 * nphi


def _example(name: str):
    def build(level, points):
        from shellcontact.problem.case import load_case

        nx, nphi = level
        return load_case(ROOT / "examples" / f"{name}.toml",
                         [f"mesh.nx={nx}", f"mesh.nphi={nphi}", f"solver.contact_points={points}"])
    return build


def _full_cylinder(length: float, x_max: str, punch: dict, grade: list[float]):
    def build(level, points):
        from shellcontact.problem.case import case_from_dict

        nx, nphi = level
        return case_from_dict({
            "shell": {"radius": A, "length": length, "x_start": 0.0, "full": True, "thickness": T, "young": E,
                      "poisson": MU},
            "supports": {"x_min": "symmetry", "x_max": x_max, "phi_min": "periodic", "phi_max": "periodic"},
            "mesh": {"nx": nx, "nphi": nphi, "grading": {"x": grade, "ratio": 4.0}},
            "punch": [punch],
            "solver": {"method": "active-set", "contact_points": points},
        })
    return build


def _plane(level, points):
    """A rigid flat plate 200 mm long (its zone) pressed 1 mm onto a pipe clamped at both ends: a contact
    line along the crown."""
    from shellcontact.problem.case import case_from_dict

    nx, nphi = level
    return case_from_dict({
        "shell": {"radius": 0.1, "length": 0.6, "full": True, "thickness": 0.004, "young": 2.1e11, "poisson": 0.3},
        "supports": {"x_min": "clamped", "x_max": "clamped"},
        "mesh": {"nx": nx, "nphi": nphi, "grading": {"phi": [90.0], "ratio": 4.0}},
        "punch": [{"shape": "plane", "center": [0.0, 0.0, 0.2], "normal": [0.0, 0.0, -1.0],
                   "direction": [0.0, 0.0, -1.0], "indentation": 1e-3, "side": "outer",
                   "zone": {"x": [-0.1, 0.1], "phi": [45.0, 135.0]}}],
        "solver": {"method": "active-set", "contact_points": points},
    })


def _ring_exact() -> dict:
    from oracles.axisym import Shell1D, ring_stiffness

    # the half model x ≥ 0 carries half the ring force 2πa · P, P = 8 D β_m² α δ per unit circumference;
    # the shell under the ring moves in by exactly δ (the largest |w|)
    return {"force": math.pi * A * ring_stiffness(Shell1D(A, T, E, MU, 0.0, 2.0)) * DELTA, "max_abs_w": DELTA}


def _sleeve(shell, radius: float, end: float, scale: float, **kw) -> dict:
    import numpy as np
    from oracles.axisym import sleeve_free_boundary

    ref = sleeve_free_boundary(shell, radius, end, **kw)
    x = np.linspace(shell.x0, shell.x1, 4001)
    return {"force": scale * ref.total_normal_force, "max_abs_w": float(np.max(np.abs(ref.solution.w(x))))}


def _sleeve_exact() -> dict:
    from oracles.axisym import Shell1D

    return _sleeve(Shell1D(A, T, E, MU, 0.0, 1.0), SLEEVE_RADIUS, SLEEVE_END, 1.0)


def _band_exact() -> dict:
    from oracles.axisym import Shell1D

    from shellcontact.problem.case import load_case

    raw = load_case(ROOT / "examples" / "band_clamp.toml").raw
    sh, p = raw["shell"], raw["punch"][0]
    half = Shell1D(sh["radius"], sh["thickness"], sh["young"], sh["poisson"], 0.0, sh["length"] / 2)
    # symmetry plane at x = 0: the half band carries half the force
    return _sleeve(half, p["radius"], p["zone"]["x"][1], 2.0, h_min=1e-4, h_max=5e-3)


TORUS = {"shape": "torus", "center": [0.0, 0.0, 0.0], "axis": [1.0, 0.0, 0.0],
         "major_radius": A + T / 2 - DELTA + R_MINOR, "minor_radius": R_MINOR, "side": "outer",
         "zone": {"x": [0.0, 0.2]}}
SLEEVE = {"shape": "cylinder", "inverted": True, "center": [0.0, 0.0, 0.0], "axis": [1.0, 0.0, 0.0],
          "radius": SLEEVE_RADIUS, "side": "outer", "zone": {"x": [0.0, SLEEVE_END]}}

BENCHES = (
    Bench("sphere", _example("paper_panel"), 0, ((16, 16), (32, 32), (48, 48)), ((16, 16), (32, 32))),
    Bench("ring", _full_cylinder(2.0, "simply_supported", TORUS, [0.0]), 0, ((20, 16), (40, 32), (80, 64)),
          ((20, 16), (40, 32)), _ring_exact),
    Bench("sleeve", _full_cylinder(1.0, "clamped", SLEEVE, [SLEEVE_END]), 0, ((20, 24), (40, 48), (60, 72)),
          ((20, 24), (40, 48)), _sleeve_exact),
    Bench("band clamp", _example("band_clamp"), 0, ((60, 8), (120, 16), (240, 32)), ((60, 8), (120, 16)),
          _band_exact),
    Bench("plane", _plane, 0, ((16, 16), (32, 32), (48, 48)), ((16, 16), (32, 32))),
    Bench("saddle", _example("saddle_support"), 1, ((20, 24), (40, 48), (80, 96)), ((20, 24), (40, 48))),
)


def measure(bench: Bench, level, points: str, repeat: int) -> dict:
    """One solve's force, largest |w| and cost: the process CPU time of ``solve`` (single-threaded BLAS; the
    fairer figure on this shared machine, see benchmarks/common.py) and its wall time, best of ``repeat``."""
    from shellcontact.analysis.pipeline import solve

    case = bench.build(level, points)
    cpu = wall = math.inf
    for _ in range(max(1, repeat)):
        c0, t0 = time.process_time(), time.perf_counter()
        res = solve(case)
        cpu, wall = min(cpu, time.process_time() - c0), min(wall, time.perf_counter() - t0)
    s = res.summary()
    return {"level": list(level), "points": points, "unknowns": int(s["unknowns"]),
            "force": float(s["contact"][bench.punch]["total_normal_force"]), "max_abs_w": float(s["max_abs_w"]),
            "seconds": cpu, "wall_seconds": wall, "iterations": s["iterations"],
            "active_points": int(s["contact"][bench.punch]["active_points"])}


def _rel(value: float, ref: float) -> float:
    return abs(value / ref - 1.0)


def _digits(err: float) -> float:
    return -math.log10(max(err, 1e-16))


def run_case(bench: Bench, quick: bool, repeat: int, log) -> dict:
    t0 = time.perf_counter()
    if bench.exact is not None:
        ref, fine = bench.exact(), None
        source = "exact solution of this shell model (tests/oracles/axisym.py)"
    else:
        level = bench.reference_level(quick)
        fine = {p: measure(bench, level, p, 1) for p in POINTS}
        ref = fine[REFERENCE_POINTS]
        source = f"{level[0]} × {level[1]} mesh, {REFERENCE_POINTS}"
    rows = []
    for level in bench.quick_levels if quick else bench.levels:
        for p in POINTS:
            m = measure(bench, level, p, repeat)
            m["force_error"] = _rel(m["force"], ref["force"])
            m["w_error"] = _rel(m["max_abs_w"], ref["max_abs_w"])
            m["digits"] = _digits(m["force_error"])
            m["accuracy_per_second"] = 1.0 / (max(m["force_error"], 1e-16) * m["seconds"])
            rows.append(m)
    log(f"({bench.name}: {time.perf_counter() - t0:.0f} s)")
    out = {"case": bench.name, "punch": bench.punch, "reference": source, "force_reference": ref["force"],
           "max_abs_w_reference": ref["max_abs_w"], "rows": rows}
    if fine is not None:
        out["reference_spread"] = {"force": _rel(fine["vertices"]["force"], ref["force"]),
                                   "max_abs_w": _rel(fine["vertices"]["max_abs_w"], ref["max_abs_w"]),
                                   "seconds": {p: fine[p]["seconds"] for p in POINTS}}
    return out


def decide(results: list[dict]) -> dict:
    """Accuracy per second of a row: 1 / (relative force error × CPU seconds). At each mesh of each case the
    choice with the larger value wins; on balance, the geometric mean over all rows of its ratio
    (vertices+midpoints / vertices) decides, with those of the error and of the time beside it."""
    ratios: dict[str, list[float]] = {"accuracy_per_second": [], "error": [], "time": []}
    wins = {p: 0 for p in POINTS}
    for r in results:
        by = {(tuple(m["level"]), m["points"]): m for m in r["rows"]}
        for level in dict.fromkeys(tuple(m["level"]) for m in r["rows"]):
            v, vm = by[(level, "vertices")], by[(level, "vertices+midpoints")]
            ratios["accuracy_per_second"].append(vm["accuracy_per_second"] / v["accuracy_per_second"])
            ratios["error"].append(max(vm["force_error"], 1e-16) / max(v["force_error"], 1e-16))
            ratios["time"].append(vm["seconds"] / v["seconds"])
            wins["vertices" if v["accuracy_per_second"] > vm["accuracy_per_second"] else "vertices+midpoints"] += 1

    def gmean(xs):
        return math.exp(sum(math.log(x) for x in xs) / len(xs))

    means = {k: gmean(v) for k, v in ratios.items()}
    return {"wins": wins, "midpoints_over_vertices_geomean": means,
            "better": "vertices+midpoints" if means["accuracy_per_second"] > 1.0 else "vertices"}


def main(argv=None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--quick", action="store_true", help="two meshes per case and coarser references")
    ap.add_argument("--cases", default=",".join(b.name for b in BENCHES), help="comma-separated case names")
    ap.add_argument("--repeat", type=int, default=2, help="timed solves of each row (the fastest is kept)")
    args = ap.parse_args(argv)
    names = [n.strip() for n in args.cases.split(",")]
    unknown = sorted(set(names) - {b.name for b in BENCHES})
    if unknown:
        ap.error(f"unknown case(s) {unknown}; choose from {[b.name for b in BENCHES]}")
    print(common.machine_line(common.machine()), flush=True)
    from shellcontact.analysis.pipeline import solve

    solve(_example("paper_panel")((8, 8), "vertices"))  # warm-up: imports and caches outside the timings

    results = []
    for b in BENCHES:
        if b.name in names:
            results.append(run_case(b, args.quick, args.repeat, lambda s: print(s, file=sys.stderr, flush=True)))
    headers = ["case", "mesh", "contact_points", "force error", "max |w| error", "CPU s", "digits", "accuracy/s"]
    rows = []
    for r in results:
        for m in r["rows"]:
            rows.append([r["case"], f"{m['level'][0]}×{m['level'][1]}", m["points"], f"{m['force_error']:.1e}",
                         f"{m['w_error']:.1e}", f"{m['seconds']:.2f}", f"{m['digits']:.1f}",
                         f"{m['accuracy_per_second']:.2g}"])
    print(common.table(headers, rows))
    print()
    spread = {r["case"]: r.get("reference_spread") for r in results}
    print(common.table(["case", "force reference", "max |w| reference", "reference", "ref. spread (force, max |w|)"],
                       [[r["case"], f"{r['force_reference']:.6g} N", f"{r['max_abs_w_reference']:.6g} m",
                         r["reference"], "exact" if spread[r["case"]] is None
                         else f"{spread[r['case']]['force']:.1e}, {spread[r['case']]['max_abs_w']:.1e}"]
                        for r in results]))
    decision = decide(results)
    g = decision["midpoints_over_vertices_geomean"]
    print(f"\nhigher accuracy/s (rows won): {decision['wins']}; vertices+midpoints / vertices, geometric means: "
          f"accuracy/s × {g['accuracy_per_second']:.3g}, force error × {g['error']:.2g}, CPU time × {g['time']:.2f}; "
          f"better on balance: {decision['better']}")
    out = {"cases": results, "decision": decision}
    print(json.dumps(out))
    return out


if __name__ == "__main__":
    main()
