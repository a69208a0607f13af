"""Meshes: structured patterns, grading, nested refinement, unstructured meshes read with meshio."""

from __future__ import annotations

import dataclasses
import math

import meshio
import numpy as np
import pytest
from scipy.spatial import Delaunay

import shellcontact as sc
from shellcontact.errors import InputError
from shellcontact.shell.geometry import Shell
from shellcontact.shell.material import Isotropic
from shellcontact.shell.mesh import PATTERNS, graded_nodes, structured

SHELL = Shell(radius=2.0, length=3.0, thickness=0.05, material=Isotropic(1e5, 0.3), alpha=0.2, beta=1.4)


@pytest.mark.parametrize("pattern", PATTERNS)
def test_patterns_cover_the_domain_with_positive_triangles(pattern):
    m = structured(SHELL, 5, 4, pattern)
    p, t = m.p, m.t
    d1, d2 = p[:, t[1]] - p[:, t[0]], p[:, t[2]] - p[:, t[0]]
    area = 0.5 * np.abs(d1[0] * d2[1] - d1[1] * d2[0])
    assert np.all(area > 0)
    assert area.sum() == pytest.approx(SHELL.length * (SHELL.s_max - SHELL.s_min), rel=1e-13)
    assert m.nelements == (4 if pattern == "crossed" else 2) * 5 * 4
    # every boundary edge of the rectangle is found
    for edge, n in (("x_min", 4), ("x_max", 4), ("phi_min", 5), ("phi_max", 5)):
        assert m.edge_facets(edge).size == n


def test_grading_shrinks_elements_toward_the_focus_by_the_ratio():
    x = graded_nodes(0.0, 1.0, 20, focus=[0.3], ratio=8.0)
    assert np.any(np.isclose(x, 0.3, atol=1e-15))
    h = np.diff(x)
    i = int(np.argmin(np.abs(x - 0.3)))
    assert h[i - 1] == pytest.approx(h[i], rel=0.5)  # both sides graded toward the focus
    for side in (x <= 0.3 + 1e-15, x >= 0.3 - 1e-15):  # each side of the focus is graded to the ratio
        hs = np.diff(x[side])
        assert hs.max() / hs.min() == pytest.approx(8.0, rel=1e-9)
    assert np.all(h > 0)
    # required lines become nodes
    y = graded_nodes(0.0, 1.0, 7, required=[0.123, 0.9])
    assert np.any(np.isclose(y, 0.123)) and np.any(np.isclose(y, 0.9))


def test_refinement_is_nested():
    m = structured(SHELL, 3, 3, "alternate")
    f = m.refined(2)
    assert f.nelements == 16 * m.nelements
    coarse = {tuple(np.round(c, 12)) for c in m.p.T}
    fine = {tuple(np.round(c, 12)) for c in f.p.T}
    assert coarse <= fine


def _unstructured_rectangle(shell: Shell, n: int, seed: int = 1) -> tuple[np.ndarray, np.ndarray]:
    """A Delaunay triangulation of jittered interior points and uniform boundary points in (x, s)."""
    rng = np.random.default_rng(seed)
    x0, x1, s0, s1 = shell.x_min, shell.x_max, shell.s_min, shell.s_max
    bx, bs = np.linspace(x0, x1, n + 1), np.linspace(s0, s1, n + 1)
    boundary = np.vstack([
        np.c_[bx, np.full_like(bx, s0)], np.c_[bx, np.full_like(bx, s1)],
        np.c_[np.full_like(bs[1:-1], x0), bs[1:-1]], np.c_[np.full_like(bs[1:-1], x1), bs[1:-1]],
    ])
    gx, gs = np.meshgrid(bx[1:-1], bs[1:-1])
    h = np.array([(x1 - x0) / n, (s1 - s0) / n])
    inner = np.c_[gx.ravel(), gs.ravel()] + rng.uniform(-0.2, 0.2, (gx.size, 2)) * h
    pts = np.vstack([boundary, inner])
    return pts, Delaunay(pts).simplices


@pytest.mark.parametrize("suffix", [".vtk", ".msh"])
def test_unstructured_mesh_file_solves_the_scordelis_lo_roof(tmp_path, examples_dir, suffix):
    """A meshio-read Delaunay mesh gives the benchmark value like the structured one."""
    case = sc.load_case(examples_dir / "scordelis_lo.toml")
    pts, tri = _unstructured_rectangle(case.shell, 12)
    path = tmp_path / f"roof{suffix}"
    fmt = {".vtk": "vtk", ".msh": "gmsh22"}[suffix]
    meshio.write(path, meshio.Mesh(np.c_[pts, np.zeros(len(pts))], [("triangle", tri)]), file_format=fmt)
    case.mesh = dataclasses.replace(case.mesh, file=str(path))
    res = sc.solve(case)
    assert res.solution.space.mesh.nelements == len(tri)
    uz = res.summary()["probes"][0]["displacement"][2]
    assert uz == pytest.approx(-0.3006, rel=0.01)  # the converged value; 12×12-ish unstructured mesh
    # nested refinement of a file mesh
    case.mesh = dataclasses.replace(case.mesh, refine=1)
    uz1 = sc.solve(case).summary()["probes"][0]["displacement"][2]
    assert abs(uz1 + 0.3006) < abs(uz + 0.3006)


def test_mesh_file_outside_the_domain_is_rejected(tmp_path, examples_dir):
    case = sc.load_case(examples_dir / "scordelis_lo.toml")
    pts, tri = _unstructured_rectangle(case.shell, 4)
    pts = pts * 2.0  # in (x, φ-degrees)-like wrong units
    path = tmp_path / "wrong.vtk"
    meshio.write(path, meshio.Mesh(np.c_[pts, np.zeros(len(pts))], [("triangle", tri)]))
    case.mesh = dataclasses.replace(case.mesh, file=str(path))
    with pytest.raises(InputError, match="mesh"):
        sc.solve(case)


def test_crossed_full_cylinder_is_periodic_and_axisymmetric_under_pressure():
    d = {
        "shell": {"radius": 1.0, "length": 2.0, "full": True, "thickness": 0.02, "young": 1e6, "poisson": 0.3},
        "supports": {"x_min": "clamped", "x_max": "clamped"},
        "mesh": {"nx": 8, "nphi": 8, "pattern": "crossed"},
        "loads": {"normal": 1.0},
        "probes": [{"x": 0.0, "phi": p} for p in (0.0, 22.5, 45.0, 200.0, 359.0)],
    }
    w = [p["w"] for p in sc.solve(sc.case_from_dict(d)).summary()["probes"]]
    assert np.ptp(w) < 1e-3 * abs(np.mean(w))
    assert np.mean(w) == pytest.approx(1.0 * 1.0**2 * (1 - 0.09) / (1e6 * 0.02), rel=0.02)  # plane strain
    assert math.isfinite(np.mean(w))


@pytest.mark.parametrize("nx", [20, 39, 40, 41])
def test_mirrored_node_lines_give_a_mesh_that_is_its_own_mirror_image(nx):
    """Node lines mirrored about the middle (a saddle pair at ±3.5 m with faces ±0.15 m on a 10 m vessel) give
    equal counts in mirror segments and an even total, so the "alternate" triangles map onto themselves
    (``ShellMesh.x_mirror``, checked on the triangles, not on the counts): before, nx = 40 and 20 gave 39 and 21
    columns, which the mirror does not map onto themselves."""
    shell = Shell(radius=1.0, length=10.0, thickness=0.01, material=Isotropic(2e11, 0.3), full=True)
    xs = graded_nodes(-5.0, 5.0, nx, required=[-3.65, -3.35, 3.35, 3.65])
    assert (len(xs) - 1) % 2 == 0
    assert np.allclose(xs, -xs[::-1], atol=1e-12)
    mesh = structured(shell, len(xs) - 1, 8, "alternate", x_nodes=xs, s_nodes=np.linspace(0.0, 2 * np.pi, 9))
    assert mesh.x_mirror() is not None
    odd = structured(shell, len(xs) - 2, 8, "alternate", x_nodes=np.linspace(-5.0, 5.0, len(xs) - 1),
                     s_nodes=np.linspace(0.0, 2 * np.pi, 9))
    assert odd.x_mirror() is None  # the check can fail: an odd count is not its own mirror image


def test_a_count_without_node_lines_is_kept_as_given():
    assert len(graded_nodes(0.0, 1.0, 15)) == 16
