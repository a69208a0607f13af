"""The discrete problem of a case: its mesh (fitted to the punches), the space V_h, the stiffness A, the
load F, the support reduction U = P U_r and the contact rows B; ``Timer`` times the stages."""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np
import scipy.sparse as sp

from ..contact.floating import Floating
from ..contact.floating import analyse as analyse_floating
from ..contact.operator import ContactOperator, contact_operator, row_flexibility
from ..contact.punches import Punch, place_punches
from ..errors import InputError
from ..problem.case import Case
from ..problem.options import SolverOptions
from ..problem.sizing import mesh_lines
from ..shell import model
from ..shell.loads import load_vector
from ..shell.mesh import ShellMesh, build_mesh
from ..shell.spaces import ShellSpace
from ..shell.supports import Reduction
from ..solvers import ContactQP


class Timer:
    """Accumulates wall-clock seconds per named stage."""

    def __init__(self) -> None:
        self.times: dict[str, float] = {}
        self._t0 = time.perf_counter()

    def stage(self, name: str):
        timer = self

        class _Stage:
            def __enter__(self):
                self.t = time.perf_counter()

            def __exit__(self, *exc):
                timer.times[name] = timer.times.get(name, 0.0) + time.perf_counter() - self.t

        return _Stage()

    def total(self) -> dict[str, float]:
        """Seconds per stage; ``output`` is 0 until the result is written (outputs.write_outputs adds it)."""
        return {"output": 0.0, **self.times, "total": time.perf_counter() - self._t0}


@dataclass
class Discretization:
    """The discrete problem of a case: V_h, A, F, the support reduction and the contact rows."""

    space: ShellSpace
    A: sp.csr_matrix  # full stiffness
    F: np.ndarray  # full load vector
    reduction: Reduction
    Ar: sp.csr_matrix  # Pᵀ A P
    Fr: np.ndarray  # Pᵀ F
    punches: list[Punch]
    operator: ContactOperator | None  # None without punches
    Br: sp.csr_matrix | None  # B P
    floating: Floating | None = None  # the free rigid motions when contact alone holds the shell
    #: |Ar| (``ContactQP.abs_A``), computed once for every QP of this discretisation and of copies of it
    #: (``dataclasses.replace`` keeps the dict: the points of a curve share their stiffness)
    shared: dict = field(default_factory=dict, repr=False, compare=False)

    def qp(self) -> ContactQP:
        """The reduced contact QP of MODEL.md §8; a floating shell's restrained rigid motions are unknowns
        after the force-controlled travels (columns of D, loads in P: floating.py)."""
        op = self.operator
        if op is None:
            raise InputError("punch", "the case has no punch: there is no contact problem")
        D, P = op.D, op.forces if op.D is not None else None
        labels = [f"punch.{k}.force" for k in op.force_punches]
        fl = self.floating
        if fl is not None and fl.P.size:
            D = fl.D if D is None else np.hstack([D, fl.D])
            P = fl.P if P is None else np.concatenate([P, fl.P])
            labels += [f"rigid motion: {name}" for name in fl.names]
        rows = self.shared.get("rows")  # the labels and flexibilities of the rows B: the same for a force curve
        if rows is None or rows[0] is not op.B:
            rows = self.shared["rows"] = (op.B, _row_labels(op), row_flexibility(self.space.mesh.shell, op))
        held = None
        if fl is not None and fl.by_friction:  # the last of the restrained motions: held by friction alone
            held = np.zeros(D.shape[1], bool)
            kr = D.shape[1] - fl.D.shape[1] + len(fl.restrained)
            held[kr - fl.by_friction:kr] = True
        qp = ContactQP(self.Ar, self.Fr, self.Br, op.G, op.weights, D=D, P=P, row_labels=rows[1], friction_held=held,
                       force_labels=labels if D is not None else None, symmetric=True, flexibility=rows[2],
                       finite=self.shared.get("finite_A") is self.Ar)
        self.shared["finite_A"] = self.Ar  # checked
        if "abs_A" not in self.shared:
            self.shared["abs_A"] = qp.abs_A
        qp._abs_A = self.shared["abs_A"]
        return qp


def case_mesh(case: Case, punches: list[Punch] | tuple[()] = ()) -> ShellMesh:
    """The mesh of a case: node lines at the loads and at the punches' fitted lines (zone edges,
    first-contact lines), graded toward first contact when ``[mesh.grading]`` has a ratio but no focus."""
    return build_mesh(case.shell, case.mesh, *mesh_lines(case, punches))


def discretize(case: Case, contact_points: str = SolverOptions.contact_points, timer: Timer | None = None,
               punches: list[Punch] | None = None) -> Discretization:
    """Mesh (fitted to the punches), space, assembly, supports and contact operator of ``case``
    (``punches``: the case's punches already placed)."""
    timer = timer or Timer()
    with timer.stage("mesh"):
        if punches is None:
            punches = place_punches(case.punches, case.shell, case.units)
        space = ShellSpace(case_mesh(case, punches))
    with timer.stage("assembly"):
        A = model.stiffness(space)
        F = load_vector(space, case.loads)
        red = Reduction.build(space, case.supports, floating=bool(punches))
        op = contact_operator(space, punches, contact_points) if punches else None
        rubbing = None if op is None else np.array([case.punches[k].friction.active for k in op.punch], bool)
        floating = analyse_floating(space, red, op, F, rubbing) if op is not None and red.motions.size else None
        return Discretization(space, A, F, red, red.reduce_matrix(A), red.reduce_vector(F), punches, op,
                              None if op is None else op.B @ red.P, floating)


def _row_labels(op: ContactOperator) -> list[str]:
    deg = np.degrees(op.phi)
    return [f"punch.{k} point (x={x:.6g}, phi={p:.6g} deg)" for k, x, p in zip(op.punch, op.x, deg)]
