"""The size guard (issue 12, item 3): counts before building, refusal before allocation."""

from __future__ import annotations

import subprocess
import sys
import time
import tomllib
from pathlib import Path

import pytest

from shellcontact.analysis.discretization import discretize
from shellcontact.analysis.pipeline import solve
from shellcontact.cli import main
from shellcontact.contact.punches import place_punches
from shellcontact.errors import InputError
from shellcontact.problem import sizing
from shellcontact.problem.case import case_from_dict
from shellcontact.studies.sweeps import parse_values, sweep

ROOT = Path(__file__).resolve().parent.parent
PANEL = ROOT / "examples" / "paper_panel.toml"
HUGE_REFINE = "1234567890123456789012345678901234567890"


def _case(**mesh):
    raw = tomllib.loads(PANEL.read_text())
    raw["mesh"] = {**raw["mesh"], **mesh}
    return case_from_dict(raw)


@pytest.mark.parametrize("mesh", [
    {"nx": 6, "nphi": 5},
    {"nx": 4, "nphi": 4, "refine": 1},
    {"nx": 5, "nphi": 4, "pattern": "crossed"},
    {"nx": 4, "nphi": 6, "pattern": "right", "x_lines": [0.13, -0.31]},
], ids=["graded", "refined", "crossed", "lines"])
@pytest.mark.parametrize("points", ["vertices", "vertices+midpoints"])
def test_counts_before_building_equal_the_built_ones(mesh: dict, points: str) -> None:
    """Vertices, triangles, edges, dofs, stiffness nonzeros and contact rows from the MeshSpec alone
    are those of the mesh, space, stiffness and contact operator built afterwards."""
    case = _case(**mesh)
    case = case_from_dict({**case.raw, "solver": {"contact_points": points}})
    est = sizing.estimate(case, place_punches(case.punches, case.shell))
    d = discretize(case, points)
    mesh_ = d.space.mesh
    assert (est.vertices, est.elements, est.facets) == (mesh_.nvertices, mesh_.nelements, mesh_.nfacets)
    assert est.dofs == d.space.ndofs
    assert est.nnz == d.A.nnz
    assert est.contact_rows == d.operator.m


def test_refuses_a_40_digit_refine_at_once(tmp_path: Path) -> None:
    """A 40-digit refine is beyond a 64-bit integer (the schema refuses it); refine = 30 fits one and is
    refused by the memory estimate, before anything is built."""
    t0 = time.perf_counter()
    r = subprocess.run([sys.executable, "-m", "shellcontact.cli", "run", str(PANEL), "-o", str(tmp_path / "o"),
                        "--set", f"mesh.refine={HUGE_REFINE}"], capture_output=True, text=True, timeout=60)
    assert r.returncode == 2 and "mesh.refine" in r.stderr and "Traceback" not in r.stderr, r.stderr
    r = subprocess.run([sys.executable, "-m", "shellcontact.cli", "run", str(PANEL), "-o", str(tmp_path / "o"),
                        "--set", "mesh.refine=30"], capture_output=True, text=True, timeout=60)
    assert r.returncode == 2, r.stderr
    assert "mesh.refine" in r.stderr and "memory available" in r.stderr and "--max-memory" in r.stderr
    assert "Traceback" not in r.stderr
    with pytest.raises(InputError, match="mesh.refine"):
        t1 = time.perf_counter()
        solve(_case(refine=30))
    assert time.perf_counter() - t1 < 0.5  # in-process: no interpreter start-up
    assert not (tmp_path / "o").exists() or not any((tmp_path / "o").iterdir())
    assert time.perf_counter() - t0 < 60


def test_max_memory_overrides_the_available_memory(tmp_path: Path, capsys) -> None:
    case = _case(nx=8, nphi=8)
    need = sizing.estimate(case, place_punches(case.punches, case.shell)).bytes
    with pytest.raises(InputError) as exc:
        solve(case, max_memory=need / 2)
    assert exc.value.field == "mesh.nx" and "max_memory" in exc.value.message
    assert solve(case, max_memory=f"{2 * need / 1e6:.0f}M").contact is not None
    code = main(["run", str(PANEL), "-o", str(tmp_path / "o"), "--max-memory", "10M", "--no-figures"])
    assert code == 2 and "mesh.nphi" in capsys.readouterr().err
    code = main(["run", str(PANEL), "-o", str(tmp_path / "o"), "--max-memory", "lots"])
    assert code == 2 and "--max-memory" in capsys.readouterr().err


def test_parse_memory() -> None:
    assert sizing.parse_memory("8G") == 8e9
    assert sizing.parse_memory("512 MiB") == 512 * 2**20
    assert sizing.parse_memory(1e9) == 1e9
    for bad in ("", "8Q", "-1G", "0", "nan", True):
        with pytest.raises(InputError):
            sizing.parse_memory(bad)


def test_sweep_of_1e8_steps_is_refused_before_any_list() -> None:
    t0 = time.perf_counter()
    with pytest.raises(InputError) as exc:
        parse_values("0:1e-3:100000000")
    assert time.perf_counter() - t0 < 0.5
    assert exc.value.field == "--values" and "steps" in exc.value.message
    assert len(parse_values("0:1e-3:11")) == 11
    with pytest.raises(InputError, match="--values"):
        sweep(_case(nx=4, nphi=4), "punch.0.indentation", range(10**8))


def test_sweep_cli_refuses_1e8_steps(tmp_path: Path, capsys) -> None:
    t0 = time.perf_counter()
    code = main(["sweep", str(PANEL), "--param", "punch.0.indentation", "--values", "0:1e-3:100000000",
                 "-o", str(tmp_path / "s")])
    assert code == 2 and "--values" in capsys.readouterr().err
    assert time.perf_counter() - t0 < 1.0


def test_convergence_refuses_a_finest_level_that_cannot_fit(tmp_path: Path, capsys) -> None:
    code = main(["convergence", str(PANEL), "--levels", "40", "-o", str(tmp_path / "c")])
    assert code == 2
    err = capsys.readouterr().err
    assert "--levels" in err and "refine 39" in err


@pytest.mark.parametrize("path", sorted((ROOT / "examples").glob("*.toml")), ids=lambda p: p.stem)
def test_counts_on_every_example(path: Path) -> None:
    """Exact dofs and stiffness nonzeros; contact rows exact, or over by the seam of a full cylinder
    whose zone wraps around (the vertices at φ = 0 and 360° are one constraint point)."""
    from shellcontact.problem.case import load_case

    case = load_case(path)
    est = sizing.estimate(case, place_punches(case.punches, case.shell))
    d = discretize(case, case.solver.contact_points)
    assert est.dofs == d.space.ndofs and est.nnz == d.A.nnz
    rows = d.operator.m if d.operator is not None else 0
    seam = len(set(d.space.mesh.p[0, d.space.mesh.edge_vertices("phi_min")])) if case.shell.full else 0
    assert rows <= est.contact_rows <= rows + seam
