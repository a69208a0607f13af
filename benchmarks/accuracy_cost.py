"""What stating the accuracy costs (issue 22 item 4): ``run --estimate`` against a plain ``run``, and
``run --accuracy TOL`` against a plain run at the finest level it reached.

    python benchmarks/accuracy_cost.py                          # the demo case (paper panel), 3 repeats
    python benchmarks/accuracy_cost.py --accuracy 1e-3 --max-levels 2   # also --accuracy (refine 2: 290k dofs)

Each command is the command line in a fresh process (wall time, best of ``--repeat``; imports included,
figures and report skipped), one thread. Prints a table and one JSON line.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
ENV = {**os.environ, "OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1"}


def run(case: str, *extra: str) -> tuple[float, dict]:
    """Wall seconds of ``shellcontact run CASE EXTRA`` and its summary."""
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "out"
        t0 = time.perf_counter()
        subprocess.run([sys.executable, "-m", "shellcontact.cli", "run", case, "-o", str(out), "-q", "--no-figures",
                        "--no-report", *extra], env=ENV, check=True)
        seconds = time.perf_counter() - t0
        return seconds, json.loads((out / "summary.json").read_text())


def best(repeat: int, case: str, *extra: str) -> tuple[float, dict]:
    runs = [run(case, *extra) for _ in range(repeat)]
    return min(r[0] for r in runs), runs[0][1]


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--case", default=str(ROOT / "examples" / "paper_panel.toml"))
    p.add_argument("--repeat", type=int, default=3)
    p.add_argument("--accuracy", type=float, help="also time --accuracy TOL and a plain run at the level reached")
    p.add_argument("--max-levels", type=int, default=2)
    a = p.parse_args()
    plain, s = best(a.repeat, a.case)
    est, se = best(a.repeat, a.case, "--estimate")
    out = {"case": a.case, "dofs": s["dofs"], "plain_s": plain, "estimate_s": est, "estimate_ratio": est / plain,
           "estimate_levels": [lv["dofs"] for lv in se["refinement"]["levels"]]}
    print(f"{a.case}: {s['dofs']} dofs; plain run {plain:.2f} s, --estimate {est:.2f} s "
          f"({est / plain:.2f}x; levels {out['estimate_levels']} dofs)")
    if a.accuracy is not None:
        acc, sa = run(a.case, "--accuracy", str(a.accuracy), "--max-levels", str(a.max_levels))
        refine = sa["refinement"]["levels"][0]["mesh"]["refine"]
        uniform, su = run(a.case, "--set", f"mesh.refine={refine}")
        unmet = [k for k, e in sa["accuracy"].items() if not e["met"]]
        out.update(accuracy=a.accuracy, accuracy_s=acc, uniform_s=uniform, accuracy_ratio=acc / uniform,
                   reached_refine=refine, reached_dofs=su["dofs"], stopped=sa["refinement"]["stopped"], unmet=unmet)
        print(f"--accuracy {a.accuracy:g}: {acc:.2f} s, finest mesh.refine = {refine} ({su['dofs']} dofs); a plain run "
              f"there {uniform:.2f} s ({acc / uniform:.2f}x); stopped: {sa['refinement']['stopped']}; "
              f"not met: {', '.join(unmet) or 'none'}")
    print(json.dumps(out))


if __name__ == "__main__":
    main()
