"""Issue 23, item 5: numbers that were quietly wrong at the edges either come out right or say why they cannot.

Independent references: the force of a single contact point is proportional to the indentation; a shell that
nothing but its punch holds moves rigidly (zero force is then the model's answer, never the one meant); the
global balance's residual falls under refinement; the material and mesh limits are those of the inputs."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import shellcontact as sc
from shellcontact.analysis.validity import EQUILIBRIUM_LIMIT
from shellcontact.errors import InputError
from shellcontact.problem.case import read_case_dict

ROOT = Path(__file__).resolve().parents[1]
PANEL = ROOT / "examples" / "paper_panel.toml"
COARSE = ["mesh.nx=16", "mesh.nphi=16"]


def _codes(result) -> list[str]:
    return [w["code"] for w in result.summary()["warnings"]]


def _force(result) -> float:
    return result.summary()["contact"][0]["total_normal_force"]


def test_an_indentation_below_the_gaps_round_off_is_refused() -> None:
    """1e-15 m on the paper's panel (issue 23: 11 % off, and 0 N at 1e-16 m, exit 0) is refused naming the key;
    the smallest accepted indentation, 1e-9 m, touches at one point, so its force is exactly proportional to
    the indentation: F(1e-9) = F(1e-7)/100 (measured to 1e-9 relative; bound 1e-6)."""
    for d in (1e-15, 1e-16, 5e-10):
        with pytest.raises(InputError) as e:
            sc.solve(sc.load_case(PANEL, [*COARSE, f"punch.0.indentation={d}"]))
        assert e.value.field == "punch.0.indentation" and "resolves" in e.value.message
    small, large = (sc.solve(sc.load_case(PANEL, [*COARSE, f"punch.0.indentation={d}"])) for d in (1e-9, 1e-7))
    assert _force(small) == pytest.approx(_force(large) / 100, rel=1e-6)
    # zero is "just touching": no force, no error
    assert _force(sc.solve(sc.load_case(PANEL, [*COARSE, "punch.0.indentation=0"]))) == 0.0


def _pipe_pressed(indentation: bool, bottom_plate: bool, method: str | None = None) -> dict:
    raw = read_case_dict(ROOT / "examples" / "ring_stiffness.toml")
    raw["mesh"]["nphi"] = 32
    if method is not None:
        raw["solver"]["method"] = method
    top = dict(raw["punch"][0])
    if indentation:
        del top["force"]
        top["indentation"] = 1e-3
    raw["punch"] = [top, *raw["punch"][1:]] if bottom_plate else [top]
    return raw


@pytest.mark.parametrize("method", ["active-set", "dual", "penalty"])
def test_a_floating_shell_pushed_by_its_only_punch_says_it_moved_rigidly(method: str) -> None:
    """The pipe of ring_stiffness without its bottom plate, its top plate moved 1 mm: the pipe moves 1 mm with
    it and no force arises (before: 'force 0 N' and no word; then every method failed or passed by round-off:
    the zero force's round-off, 6e-14 N, was measured against itself, not the problem's force scale Λ_ref =
    1e-3 m / 1.36e-5 m/N = 74 N). With the bottom plate the same indentation squeezes the pipe: a force, and no
    such warning."""
    alone = sc.solve(sc.case_from_dict(_pipe_pressed(indentation=True, bottom_plate=False, method=method)))
    assert _force(alone) == 0.0
    assert alone.summary()["rigid_motion"]["translation"][2] == pytest.approx(-1e-3, rel=1e-9)
    assert "rigid_push" in _codes(alone)
    held = sc.solve(sc.case_from_dict(_pipe_pressed(indentation=True, bottom_plate=True, method=method)))
    assert "rigid_push" not in _codes(held)
    # thin-ring theory (docs/examples.md, ring stiffness): δ = (π/4 − 2/π) (F/L) a³ / D, D = E t³ / (12 (1 − ν²))
    a, t, length, young, nu, travel = 0.1, 0.006, 0.3, 1e9, 0.4, 1e-3
    ring = travel * length * young * t**3 / (12 * (1 - nu**2)) / ((np.pi / 4 - 2 / np.pi) * a**3)
    assert _force(held) == pytest.approx(ring, rel=0.03)  # measured 43.596 N against 43.209 N: 0.9 % (nphi = 32)


def _saddle_pushed_up(shift: float) -> dict:
    """The saddle of examples/saddle_support.toml alone (coarse: 20 x 24, grading focus at 270 deg), pushed up
    0.1 mm into the clamped pipe, its centre and extent written ``shift`` further out along its direction."""
    raw = read_case_dict(ROOT / "examples" / "saddle_support.toml")
    saddle = dict(raw["punch"][1], direction=[0.0, 0.0, 1.0], indentation=1e-4, center=[0.0, 0.0, 0.009 - shift])
    saddle["extent"] = {"x": [-0.1, 0.1], "z": [-0.15 - shift, -0.07325 - shift]}
    raw["punch"], raw["probes"] = [saddle], raw["probes"][1:2]
    raw["mesh"].update(nx=20, nphi=24)
    return raw


def test_a_finite_punch_gives_the_same_force_wherever_its_centre_is_written() -> None:
    """Written 0.5 m out, the body faced no point of the shell where written: refused (the faces-the-body check ran
    before the travel); with the travel scanned first, its first-contact line came out 1e-7 rad off the grading
    focus at 270 deg (Z's round-off hides the minimiser's position; the polished one was rejected by a Z
    comparison) and the sliver between the two node lines made the stiffness not positive definite. Now: the same
    placement and force to round-off (measured 5.6e-12 relative: 218.44861004685 N)."""
    near, far = (sc.solve(sc.case_from_dict(_saddle_pushed_up(s))) for s in (0.0, 0.5))
    assert _force(far) == pytest.approx(_force(near), rel=1e-9)
    assert [p.first_contact[1] for p in (near.contact.operator.punches[0], far.contact.operator.punches[0])] == [
        pytest.approx(1.5 * np.pi, abs=1e-12)] * 2


def test_node_lines_closer_than_a_small_share_of_an_interval_are_one_line() -> None:
    """A required line 1e-7 rad from a grading focus (a 48-interval circle: 1e-6 of an interval) is merged into
    the focus; lines a tenth of an interval apart stay two."""
    from shellcontact.shell.mesh import graded_nodes

    two_pi = 2 * np.pi
    nodes = graded_nodes(0.0, two_pi, 48, focus=[1.5 * np.pi], ratio=12.0, required=[1.5 * np.pi - 1e-7])
    assert np.min(np.diff(nodes)) > 1e-3 * two_pi / 48 and np.any(nodes == 1.5 * np.pi)
    apart = graded_nodes(0.0, two_pi, 48, focus=[1.5 * np.pi], ratio=12.0, required=[1.5 * np.pi - 0.1 * two_pi / 48])
    assert np.any(np.isclose(apart, 1.5 * np.pi - 0.1 * two_pi / 48, rtol=0, atol=1e-15))


def test_an_equilibrium_residual_above_its_limit_is_warned_and_refinement_removes_it() -> None:
    """pipe_rollers on a coarse 8 x 8 mesh: the loads, reactions and contact forces balance only to 2.1e-2 of the
    largest force (issue 23 saw 7.1e-3): warned. On the example's own mesh the residual (measured 2.9e-4) is below
    the limit 1e-3, and no such warning."""
    coarse = sc.solve(sc.load_case(ROOT / "examples" / "pipe_rollers.toml", ["mesh.nx=8", "mesh.nphi=8"]))
    assert coarse.equilibrium()["relative_residual"] > EQUILIBRIUM_LIMIT and "equilibrium" in _codes(coarse)
    fine = sc.solve(sc.load_case(ROOT / "examples" / "pipe_rollers.toml"))
    assert fine.equilibrium()["relative_residual"] < EQUILIBRIUM_LIMIT / 3 and "equilibrium" not in _codes(fine)


def _orthotropic(**constants) -> dict:
    raw = read_case_dict(PANEL)
    for key in ("young", "poisson"):
        raw["shell"].pop(key)
    raw["material"] = {"model": "orthotropic", "e1": 2.1e11, "e2": 2.1e11, "g12": 8e10, "nu12": 0.3, **constants}
    return raw


@pytest.mark.parametrize(("constants", "key"), [
    ({"nu12": 0.99999999999}, "material.nu12"),  # 1 − ν12ν21 = 2e-11
    ({"e2": 1e4}, "material.e2"),
    ({"g12": 1e3}, "material.g12"),
])
def test_nearly_singular_orthotropic_constants_name_their_key(constants: dict, key: str) -> None:
    """Before: a factorisation failure asking whether the supports are enough. A composite's constants (E1/E2 ≤ 50,
    G12/E1 ≥ 0.01) pass."""
    with pytest.raises(InputError) as e:
        sc.case_from_dict(_orthotropic(**constants))
    assert e.value.field == key
    sc.case_from_dict(_orthotropic(e2=2.1e11 / 50, g12=2.1e9, nu12=0.3))


def test_an_extreme_grading_ratio_names_its_key() -> None:
    """mesh.grading.ratio = 1e6 ended in "are the supports enough?" (3e3 already fails the KKT tolerance on the
    paper's panel; 1e3 solves it within 0.03 % of ratio 14): refused above 1000, naming the key."""
    with pytest.raises(InputError) as e:
        sc.load_case(PANEL, ["mesh.grading.ratio=1e6"])
    assert e.value.field == "mesh.grading.ratio"
    sc.load_case(PANEL, ["mesh.grading.ratio=1000"])
