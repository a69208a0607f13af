"""Targets 5 and 6: the demo case end to end from ~10k to ~1M dofs, and the digits of its contact force.

    python benchmarks/scale_1m.py            # levels mesh.refine = 0..3 of the 32 × 32 demo mesh (18k → 1.13M dofs)
                                             # plus a 24 × 24 mesh (10k dofs); several minutes, ~10 GB
    python benchmarks/scale_1m.py --quick    # refine 0..1 only (18k, 72k dofs): the 1M targets stay null
    python benchmarks/scale_1m.py --levels 2 --method dual --nested
    python benchmarks/scale_1m.py --threads 2    # both cores (what run.py / make bench do)

Every size runs ``shellcontact.solve(case)`` on src/shellcontact/cases/paper_panel.toml with
``mesh.refine = r`` (nested uniform refinement of the graded, punch-fitted 32 × 32 mesh) in a fresh
subprocess, then writes summary.json, fields.vtu and results.npz to a temporary directory
(``Result.write(..., figures=False, report=False)``). Per stage (the stages of ``Result.timings``:
mesh, assembly, factorization, nested, solve; and output) it records wall and CPU seconds and the
peak resident set of the process during that stage (Linux VmHWM, reset at every stage start through
/proc/self/clear_refs; the benchmark wraps ``analysis.Timer`` for this, the package is unchanged).
The whole-run peak is the largest of those.

Force digits (target 6): the punch force (``contact[0].force_magnitude``) at the nested levels
r = 0..L; Richardson extrapolation from the last three levels, F∞ = F_L + (F_L − F_{L−1})/(2^p − 1)
with the observed order p = log2((F_{L−2} − F_{L−1})/(F_{L−1} − F_L)); digits of F_L =
−log10(|F_L − F∞| / |F∞|). This measures the discretisation error of the finest level, which
bounds the digits it can agree with the extrapolation, whatever the algebra does.

Round-off (full runs only): the finest level is solved again with another thread count (PARDISO's
sums then run in another order), once in double and once with ``solver.extended_precision = true``
(the final solves refined with extended-precision residuals) at both thread counts; the table gives
the digits in which the forces agree and whether the active sets are identical. Runs in double agree
with each other better than with the extended-precision answer (71k dofs: 7e-13 between thread
counts, 7e-11 from the extended result), so "double vs extended" is the double run's error.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import re
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import common  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
CASE = ROOT / "src" / "shellcontact" / "cases" / "paper_panel.toml"
GOALS = {"seconds_1M_dofs": 60.0, "peak_gb_1M_dofs": 10.0, "force_digits_1M_dofs": 8.0}  # issue 23: 10 GB
STAGES = ("mesh", "assembly", "factorization", "nested", "solve", "postprocess", "output")

# ---- per-stage peak RSS -------------------------------------------------------------------------------------------


def _hwm_bytes() -> int:
    m = re.search(r"VmHWM:\s+(\d+)\s*kB", Path("/proc/self/status").read_text())
    return int(m.group(1)) * 1024 if m else common.max_rss_bytes()


def _reset_hwm() -> bool:
    try:
        Path("/proc/self/clear_refs").write_text("5")
        return True
    except OSError:
        return False


class _Peaks:
    """Peak RSS per (possibly nested) stage: fold VmHWM into every open stage, then reset it."""

    def __init__(self) -> None:
        self.open: list[list] = []  # [name, peak]
        self.peaks: dict[str, int] = {}
        self.overall = 0
        self.resettable = True

    def _fold(self) -> None:
        h = _hwm_bytes()
        self.overall = max(self.overall, h)
        for s in self.open:
            s[1] = max(s[1], h)

    def enter(self, name: str) -> None:
        self._fold()
        self.resettable = _reset_hwm() and self.resettable
        self.open.append([name, 0])
        self._fold()

    def exit(self) -> None:
        self._fold()
        name, peak = self.open.pop()
        self.peaks[name] = max(self.peaks.get(name, 0), peak)


PEAKS = _Peaks()
CPU: dict[str, float] = {}


def _install_timer() -> None:
    """Wrap analysis.Timer so that each stage also records its peak RSS and CPU seconds."""
    from shellcontact.analysis import pipeline as analysis

    base = analysis.Timer

    class MemTimer(base):
        def stage(self, name: str):
            inner = base.stage(self, name)

            class _S:
                def __enter__(self_):
                    PEAKS.enter(name)
                    self_.c0 = time.process_time()
                    return inner.__enter__()

                def __exit__(self_, *exc):
                    out = inner.__exit__(*exc)
                    CPU[name] = CPU.get(name, 0.0) + time.process_time() - self_.c0
                    PEAKS.exit()
                    return out

            return _S()

    analysis.Timer = MemTimer


def worker(n: int, refine: int, method: str, nested: bool, backend: str = "auto", extended: bool = False) -> dict:
    import scipy.sparse as sp

    from shellcontact import linalg
    from shellcontact.analysis.pipeline import solve
    from shellcontact.problem.case import load_case

    linalg.factorize(sp.identity(4, format="csr")).solve(np.ones(4))  # load the libraries outside the timings
    _install_timer()
    over = [f"mesh.nx={n}", f"mesh.nphi={n}", f"mesh.refine={refine}", f"solver.method={method}"]
    if nested:
        over.append("solver.nested=true")
    if backend != "auto":
        over.append(f"solver.backend={backend}")
    if extended:
        over.append("solver.extended_precision=true")
    case = load_case(CASE, over)
    t0, c0 = time.perf_counter(), time.process_time()
    res = solve(case)
    with tempfile.TemporaryDirectory() as tmp:
        PEAKS.enter("output")
        c1, t1 = time.process_time(), time.perf_counter()
        written = res.write(tmp, figures=False, report=False)
        t_out, c_out = time.perf_counter() - t1, time.process_time() - c1
        PEAKS.exit()
        sizes = {k: Path(p).stat().st_size for k, p in written.items()}
        summary = json.loads((Path(tmp) / "summary.json").read_text())
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    timings = {k: float(v) for k, v in res.timings.items() if k not in ("total", "output")}
    timings["output"] = t_out
    CPU["output"] = c_out
    cs = res.contact.solution
    c0_ = summary["contact"][0]
    return {
        "n": n, "refine": refine, "method": method, "nested": nested,
        "dofs": int(res.solution.space.ndofs), "unknowns": int(res.info["unknowns"]),
        "triangles": int(res.solution.space.mesh.nelements), "nnz_A": int(res.solution.A.nnz),
        "constraints": int(res.contact.operator.m), "active": int(res.contact.active.sum()),
        "active_hash": common.active_hash(res.contact.active), "extended": extended,
        "threads": os.environ.get("MKL_NUM_THREADS"),
        "iterations": int(cs.iterations), "nested_iterations": res.info.get("nested_iterations"),
        "backend": res.info.get("backend"),
        "timings": timings, "cpu": dict(CPU), "wall": wall, "cpu_total": cpu,
        "peak_rss": {k: v for k, v in PEAKS.peaks.items()}, "peak_rss_overall": PEAKS.overall,
        "hwm_reset": PEAKS.resettable,
        "force": float(c0_["force_magnitude"]), "total_normal_force": float(c0_["total_normal_force"]),
        "kkt_scaled": summary.get("kkt_scaled"), "kkt": summary.get("kkt"), "written_bytes": sizes,
        "warnings": summary.get("warnings", []),
        # the contact solve's parts (wall s), its border (the screened rows per round) and Schur columns
        "solver_timings": {k: float(v) for k, v in res.info.get("solver_timings", {}).items()},
        "screening": cs.info.get("screening"),
    }


def _run(n: int, r: int, args, extended: bool, threads: int | None = None) -> dict:
    """One worker run; ``threads`` overrides the thread count of this run only."""
    return common.run_worker(Path(__file__), [str(n), str(r), args.method, "1" if args.nested else "0",
                                              args.backend, "1" if extended else "0"], timeout=1200, threads=threads)


def roundoff(finest: dict, args) -> dict:
    """Digits of the finest force that survive round-off: the same case solved with 1 thread and with
    ``finest``'s threads (PARDISO then sums in another order), in double and with the final solves
    refined in extended precision (solver.extended_precision); are the active sets the same?"""
    threads = int(finest.get("threads") or 1)
    other = 1 if threads > 1 else 2
    runs = {("double", threads): finest}
    runs[("double", other)] = _run(finest["n"], finest["refine"], args, extended=False, threads=other)
    for t in (threads, other):
        runs[("extended", t)] = _run(finest["n"], finest["refine"], args, extended=True, threads=t)
    out: dict = {"threads": [threads, other], "runs": {f"{k[0]}/{k[1]}": {
        "force": v["force"], "active": v["active"], "active_hash": v["active_hash"], "wall": v["wall"],
        "solve_s": v["timings"].get("solve")} for k, v in runs.items()}}
    pairs = {"double": (("double", threads), ("double", other)),
             "extended": (("extended", threads), ("extended", other)),
             "double_vs_extended": (("double", threads), ("extended", threads))}
    for name, (ka, kb) in pairs.items():
        a, b = runs[ka], runs[kb]
        rel = abs(a["force"] - b["force"]) / abs(a["force"])
        out[name] = {"relative_difference": rel, "digits": -math.log10(rel) if rel > 0 else 16.0,
                     "same_active_set": a["active_hash"] == b["active_hash"]}
    return out


def fit_exponent(x, y) -> float | None:
    x, y = np.asarray(x, float), np.asarray(y, float)
    ok = (x > 0) & (y > 0)
    if ok.sum() < 2:
        return None
    return float(np.polyfit(np.log(x[ok]), np.log(y[ok]), 1)[0])


def main(argv=None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--quick", action="store_true", help="refine 0..1 only; the 1M targets stay null")
    ap.add_argument("--n", type=int, default=32, help="base mesh n × n (default 32, the case's own)")
    ap.add_argument("--levels", type=int, help="finest mesh.refine (default 3: 1.13M dofs; quick 1)")
    ap.add_argument("--method", default="active-set")
    ap.add_argument("--nested", action="store_true", help="solver.nested = true (coarse-level start)")
    ap.add_argument("--backend", default="auto", help="solver.backend (pardiso, cholmod, superlu; default auto)")
    ap.add_argument("--extra", default="24", help="extra unrefined meshes n for the scaling table (comma list)")
    ap.add_argument("--threads", type=int, help="MKL/OpenBLAS/OpenMP threads of the runs (default: as set, else 1); "
                                                "the 1M goal is for the whole machine: run.py passes its cores")
    ap.add_argument("--worker", nargs="*")
    args = ap.parse_args(argv)
    common.set_threads(args.threads)
    if args.worker:
        n, r, m, nest, backend, ext = args.worker
        res = worker(int(n), int(r), m, nest == "1", backend, ext == "1")
        common.emit(res)
        return res
    L = args.levels if args.levels is not None else (1 if args.quick else 3)
    info = common.machine()
    runs = []
    plan = [(int(e), 0) for e in args.extra.split(",") if e and not args.quick] + [(args.n, r) for r in range(L + 1)]
    for n, r in plan:
        t0 = time.perf_counter()
        try:
            res = _run(n, r, args, extended=False)
        except Exception as exc:
            print(f"n={n} refine={r}: failed: {str(exc)[-600:]}", flush=True)
            break
        res["wall_process"] = time.perf_counter() - t0
        runs.append(res)
        print(f"  n={n} refine={r}: {res['dofs']} dofs, {res['wall']:.1f} s, "
              f"peak {res['peak_rss_overall'] / 2**30:.2f} GB, force {res['force']:.12g} N", flush=True)
    runs.sort(key=lambda r: r["dofs"])
    print(f"# Demo case end to end ({CASE.name}, method {args.method}{', nested' if args.nested else ''}; "
          f"outputs: summary.json, fields.vtu, results.npz; figures off)")
    print(common.machine_line(info))
    stages = [s for s in STAGES if any(s in r["timings"] for r in runs)]
    gb = 2**30
    rows = [[r["dofs"], f"{r['n']}/{r['refine']}", r["constraints"], r["active"], r["iterations"],
             *[r["timings"].get(s, 0.0) for s in stages], r["wall"], r["cpu_total"], r["peak_rss_overall"] / gb]
            for r in runs]
    expo = ["exponent p (wall)", "", "", "", "", *[fit_exponent([r["dofs"] for r in runs],
                                                               [r["timings"].get(s, 0.0) for r in runs])
                                                  for s in stages],
            fit_exponent([r["dofs"] for r in runs], [r["wall"] for r in runs]),
            fit_exponent([r["dofs"] for r in runs], [r["cpu_total"] for r in runs]),
            fit_exponent([r["dofs"] for r in runs], [r["peak_rss_overall"] for r in runs])]
    print("\nwall seconds per stage (Result.timings), total wall and CPU seconds, peak RSS GB")
    print(common.table(["dofs", "n/refine", "constraints", "active", "iterations", *stages, "total s", "CPU s",
                        "peak GB"], rows + [[e if e is not None else "-" for e in expo]]))
    print("\npeak RSS GB per stage (VmHWM reset at each stage start) and CPU seconds per stage")
    print(common.table(["dofs", *[f"{s} GB" for s in stages], *[f"{s} CPU s" for s in stages]],
                       [[r["dofs"], *[r["peak_rss"].get(s, 0) / gb for s in stages],
                         *[r["cpu"].get(s, 0.0) for s in stages]] for r in runs]))
    nested_runs = [r for r in runs if r["n"] == args.n]
    forces = [r["force"] for r in nested_runs]
    rich = common.richardson(forces)
    print("\ncontact force at the nested levels (punch force magnitude, N)")
    print(common.table(["refine", "dofs", "force N", "difference to previous", "largest scaled KKT"],
                       [[r["refine"], r["dofs"], f"{r['force']:.12g}",
                         f"{r['force'] - nested_runs[i - 1]['force']:.4g}" if i else "-",
                         max((r["kkt_scaled"] or {"-": float("nan")}).values())]
                        for i, r in enumerate(nested_runs)]))
    print("Richardson: " + json.dumps(rich))
    finest = nested_runs[-1] if nested_runs else None
    targets = {}
    if args.quick or finest is None or finest["dofs"] < 900_000:
        why = ("--quick: no 1M-dof run" if args.quick else
               f"the finest run has {finest['dofs'] if finest else 0} dofs (< 900k)")
        for k, g in GOALS.items():
            targets[k] = common.target(None, g, None, None, reason=why)
    else:
        rnd = roundoff(finest, args)
        print("\nround-off: the finest level again with another thread count (PARDISO sums in another order)")
        print(common.table(["final solves", "threads", "force N", "active", "active set hash", "solve s"],
                           [[k.split("/")[0], k.split("/")[1], f"{v['force']:.12g}", v["active"], v["active_hash"][:10],
                             v["solve_s"]] for k, v in rnd["runs"].items()]))
        for mode, what in (("double", "double, 1 vs n threads"), ("extended", "extended, 1 vs n threads"),
                           ("double_vs_extended", "double vs extended (the double run's round-off error)")):
            print(f"  {what}: forces differ by {rnd[mode]['relative_difference']:.2g} "
                  f"({rnd[mode]['digits']:.1f} digits), same active set: {rnd[mode]['same_active_set']}")
        d = finest["dofs"]
        targets["seconds_1M_dofs"] = common.target(
            round(finest["wall"], 1), GOALS["seconds_1M_dofs"], "s wall, mesh + assembly + contact solve + outputs",
            "goal of issue 5", dofs=d, cpu_seconds=round(finest["cpu_total"], 1), method=args.method,
            nested=args.nested, stages={k: round(v, 2) for k, v in finest["timings"].items()})
        targets["peak_gb_1M_dofs"] = common.target(
            round(finest["peak_rss_overall"] / gb, 2), GOALS["peak_gb_1M_dofs"], "GB peak resident set of the process",
            "goal of issue 5", dofs=d)
        if "digits" in rich:
            targets["force_digits_1M_dofs"] = common.target(
                round(rich["digits"], 2), GOALS["force_digits_1M_dofs"],
                "significant digits of the 1M-dof force that agree with the Richardson extrapolation of the nested "
                "levels", "Richardson extrapolation", dofs=d, order=round(rich["order"], 3),
                extrapolated=rich["extrapolated"], force=finest["force"])
        elif rich.get("digits_vs_previous_level") is not None:
            # no asymptotic order: the best available statement is the agreement with the previous level
            targets["force_digits_1M_dofs"] = common.target(
                round(rich["digits_vs_previous_level"], 2), GOALS["force_digits_1M_dofs"],
                "significant digits of the 1M-dof force that agree with the previous nested level",
                "previous nested level (no Richardson extrapolation possible)", dofs=d, force=finest["force"],
                differences=rich["differences"], note=rich["reason"] + "; the value is -log10(|F_L - F_{L-1}|/|F_L|)")
        else:
            targets["force_digits_1M_dofs"] = common.target(None, GOALS["force_digits_1M_dofs"], None, None,
                                                            reason=rich.get("reason", ""))
        targets["force_digits_1M_dofs"]["roundoff"] = {m: rnd[m] for m in ("double", "extended", "double_vs_extended")}
    out = {"targets": targets, "runs": runs, "richardson": rich, "machine": info}
    print(json.dumps(out))
    return out


if __name__ == "__main__":
    main()
