"""Run the benchmark targets of issues 5 and 11 and end with ONE JSON line of all targets.

    python benchmarks/run.py            # full sizes (assembly at 32k triangles, solve at ~430k unknowns,
                                        # scaling to ~1M dofs)
    python benchmarks/run.py --quick    # small sizes, a few minutes (the 1M-dof targets stay null)

Each script prints its own table (peer, ratio, machine). The last line printed here is

    {"targets": {name: {"value": ..., "goal": ..., "unit": ..., "peer": ...}, ...}}

for assembly_speedup, contact_vs_linear, curve_vs_linear, speedup_vs_qp_peer, seconds_1M_dofs, peak_gb_1M_dofs,
force_digits_1M_dofs, cli_help_seconds and import_seconds (start-up, benchmarks/startup.py), plus
"contact_points": the decision of benchmarks/contact_points.py (accuracy per second of the two
``[solver] contact_points`` choices). A target that this run does not measure has value null and a "reason".
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import common  # noqa: E402

HERE = Path(__file__).resolve().parent
NAMES = ("assembly_speedup", "contact_vs_linear", "curve_vs_linear", "speedup_vs_qp_peer", "seconds_1M_dofs",
         "peak_gb_1M_dofs", "force_digits_1M_dofs", "cli_help_seconds", "import_seconds")
GOALS = {
    "assembly_speedup": (30.0, "x over scikit-fem (basis + assembly)"),
    "contact_vs_linear": (1.5, "contact solve seconds / (factorise + solve) seconds"),
    "curve_vs_linear": (3.0, "20-point curve seconds / (factorise + solve) seconds"),
    "speedup_vs_qp_peer": (20.0, "x over the fastest generic QP solver"),
    "seconds_1M_dofs": (60.0, "s, 1M-dof contact solve end to end"),
    "peak_gb_1M_dofs": (10.0, "GB peak memory, 1M-dof contact solve (issue 23)"),
    "force_digits_1M_dofs": (8.0, "significant digits of the contact force at 1M dofs"),
    "cli_help_seconds": (0.3, "s, shellcontact --help in a fresh process (median)"),
    "import_seconds": (0.5, "s, import shellcontact in a fresh process (median)"),
}
REASONS = {
    "contact_vs_linear": "benchmarks/contact_vs_linear.py did not run or failed",
    "curve_vs_linear": "benchmarks/curve.py did not run or failed",
    "speedup_vs_qp_peer": "benchmarks/qp_peers.py did not run or failed (peers: pip install -e '.[bench]')",
    "seconds_1M_dofs": "benchmarks/scale_1m.py did not run or failed",
    "peak_gb_1M_dofs": "benchmarks/scale_1m.py did not run or failed",
    "force_digits_1M_dofs": "benchmarks/force_digits.py did not run or failed",
    "cli_help_seconds": "benchmarks/startup.py failed",
    "import_seconds": "benchmarks/startup.py failed",
}


def run_script(name: str, args: list[str]) -> dict | None:
    """Run benchmarks/<name>.py, stream its table, return its last JSON line."""
    cmd = [sys.executable, str(HERE / f"{name}.py"), *args]
    print(f"\n$ {' '.join(cmd[1:])}", flush=True)
    t0 = time.perf_counter()
    proc = subprocess.run(cmd, capture_output=True, text=True, env=common.single_thread_env())
    lines = proc.stdout.strip().splitlines()
    for line in lines[:-1]:
        print(line)
    if proc.returncode != 0:
        print(proc.stderr[-3000:])
        print(f"({name} failed after {time.perf_counter() - t0:.0f} s)")
        return None
    print(f"({name}: {time.perf_counter() - t0:.0f} s)", flush=True)
    return json.loads(lines[-1])


def main(argv=None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--quick", action="store_true", help="small sizes (about 3 minutes)")
    args = ap.parse_args(argv)
    quick = ["--quick"] if args.quick else []
    info = common.machine()
    print(common.machine_line(info))
    targets = {n: common.target(None, GOALS[n][0], GOALS[n][1], None, reason=REASONS.get(n, "")) for n in NAMES}
    startup = run_script("startup", quick)  # start-up times against the peer commit: 1-2 minutes
    targets.update((startup or {}).get("targets") or {})
    asm = run_script("assembly", quick)
    if asm:
        targets["assembly_speedup"] = asm["targets"]["assembly_speedup"]
        targets["assembly_speedup"].pop("machine", None)
    else:
        targets["assembly_speedup"]["reason"] = "benchmarks/assembly.py failed"
    run_script("linear_solve", quick)
    run_script("scaling", quick)
    points = run_script("contact_points", quick)  # the default contact points (issue 13): no goal, its decision
    for name in ("contact_vs_linear", "curve", "qp_peers", "scale_1m", "force_digits"):
        if (HERE / f"{name}.py").exists():
            # the peers' comparisons run on one thread; the 1M-dof goals are for the whole machine
            extra = ["--threads", str(os.cpu_count() or 1)] if name in ("scale_1m", "force_digits") else []
            res = run_script(name, quick + extra)
            for k, v in ((res or {}).get("targets") or {}).items():
                if name == "force_digits" and k in targets:  # the demo case's figure stays alongside
                    v = {**v, "demo_case": targets[k]}
                targets[k] = v
    out = {"targets": targets, "contact_points": (points or {}).get("decision")}
    print(json.dumps(out))
    return out


if __name__ == "__main__":
    main()
