"""How accurate each headline number is: its discretisation error estimated from coarser meshes
(``run --estimate``, ``estimate(case)``) and uniform refinement until every estimate meets a tolerance
(``run --accuracy TOL``, ``refine_to(case, tol)``).

The case's own mesh is level 0. The next coarser mesh is ``mesh.refine − 1`` or, for a structured mesh at
``mesh.refine = 0``, the same mesh with half of ``mesh.nx`` and ``mesh.nphi`` (a count of 1 stays 1): either
way every element size doubles, ratio r = 2. For a headline q with values q0 (finest), q1, q2 on three
successive meshes, the differences d1 = q0 − q1 and d2 = q1 − q2 give the observed order
p = log(d2/d1)/log r when they have one sign and |d1| < |d2| (the asymptotic range), clamped to
[``MIN_ORDER``, ``MAX_ORDER``]; the error of q0 is then Richardson's d1/(r^p − 1). Otherwise (two meshes
only, or differences that change sign or grow) the order is taken as ``ASSUMED_ORDER`` = 1: the estimate is
|d1| itself, conservative for any quantity converging at least linearly. The relative estimate divides by
|q0| or by a reference size where that is larger (``HEADLINES``: a probe component by its probe's displacement
magnitude, a resultant force by the total normal force). What is assumed: the meshes are in the asymptotic
range and the quantity converges monotonically; docs/outputs.md#accuracy-of-the-headline-numbers, and the
tests against closed forms and series values (tests/test_accuracy.py) show how far that holds.

The headline paths are listed once, in ``HEADLINES``: read from the summary by dotted path, ``*`` standing
for every list index or dictionary key, so a quantity added to the summary needs one line here.
"""

from __future__ import annotations

import contextlib
import functools
import logging
import math
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from fnmatch import fnmatchcase
from typing import Any

from ..analysis.validity import ResultWarning, record
from ..errors import InputError, ShellContactError
from ..inputs.arguments import expect_callable, expect_integer
from ..units import unit_kind, with_unit
from .refine_advice import advice

#: the headline quantities by summary path (``*``: every list index or key), each with the numbers its relative
#: error is measured against besides its own size: (path, factor) pairs, the path's indices those of the
#: headline. A probe component against its probe's displacement (one that vanishes by symmetry has no relative
#: error of its own) and, at a point that hardly moves, 1e-6 × max |w|; a resultant force that vanishes (a band
#: round a pipe) against the total normal force. ONE list: edit here.
_PROBE = (("probes.*.displacement", 1.0), ("max_abs_w", 1e-6))
HEADLINES: tuple[tuple[str, tuple[tuple[str, float], ...]], ...] = (
    ("max_abs_w", ()),
    ("probes.*.u", _PROBE),
    ("probes.*.v", _PROBE),
    ("probes.*.w", _PROBE),
    ("probes.*.displacement.*", _PROBE),
    ("stresses.*.von_mises_max", ()),
    ("contact.*.force_magnitude", (("contact.*.total_normal_force", 1.0),)),
    ("contact.*.total_normal_force", ()),
    ("contact.*.punch_travel", ()),
    ("contact.*.zone.area", ()),
    ("contact.*.rim.length", ()),
    ("contact.*.rim.force", (("contact.*.total_normal_force", 1.0),)),
    ("contact.*.rim.mean_line_force", ()),
    ("contact.*.rim.line_loads.length", ()),
    ("contact.*.rim.line_loads.force", (("contact.*.total_normal_force", 1.0),)),
    ("contact.*.rim.line_loads.mean_line_force", ()),
    ("contact.*.rim.point_forces.*.force", (("contact.*.total_normal_force", 1.0),)),
)
#: headlines that are none where another summary entry has a value: the area of a line contact (a plate on a
#: pipe) is zero in the limit, what a mesh gives is the width of its strip of carrying points or of the gap
#: tolerance; its line load (rim.length, rim.mean_line_force) is the converging headline
NOT_WHEN: dict[str, tuple[str, Any]] = {"contact.*.zone.area": ("contact.*.rim.kind", "line")}
RATIO = 2.0  # element size of a mesh over that of the next finer one
ASSUMED_ORDER = 1.0  # when no order can be observed (MODULE docstring)
MIN_ORDER, MAX_ORDER = 0.5, 6.0  # observed orders are clamped into this range
WARN_ABOVE = 0.01  # a headline estimated above 1 % is a warning
TOLERANCE_RANGE = (1e-6, 0.5)  # --accuracy TOL: below 1e-6 round-off and solver tolerances dominate
DEFAULT_MAX_LEVELS = 3  # --accuracy: refinements beyond the case's mesh


# -- reading headlines --------------------------------------------------------------------------------------
def _walk(data: Any, parts: Sequence[str], prefix: str) -> list[tuple[str, Any]]:
    if not parts:
        return [(prefix, data)]
    head, rest = parts[0], parts[1:]
    if isinstance(data, Mapping):
        items = [(k, v) for k, v in data.items() if fnmatchcase(str(k), head)]
    elif isinstance(data, list):
        items = [(str(i), v) for i, v in enumerate(data) if head == "*" or head == str(i)]
    else:
        return []
    return [hit for k, v in items for hit in _walk(v, rest, f"{prefix}{k}.")]


def lookup(summary: Mapping[str, Any], path: str) -> Any:
    """The value at a concrete dotted ``path`` (list indices as numbers), or None."""
    hits = _walk(summary, path.split("."), "")
    return hits[0][1] if hits else None


def _number(v: Any) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)


def headline_values(summary: Mapping[str, Any]) -> dict[str, tuple[float, float]]:
    """Every headline number of ``summary`` by concrete path: (value, the size its relative error refers to:
    the largest of its own and its references' in ``HEADLINES``)."""
    out: dict[str, tuple[float, float]] = {}
    for pattern, refs in HEADLINES:
        for path, value in _walk(summary, pattern.split("."), ""):
            path = path.rstrip(".")
            if not _number(value):
                continue
            scale = abs(float(value))
            stars = [p for p, q in zip(path.split("."), pattern.split(".")) if q == "*"]
            if pattern in NOT_WHEN:
                other, excluded = NOT_WHEN[pattern]
                for star in stars:
                    other = other.replace("*", star, 1)
                if lookup(summary, other) == excluded:
                    continue
            for ref_pattern, factor in refs:  # the headline's indices in the reference's pattern
                concrete = ref_pattern
                for star in stars[:ref_pattern.count("*")]:
                    concrete = concrete.replace("*", star, 1)
                ref = lookup(summary, concrete)
                if isinstance(ref, list) and all(_number(c) for c in ref):
                    scale = max(scale, factor * math.sqrt(sum(float(c) ** 2 for c in ref)))
                elif _number(ref):
                    scale = max(scale, factor * abs(float(ref)))
            out[path] = (float(value), scale)
    return out


# -- the estimate ------------------------------------------------------------------------------------------
def richardson(values: Sequence[float | None], ratio: float = RATIO) -> tuple[float | None, float | None]:
    """(absolute error estimate of values[0], observed order or None) from one quantity on successively
    coarser meshes (``values[0]`` the finest; element size ×``ratio`` per step). None: not estimable."""
    if len(values) < 2 or values[0] is None or values[1] is None:
        return None, None
    d1 = values[0] - values[1]
    if d1 == 0.0:
        return 0.0, None
    if len(values) >= 3 and values[2] is not None:
        d2 = values[1] - values[2]
        if d2 != 0.0 and d1 / d2 > 0.0 and abs(d1) < abs(d2):
            order = math.log(abs(d2) / abs(d1)) / math.log(ratio)
            used = min(max(order, MIN_ORDER), MAX_ORDER)
            return abs(d1) / (ratio**used - 1.0), order
    return abs(d1) / (ratio**ASSUMED_ORDER - 1.0), None


def accuracy_table(summaries: Sequence[Mapping[str, Any]], ratio: float = RATIO) -> dict[str, dict[str, Any]]:
    """summary.json's ``accuracy``: per headline path of ``summaries[0]`` (the finest mesh; the others
    successively coarser) ``value``, ``estimate`` (estimated relative error, None when a coarser mesh lacks
    the quantity) and ``order`` (observed, None when the estimate assumed ``ASSUMED_ORDER``)."""
    levels = [headline_values(s) for s in summaries]
    out: dict[str, dict[str, Any]] = {}
    for path, (value, scale) in levels[0].items():
        values = [lv[path][0] if path in lv else None for lv in levels]
        err, order = richardson(values, ratio)
        rel = None if err is None else (0.0 if err == 0.0 else err / scale if scale > 0.0 else math.inf)
        out[path] = {"value": value, "estimate": None if rel is None or not math.isfinite(rel) else rel,
                     "order": order}
    return out


# -- meshes ------------------------------------------------------------------------------------------------
def _with(case, assignments: Mapping[str, Any]):
    from ..inputs.overrides import apply_overrides
    from ..problem.case import case_from_dict

    return case_from_dict(apply_overrides(case.raw, assignments), source=case.source)


def coarser(case):
    """The case on the next coarser mesh (element sizes doubled), or None when there is none:
    ``mesh.refine − 1``, else half of ``mesh.nx`` and ``mesh.nphi`` (each even, or 1 and kept)."""
    spec = case.mesh
    if spec.refine >= 1:
        return _with(case, {"mesh.refine": spec.refine - 1})
    counts = {"mesh.nx": spec.nx, "mesh.nphi": spec.nphi}
    if spec.file or any(n != 1 and n % 2 for n in counts.values()) or all(n == 1 for n in counts.values()):
        return None
    return _with(case, {k: max(n // 2, 1) for k, n in counts.items()})


def no_coarser(case) -> InputError:
    spec = case.mesh
    why = ("a mesh read from a file" if spec.file else
           f"mesh.nx = {spec.nx} and mesh.nphi = {spec.nphi} cannot both be halved (each must be even or 1)")
    return InputError("mesh.refine", "the accuracy estimate compares with the next coarser mesh (mesh.refine − 1, "
                      f"or at mesh.refine = 0 half of mesh.nx and mesh.nphi), and this case has none ({why}): set "
                      "mesh.refine >= 1 (e.g. --set mesh.refine=1 with mesh.nx and mesh.nphi halved)")


def _mesh_of(case) -> dict[str, int]:
    return {"refine": case.mesh.refine, "nx": case.mesh.nx, "nphi": case.mesh.nphi}


@dataclass
class Estimate:
    """A solution with the estimated accuracy of its headlines: ``result`` on the finest mesh solved,
    ``accuracy`` (see ``accuracy_table``), ``levels`` (finest first: mesh, dofs, seconds), and for
    ``refine_to`` the ``tolerance`` and why refinement ``stopped`` short of it (None: it was met)."""

    result: Any
    accuracy: dict[str, dict[str, Any]]
    levels: list[dict[str, Any]]
    tolerance: float | None = None
    stopped: str | None = None
    summaries: list[dict[str, Any]] = field(default_factory=list, repr=False)

    @property
    def met(self) -> bool:
        """Every headline estimate at or below the tolerance (``refine_to``)."""
        tol = self.tolerance
        return tol is not None and all(e["estimate"] is not None and e["estimate"] <= tol
                                       for e in self.accuracy.values())

    def warnings(self) -> list[str]:
        above = {p: e["estimate"] for p, e in self.accuracy.items()
                 if e["estimate"] is not None and e["estimate"] > WARN_ABOVE}
        missing = [p for p, e in self.accuracy.items() if e["estimate"] is None]
        out = []
        if above:
            fine = self.summaries[0] if self.summaries else self.result.summary()
            out.append("accuracy: estimated discretisation error above 1 % (each with what to refine; --set KEY=VALUE "
                       "or the case's [mesh], or run --accuracy 1e-2):\n  " + ";\n  ".join(
                           f"{p} {100 * v:.3g} %{advice(self.result, fine, p)}"
                           for p, v in sorted(above.items(), key=lambda kv: -kv[1])))
        if missing:
            out.append("accuracy: not estimated (missing on the coarser mesh): " + ", ".join(missing)
                       + "; refine the mesh so that the coarser one has it too")
        if self.tolerance is not None and not self.met:
            out.append(f"accuracy: the tolerance {self.tolerance:g} is not met by every headline ({self.stopped}); "
                       "the results are those of the finest mesh reached")
        return out

    def summary(self, summary: dict[str, Any] | None = None) -> dict[str, Any]:
        """``result.summary()`` (or ``summary``) with ``accuracy``, ``refinement`` and the warnings above."""
        s = self.result.summary() if summary is None else summary
        acc = self.accuracy
        if self.tolerance is not None:
            acc = {p: {**e, "met": e["estimate"] is not None and e["estimate"] <= self.tolerance}
                   for p, e in acc.items()}
        fine = self.summaries[0] if self.summaries else s
        acc = {p: {**e, "refine": advice(self.result, fine, p).split("refine ", 1)[-1]}
               if e["estimate"] is not None and e["estimate"] > WARN_ABOVE else e for p, e in acc.items()}
        s["accuracy"] = acc
        s["refinement"] = {"ratio": RATIO, "tolerance": self.tolerance, "stopped": self.stopped,
                           "levels": self.levels}
        s["warnings"] = list(s.get("warnings", [])) + [record(ResultWarning("accuracy", w)) for w in self.warnings()]
        return s


Progress = Callable[[str], None]


class _Coarser(logging.Filter):
    """A coarser mesh's warnings are about that mesh, not the result: logged as info, so named."""

    def filter(self, record: logging.LogRecord) -> bool:
        if record.levelno == logging.WARNING:
            record.levelno, record.levelname = logging.INFO, "INFO"
            record.msg = f"(coarser mesh, for the estimate) {record.msg}"
        return True


def _solve_level(case, max_memory, levels: list[dict[str, Any]], announce: Progress | None, coarse: bool = False):
    from ..analysis.pipeline import solve

    if announce:
        announce(f"solving mesh.refine={case.mesh.refine} nx={case.mesh.nx} nphi={case.mesh.nphi}")
    t0 = time.perf_counter()
    logger, demote = logging.getLogger("shellcontact"), _Coarser()
    with contextlib.ExitStack() as stack:
        if coarse:
            logger.addFilter(demote)
            stack.callback(logger.removeFilter, demote)
        result = solve(case, max_memory=max_memory)
        summary = result.summary()  # a lazy result logs its warnings here
    levels.append({"mesh": _mesh_of(case), "dofs": summary["dofs"], "seconds": time.perf_counter() - t0})
    return result, summary


def estimate(case, levels: int = 3, *, max_memory: float | str | None = None,
             announce: Progress | None = None, function: str = "estimate", log: bool = True) -> Estimate:
    """Solve ``case`` and the ``levels − 1`` next coarser meshes (3: about 1 + 1/4 + 1/16 of one solve) and
    estimate each headline's discretisation error (module docstring). A case with no coarser mesh is
    refused (InputError naming mesh.refine); a third level that does not exist is skipped (the estimate
    then assumes the order ``ASSUMED_ORDER``)."""
    from ..problem.case import expect_case

    expect_case(case, function)
    levels = expect_integer(levels, function, "levels", 2)
    expect_callable(announce, function, "announce")
    ladder = [case]
    while len(ladder) < levels:
        below = coarser(ladder[-1])
        if below is None:
            break
        ladder.append(below)
    if len(ladder) < 2:
        raise no_coarser(case)
    done: list[dict[str, Any]] = []
    sums = []
    for k, c in reversed(list(enumerate(ladder[1:], 1))):  # the coarse meshes first: cheap, a failure costs little
        try:
            sums.insert(0, _solve_level(c, max_memory, done, announce, coarse=True)[1])
        except ShellContactError as exc:
            if k == 1 and isinstance(exc, InputError):  # no estimate without the next coarser mesh
                raise InputError(exc.field, f"{exc.message} (on the next coarser mesh, {_mesh_of(c)}, which the "
                                 "accuracy estimate solves: refine the case's mesh)") from exc
            if k == 1:
                raise
            logging.getLogger("shellcontact").info("accuracy: the coarsest mesh %s failed (%s); two meshes only",
                                                   _mesh_of(c), exc)
    result, fine = _solve_level(case, max_memory, done, announce)
    sums.insert(0, fine)
    return _logged(Estimate(result, accuracy_table(sums), list(reversed(done)), summaries=sums), log)


def _logged(est: Estimate, log: bool) -> Estimate:
    """The estimate's warnings on the package's logger, as analysis logs a result's (stderr from the CLI)."""
    for w in est.warnings() if log else ():
        logging.getLogger("shellcontact").warning("warning: %s", w)
    return est


def check_tolerance(tolerance: Any, option: str = "--accuracy") -> float:
    lo, hi = TOLERANCE_RANGE
    if not isinstance(tolerance, (int, float)) or isinstance(tolerance, bool):
        raise TypeError(f"refine_to(): {option} must be a number, got {type(tolerance).__name__}")
    if not lo <= tolerance <= hi:
        raise InputError(option, f"the relative tolerance must lie in [{lo:g}, {hi:g}] (below {lo:g} round-off "
                         f"and the solver's tolerance decide, above {hi:g} nothing is estimated), got {tolerance!r}")
    return float(tolerance)


def refine_to(case, tolerance: float, *, max_levels: int = DEFAULT_MAX_LEVELS,
              max_memory: float | str | None = None, announce: Progress | None = None) -> Estimate:
    """Estimate on ``case``'s mesh (``estimate``), then refine uniformly (``mesh.refine + 1``) and
    re-estimate with the meshes already solved, until every headline estimate is at most ``tolerance``,
    ``max_levels`` refinements were made, the memory guard (``sizing.check_size``) refuses the next mesh or its
    solve fails. Returns the finest mesh's results with ``stopped`` saying why short of the tolerance (None: met)."""
    from ..contact.punches import place_punches
    from ..problem.sizing import check_size

    tolerance = check_tolerance(tolerance, "tolerance")
    max_levels = expect_integer(max_levels, "refine_to", "max_levels", 0)
    est = estimate(case, 3, max_memory=max_memory, announce=announce, function="refine_to", log=False)
    est.tolerance = tolerance
    current, made = case, 0
    while not est.met:
        if made >= max_levels:
            est.stopped = f"stopped after {made} refinement{'s' * (made != 1)} (--max-levels {max_levels})"
            break
        finer = _with(current, {"mesh.refine": current.mesh.refine + 1})
        try:
            check_size(finer, place_punches(finer.punches, finer.shell), max_memory, finer.solver.method,
                       finer.solver.backend, what=f"mesh.refine = {finer.mesh.refine}")
        except InputError as exc:
            est.stopped = f"the memory guard stopped the refinement: {exc.message}"
            break
        try:
            result, fine = _solve_level(finer, max_memory, est.levels, announce)
        except ShellContactError as exc:  # the results reached stand
            est.stopped = f"the solve on mesh.refine = {finer.mesh.refine} failed: {exc}"
            break
        est.levels.insert(0, est.levels.pop())
        est.summaries.insert(0, fine)
        est = Estimate(result, accuracy_table(est.summaries[:3]), est.levels, tolerance, None, est.summaries)
        current, made = finer, made + 1
    return _logged(est, True)


def run_mode(case, estimate_only: bool, tolerance: float | None, strict: bool, max_levels: int):
    """``run``'s --estimate / --accuracy TOL / --strict / --max-levels, checked before anything is solved:
    how to solve (``estimate`` or ``refine_to`` with the options bound), None for a plain run."""
    if estimate_only and tolerance is not None:
        raise InputError("--accuracy", "refines until the estimates meet TOL and estimates anyway: drop --estimate")
    if strict and tolerance is None:
        raise InputError("--strict", "makes an unmet --accuracy TOL exit 1: give --accuracy TOL too")
    if not estimate_only and tolerance is None:
        return None
    if coarser(case) is None:
        raise no_coarser(case)
    if estimate_only:
        return estimate
    tolerance = check_tolerance(tolerance)
    if max_levels < 0:
        raise InputError("--max-levels", f"must be an integer >= 0, got {max_levels}")
    return functools.partial(refine_to, tolerance=tolerance, max_levels=max_levels)


def _valued(path: str, value: float, system: str) -> str:
    """A headline's value with the unit of its quantity (as summary.json's ``units`` gives it)."""
    kind = unit_kind(f"accuracy.{path}.value")  # none or nobody classified it: shown bare, as in the units map
    return with_unit(f"{value:.6g}", kind, system) if kind else f"{value:.6g}"


def describe(est: Estimate) -> list[str]:
    """Console lines: the meshes solved and the headlines with their estimates."""
    system = est.result.case.units
    meshes = ", ".join(f"{lv['dofs']} dofs ({lv['seconds']:.2f} s)" for lv in est.levels)
    lines = [f"accuracy: from {len(est.levels)} meshes, finest first: {meshes}"]
    for path, e in est.accuracy.items():
        v = e["estimate"]
        how = "not estimated" if v is None else f"{100 * v:.2g} %" + (
            f" (observed order {e['order']:.2g})" if e["order"] is not None else " (order 1 assumed)")
        met = "" if est.tolerance is None or v is None else (" met" if v <= est.tolerance else " NOT met")
        lines.append(f"  {path:<34} {_valued(path, e['value'], system):<16} ± {how}{met}")
    if est.tolerance is not None:
        lines.append(f"tolerance {est.tolerance:g}: " + ("met by every headline" if est.met else est.stopped or ""))
    return lines
