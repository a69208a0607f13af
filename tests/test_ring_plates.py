"""The pipe between two plates (examples/ring_stiffness.toml) against the closed-form ring of this model.

Issue 14: "at a converged mesh the plates problem agrees with the closed-form ring solution of this model
(bending plus membrane) to 1e-4". The plates problem is solved as the example poses it — the ends keep the
section plane (symmetry supports: plane strain), force control, no symmetry plane through the axis, the
shell held by the plates alone — and compared with ``tests/oracles/ring.py`` (two inward line loads
P = F/L per unit length of generator, δ = (π/4 − 2/π) P a³/D + 2 P a³/(π (B a² + D))):

* force control: the top plate's travel (the approach of the plates: the bottom one is fixed) and the
  change of the vertical diameter, refined in φ on 32, 64, 128 elements around; the error falls at the
  rate of the elements (measured 7.8e-3, 5.2e-4, 3.0e-5: h⁴) and is below 1e-4 at 128;
* the force: both plates carry F (prescribed on the top one, a reaction on the bottom one), and with
  the travel prescribed instead (indentation control, δ of the ring) the plates' forces are F to 1e-4
  (dual and active set; measured 3.0e-5).

The contact is a line at the crown and at the invert (the node lines φ = 90° and 270°): the initial gap
R(1 − cos θ) of a plate tangent to the pipe keeps the rest open at this load (δ/d ≈ 2 %), so the linear
ring is the exact answer of the contact problem.
"""

from __future__ import annotations

import copy
from pathlib import Path

import numpy as np
import pytest
from oracles.ring import Ring

import shellcontact as sc
from shellcontact.problem.case import case_from_dict

EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "ring_stiffness.toml"
MESHES = (32, 64, 128)
ZONES = ("punch.0.zone={phi=[67.5,112.5]}", "punch.1.zone={phi=[247.5,292.5]}")
NX = 2  # the problem is uniform along x: the line contact at the vertices and midpoints of 2 elements


def _case(nphi: int, *extra: str) -> sc.Case:
    return sc.load_case(EXAMPLE, sets=(f"mesh.nx={NX}", f"mesh.nphi={nphi}", "mesh.refine=0", *extra))


def _ring_and_load(case: sc.Case) -> tuple[Ring, float, float]:
    raw = case.raw
    shell, force = raw["shell"], raw["punch"][0]["force"]
    ring = Ring(shell["radius"], shell["thickness"], shell["young"], shell["poisson"])
    return ring, force, force / shell["length"]


def _vertical_diameter_change(res: sc.Result) -> float:
    """Shortening of the diameter between the plates: w_z(crown) − w_z(invert), at mid-length."""
    u = res.solution.displacement([0.0, 0.0], np.radians([90.0, 270.0]))
    return float(u[2, 1] - u[2, 0])


def test_plates_converge_to_the_closed_form_ring_at_the_rate_of_the_elements():
    errors = {}
    for nphi in MESHES:
        res = sc.solve(_case(nphi), method="active-set")
        ring, force, P = _ring_and_load(res.case)
        exact = ring.diametral_change(P)
        s = res.summary()
        travel = s["contact"][0]["punch_travel"]
        # both plates carry the force: prescribed on the top one, the reaction of the fixed bottom one
        assert abs(s["contact"][0]["force"][2] + force) <= 1e-10 * force
        assert abs(s["contact"][1]["force"][2] - force) <= 1e-10 * force
        # the travel is the change of the diameter (the pipe touches both plates on its outer surface)
        assert abs(_vertical_diameter_change(res) - travel) <= 1e-8 * travel
        errors[nphi] = abs(travel - exact) / exact
    print(f"\nrelative error of the diametral change vs the closed-form ring: {errors}")
    rates = [np.log2(errors[a] / errors[b]) for a, b in zip(MESHES, MESHES[1:], strict=False)]
    assert all(r > 3.5 for r in rates), rates  # Argyris/P2 in φ: h⁴ measured (3.9, 4.1)
    assert errors[MESHES[-1]] < 1e-4


@pytest.mark.parametrize("method", ["active-set", "dual"])
def test_prescribed_travel_gives_the_closed_form_force(method):
    """Indentation control of a floating shell: the rigid translation along z is restrained with no load on it
    (P = 0), its equilibrium (top force = bottom force) a condition on the contact forces alone."""
    ring, force, P = _ring_and_load(_case(MESHES[-1]))
    delta = ring.diametral_change(P)
    # explicit zones, as in the force-controlled solve: the automatic zone of a plate placed at its indented
    # position fits the mesh to the edges of the band it overlaps, a different mesh (measured: 0.6 % stiffer
    # at 128 elements, contact spreading to the rows beside the crown)
    data = copy.deepcopy(_case(MESHES[-1], *ZONES).raw)
    top_plate = data["punch"][0]
    del top_plate["force"]
    top_plate["indentation"] = delta
    res = sc.solve(case_from_dict(data), method=method)
    s = res.summary()
    top, bottom = -s["contact"][0]["force"][2], s["contact"][1]["force"][2]
    assert abs(top - bottom) <= 1e-8 * force
    assert abs(top - force) <= 1e-4 * force, (top, force)


_fine: dict[int, sc.Result] = {}


def _fine_ring(nphi: int) -> sc.Result:
    if nphi not in _fine:
        _fine[nphi] = sc.solve(_case(nphi), method="active-set")
    return _fine[nphi]


def _offset_and_moments(res: sc.Result, ring: Ring, P: float) -> tuple[float, float, float]:
    """The top plate's line of action off the crown (its moment about the plate's centre over its force, m),
    and the hoop moments M22 = D κ22 (κ22 from the surface strains: plane strain, κ11 = 0) at the crown and
    at 45° relative to the closed form."""
    s = res.summary()["contact"][0]
    offset = abs(s["moment"][0] / s["force"][2])

    def moment(phi_deg: float) -> float:
        strain = res.solution.probe(0.0, np.radians(phi_deg))["strain"]
        return ring.D * (strain["top"]["e22"] - strain["bottom"]["e22"]) / res.case.shell.thickness

    return (offset, moment(90.0) / ring.moment(0.0, P) - 1.0, moment(45.0) / ring.moment(np.pi / 4, P) - 1.0)


@pytest.mark.parametrize("nphi", [384, 512])
def test_a_floating_ring_stays_right_on_fine_meshes(nphi):
    """Issue 23 item 1: the ring held by the plates alone was right up to 256 elements around and then, at 384
    and 512 (among others), converged to a contact line a row off the crown (here, before the fix: 2.2 % and
    1.9 % too stiff, the line of action 1.7 and 1.9 mm off the crown, hoop moments 3.6 % and 4.0 % low at the
    crown, 14 % and 19 % at 45°, no warning): the gauge fixing the unloaded rotation about the axis left a
    rotation θ in the solution, and the linearised gap beside the crown is not invariant to it. Now that
    rotation is an unknown the contact forces balance (floating.py: a balanced motion) and is removed
    afterwards as far as the gaps allow.

    Against the closed-form ring and 256 elements around, with 2 elements along x (measured: travel errors
    1.9e-6 at 256, 3.8e-7 at 384, 2.1e-7 at 512; hoop moment errors 5.8e-5 and 3.2e-5 at the crown, 1.9e-5
    and 9.8e-6 at 45°; the line of action 6e-18 m off the crown, round-off): refinement does not make the
    travel worse, and the line of action stays on the crown, as the symmetry of the problem demands."""
    coarse, fine = _fine_ring(256), _fine_ring(nphi)
    ring, force, P = _ring_and_load(fine.case)
    exact = ring.diametral_change(P)
    err = {n: abs(r.summary()["contact"][0]["punch_travel"] - exact) / exact for n, r in ((256, coarse), (nphi, fine))}
    offset, m_crown, m_45 = _offset_and_moments(fine, ring, P)
    print(f"\nnphi {nphi}: travel error {err[nphi]:.2e} (256: {err[256]:.2e}), line of action {offset:.2e} m off the "
          f"crown, hoop moment errors {m_crown:.2e} (crown), {m_45:.2e} (45°)")
    assert err[nphi] <= err[256]
    assert err[nphi] < 2e-6
    assert offset <= 1e-12
    assert abs(m_crown) < 3e-4 and abs(m_45) < 1e-4
