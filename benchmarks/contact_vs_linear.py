"""Target 3: the cost of a contact solve relative to one linear solve of the same stiffness.

    python benchmarks/contact_vs_linear.py             # paper panel (examples/paper_panel.toml), 112 × 112 mesh
    python benchmarks/contact_vs_linear.py --quick     # 40 × 40
    python benchmarks/contact_vs_linear.py --n 80 --methods active-set,dual

For each contact method, in a fresh subprocess: shellcontact.solve(case) on the demo case with
the mesh overridden to n × n (KKT tolerance from the case file, 1e-10), and then, on the same
reduced stiffness, one linear solve: factorise + solve the load vector with the same backend.
The ratio is (factorisation + contact solve) / (factorisation + linear solve); the goal of
issue 5 is ≤ 1.5 at ≥ 200k dofs.
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
GOAL = 1.5


def worker(n: int, method: str) -> dict:
    import scipy.sparse as sp

    from shellcontact import linalg
    from shellcontact.analysis import solve
    from shellcontact.case import load_case
    from shellcontact.supports import Reduction

    linalg.factorize(sp.identity(4, format="csr")).solve(np.ones(4))  # load the libraries outside the timings
    case = load_case(CASE, [f"mesh.nx={n}", f"mesh.nphi={n}"])
    t0 = time.perf_counter()
    res = solve(case, method=method)
    wall = time.perf_counter() - t0
    sol = res.solution
    red = Reduction.build(sol.space, case.supports)
    Ar, Fr = red.reduce_matrix(sol.A), red.reduce_vector(sol.F)
    t0 = time.perf_counter()
    fac = linalg.factorize(Ar, res.info.get("backend", "auto"))
    t_fact = time.perf_counter() - t0
    t0 = time.perf_counter()
    fac.solve(Fr)
    t_solve = time.perf_counter() - t0
    cs = res.contact.solution
    contact_cost = res.timings["factorization"] + res.timings["solve"]
    residuals = {k: float(v) for k, v in (cs.residuals or {}).items() if isinstance(v, (int, float))}
    return {"n": n, "method": method, "dofs": int(sol.space.ndofs), "unknowns": int(Ar.shape[0]),
            "constraints": int(res.contact.operator.B.shape[0]), "active": int(res.contact.active.sum()),
            "iterations": cs.iterations, "timings": res.timings, "wall": wall,
            "contact_cost": contact_cost, "linear_factorize": t_fact, "linear_solve": t_solve,
            "ratio": contact_cost / (t_fact + t_solve), "residuals": residuals}


def main(argv=None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--n", type=int, help="mesh n × n (default 112, quick 40)")
    ap.add_argument("--methods", default="active-set,dual,penalty")
    ap.add_argument("--worker", nargs="*")
    args = ap.parse_args(argv)
    if args.worker:
        res = worker(int(args.worker[0]), args.worker[1])
        common.emit(res)
        return res
    n = args.n or (40 if args.quick else 112)
    info = common.machine()
    runs = {}
    for m in args.methods.split(","):
        try:
            runs[m] = common.run_worker(Path(__file__), [str(n), m])
        except RuntimeError as exc:
            print(f"{m}: failed: {str(exc)[-500:]}")
    print(f"# Contact solve vs one linear solve ({CASE.name}, mesh {n}×{n})")
    print(common.machine_line(info))
    rows = [[m, r["dofs"], r["constraints"], r["active"], r["iterations"], r["timings"]["factorization"],
             r["timings"]["solve"], r["linear_factorize"] + r["linear_solve"], r["ratio"],
             max(r["residuals"].values()) if r["residuals"] else None] for m, r in runs.items()]
    print(common.table(["method", "dofs", "constraints", "active", "iterations", "factorize s", "contact solve s",
                        "linear (factorize + solve) s", "ratio", "largest KKT residual"], rows))
    best = min(runs.values(), key=lambda r: r["ratio"]) if runs else None
    target = common.target(
        round(best["ratio"], 3) if best else None, GOAL, "contact (factorise + solve) seconds / linear "
        "(factorise + solve) seconds", "one linear solve of the same stiffness",
        method=best["method"] if best else None, dofs=best["dofs"] if best else None,
        **({} if best else {"reason": "every contact method failed"}))
    out = {"targets": {"contact_vs_linear": target}, "runs": runs, "machine": info}
    print(json.dumps(out))
    return out


if __name__ == "__main__":
    main()
