"""curves.solve_family: points of one family on one mesh and factorisation give the Results of solving each
case on its own (the independent reference: a fresh mesh, assembly and factorisation per case, no warm
start), to round-off with a warm start and bit for bit without; family_key keeps apart what must not share."""

from __future__ import annotations

import meshio
import numpy as np
import pytest

from shellcontact.analysis.pipeline import solve
from shellcontact.errors import InputError
from shellcontact.inputs.overrides import apply_overrides
from shellcontact.problem.case import case_from_dict
from shellcontact.shell.mesh import structured
from shellcontact.studies.curves import family_key, solve_family

#: fields and forces of a warm-started point against the lone solve, relative to their size: both are the
#: KKT point of the same strictly convex QP at tolerance 1e-10 (measured differences ~1e-13)
RTOL = 1e-8


def panel(punch: dict, **solver) -> dict:
    """The paper's panel (clamped 60° sector, sphere above the crown), coarse."""
    return {
        "shell": {"radius": 1.0, "length": 1.0, "angle": [60.0, 120.0], "thickness": 0.01, "young": 2.1e11,
                  "poisson": 0.3},
        "mesh": {"nx": 10, "nphi": 10},
        "punch": [{"shape": "sphere", "center": [0.0, 0.0, 3.5], "radius": 2.0, "direction": [0.0, 0.0, -1.0],
                   "zone": {"x": [-0.2, 0.2], "phi": [78.0, 102.0]}, **punch}],
        "solver": {"tolerance": 1e-10, **solver},
        "probes": [{"x": 0.0, "phi": 90.0}],
    }


def cases(raw: dict, key: str, values) -> list:
    return [case_from_dict(apply_overrides(raw, {key: v})) for v in values]


def assert_same(family, alone, rtol: float | None) -> None:
    """Displacements, contact forces, travels and the summary's figures of each point agree (rtol None: bit
    for bit)."""
    assert len(family) == len(alone)
    for a, b in zip(family, alone):
        sa, sb = a.summary(), b.summary()
        ca, cb = a.contact, b.contact
        if rtol is None:
            assert np.array_equal(a.solution.U, b.solution.U)
            assert np.array_equal(ca.Lambda, cb.Lambda)
            for k in ("energy", "max_abs_w", "probes", "stresses", "kkt", "contact"):
                assert sa[k] == sb[k], k
            continue
        scale = np.abs(b.solution.U).max()
        assert np.abs(a.solution.U - b.solution.U).max() <= rtol * scale
        assert np.abs(ca.Lambda - cb.Lambda).max() <= rtol * np.abs(cb.Lambda).max()
        assert np.array_equal(ca.active, cb.active)
        for ea, eb in zip(sa["contact"], sb["contact"]):
            assert ea["force_magnitude"] == pytest.approx(eb["force_magnitude"], rel=rtol)
            assert ea["area"] == pytest.approx(eb["area"], rel=rtol)
            if eb.get("punch_travel") is not None:
                assert ea["punch_travel"] == pytest.approx(eb["punch_travel"], rel=rtol)
            # the contact zone and the rim: made when first asked for on a curve's points (lazily)
            assert ea["zone"]["area"] == pytest.approx(eb["zone"]["area"], rel=1e-6)
            assert ("rim" in ea) == ("rim" in eb)
        assert sa["energy"] == pytest.approx(sb["energy"], rel=rtol)
        assert sa["probes"][0]["w"] == pytest.approx(sb["probes"][0]["w"], rel=rtol)


CURVES = {
    "indentation": ({"indentation": 1e-3}, "punch.0.indentation", [1e-3, 4e-3, 7e-3, 1e-2]),
    "force": ({"force": 1e4}, "punch.0.force", [2e4, 6e4, 1.2e5, 2e5]),
}


@pytest.mark.parametrize("substructure", [False, True], ids=["plain", "bordered"])
@pytest.mark.parametrize("curve", CURVES)
def test_a_curve_equals_its_points_solved_alone(curve, substructure):
    punch, key, values = CURVES[curve]
    points = cases(panel(punch, substructure=substructure), key, values)
    assert len({family_key(c) for c in points}) == 1
    alone = [solve(c) for c in points]
    forces = [r.summary()["contact"][0]["force_magnitude"] for r in alone]
    assert np.all(np.diff(forces) > 0) and forces[0] > 0  # a real curve: every point in contact, each deeper
    seen = set()
    warm = list(solve_family(points, progress=lambda i, it, res: seen.add(i)))
    assert seen == set(range(len(points)))  # every point reports its solver's iterations
    # a force curve's points differ in P only: their final checks share block solves (screening.solve_screened_curve)
    assert all(("curve" in r.contact.solution.info) == (curve == "force") for r in warm)
    assert_same(warm, alone, RTOL)
    cold = list(solve_family(points, warm_start=False))
    assert_same(cold, alone, None)
    # A alone serves every point; A bordered by the screened rows serves the points with those rows: all
    # of a force curve (the punch stays where it first touches), none of an indentation curve (∇Z at
    # the contact points, the entries of B, turns as the sphere moves) — unless the warm-started family
    # borders A by the Cartesian displacement rows of the contact points, which serve every B
    assert warm[-1].info["family"]["factorizations"] == 1
    assert cold[-1].info["family"]["factorizations"] == (len(values) if substructure and curve == "indentation" else 1)


@pytest.mark.parametrize("substructure", [False, True], ids=["plain", "bordered"])
def test_punch_positions_on_one_mesh_file_are_one_family(tmp_path, substructure):
    """Moving the sphere along the axis changes its rows B and gaps G, not the mesh read from a file."""
    raw = panel({"indentation": 5e-3}, substructure=substructure)
    first = case_from_dict(raw)
    m = structured(first.shell, 10, 10).mesh
    path = tmp_path / "panel.msh"
    meshio.write(path, meshio.Mesh(np.c_[m.p.T, np.zeros(m.p.shape[1])], [("triangle", m.t.T)]),
                 file_format="gmsh22")
    raw["mesh"] = {"file": str(path)}
    points = cases(raw, "punch.0.center", [[x, 0.0, 3.5] for x in (-0.08, 0.0, 0.05, 0.12)])
    assert len({family_key(c) for c in points}) == 1
    alone = [solve(c) for c in points]
    centres = [r.summary()["contact"][0] for r in alone]
    assert len({round(c["force_magnitude"], 6) for c in centres}) > 1  # the positions differ in their results
    warm = list(solve_family(points))
    assert_same(warm, alone, RTOL)
    assert warm[-1].info["family"]["factorizations"] == 1
    assert_same(list(solve_family(points, warm_start=False)), alone, None)


def test_family_key_separates_what_cannot_share_a_factorisation():
    raw = panel({"indentation": 5e-3})
    key = family_key(case_from_dict(raw))
    same = {
        "indentation": ("punch.0.indentation", 2e-3),
        "probe": ("probes", [{"x": 0.1, "phi": 85.0}]),
    }
    for name, (k, v) in same.items():
        assert family_key(case_from_dict(apply_overrides(raw, {k: v}))) == key, name
    other = {
        "thickness": ("shell.thickness", 0.012),
        "material": ("shell.young", 2.0e11),
        "supports": ("supports.x_max", "free"),
        "mesh": ("mesh.nx", 12),
        "load": ("loads.normal", -1e3),
        "tolerance": ("solver.tolerance", 1e-9),
        "contact points": ("solver.contact_points", "vertices"),
        "method": ("solver.method", "dual"),
        # on a mesh fitted to the punch the first-contact line follows the sphere
        "position": ("punch.0.center", [0.05, 0.0, 3.5]),
        "automatic zone": ("punch.0.zone", None),
    }
    for name, (k, v) in other.items():
        changed = apply_overrides(raw, {k: v}) if v is not None else {
            **raw, "punch": [{kk: vv for kk, vv in raw["punch"][0].items() if kk != "zone"}]}
        assert family_key(case_from_dict(changed)) != key, name
    # an automatic zone {Z < g} grows with the indentation, and its edges are node lines
    auto = apply_overrides(raw, {"punch.0.zone": {"gap": 0.01}})
    assert family_key(case_from_dict(apply_overrides(auto, {"punch.0.indentation": 2e-2}))) != family_key(
        case_from_dict(auto))


def test_cases_of_different_families_are_refused():
    raw = panel({"indentation": 5e-3})
    mixed = [case_from_dict(raw), case_from_dict(apply_overrides(raw, {"mesh.nx": 12}))]
    with pytest.raises(InputError) as e:
        solve_family(mixed)
    assert e.value.field == "cases" and "case 1" in e.value.message
    assert list(solve_family([])) == []


def test_a_punch_sweep_is_the_separate_solves_bit_for_bit():
    """sweep over a punch key solves its steps as one family (no warm start): each CSV row is the lone
    solve's, digit for digit, as a resumed sweep needs."""
    from shellcontact.studies.rows import summary_row
    from shellcontact.studies.sweeps import sweep

    raw = panel({"force": 1e4})
    values = [2e4, 6e4, 1.2e5]
    res = sweep(case_from_dict(raw), "punch.0.force", values, figures=False)
    for v, row in zip(values, res.rows):
        alone = solve(case_from_dict(apply_overrides(raw, {"punch.0.force": v})))
        assert row == {"punch.0.force": v, **summary_row(alone.summary())}


def test_a_force_curve_with_a_poor_border_runs_those_points_alone(monkeypatch):
    """When the rows bordering the factorisation miss rows a point touches, that point's outside rows
    penetrate on the block solves' U and it runs the lone screened solve: the same Results."""
    import shellcontact.studies.curves as curves

    punch, key, values = CURVES["force"]
    points = cases(panel(punch, substructure=True), key, values)
    alone = [solve(c) for c in points]
    monkeypatch.setattr(curves, "initial_rows", lambda G, groups: np.argsort(G, kind="stable")[:2])
    warm = list(solve_family(points))
    shared = [r.contact.solution.info["curve"]["shared_final_solves"] for r in warm]
    assert not all(shared)
    assert_same(warm, alone, RTOL)


def test_a_curve_point_checks_its_summary_when_first_asked(monkeypatch):
    """A curve's points make their contact zone, rim and summary lazily: a non-finite result is still
    refused (SolverError naming the quantity), at the first summary instead of at the solve."""
    from shellcontact.errors import SolverError

    punch, key, values = CURVES["force"]
    warm = list(solve_family(cases(panel(punch), key, values[:2])))
    assert all(r.check_pending for r in warm)
    warm[0].summary()
    assert not warm[0].check_pending
    warm[1].solution.U[:] = np.nan
    with pytest.raises(SolverError, match="non-finite result"):
        warm[1].summary()


def test_a_curve_point_beyond_the_linear_range_comes_after_the_points_before_it():
    """A force curve whose last force moves the punch past the linear range: the points before it come out, as
    from a loop of separate solves, then the same InputError as its lone solve."""
    punch, key, _ = CURVES["force"]
    points = cases(panel(punch), key, [2e4, 6e4, 5e7])
    with pytest.raises(InputError, match="punch.0.force") as lone:
        solve(points[-1])
    got = []
    with pytest.raises(InputError, match="punch.0.force") as family:
        for r in solve_family(points):
            got.append(r)
    assert str(family.value) == str(lone.value)
    assert_same(got, [solve(c) for c in points[:2]], RTOL)


def test_a_floating_ring_force_curve_equals_its_points_solved_alone():
    """A pipe held by the two plates alone (examples/ring_stiffness.toml, coarser): the rigid motions the plates
    restrain are columns of D with the travel, so the points still differ in P only and finish together."""
    from pathlib import Path

    from shellcontact import load_case

    path = Path(__file__).resolve().parent.parent / "examples" / "ring_stiffness.toml"
    points = [load_case(path, [f"punch.0.force={f}", "mesh.nphi=32"]) for f in (100.0, 400.0)]
    warm = list(solve_family(points))
    assert all(r.contact.solution.info["curve"]["shared_final_solves"] for r in warm)
    assert_same(warm, [solve(c) for c in points], RTOL)
