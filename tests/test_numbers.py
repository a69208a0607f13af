"""Numbers that never lie (issue 12, item 6): scale-free stopping tests, the penalty range, KKT
warnings, strict JSON, non-finite results, extreme moduli, the force-control travel range."""

from __future__ import annotations

import json
import math
import tomllib
from pathlib import Path

import numpy as np
import pytest

from shellcontact.analysis.discretization import discretize
from shellcontact.analysis.pipeline import penalty_ratio, solve
from shellcontact.cli import main
from shellcontact.errors import InputError, SolverError
from shellcontact.outputs.files import json_text
from shellcontact.problem.case import case_from_dict
from shellcontact.solvers import solve_active_set, solve_dual
from shellcontact.solvers.qp import ContactQP

ROOT = Path(__file__).resolve().parent.parent
PANEL = tomllib.loads((ROOT / "examples" / "paper_panel.toml").read_text())
COARSE = {"nx": 8, "nphi": 8, "grading": {"x": [0.0], "phi": [90.0], "ratio": 4.0}}


def panel(**changes) -> dict:
    """The paper panel on a coarse mesh, with section-level changes (``punch=`` replaces punch 0's keys)."""
    raw = json.loads(json.dumps(PANEL))
    raw["mesh"] = dict(COARSE)
    for section, values in changes.items():
        if section == "punch":
            raw["punch"][0].update(values)
            raw["punch"][0] = {k: v for k, v in raw["punch"][0].items() if v is not None}
        else:
            raw.setdefault(section, {}).update(values)
    return raw


def strict_loads(text: str):
    def refuse(name: str):
        raise AssertionError(f"non-strict JSON constant {name}")

    return json.loads(text, parse_constant=refuse)


# -- the dual at tiny indentations ---------------------------------------------------------------------------
def test_dual_agrees_with_active_set_from_1e_9_to_1e_2() -> None:
    """Both exact methods solve the same QP; they must give the same force at every indentation (the
    dual returned force 0 at 1e-12: its stopping test was absolute, relative to max|G| of the zone). Below
    1e-9 m an indentation is refused, as below what the gap resolves (tests/test_edges.py)."""
    compliance = {}
    for d in 10.0 ** np.arange(-9, -1):
        case = case_from_dict(panel(punch={"indentation": float(d)}))
        results = {m: solve(case, method=m) for m in ("active-set", "dual")}
        forces = {m: r.summary()["contact"][0]["force_magnitude"] for m, r in results.items()}
        assert forces["active-set"] > 0
        # tol = 1e-10 on the scaled residuals; 100x for the conditioning of the active block of S
        assert abs(forces["dual"] - forces["active-set"]) <= 1e-8 * forces["active-set"], (d, forces)
        for m, r in results.items():
            c = r.contact
            if c.active.sum() == 1:  # one contact point i: Λ_i = −G_i / S_ii exactly (F = 0)
                i = int(np.flatnonzero(c.active)[0])
                compliance.setdefault((m, i), []).append(-c.operator.G[i] / c.Lambda[i])
    # while the active set is the same single point (same mesh: the zone is given), S_ii is the same
    # number: linear in the overlap to round-off, down to 1e-9
    assert compliance and all(len(v) >= 5 for v in compliance.values()), compliance
    for v in compliance.values():
        assert np.ptp(v) <= 1e-12 * np.mean(v), v


def _scaled(qp: ContactQP, s: float) -> ContactQP:
    return ContactQP(qp.A, qp.F, qp.B, s * qp.G, qp.weights, symmetric=True)


@pytest.mark.parametrize("solver", [solve_active_set, solve_dual], ids=["active-set", "dual"])
def test_exact_linearity_in_the_gap(solver) -> None:
    """Without loads (F = 0) the QP is homogeneous in G: Λ(sG) = sΛ(G) exactly. With s a power of two
    the floating-point operations scale exactly too, so solvers whose every threshold is relative to
    the problem's own scales (no absolute tolerance anywhere) reproduce Λ(G) to round-off and the
    same active set from s = 2⁻⁴⁰ (indentation 1e-14) to 2⁴."""
    d = discretize(case_from_dict(panel(punch={"indentation": 1e-2})))
    qp = d.qp()
    assert not np.any(qp.F)
    ref = solver(qp)
    assert ref.active.sum() > 1  # a contact zone, not a single point
    for k in range(-40, 5, 4):
        s = 2.0**k
        sol = solver(_scaled(qp, s))
        assert np.array_equal(sol.active, ref.active), k
        np.testing.assert_allclose(sol.Lambda / s, ref.Lambda, rtol=0, atol=1e-12 * ref.Lambda.max())


# -- penalty range and KKT warnings --------------------------------------------------------------------------
def test_penalty_far_outside_its_range_is_refused() -> None:
    case = case_from_dict(panel(solver={"method": "penalty"}))
    eps_unit = 1.0 / penalty_ratio(case, 1.0)  # ε for κ = 1
    for kappa in (10.0, 1e-16):
        c = case_from_dict(panel(solver={"method": "penalty", "penalty": kappa * eps_unit}))
        with pytest.raises(InputError) as exc:
            solve(c)
        assert exc.value.field == "solver.penalty"
    c = case_from_dict(panel(solver={"method": "penalty", "continuation": [10 * eps_unit]}))
    with pytest.raises(InputError, match="solver.continuation"):
        solve(c)


def test_penalty_warnings_in_summary_and_on_stderr(tmp_path: Path, capsys) -> None:
    """κ = 1e-2: accepted with a warning (force error ~1 %); every penalty result carries the KKT
    warning (its residuals are O(ε), above the tolerance of its penalised equation)."""
    eps = 1e-2 / penalty_ratio(case_from_dict(panel()), 1.0)
    raw = panel(solver={"method": "penalty", "penalty": eps})
    case_path = tmp_path / "case.toml"
    case_path.write_text(_toml(raw))
    assert main(["run", str(case_path), "-o", str(tmp_path / "out"), "--no-figures", "--no-report"]) == 0
    summary = strict_loads((tmp_path / "out" / "summary.json").read_text())
    warnings = summary["warnings"]
    assert any(w["code"] == "penalty_accuracy" and w["message"].startswith("solver.penalty") for w in warnings)
    assert any(w["code"] == "kkt_residual" and "penetration" in w["message"] for w in warnings)
    # the scaled penetration the tolerance judges, then the one summary.json's kkt (and the demo's table) give, in m
    pen = (f"penetration {summary['kkt_scaled']['penetration']:.2e} "
           f"(= {summary['kkt']['penetration']:.2e} {summary['units']['kkt.penetration']})")
    assert any(pen in w["message"] for w in warnings), (pen, warnings)
    err = capsys.readouterr().err
    assert "solver.penalty" in err and "KKT" in err
    # an exact method at its tolerance: no KKT warning
    res = solve(case_from_dict(panel()))
    assert not [w for w in res.summary()["warnings"] if w["code"] == "kkt_residual"]
    assert max(res.summary()["kkt_scaled"].values()) <= res.case.solver.tolerance


def _toml(raw: dict) -> str:
    def value(v) -> str:
        if isinstance(v, bool):
            return "true" if v else "false"
        if isinstance(v, str):
            return json.dumps(v)
        if isinstance(v, dict):
            return "{" + ", ".join(f"{k} = {value(x)}" for k, x in v.items()) + "}"
        if isinstance(v, list):
            return "[" + ", ".join(value(x) for x in v) + "]"
        return repr(v)

    lines = []
    for section, body in raw.items():
        for table in body if isinstance(body, list) else [body]:
            lines.append(f"[[{section}]]" if isinstance(body, list) else f"[{section}]")
            lines += [f"{k} = {value(v)}" for k, v in table.items()]
    return "\n".join(lines) + "\n"


# -- strict JSON, non-finite results ---------------------------------------------------------------------------
def test_json_text_is_strict() -> None:
    for bad in (math.nan, math.inf, -math.inf, np.float64("nan"), np.float32("inf")):
        with pytest.raises(ValueError):
            json_text({"x": [1.0, bad]})
    assert strict_loads(json_text({"x": [1.0, np.float32(2.0)]})) == {"x": [1.0, 2.0]}


def test_summary_has_no_nan_and_omits_missing_residuals() -> None:
    for method in ("active-set", "dual", "penalty"):
        res = solve(case_from_dict(panel()), method=method)
        summary = res.summary()
        strict_loads(json_text(summary))
        assert all(isinstance(v, float) and math.isfinite(v) for v in summary["kkt"].values())
    res.contact.solution.residuals.pop("duality_gap")
    assert "duality_gap" not in res.summary()["kkt"]


def test_non_finite_result_is_exit_3_naming_the_quantity(tmp_path: Path, monkeypatch, capsys) -> None:
    from shellcontact.linalg.protocol import Factorization

    raw = panel()
    del raw["punch"]
    case_path = tmp_path / "case.toml"
    case_path.write_text(_toml(raw))
    monkeypatch.setattr(Factorization, "solve", lambda self, b, *a, **k: np.full_like(b, np.nan))
    with pytest.raises(SolverError, match="the displacements U"):
        solve(case_from_dict(raw))
    assert main(["run", str(case_path), "-o", str(tmp_path / "out")]) == 3
    assert "non-finite result: the displacements U" in capsys.readouterr().err
    assert not (tmp_path / "out" / "summary.json").exists()


# -- extreme moduli ---------------------------------------------------------------------------------------
@pytest.mark.parametrize("young", [1e200, 1e-200, 1e29])
def test_extreme_young_is_refused_by_name(young: float) -> None:
    # every dimensional number must lie within 1e±30 (schema); 1e29 (t = 0.01: E·t = 1e27) passes
    raw = panel(shell={"young": young})
    if young == 1e29:
        case_from_dict(raw)
        return
    with pytest.raises(InputError) as exc:
        case_from_dict(raw)
    assert exc.value.field == "shell.young"
    assert "1e-30" in exc.value.message and "1e+30" in exc.value.message


def test_stiffness_products_beyond_range_are_refused_by_name() -> None:
    """Each number within 1e±30, their product not: E·t³ = 1e-28 · (1e-25)³ = 1e-103 < 1e-100."""
    raw = panel(shell={"young": 1e-28, "thickness": 1e-25})
    with pytest.raises(InputError) as exc:
        case_from_dict(raw)
    assert exc.value.field == "shell.young"
    assert "1e-100" in exc.value.message and "1e+100" in exc.value.message


def test_extreme_orthotropic_modulus_is_refused_by_name(tmp_path: Path, capsys) -> None:
    raw = panel()
    del raw["shell"]["young"], raw["shell"]["poisson"]
    raw["material"] = {"model": "orthotropic", "e1": 2e11, "e2": 1e-120, "g12": 8e10, "nu12": 0.3}
    with pytest.raises(InputError) as exc:
        case_from_dict(raw)
    assert exc.value.field == "material.e2"
    case_path = tmp_path / "case.toml"
    case_path.write_text(_toml(raw))
    assert main(["run", str(case_path), "-o", str(tmp_path / "out")]) == 2
    assert "material.e2" in capsys.readouterr().err


# -- force control: the linear-theory range ---------------------------------------------------------------------
def test_force_beyond_linear_range_is_exit_2_naming_the_force() -> None:
    """The same limit as an indentation (placement: ≤ 10 thicknesses, ≤ 0.2 radius): a force whose
    travel exceeds it is refused after the solve, naming punch.0.force."""
    ok = solve(case_from_dict(panel(punch={"indentation": None, "force": 2.7e5})))
    travel = ok.summary()["contact"][0]["punch_travel"]
    assert 0 < travel < 0.1  # 10 thicknesses of 0.01
    with pytest.raises(InputError) as exc:
        solve(case_from_dict(panel(punch={"indentation": None, "force": 1e10})))
    assert exc.value.field == "punch.0.force"
    assert "thicknesses" in exc.value.message or "radius" in exc.value.message
