"""Case files (docs/case-file.md): every example loads, bad input names its key, and a
thickness given as a function t(x, φ) behaves as the mathematics says it must."""

from __future__ import annotations

import copy
import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

import shellcontact as sc
from shellcontact.errors import InputError
from shellcontact.shell.material import Isotropic

EXAMPLES = sorted((Path(__file__).resolve().parents[1] / "examples").glob("*.toml"))

BASE = {
    "shell": {"radius": 1.0, "length": 2.0, "angle": [0.0, 30.0], "thickness": 0.1, "young": 1.0, "poisson": 0.3},
    "supports": {"x_min": "clamped", "x_max": "clamped", "phi_min": "free", "phi_max": "free"},
    "mesh": {"nx": 4, "nphi": 4},
    "loads": {"normal": 1.0},
    "probes": [{"x": 0.0, "phi": 15.0}],
}


@pytest.mark.parametrize("path", EXAMPLES, ids=[p.name for p in EXAMPLES])
def test_every_example_loads(path):
    case = sc.load_case(path)
    assert case.source == path
    assert case.shell.radius > 0 and case.mesh.nx >= 1


def test_benchmark_examples_describe_the_benchmarks(examples_dir):
    sl = sc.load_case(examples_dir / "scordelis_lo.toml")
    assert (sl.shell.radius, sl.shell.thickness) == (25.0, 0.25)
    assert sl.shell.material == Isotropic(4.32e8, 0.0)
    assert math.isclose(math.degrees(sl.shell.beta - sl.shell.alpha), 40.0)  # quarter of the 80° roof
    assert sl.loads.surface == (0.0, 0.0, -90.0)
    for name in ("pinched_cylinder_eighth.toml", "pinched_cylinder_full.toml"):
        pc = sc.load_case(examples_dir / name)
        assert (pc.shell.radius, pc.shell.thickness) == (300.0, 3.0)
        assert pc.shell.material == Isotropic(3.0e6, 0.3)
        assert pc.supports.x_max == "simply_supported"
        n = 4 if "eighth" in name else 2  # each modelled load carries P/4 or P/2
        assert all(math.isclose(np.linalg.norm(p.force), 1.0 / n) for p in pc.loads.points)
    full = sc.load_case(examples_dir / "pinched_cylinder_full.toml")
    assert full.shell.full and full.supports.periodic
    pr = sc.load_case(examples_dir / "pressurized_cylinder.toml")
    assert pr.supports.x_min == pr.supports.x_max == "clamped" and pr.loads.normal > 0


def _with(path: str, value):
    """BASE with the entry at a dotted path replaced (value None deletes it)."""
    d = copy.deepcopy(BASE)
    keys = path.split(".")
    node = d
    for k in keys[:-1]:
        node = node[int(k)] if isinstance(node, list) else node.setdefault(k, {})
    if value is None:
        del node[keys[-1]]
    else:
        node[keys[-1]] = value
    return d


BAD = [
    ("shell.radius", 0.0, "shell.radius", "> 0"),
    ("shell.radius", -2.0, "shell.radius", "> 0"),
    ("shell.radius", "1", "shell.radius", "must be a number"),
    ("shell.length", 0, "shell.length", "> 0"),
    ("shell.thickness", 0.0, "shell.thickness", "> 0"),
    ("shell.thickness", -0.1, "shell.thickness", "> 0"),
    ("shell.thickness", 1.0, "shell.thickness", "< radius"),
    ("shell.thickness", 3.0, "shell.thickness", "< radius"),
    ("shell.young", -1.0, "shell.young", "> 0"),
    ("shell.poisson", 0.5, "shell.poisson", "(-1, 0.5)"),
    ("shell.poisson", -1.0, "shell.poisson", "(-1, 0.5)"),
    ("shell.poisson", 0.7, "shell.poisson", "(-1, 0.5)"),
    ("shell.poisson", None, "shell.poisson", "required"),
    ("shell.angle", [30.0, 30.0], "shell.angle", "alpha < beta"),
    ("shell.angle", [40.0, 10.0], "shell.angle", "alpha < beta"),
    ("shell.angle", [0.0, 400.0], "shell.angle", "360"),
    ("shell.angle", [0.0], "shell.angle", "list of 2"),
    ("shell.angle", None, "shell.angle", "required unless full"),
    ("shell.full", "yes", "shell.full", "true or false"),
    ("shell.radiuss", 1.0, "shell.radiuss", "did you mean 'radius'"),
    ("shell.thickness", "no_such_module_xyz:t", "shell.thickness", "--allow-code"),
    ("supports.x_min", "pinned", "supports.x_min", "must be one of"),
    ("supports.x_min", "periodic", "supports.x_min", "phi edges"),
    ("supports.phi_min", "periodic", "supports.phi_min", "both"),
    ("supports.x_mn", "free", "supports.x_mn", "did you mean 'x_min'"),
    ("mesh.nx", 3.5, "mesh.nx", "integer"),
    ("mesh.nx", 0, "mesh.nx", ">= 1"),
    ("mesh.nphi", "8", "mesh.nphi", "integer"),
    ("mesh.refine", -1, "mesh.refine", ">= 0"),
    ("mesh.pattern", "zigzag", "mesh.pattern", "alternate"),
    ("mesh.grading", {"x": [0.0], "ratios": 2.0}, "mesh.grading.ratios", "did you mean 'ratio'"),
    ("mesh.grading", {"x": [0.0], "ratio": 0.5}, "mesh.grading.ratio", "in [1, 1000]"),
    ("mesh.nxx", 4, "mesh.nxx", "did you mean 'nx'"),
    ("loads.surface", [0.0, 1.0], "loads.surface", "list of 3"),
    ("loads.normal", "high", "loads.normal", "must be a number"),
    ("loads.point", [{"x": 0.0, "phi": 10.0, "forc": [1, 2, 3]}], "loads.point.0.forc", "did you mean 'force'"),
    ("loads.point", [{"x": 0.0, "phi": 10.0}], "loads.point.0.force", "required"),
    ("loads.point", [{"x": 5.0, "phi": 10.0, "force": [0, 0, 1]}], "loads.point.0.x", "outside"),
    ("loads.point", [{"x": 0.0, "phi": 45.0, "force": [0, 0, 1]}], "loads.point.0.phi", "outside"),
    ("loads.line", [{"x": 0.0, "phi": 3.0}], "loads.line.0", "exactly one"),
    ("loads.line", [{"x": 0.0, "normal": [1.0]}], "loads.line.0.normal", "must be a number"),
    ("probes", [{"x": 0.0, "ph": 3.0}], "probes.0.ph", "did you mean 'phi'"),
    ("probes", [{"x": 0.0, "phi": -5.0}], "probes.0.phi", "outside"),
    ("solver.metod", "x", "solver.metod", "did you mean 'method'"),
    ("shel", {}, "shel", "did you mean 'shell'"),
]


@pytest.mark.parametrize(("path", "value", "field", "fragment"), BAD, ids=[f"{b[0]}={b[1]!r}" for b in BAD])
def test_bad_input_names_the_key(path, value, field, fragment):
    with pytest.raises(InputError) as exc:
        sc.case_from_dict(_with(path, value))
    assert exc.value.field == field, str(exc.value)
    assert fragment in exc.value.message, str(exc.value)


def test_full_cylinder_rules():
    d = copy.deepcopy(BASE)
    d["shell"].pop("angle")
    d["shell"]["full"] = True
    d["supports"] = {"x_min": "clamped", "x_max": "clamped"}
    case = sc.case_from_dict(d)
    assert case.supports.periodic and math.isclose(case.shell.beta - case.shell.alpha, 2 * math.pi)
    with pytest.raises(InputError, match="either 'angle' or 'full") as exc:
        sc.case_from_dict({**d, "shell": {**d["shell"], "angle": [0.0, 90.0]}})
    assert exc.value.field == "shell.angle"
    with pytest.raises(InputError) as exc:
        sc.case_from_dict({**d, "supports": {"phi_min": "free", "phi_max": "free"}})
    assert exc.value.field == "supports.phi_min"
    # periodic on a panel
    with pytest.raises(InputError, match="full cylinder") as exc:
        sc.case_from_dict(_with("supports", {"phi_min": "periodic", "phi_max": "periodic"}))
    assert exc.value.field == "supports.phi_min"


def test_file_errors(tmp_path):
    with pytest.raises(InputError) as exc:
        sc.load_case(tmp_path / "missing.toml")
    assert exc.value.field == "case" and "cannot read" in exc.value.message
    bad = tmp_path / "bad.toml"
    bad.write_text("[shell]\nradius = = 3\n")
    with pytest.raises(InputError) as exc:
        sc.load_case(bad)
    assert exc.value.field == "case" and "malformed TOML" in exc.value.message


def test_summary_of_a_solve_has_the_interface_keys():
    res = sc.solve(sc.case_from_dict(BASE))
    s = res.summary()
    for key in ("dofs", "elements", "energy", "max_abs_w", "probes", "timings"):
        assert key in s
    for key in ("mesh", "assembly", "factorization", "solve", "output", "total"):
        assert key in s["timings"]
    p = s["probes"][0]
    assert set(p) >= {"x", "phi", "u", "v", "w", "displacement"} and len(p["displacement"]) == 3
    # internal pressure pushes the shell outward; the global displacement is w n + u e1 + v e2
    phi = math.radians(p["phi"])
    n = np.array([0.0, math.cos(phi), math.sin(phi)])
    e2 = np.array([0.0, -math.sin(phi), math.cos(phi)])
    assert p["w"] > 0
    assert np.allclose(p["displacement"], p["u"] * np.array([1.0, 0, 0]) + p["v"] * e2 + p["w"] * n, atol=1e-15)


# ---------------------------------------------------------------------------------------------
# thickness as a function of (x, φ)
# ---------------------------------------------------------------------------------------------
def _compliance(case: sc.Case) -> float:
    sol = sc.solve(case).solution
    return float(sol.F @ sol.U)


def test_thickness_function_from_a_case_file(tmp_path):
    """'module:function' thickness from the case file's directory (allow_code=True); a function returning the
    constant reproduces the constant case."""
    (tmp_path / "my_thickness.py").write_text(
        "import numpy as np\n"
        "def constant(x, phi):\n    return 0.1 + 0 * x\n"
        "def tapered(x, phi):\n    return 0.1 * (1.0 + 0.5 * (x + 1.0) / 2.0)\n"
        "def too_thick(x, phi):\n    return 2.0 + 0 * x\n"
    )
    beside = {"source": tmp_path / "case.toml", "allow_code": True}
    ref = sc.solve(sc.case_from_dict(BASE)).solution
    c = sc.solve(sc.case_from_dict(_with("shell.thickness", "my_thickness:constant"), **beside)).solution
    diff = np.abs(c.U - ref.U).max() / np.abs(ref.U).max()
    print(f"\nconstant thickness as a function vs as a number: max relative difference {diff:.1e}")
    assert diff < 1e-10
    tapered = sc.case_from_dict(_with("shell.thickness", "my_thickness:tapered"), **beside)
    assert np.allclose(tapered.shell.t(np.array([-1.0, 1.0]), np.zeros(2)), [0.1, 0.15])
    with pytest.raises(InputError) as exc:
        sc.case_from_dict(_with("shell.thickness", "my_thickness:too_thick"), **beside)
    assert exc.value.field == "shell.thickness"


def test_variable_thickness_monotonicity_and_limit(rates):
    """t(x) = t0 (1 + ε ξ), ξ ∈ [0, 1]: the compliance F·U lies between those of the constant
    thicknesses t0 and t0 (1 + ε) (a(·,·) grows with t), and tends to the constant-t0 value like ε."""
    case = sc.case_from_dict(BASE)
    sh = case.shell
    t0 = float(sh.thickness)

    def shell_with(eps: float):
        return replace(sh, thickness=lambda x, phi: t0 * (1.0 + eps * (x - sh.x_min) / sh.length))

    c0 = _compliance(case)
    rows = []
    for eps in (0.08, 0.04, 0.02, 0.01):
        ce = _compliance(replace(case, shell=shell_with(eps)))
        c_thick = _compliance(replace(case, shell=replace(sh, thickness=t0 * (1.0 + eps))))
        assert c_thick < ce < c0, eps
        rows.append((eps, ce, abs(ce - c0) / c0))
    r = rates([e for e, *_ in rows], [d for *_, d in rows])
    print("\n  eps      compliance    |C(eps) - C(0)|/C(0)")
    for eps, ce, d in rows:
        print(f"{eps:6.3f} {ce:14.8e} {d:12.3e}")
    print(f"observed orders in eps: {np.round(r, 3)}")
    assert np.all(np.abs(r - 1.0) < 0.1)


def test_thickness_function_enters_the_stiffness_at_x_phi():
    """u = x (ε11 = 1, all other strains 0) has a(U, U) = E/(1 − μ²) ∫ t(x, φ) a dx dφ exactly."""
    from shellcontact.shell import model
    from shellcontact.shell.mesh import structured
    from shellcontact.shell.spaces import QUANTITIES, ShellSpace

    sh0 = sc.case_from_dict(BASE).shell
    t0, al, be = 0.1, sh0.alpha, sh0.beta
    sh = replace(sh0, thickness=lambda x, phi: t0 * (1.0 + 0.2 * x + 0.3 * (phi - al) / (be - al)))
    space = ShellSpace(structured(sh, 3, 3))
    A = model.stiffness(space)

    def stretch(x, s):
        out = {k: 0.0 * x for k in QUANTITIES}
        out.update(u=x, u_x=1.0 + 0.0 * x)
        return out

    U = space.interpolate(stretch)
    # ∫∫ t a dx dφ over [x_min, x_max] × [α, β] for the linear t above
    xm = 0.5 * (sh.x_min + sh.x_max)
    integral = t0 * sh.length * sh.radius * (be - al) * (1.0 + 0.2 * xm + 0.15)
    exact = sh.material.young / (1 - sh.material.poisson**2) * integral
    assert math.isclose(float(U @ (A @ U)), exact, rel_tol=1e-12)


def test_position_dependent_load_from_a_case_file(tmp_path, monkeypatch):
    """loads.normal = "module:callable" is the same load as the callable given from Python."""
    import shellcontact.shell.loads as ld

    (tmp_path / "myloads.py").write_text(
        "import numpy as np\n\ndef hydro(x, phi):\n    return 9810.0 * (1.0 - np.sin(phi)) * (1.0 + 0.1 * x)\n"
    )
    monkeypatch.syspath_prepend(str(tmp_path))
    raw = {
        "shell": {"radius": 1.0, "length": 2.0, "full": True, "thickness": 0.01, "young": 2e11, "poisson": 0.3},
        "supports": {"x_min": "clamped", "x_max": "clamped"},
        "mesh": {"nx": 6, "nphi": 8},
        "loads": {"normal": "myloads:hydro"},
    }
    case = sc.case_from_dict(raw, allow_modules=["myloads"])
    assert callable(case.loads.normal)
    import myloads

    from_python = sc.case_from_dict({**raw, "loads": {}})
    from_python.loads = ld.Loads(normal=myloads.hydro)
    e1, e2 = sc.solve(case).solution.energy, sc.solve(from_python).solution.energy
    assert e1 == pytest.approx(e2, rel=1e-13) and e1 > 0
    with pytest.raises(sc.InputError, match="loads.normal"):
        sc.case_from_dict({**raw, "loads": {"normal": "myloads:nothing"}}, allow_modules=["myloads"])
