"""The memory estimate (shellcontact.problem.sizing) against the peak resident set of real runs, and the fill.

    python benchmarks/memory.py                  # 10k → 281k dofs (about a minute, 2 GB)
    python benchmarks/memory.py --sizes 32/3     # n/refine pairs of the paper panel (1.12M dofs: ~8 GB)

Every size runs, in a fresh subprocess, ``sizing.estimate`` and then ``shellcontact.solve`` on
src/shellcontact/cases/paper_panel.toml with ``mesh.nx = mesh.nphi = n`` and ``mesh.refine = r``
(contact, active set, PARDISO), and reports the process's peak resident set
(``resource.getrusage(RUSAGE_SELF).ru_maxrss``). Then (after the peak is taken) it factorises the
reduced stiffness alone with each installed backend and reports nnz(L)/(n log₂ n), the constant of
``sizing.FILL``. Prints a Markdown table.
"""

from __future__ import annotations

import argparse
import json
import math
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
CASE = ROOT / "src" / "shellcontact" / "cases" / "paper_panel.toml"
SIZES = ("24/0", "32/0", "64/0", "32/1", "96/0", "64/1", "32/2")

CHILD = """
import json, math, resource, sys
from shellcontact.problem.case import load_case
from shellcontact.analysis.pipeline import solve
from shellcontact.contact.punches import place_punches
from shellcontact import sizing
n, r = map(int, sys.argv[1].split("/"))
case = load_case(sys.argv[2], sets=[f"mesh.nx={n}", f"mesh.nphi={n}", f"mesh.refine={r}"])
est = sizing.estimate(case, place_punches(case.punches, case.shell))
res = solve(case)
peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024
Ar = res.discretization.Ar
out = {"size": sys.argv[1], "dofs": res.solution.space.ndofs, "nnz": int(res.discretization.A.nnz),
       "rows": int(res.contact.operator.m), "estimate": est.bytes, "peak": peak, "est_dofs": est.dofs,
       "est_nnz": est.nnz, "est_rows": est.contact_rows, "fill": {}}
del res
from shellcontact.linalg import available_backends, factorize
for b in available_backends():
    if b == "superlu" and Ar.shape[0] > 100_000:
        continue
    f = factorize(Ar, b)
    nl = f.info()["factor_nnz"]
    out["fill"][b] = nl / (Ar.shape[0] * math.log2(Ar.shape[0]))
    f.free()
print(json.dumps(out))
"""


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--sizes", nargs="+", default=SIZES, help="n/refine pairs")
    args = ap.parse_args()
    rows = []
    for size in args.sizes:
        proc = subprocess.run([sys.executable, "-c", CHILD, size, str(CASE)], capture_output=True, text=True)
        if proc.returncode:
            print(proc.stderr, file=sys.stderr)
            continue
        rows.append(json.loads(proc.stdout.strip().splitlines()[-1]))
        print(json.dumps(rows[-1]), file=sys.stderr)
    backends = sorted({b for r in rows for b in r["fill"]})
    print("| n/refine | dofs | nnz(A) | contact rows (estimated) | estimate GB | peak RSS GB | estimate / peak | "
          + " | ".join(f"{b} nnz(L)/(n log₂n)" for b in backends) + " |")
    print("|" + "---|" * (7 + len(backends)))
    for r in rows:
        assert r["est_dofs"] == r["dofs"] and r["est_nnz"] == r["nnz"], r  # the counts are exact
        fills = " | ".join(f"{r['fill'][b]:.1f}" if b in r["fill"] else "–" for b in backends)
        print(f"| {r['size']} | {r['dofs']} | {r['nnz']} | {r['rows']} ({r['est_rows']:.0f}) | "
              f"{r['estimate'] / 1e9:.3g} | {r['peak'] / 1e9:.3g} | {r['estimate'] / r['peak']:.2f} | {fills} |")
    ratios = [r["estimate"] / r["peak"] for r in rows]
    if ratios:
        print(f"\nestimate / peak: {min(ratios):.2f} – {max(ratios):.2f} (geometric mean "
              f"{math.exp(sum(map(math.log, ratios)) / len(ratios)):.2f})")


if __name__ == "__main__":
    main()
