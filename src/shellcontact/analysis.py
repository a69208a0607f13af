"""From a validated case to a solution: mesh → space → assembly → solve, with timings."""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from . import model
from .case import Case, build_mesh
from .linalg import factorize
from .loads import load_vector
from .results import ShellSolution
from .spaces import ShellSpace
from .supports import Reduction


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
        return {**self.times, "total": time.perf_counter() - self._t0}


@dataclass
class Result:
    """The outcome of ``solve(case)``: the solution and its JSON-ready summary."""

    case: Case
    solution: ShellSolution
    timings: dict[str, float]
    info: dict[str, Any] = field(default_factory=dict)

    def summary(self) -> dict[str, Any]:
        sol = self.solution
        out = {
            "dofs": int(sol.space.ndofs),
            "unknowns": int(self.info.get("unknowns", sol.space.ndofs)),
            "elements": int(sol.space.mesh.nelements),
            "vertices": int(sol.space.mesh.nvertices),
            "energy": sol.energy,
            "max_abs_w": sol.max_abs_w,
            "probes": [sol.probe(x, phi) for x, phi in self.case.probes],
            "reaction_resultant": [float(c) for c in sol.reaction_resultant()],
            "backend": self.info.get("backend"),
            "timings": dict(self.timings),
        }
        out.update({k: v for k, v in self.info.items() if k not in out})
        return out


def solve(case: Case, backend: str | None = None) -> Result:
    """Solve the linear shell problem of ``case`` (no contact)."""
    timer = Timer()
    with timer.stage("mesh"):
        mesh = build_mesh(case)
        space = ShellSpace(mesh)
    with timer.stage("assembly"):
        A = model.stiffness(space)
        F = load_vector(space, case.loads)
        red = Reduction.build(space, case.supports)
        Ar, Fr = red.reduce_matrix(A), red.reduce_vector(F)
    with timer.stage("factorization"):
        fac = factorize(Ar, backend or case.solver.get("backend", "auto"))
    with timer.stage("solve"):
        U = red.expand(fac.solve(Fr))
    timings = timer.total()
    timings.setdefault("output", 0.0)
    sol = ShellSolution(space=space, U=U, A=A, F=F, timings=timings)
    info = {"backend": fac.backend, "unknowns": int(Ar.shape[0])}
    return Result(case=case, solution=sol, timings=timings, info=info)


def residual(sol: ShellSolution, red: Reduction) -> float:
    r = red.reduce_vector(sol.A @ sol.U - sol.F)
    return float(np.linalg.norm(r) / max(np.linalg.norm(red.reduce_vector(sol.F)), 1e-300))
