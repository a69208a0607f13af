"""Where the linear thin-shell model of MODEL.md §2–3 stops describing the shell, and the coded warnings.

The model is linear (small strains, small rotations, equilibrium on the undeformed shape) and thin
(Kirchhoff–Love: normals stay normal, the stress through the thickness is plane). A result outside that
range is still the model's exact answer, but no longer the shell's. Checked after every solve, each with a
stable ``code`` (docs/outputs.md, "Warnings"); thresholds and their sources in docs/theory.md, "Where the
model holds":

* ``thickness_ratio``: t/a above ``THICKNESS_RATIO_LIMIT`` = 1/20, the usual bound of thin-shell theory
  (a/t ≥ 20; Ventsel & Krauthammer, *Thin plates and shells*, §10.1). Kirchhoff–Love's relative error is
  of order t/a (Koiter 1960), and transverse shear, left out, grows with it.
* ``geometric_nonlinearity``: the deflection large against the thickness. Small-deflection theory holds
  while w ≪ t: for a clamped circular plate the membrane stretching the linear theory leaves out stiffens
  the centre deflection by 0.488 (w/t)² (Timoshenko & Woinowsky-Krieger, §97): 4 % at w/t = 0.3, 49 % at 1.
  On a shell, w/t alone misleads (a pressurised tube expands by w ≈ t without any nonlinearity), so the
  measure is the term itself: the stretching ½β² of the largest rotation β (von Kármán / Donnell) over the
  largest surface strain the linear model keeps. For the clamped plate under uniform load this ratio is
  0.296 w/t (w = w₀(1 − ρ²)²: β = 1.54 w₀/R, surface strain 4 t w₀/R² at the edge), so the limit
  ``STRETCH_RATIO_LIMIT`` = 0.09 is that plate at w/t = 0.3.
* ``rotation``: the largest rotation of the normal above ``ROTATION_LIMIT`` = 0.1 rad (5.7°), the usual bound of
  small rotations (sin β ≈ β to 0.2 %, 1 − cos β = 5e-3): beyond it moderate-rotation theories (Sanders–Koiter)
  apply whatever the strains.
* ``yield_stress``: von Mises stress above ``[material] yield_stress``.
* ``equilibrium``: the global balance's relative residual above ``EQUILIBRIUM_LIMIT`` = 1e-3
  (``equilibrium_warnings``).

Other layers' warnings (KKT, penalty, contact zones) carry their codes too (``ResultWarning``); a plain
string keeps the code ``"general"``. summary.json holds each as ``{"code", "message"}``.
"""

from __future__ import annotations

import contextlib
from collections.abc import Iterable, Iterator, Mapping
from typing import TYPE_CHECKING, Any

from ..errors import InputError, SolverError
from ..units import with_unit

if TYPE_CHECKING:
    from ..outputs.results import ShellSolution
    from ..problem.case import Case

THICKNESS_RATIO_LIMIT = 1.0 / 20.0
STRETCH_RATIO_LIMIT = 0.09
ROTATION_LIMIT = 0.1  # rad
EQUILIBRIUM_LIMIT = 1e-3


class ResultWarning(str):
    """A warning's message (a ``str``, so it prints and compares as before) with its stable ``code``."""

    code: str

    def __new__(cls, code: str, message: str) -> ResultWarning:
        out = super().__new__(cls, message)
        out.code = code
        return out


def record(warning: str | Mapping[str, Any]) -> dict[str, str]:
    """One warning as summary.json holds it: ``{"code", "message"}`` (a plain string: code ``"general"``)."""
    if isinstance(warning, Mapping):
        return {"code": str(warning.get("code", "general")), "message": str(warning.get("message", ""))}
    return {"code": getattr(warning, "code", "general"), "message": str(warning)}


def message(warning: str | Mapping[str, Any]) -> str:
    """The text of a warning read from a summary, either form (older summaries hold plain strings)."""
    return record(warning)["message"]


def codes(warnings: Iterable[str | Mapping[str, Any]]) -> list[str]:
    return [record(w)["code"] for w in warnings]


def range_measures(solution: ShellSolution) -> dict[str, Any]:
    """The numbers the range checks compare with their limits, over the mesh vertices (of the elastic part of
    a floating shell): ``thickness_ratio`` max t/a; ``deflection_ratio`` max |w|/t and ``deflection_at`` its
    vertex; ``rotation`` the largest rotation of the normal (rad) and ``rotation_at``; ``strain`` the largest
    surface strain component (tensor shear); ``stretch_ratio`` = ½ rotation² / strain."""
    import numpy as np  # here: report.py reads ``message`` without loading numpy

    from ..shell.model import strains

    shell = solution.shell
    x, s = solution.space.mesh.p
    phi = s / shell.radius
    t = np.broadcast_to(shell.t(x, phi), x.shape)
    d = {k: op @ solution.elastic for k, op in solution.space.point_operators(x, s).items()}
    beta = np.hypot(d["w_x"], d["w_s"] - d["v"] / shell.radius)  # rotation of the normal (about e2, about e1)
    e = strains(d, shell.radius)  # (ε11, ε22, γ12, κ11, κ22, κ12), MODEL.md §2
    strain = max(float(np.max(np.abs(e[:3] * [[1.0], [1.0], [0.5]] + sign * 0.5 * t * e[3:]))) for sign in (-1, 1))
    kw, kb = int(np.argmax(np.abs(d["w"]) / t)), int(np.argmax(beta))

    def at(k: int) -> tuple[float, float]:
        return float(x[k]), float(np.degrees(phi[k]))

    return {"thickness_ratio": float(t.max()) / shell.radius, "thickness": float(t.max()),
            "deflection": float(abs(d["w"][kw])), "deflection_ratio": float(abs(d["w"][kw]) / t[kw]),
            "deflection_at": at(kw), "rotation": float(beta[kb]), "rotation_at": at(kb), "strain": strain,
            "stretch_ratio": 0.5 * float(beta[kb]) ** 2 / max(strain, 1e-300)}


def range_warnings(solution: ShellSolution, stresses: Mapping[str, Mapping[str, Any]],
                   yield_stress: float | None, system: str = "SI") -> list[ResultWarning]:
    """The warnings of a result outside the linear thin-shell range (module docstring; ``range_measures``);
    numbers labelled in the unit ``system``."""
    import math

    def unit(value: float, kind: str) -> str:
        return with_unit(f"{value:.4g}", kind, system)

    def where(at: tuple[float, float]) -> str:
        return f"x = {unit(at[0], 'length')}, phi = {at[1]:.4g} deg"

    m = range_measures(solution)
    out = []
    if m["thickness_ratio"] > THICKNESS_RATIO_LIMIT:
        out.append(ResultWarning(
            "thickness_ratio",
            f"thickness ratio t/a = {m['thickness_ratio']:.3g} (t = {unit(m['thickness'], 'length')}, a = "
            f"{unit(solution.shell.radius, 'length')}) is above {THICKNESS_RATIO_LIMIT:g}, the range of thin-shell "
            "theory: Kirchhoff–Love leaves out transverse shear and the stress through the thickness, errors of "
            f"order t/a = {m['thickness_ratio']:.0%}; use a thick-shell or 3D solid model for this wall"))
    if m["stretch_ratio"] > STRETCH_RATIO_LIMIT:
        rot = m["rotation"]
        out.append(ResultWarning(
            "geometric_nonlinearity",
            f"the deflection is large for a linear model: max |w| = {unit(m['deflection'], 'length')} is "
            f"{m['deflection_ratio']:.3g} x the thickness (at {where(m['deflection_at'])}), and the membrane strain "
            f"of the rotations that the linear strains leave out, beta^2/2 = {0.5 * rot ** 2:.2g}, is "
            f"{m['stretch_ratio']:.2g} of the largest strain {m['strain']:.2g} (above {STRETCH_RATIO_LIMIT:g}, which "
            "a clamped plate reaches at w = 0.3 t, stiffening by 4 %); forces and stresses are those of small "
            "deflections: reduce the load or indentation, or use a geometrically nonlinear analysis"))
    if m["rotation"] > ROTATION_LIMIT:
        rot = m["rotation"]
        out.append(ResultWarning(
            "rotation",
            f"rotation of the normal {rot:.3g} rad ({math.degrees(rot):.3g} deg) at {where(m['rotation_at'])} is "
            f"above {ROTATION_LIMIT:g} rad: the linear kinematics take sin(beta) = beta and cos(beta) = 1 (error "
            f"{1 - math.cos(rot):.1e}); reduce the load or indentation, or use a geometrically nonlinear analysis"))
    if yield_stress is not None and stresses:
        name, st = max(stresses.items(), key=lambda kv: kv[1]["von_mises_max"])
        if st["von_mises_max"] > yield_stress:
            out.append(ResultWarning(
                "yield_stress",
                f"linear elastic result beyond yield: von Mises stress {unit(st['von_mises_max'], 'pressure')} "
                f"on the {name} surface at {where((st['at']['x'], st['at']['phi']))} is "
                f"{st['von_mises_max'] / yield_stress:.3g} x material.yield_stress; the stresses past yield are not "
                "physical (reduce the load or indentation, or use a plastic analysis)"))
    return out


def equilibrium_warnings(relative_residual: float) -> list[ResultWarning]:
    """The global balance off by more than ``EQUILIBRIUM_LIMIT`` (``Result.equilibrium``): the residual is the
    interpolation error of the rigid rotations, falling under refinement; above 1e-3 the reactions and contact
    forces no longer balance the loads to the 3–4 digits the outputs print (the examples: at most 4.5e-4)."""
    if relative_residual <= EQUILIBRIUM_LIMIT:
        return []
    return [ResultWarning(
        "equilibrium", f"equilibrium: the forces on the shell balance only to {relative_residual:.2g} of the largest "
        f"force (above {EQUILIBRIUM_LIMIT:g}): the rigid rotations are interpolated too coarsely for reactions and "
        "contact forces to 3 digits; refine the mesh (mesh.nx, mesh.nphi or mesh.refine) where the shell turns")]


def floating_warnings(case: Case, rigid_motion: Mapping[str, Any] | None, contact: list[Mapping[str, Any]],
                      system: str = "SI") -> list[ResultWarning]:
    """A shell held by contact alone whose punches prescribe their travel (indentation) and carry no force: the
    shell moved with them as a rigid body. Zero is the model's right answer, but never what was meant."""
    if not rigid_motion or not rigid_motion.get("restrained") or not contact:
        return []
    pushed = [p for p in case.punches if p.mode == "indentation" and p.indentation > 0.0]
    if not pushed or any(p.mode == "force" for p in case.punches):
        return []
    t = case.shell.thickness if not callable(case.shell.thickness) else case.shell.radius * 1e-2
    scale = case.shell.material.hoop_modulus * float(t) * max(p.indentation for p in pushed)  # E t δ: a force
    total = sum(float(c.get("total_normal_force", 0.0)) for c in contact)
    if total > 1e-12 * scale:
        return []
    keys = ", ".join(f"{p.where}.indentation" for p in pushed)
    moved = ", ".join(rigid_motion["restrained"])
    return [ResultWarning(
        "rigid_push", f"the shell is held by nothing but its punches, and {keys} moved it as a rigid body ({moved}) "
        f"with no contact force ({with_unit(f'{total:.3g}', 'force', system)}): hold it with supports or another "
        f"punch, or push it with a force (punch.<i>.force) instead of an indentation")]


# -- input in the wrong unit (issue 23: radians where degrees are expected, millimetres in an SI case) --------
#: a modulus in this range reads as pascals (steel 2.1e11, aluminium 7e10, GRP 1e10, polymers 1e9, rubber 1e6)
SI_MODULUS = (1e6, 1e12)
#: thinner than any steel shell built (tanks and gas holders reach a/t ≈ 5000): a length is in another unit
RADIUS_THICKNESS_MAX = 1e4


def unit_scale_hint(radius: float, length: float, thickness: float | None, modulus: float, system: str) -> str:
    """A sentence when one length of an SI-looking case (a modulus in pascals) is out of scale with the others,
    e.g. ``radius = 1000`` (mm) beside ``thickness = 0.01`` (m); "" otherwise."""
    if system != "SI" or not SI_MODULUS[0] <= modulus <= SI_MODULUS[1]:
        return ""
    lengths = {"shell.radius": radius, "shell.length": length}
    if thickness is not None:
        lengths["shell.thickness"] = thickness
    big = max(lengths, key=lengths.__getitem__)
    small = min(lengths, key=lengths.__getitem__)
    if lengths[big] / lengths[small] <= RADIUS_THICKNESS_MAX and max(radius / length, length / radius) <= 1e3:
        return ""
    if max(radius / length, length / radius) > 1e3:
        small = "shell.length" if big == "shell.radius" else "shell.radius"
    return (f"{big} = {lengths[big]:g} m is {lengths[big] / lengths[small]:.3g} x {small} = {lengths[small]:g} m "
            f"in a case whose modulus ({modulus:.3g}) reads as Pa, so lengths are in m: if {big} is in mm, write "
            f"it in m ({lengths[big] / 1000:g}), or give every length in mm and the moduli in MPa with [units] "
            'system = "mm"')


def case_unit_hint(case: Case) -> str:
    sh = case.shell
    return unit_scale_hint(sh.radius, sh.length, None if callable(sh.thickness) else float(sh.thickness),
                           sh.material.hoop_modulus, case.units)


def case_warnings(case: Case) -> list[ResultWarning]:
    """The warnings the case alone gives (a length out of scale: ``unit_scale``)."""
    hint = case_unit_hint(case)
    return [ResultWarning("unit_scale", f"{hint}; the result is that of the numbers as given")] if hint else []


@contextlib.contextmanager
def unit_hint_on_error(case: Case) -> Iterator[None]:
    """An input or solver error of a case with a length out of scale ends with the unit hint: a radius of 1000
    (mm) in an SI case fails as a punch that never touches, which says nothing of the cause."""
    try:
        yield
    except (InputError, SolverError) as exc:
        hint = case_unit_hint(case)
        if hint:
            if isinstance(exc, InputError):
                exc.message = f"{exc.message}; {hint}"
                exc.args = (f"{exc.field}: {exc.message}",)
            else:
                exc.args = (f"{exc}; {hint}",)
        raise
