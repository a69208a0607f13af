"""docs/scaling.md, FETI: how exactly the shell's stiffness holds the rigid motions (a floating subdomain's kernel).

    python benchmarks/floating_kernel.py            # the paper's panel, 4 × 4, 8 × 8, 12 × 12, no supports

The unsupported stiffness of the panel, equilibrated (unit diagonal), has as many zero eigenvalues as rigid
motions the space P2 × P2 × Argyris holds exactly; the others show as small eigenvalues that fall with h.
Prints the eight smallest eigenvalues (dense: small meshes only).
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent


def main(sizes=(4, 8, 12)) -> None:
    from shellcontact.analysis.discretization import discretize
    from shellcontact.problem.case import load_case

    for n in sizes:
        case = load_case(ROOT / "examples" / "paper_panel.toml", [f"mesh.nx={n}", f"mesh.nphi={n}"])
        A = discretize(case).A.toarray()  # the full stiffness: no support is applied to it
        s = 1.0 / np.sqrt(np.diag(A))
        ev = np.linalg.eigvalsh(s[:, None] * A * s[None, :])
        print(f"{n:3d} × {n:<3d} {A.shape[0]:6d} dofs: " + " ".join(f"{v:9.1e}" for v in ev[:8]))


if __name__ == "__main__":
    main(tuple(int(a) for a in sys.argv[1:]) or (4, 8, 12))
