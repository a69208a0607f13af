"""Does a definition of the paper panel's interior contact converge? (docs/outputs.md, issue 22 item 4)

Per ``mesh.refine`` level: the rim's interior force and its pressure where the shell carries, the element-level
carrying area (elements inside the rim, more than three element widths from it, with a carrying row) and the
interior force over it, and the gaps of the constraint rows inside the rim.

Run: ``OPENBLAS_NUM_THREADS=1 .venv/bin/python benchmarks/panel_interior.py 0 1 2`` (refine 2: 2.7 GB).
"""

from __future__ import annotations

import logging
import sys
from pathlib import Path

import numpy as np
from matplotlib.path import Path as Polygon

import shellcontact
from shellcontact.contact.rim import _nearest_segment
from shellcontact.problem.case import load_case

CASE = Path(__file__).resolve().parents[1] / "examples" / "paper_panel.toml"


def interior_at(refine: int) -> str:
    res = shellcontact.solve(load_case(CASE, [f"mesh.refine={refine}"]))
    c, m = res.contact, res.solution.space.mesh
    op, rim, outline = c.operator, c.rim[0], c.rim_lines[0][0]  # the panel's rim: one closed curve in (x, s)
    lam, rows = np.asarray(c.Lambda), op.rows(0)
    carrying = np.zeros(m.nvertices, bool)
    vertex_rows = rows[op.vertex[rows] >= 0]
    carrying[op.vertex[vertex_rows][lam[vertex_rows] > 0]] = True
    centroid = m.p[:, m.t].mean(axis=1).T
    area = 0.5 * np.abs(m._det())
    _, _, depth = _nearest_segment(centroid, outline[:-1], outline[1:])
    deep = Polygon(outline).contains_points(centroid) & (depth > 3.0 * np.sqrt(area))
    element_area = float(area[deep & carrying[m.t].any(axis=0)].sum())
    radius = res.solution.shell.radius
    inside = Polygon(outline).contains_points(np.stack([op.x[rows], radius * op.phi[rows]], axis=1))
    gap = c.gap[rows][inside]
    per_area = rim["interior_force"] / element_area if element_area > 0 else 0.0
    return (f"refine {refine}: rim force {rim['force']:.1f} N, length {rim['length']:.5f} m; interior force "
            f"{rim['interior_force']:.1f} N, pressure where it carries {rim['interior_pressure']:.4g} Pa over "
            f"{rim['carrying_area']:.4g} m2; element-level carrying area {element_area:.4g} m2, force over it "
            f"{per_area:.4g} Pa; rows inside the rim {inside.sum()}: gap median {np.median(gap):.3g} m, max "
            f"{gap.max():.3g} m, carrying {int(np.count_nonzero(lam[rows][inside] > 0))}")


if __name__ == "__main__":
    logging.getLogger("shellcontact").setLevel(logging.ERROR)
    for level in sys.argv[1:] or ["0", "1", "2"]:
        print(interior_at(int(level)), flush=True)
