"""Issue 27: what 4, 8 and 16 nodes of 24 GB would hold with the mumps backend, from the per-rank figures.

    python benchmarks/mumps_nodes.py                      # the demo case (src/shellcontact/cases/paper_panel.toml)
    python benchmarks/mumps_nodes.py --linear             # the same mesh without the punch
    python benchmarks/mumps_nodes.py --share 1.29 --node-gb 24

An extrapolation, not a measurement: ``sizing.estimate`` (checked against measured peaks, 10k – 1.12M
dofs: 0.94 – 1.15) gives the one-process peak of the paper's panel at n × n elements and its factor part F
(PARDISO's). Under ``mpiexec -n p`` with the mumps backend rank 0 keeps everything but the factors and holds
its share of MUMPS's factors; the other ranks hold their share alone:

    rank 0 = peak − F + share · F / p,   rank k = share · F / p + 0.5 GB (interpreter, MPI, MUMPS's buffers)

``share`` is the sum over the ranks of MUMPS's factor memory (INFO(16)) over PARDISO's factor bytes, measured
by benchmarks/mumps_ranks.py (276k unknowns: 850 MB on 1 rank, 534 + 493 MB on 2, against PARDISO's 97.3M
factor entries at 11.5 bytes, 1.12 GB: 0.76 and 0.92; 1.11M unknowns: 3 911 MB on 1 rank, 2 568 + 2 197 MB on
2, against 321.1M entries, 3.69 GB: 1.06 and 1.29). The default is the largest, 1.29 (2 ranks at 1.11M: the
share grows with the size and the ranks; more ranks' overhead is not measured here). Prints, per node count,
the largest model whose every rank fits a node.
"""

from __future__ import annotations

import argparse
from pathlib import Path

CASE = Path(__file__).resolve().parent.parent / "src" / "shellcontact" / "cases" / "paper_panel.toml"


def per_rank(n: int, linear: bool, share: float, ranks: int) -> tuple[float, float, float]:
    """(dofs, rank 0 GB, other ranks GB) of the n × n panel on ``ranks`` ranks."""
    import shellcontact
    from shellcontact.contact.punches import place_punches
    from shellcontact.problem.sizing import estimate

    case = shellcontact.load_case(CASE, [f"mesh.nx={n}", f"mesh.nphi={n}"])
    punches = [] if linear else place_punches(case.punches, case.shell, case.units)
    est = estimate(case, punches, backend="pardiso")
    factor = est.parts["factor"]
    rank0 = est.bytes - factor + share * factor / ranks
    other = share * factor / ranks + 0.5e9
    return est.dofs, rank0 / 1e9, other / 1e9


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--linear", action="store_true", help="no punch: the linear model")
    p.add_argument("--share", type=float, default=1.29)
    p.add_argument("--node-gb", type=float, default=24.0)
    args = p.parse_args()
    print("| nodes (ranks) | largest N (dofs) | rank 0 GB | each other rank GB |")
    print("|---|---|---|---|")
    for ranks in (2, 4, 8, 16):
        best = None
        for n in range(64, 2049, 16):
            dofs, r0, rk = per_rank(n, args.linear, args.share, ranks)
            if max(r0, rk) > args.node_gb:
                break
            best = (dofs, r0, rk)
        if best:
            print(f"| {ranks} | {best[0] / 1e6:.2f} M | {best[1]:.1f} | {best[2]:.1f} |")


if __name__ == "__main__":
    main()
