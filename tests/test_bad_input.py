"""Every kind of bad input gives one clear message naming the key and what is allowed, exit
status 2 and no traceback; a solver failure gives exit status 3 with the residuals.

Each case runs the command line as a subprocess (``python -m shellcontact.cli``).
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest
from inprocess import run_cli

ENV = {**os.environ, "OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1"}

BASE = textwrap.dedent(
    """\
    [shell]
    radius = 25.0
    length = 25.0
    x_start = 0.0
    angle = [50.0, 90.0]
    thickness = 0.25
    young = 4.32e8
    poisson = 0.0

    [supports]
    x_min = "symmetry"
    x_max = "simply_supported"
    phi_min = "free"
    phi_max = "symmetry"

    [mesh]
    nx = 2
    nphi = 2

    [loads]
    surface = [0.0, 0.0, -90.0]

    [[probes]]
    x = 0.0
    phi = 50.0
    """
)


def cli(*args: str, cwd: Path) -> subprocess.CompletedProcess:
    cmd = [sys.executable, "-m", "shellcontact.cli", *args]
    return subprocess.run(cmd, cwd=cwd, env=ENV, capture_output=True, text=True, timeout=120)


def edit(text: str, old: str, new: str) -> str:
    assert old in text, old
    return text.replace(old, new)


# (id, case text, extra arguments, fragments the message must contain)
CASES = [
    (
        "unknown-key-did-you-mean",
        edit(BASE, "radius = 25.0", "radus = 25.0"),
        [],
        ["shell.radus", "unknown key", "did you mean 'radius'"],
    ),
    ("unknown-section-did-you-mean", edit(BASE, "[mesh]", "[mseh]"), [], ["mseh", "did you mean 'mesh'"]),
    (
        "wrong-type-number",
        edit(BASE, "young = 4.32e8", 'young = "steel"'),
        [],
        ["shell.young", "must be a number", "str"],
    ),
    ("wrong-type-integer", edit(BASE, "nx = 2", "nx = 2.5"), [], ["mesh.nx", "must be an integer"]),
    (
        "wrong-type-bool",
        edit(BASE, "x_start = 0.0", 'full = "yes"\nx_start = 0.0'),
        [],
        ["shell.full", "true or false"],
    ),
    ("poisson-out-of-range", edit(BASE, "poisson = 0.0", "poisson = 0.7"), [], ["shell.poisson", "(-1, 0.5)"]),
    ("thickness-negative", edit(BASE, "thickness = 0.25", "thickness = -0.25"), [], ["shell.thickness", "> 0"]),
    ("thickness-above-radius", edit(BASE, "thickness = 0.25", "thickness = 30.0"), [], ["shell.thickness", "< radius"]),
    ("angle-order", edit(BASE, "angle = [50.0, 90.0]", "angle = [90.0, 50.0]"), [], ["shell.angle", "alpha < beta"]),
    ("mesh-nx-zero", edit(BASE, "nx = 2", "nx = 0"), [], ["mesh.nx", ">= 1"]),
    (
        "mesh-pattern",
        edit(BASE, "nphi = 2", 'nphi = 2\npattern = "zigzag"'),
        [],
        ["mesh.pattern", "must be one of", "zigzag"],
    ),
    (
        "support-kind",
        edit(BASE, 'x_min = "symmetry"', 'x_min = "glued"'),
        [],
        ["supports.x_min", "must be one of", "clamped", "glued"],
    ),
    ("rigid-motion-free", edit(BASE, 'x_min = "symmetry"', 'x_min = "free"'), [], ["supports", "rigid-body motion"]),
    (
        "vector-length",
        edit(BASE, "surface = [0.0, 0.0, -90.0]", "surface = [0.0, -90.0]"),
        [],
        ["loads.surface", "list of 3"],
    ),
    (
        "missing-section",
        BASE.split("[supports]")[0].replace("[shell]", "[mesh]\nnx = 2").split("radius")[0],
        [],
        ["shell", "section [shell] is required"],
    ),
    ("missing-key", edit(BASE, "young = 4.32e8\n", ""), [], ["shell.young", "is required"]),
    ("malformed-toml", edit(BASE, "radius = 25.0", "radius = = 25.0"), [], ["malformed TOML", "line 2"]),
    ("probe-outside", edit(BASE, "x = 0.0\nphi = 50.0", "x = 100.0\nphi = 50.0"), [], ["probes.0.x", "[0, 25]"]),
    (
        "mesh-file-unreadable",
        edit(BASE, "nphi = 2", 'nphi = 2\nfile = "missing.msh"'),
        [],
        ["mesh.file", "cannot read mesh file", "missing.msh"],
    ),
    ("set-unknown-key", BASE, ["--set", "mesh.nxx=3"], ["mesh.nxx", "did you mean 'nx'"]),
    ("set-bad-value", BASE, ["--set", "mesh.nx=[1,"], ["--set mesh.nx", "not a TOML literal"]),
    ("set-no-equals", BASE, ["--set", "mesh.nx"], ["--set", "expected key=value"]),
    ("set-bad-path", BASE, ["--set", "mesh..nx=3"], ["--set", "bad key path"]),
    ("set-index-range", BASE, ["--set", "probes.5.x=1.0"], ["--set probes.5.x", "out of range", "1 entries"]),
    ("set-into-scalar", BASE, ["--set", "shell.radius.value=3"], ["--set shell.radius.value", "not a table"]),
    ("set-missing-array", BASE, ["--set", "punch.0.indentation=1e-3"], ["punch", "no entries", "[[punch]]"]),
    ("set-wrong-type", BASE, ["--set", "mesh.nx=four"], ["mesh.nx", "must be an integer", "four"]),
    ("method-choice", BASE, ["--method", "magic"], ["--method", "invalid choice", "dual"]),
]


@pytest.mark.parametrize("text,extra,fragments", [c[1:] for c in CASES], ids=[c[0] for c in CASES])
def test_bad_case(tmp_path: Path, text: str, extra: list[str], fragments: list[str]) -> None:
    (tmp_path / "case.toml").write_text(text)
    r = cli("run", "case.toml", "-o", "out", "--no-figures", *extra, cwd=tmp_path)
    assert r.returncode == 2, r.stderr
    assert "Traceback" not in r.stderr
    msg = r.stderr.strip().splitlines()[-1]
    for f in fragments:
        assert f in msg, (f, msg)
    assert not (tmp_path / "out" / "summary.json").exists()


def test_missing_case_file(tmp_path: Path) -> None:
    r = cli("run", "nowhere.toml", "-o", "out", cwd=tmp_path)
    assert r.returncode == 2 and "Traceback" not in r.stderr
    assert "cannot read 'nowhere.toml'" in r.stderr and "No such file" in r.stderr


def test_not_utf8(tmp_path: Path) -> None:
    (tmp_path / "case.toml").write_bytes(b"[shell]\nradius = \xff\xfe\n")
    r = cli("run", "case.toml", cwd=tmp_path)
    assert r.returncode == 2 and "Traceback" not in r.stderr
    assert "not a UTF-8 text file" in r.stderr


def test_output_dir_exists(tmp_path: Path) -> None:
    (tmp_path / "case.toml").write_text(BASE)
    (tmp_path / "out").mkdir()
    (tmp_path / "out" / "keep.txt").write_text("precious")
    r = cli("run", "case.toml", "-o", "out", cwd=tmp_path)
    assert r.returncode == 2 and "Traceback" not in r.stderr
    assert "--output" in r.stderr and "exists and is not empty; use --force" in r.stderr
    assert (tmp_path / "out" / "keep.txt").read_text() == "precious"
    assert not (tmp_path / "out" / "summary.json").exists()


def test_output_is_a_file(tmp_path: Path) -> None:
    (tmp_path / "case.toml").write_text(BASE)
    (tmp_path / "out").write_text("")
    r = cli("run", "case.toml", "-o", "out", cwd=tmp_path)
    assert r.returncode == 2 and "exists and is not a directory" in r.stderr


@pytest.mark.parametrize(
    "args,fragments",
    [
        (["sweep", "case.toml", "--param", "shell.thickness", "--values", "0:1"], ["--values", "start:stop:count"]),
        (
            ["sweep", "case.toml", "--param", "shell.thicknes", "--values", "0.2,0.3"],
            ["shell.thicknes", "did you mean 'thickness'"],
        ),
        (
            ["sweep", "case.toml", "--param", "shell.thickness", "--values", "0.2,0.3", "--jobs", "0"],
            ["--jobs", ">= 1"],
        ),
        (["convergence", "case.toml", "--levels", "1"], ["--levels", ">= 2"]),
    ],
    ids=["sweep-values", "sweep-param", "sweep-jobs", "convergence-levels"],
)
def test_bad_study_arguments(tmp_path: Path, args: list[str], fragments: list[str]) -> None:
    (tmp_path / "case.toml").write_text(BASE)
    r = cli(*args, cwd=tmp_path)
    assert r.returncode == 2 and "Traceback" not in r.stderr, r.stderr
    for f in fragments:
        assert f in r.stderr, (f, r.stderr)


PANEL = str(Path(__file__).resolve().parents[1] / "examples" / "paper_panel.toml")


@pytest.mark.parametrize(
    "setting,fragments",
    [
        ("punch.0.radius=-1", ["punch.0.radius", "> 0"]),
        ("punch.0.shape=cube", ["punch.0.shape", "must be one of", "sphere", "cube"]),
        ("punch.0.indentaton=1e-3", ["punch.0.indentaton", "did you mean 'indentation'"]),
        ("solver.penalty=0", ["solver.penalty", "> 0"]),
        ("punch.0.zone={x=[5.0, 6.0], phi=[70.0, 110.0]}", ["punch.0.zone.x", "outside the shell"]),
        ('solver.substructure="yes"', ["solver.substructure", '"auto", true or false', "yes"]),
    ],
    ids=["punch-radius", "punch-shape", "punch-key", "penalty-epsilon", "zone-outside", "substructure"],
)
def test_bad_contact_input(tmp_path: Path, setting: str, fragments: list[str]) -> None:
    r = cli("run", PANEL, "-o", "out", "--set", "mesh.nx=4", "--set", "mesh.nphi=4", "--set", setting, cwd=tmp_path)
    assert r.returncode == 2 and "Traceback" not in r.stderr, r.stderr
    for f in fragments:
        assert f in r.stderr, (f, r.stderr)


def test_solver_failure_exit_3(tmp_path: Path) -> None:
    """A contact solve stopped after one iteration fails loudly: exit status 3, the residuals, no outputs."""
    args = ["--set", "mesh.nx=8", "--set", "mesh.nphi=8", "--set", "solver.max_iterations=1", "--method", "dual"]
    r = cli("run", PANEL, "-o", "out", *args, cwd=tmp_path)
    assert r.returncode == 3, r.stderr
    assert "Traceback" not in r.stderr
    assert r.stderr.startswith("solver failed: dual") and "after 1 iterations" in r.stderr
    table = [ln.split() for ln in r.stderr.splitlines()[1:]]
    assert table and all(len(row) == 2 and float(row[1]) >= 0 for row in table)  # one residual per line
    assert "penetration" in r.stderr
    assert not (tmp_path / "out" / "summary.json").exists()


# -- issue 12: bad values never crash (these run the command line in this process: faster) ----------------
class InProcess:
    """``shellcontact ARGS`` in this process, in a directory holding ``usermod`` (user functions)."""

    def __init__(self, directory: Path, monkeypatch: pytest.MonkeyPatch) -> None:
        (directory / "usermod.py").write_text(USER_MODULE)
        monkeypatch.chdir(directory)
        monkeypatch.syspath_prepend(str(directory))
        monkeypatch.delitem(sys.modules, "usermod", raising=False)

    def __call__(self, *args: str) -> subprocess.CompletedProcess:
        if any("usermod:" in a for a in args):  # the user's consent to import it (the trust model)
            args = (*args, "--allow-module", "usermod")
        code, stderr = run_cli(list(args))
        return subprocess.CompletedProcess(list(args), code, "", stderr)


@pytest.fixture
def run(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> InProcess:
    return InProcess(tmp_path, monkeypatch)


USER_MODULE = textwrap.dedent(
    """\
    import numpy as np

    def raises(*args):
        raise RuntimeError("user code failed")

    def nan_field(*args):
        return np.full(np.shape(args[0]), np.nan)

    def wrong_shape(*args):
        return np.ones(7)

    def text(*args):
        return "abc"

    def nan_later(x, phi):  # finite on the 9 x 9 grid sampled when the case is read, NaN in assembly
        return np.full(np.shape(x), 0.25 if np.size(x) == 81 else np.nan)

    def z_nan(X):
        return np.full(X.shape[1], np.nan), np.zeros(X.shape)

    def z_shapes(X):
        return np.ones(3), np.ones(3)

    def z_later(X):  # good on the 3 x 3 grid sampled at placement, raises in assembly
        if X.shape[1] != 9:
            raise ValueError("user code failed later")
        d = X - np.array([[0.0], [0.0], [3.5]])
        r = np.linalg.norm(d, axis=0)
        return r - 2.0, d / r
    """
)
FUNCTION_KEYS = ["shell.thickness", "loads.normal", "loads.surface", "loads.line.0.normal", "loads.line.0.force"]
BEHAVIOURS = {
    "raises": ["raised RuntimeError: user code failed"],
    "nan_field": ["non-finite"],
    "wrong_shape": ["must return", "shape (7,)"],
    "text": ["must return", "str"],
    "nan_later": ["non-finite"],
}


@pytest.mark.parametrize("behaviour", sorted(BEHAVIOURS))
@pytest.mark.parametrize("key", FUNCTION_KEYS)
def test_user_function_fails_by_its_key(run: InProcess, tmp_path: Path, key: str, behaviour: str) -> None:
    """A "module:function" that raises, returns the wrong shape or NaN — when the case is read or only later,
    during assembly (nan_later) — is exit 2 naming its key."""
    text = edit(BASE, "[[probes]]", "[[loads.line]]\nx = 12.5\n\n[[probes]]")
    (tmp_path / "case.toml").write_text(text)
    r = run("run", "case.toml", "-o", "out", "--no-figures", "--set", f'{key}="usermod:{behaviour}"')
    assert r.returncode == 2, r.stderr
    assert "Traceback" not in r.stderr
    msg = r.stderr.strip().splitlines()[-1]
    assert msg.startswith(f"error: {key}: usermod:{behaviour}"), msg
    for fragment in BEHAVIOURS[behaviour]:
        assert fragment in msg, (fragment, msg)
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize(
    "function,fragments",
    [
        ("raises", ["raised RuntimeError: user code failed"]),
        ("z_nan", ["non-finite"]),
        ("z_shapes", ["shapes (9,) and (3, 9)", "got (3,) and (3,)"]),
        ("text", ["must return a pair (Z, gradZ)", "str"]),
        ("z_later", ["raised ValueError: user code failed later"]),
    ],
)
def test_custom_punch_function_fails_by_its_key(run: InProcess, function: str, fragments: list[str]) -> None:
    punch = f'punch.0={{shape="custom", function="usermod:{function}", direction=[0, 0, -1], indentation=1e-3}}'
    r = run("run", PANEL, "-o", "out", "--no-figures", "--set", "mesh.nx=4", "--set", "mesh.nphi=4",
            "--set", punch)
    assert r.returncode == 2 and "Traceback" not in r.stderr, r.stderr
    msg = r.stderr.strip().splitlines()[-1]
    assert msg.startswith(f"error: punch.0.function: usermod:{function}"), msg
    for fragment in fragments:
        assert fragment in msg, (fragment, msg)


@pytest.mark.parametrize(
    "setting,fragments",
    [
        ("shell.young=" + "9" * 400,
         ["shell.young", "too large for a floating-point number", "an integer of 400 digits"]),
        ("mesh.refine=" + "9" * 40, ["mesh.refine", "too large: 40 digits", "2^63 - 1"]),
        ("mesh.nx=-" + "9" * 25, ["mesh.nx", "too large: 25 digits"]),
        ("shell.radius=1e300", ["shell.radius", "magnitude between 1e-30 and 1e+30", "1e+300"]),
        ("shell.length=1e-300", ["shell.length", "magnitude between 1e-30 and 1e+30"]),
        ("loads.surface=[0, 0, -1e200]", ["loads.surface", "must be 0 or of magnitude"]),
        ("shell.young=nan", ["shell.young", "must be finite"]),
        ("shell.young=-inf", ["shell.young", "must be finite"]),
        ('shell.young="1e999"', ["shell.young", "must be a number", "str"]),
        ("probes={x = 1.0, phi = 60.0}", ["probes", "must be an array of tables [[probes]]", "dict"]),
        ("probes=3", ["probes", "must be an array of tables [[probes]]", "int"]),
        ("probes=[1, 2]", ["probes.0", "must be a table", "int"]),
        ("loads.point={x = 1.0, phi = 60.0, force = [0, 0, 1]}", ["loads.point", "array of tables [[loads.point]]"]),
        ("loads.line=1", ["loads.line", "must be an array of tables [[loads.line]]"]),
        ("punch=1", ["punch", "must be an array of tables [[punch]]"]),
        ("mesh=[1]", ["mesh", "must be a table", "list"]),
        ("shell.thickness=\"usermod:nothing\"", ["shell.thickness", "cannot import", "AttributeError"]),
        ("shell.thickness=\":f\"", ["shell.thickness", "both names given"]),
    ],
)
def test_absurd_values_are_refused_by_name(run: InProcess, tmp_path: Path, setting: str, fragments: list[str]) -> None:
    (tmp_path / "case.toml").write_text(BASE)
    r = run("run", "case.toml", "-o", "out", "--no-figures", "--set", setting)
    assert r.returncode == 2 and "Traceback" not in r.stderr, r.stderr
    msg = r.stderr.strip().splitlines()[-1]
    for fragment in fragments:
        assert fragment in msg, (fragment, msg)


def test_huge_punch_is_refused_by_name(run: InProcess, tmp_path: Path) -> None:
    """A sphere whose radius dwarfs the shell: its distance function has no digits left on the shell's scale
    (it was placed with a random force, here 0, or failed to converge with a traceback)."""
    args = ["--set", "mesh.nx=4", "--set", "mesh.nphi=4", "--set", "punch.0.radius=1e20",
            "--set", "punch.0.center=[0, 0, 1.00000000000000001e20]"]
    r = run("run", PANEL, "-o", "out", "--no-figures", *args)
    assert r.returncode == 2 and "Traceback" not in r.stderr, r.stderr
    msg = r.stderr.strip().splitlines()[-1]
    assert msg.startswith("error: punch.0: a punch of size 1e+20") and "resolves the gap only to" in msg, msg


def test_utf8_byte_order_mark_is_accepted(run: InProcess, tmp_path: Path) -> None:
    (tmp_path / "case.toml").write_bytes(b"\xef\xbb\xbf" + BASE.encode())
    r = run("run", "case.toml", "-o", "out", "--no-figures", "--no-report")
    assert r.returncode == 0, r.stderr
    assert (tmp_path / "out" / "summary.json").is_file()


def test_utf16_is_refused_by_name(run: InProcess, tmp_path: Path) -> None:
    (tmp_path / "case.toml").write_bytes(BASE.encode("utf-16"))
    r = run("run", "case.toml", "-o", "out")
    assert r.returncode == 2 and "Traceback" not in r.stderr
    assert "UTF-16" in r.stderr and "byte-order mark" in r.stderr and "save it as UTF-8" in r.stderr


def test_case_file_is_a_directory(run: InProcess, tmp_path: Path) -> None:
    (tmp_path / "case.toml").mkdir()
    r = run("run", "case.toml", "-o", "out")
    assert r.returncode == 2 and "Traceback" not in r.stderr
    assert "case: cannot read 'case.toml'" in r.stderr and "directory" in r.stderr


@pytest.mark.parametrize(
    "args,fragments",
    [
        (["run", "case.toml", "-o", ""], ["-o/--output", "must name a directory"]),
        (["sweep", "case.toml", "--param", "mesh.nx", "--values", "2,3", "-o", " "], ["-o/--output"]),
        (["demo", "-o", ""], ["-o/--output"]),
        (["run", "case.toml", "--profile-x", "nan"], ["--profile-x", "must be finite"]),
        (["run", "case.toml", "--profile-phi", "inf"], ["--profile-phi", "must be finite"]),
        (["run", "case.toml", "-o", "out", "--profile-x", "1e300"],
         ["--profile-x", "must lie on the shell", "[0, 25]"]),
        (["run", "case.toml", "-o", "out", "--profile-phi", "95"], ["--profile-phi", "[50, 90]"]),
    ],
    ids=["run-o", "sweep-o", "demo-o", "profile-x-nan", "profile-phi-inf", "profile-x-outside", "profile-phi-outside"],
)
def test_bad_arguments(run: InProcess, tmp_path: Path, args: list[str], fragments: list[str]) -> None:
    (tmp_path / "case.toml").write_text(BASE)
    r = run(*args)
    assert r.returncode == 2 and "Traceback" not in r.stderr, r.stderr
    for fragment in fragments:
        assert fragment in r.stderr, (fragment, r.stderr)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["case.toml", "usermod.py"]  # nothing written


def test_unexpected_error_is_one_line_and_please_report(monkeypatch: pytest.MonkeyPatch, capsys, tmp_path: Path):
    """A bug (here: a command that raises an exception no layer expects) is exit 1 with a short message;
    the traceback is shown under -v and written to --log."""
    from shellcontact import cli as cli_module

    def broken(args, con):
        raise ZeroDivisionError("a bug")

    monkeypatch.setattr(cli_module, "cmd_info", broken)
    assert cli_module.main(["info"]) == 1
    err = capsys.readouterr().err
    assert "internal error: ZeroDivisionError: a bug" in err and "please report" in err
    assert "Traceback" not in err
    log = tmp_path / "run.log"
    assert cli_module.main(["info", "-v", "--log", str(log)]) == 1
    err = capsys.readouterr().err
    assert "Traceback (most recent call last)" in err and "ZeroDivisionError: a bug" in err
    assert "Traceback (most recent call last)" in log.read_text()


def test_deeply_nested_values(run: InProcess, tmp_path: Path) -> None:
    """tomllib reads nested arrays recursively: nesting beyond the recursion limit is bad input, not a crash."""
    deep = "[" * 100_000 + "]" * 100_000
    (tmp_path / "case.toml").write_text(BASE + f"x = {deep}\n")
    r = run("run", "case.toml", "-o", "out")
    assert r.returncode == 2 and "Traceback" not in r.stderr, r.stderr
    assert "error: case: 'case.toml' nests arrays or inline tables too deeply" in r.stderr
    (tmp_path / "case.toml").write_text(BASE)
    r = run("run", "case.toml", "-o", "out", "--set", f"mesh.x_lines={deep}")
    assert r.returncode == 2 and "error: --set mesh.x_lines: the value nests arrays" in r.stderr, r.stderr


def test_mesh_file_no_reader_takes(run: InProcess, tmp_path: Path) -> None:
    """meshio exits (SystemExit) on a .msh file that none of its readers takes: refused by name, not exit 1."""
    (tmp_path / "garbage.msh").write_bytes(bytes(range(256)) * 4)
    (tmp_path / "case.toml").write_text(BASE)
    r = run("run", "case.toml", "-o", "out", "--set", 'mesh.file="garbage.msh"')
    assert r.returncode == 2, r.stderr
    expected = "error: mesh.file: cannot read mesh file 'garbage.msh': no reader of meshio recognises it"
    assert r.stderr.strip() == expected


def test_a_plane_pushed_onto_a_clamped_edge_is_solved_by_every_method(run: InProcess, tmp_path: Path) -> None:
    """Found by the fuzzer: a force-controlled plane whose first contact is on a clamped edge. The dual Hessian
    B A⁻¹ Bᵀ vanishes on the rows the clamp holds: MPRGP once divided by zero (exit 1), then the dual refused and,
    after the singular-face handling, the active set dropped the whole face (force_balance 1). The bordered face
    system [[S, D], [Dᵀ, 0]] is regular all the same (the prescribed 1 N fixes the forces: solvers/face.py), so
    every method solves it, and they agree: the clamp carries the 1 N, the plane does not move (4.5e-11 m)."""
    (tmp_path / "case.toml").write_text(textwrap.dedent("""\
        shell = {radius = 1.0, length = 1.0, angle = [60.0, 120.0], thickness = 0.01, young = 2.1e11, poisson = 0.3}
        mesh = {nx = 4, nphi = 4}
        punch = [{shape = "plane", force = 1.0, center = [298681.0, 0.0, 0.0], normal = [18605.0, 3.0, 3.0]}]
        """))
    found = {}
    for method in ("active-set", "dual", "penalty"):
        r = run("run", "case.toml", "-o", method, "--no-figures", "--no-report", "--method", method)
        assert r.returncode == 0, (method, r.stderr)
        c = json.loads((tmp_path / method / "summary.json").read_text())["contact"][0]
        found[method] = np.array(c["force"]), c["punch_travel"]
    n = np.array([18605.0, 3.0, 3.0]) / np.linalg.norm([18605.0, 3.0, 3.0])
    for method, (force, travel) in found.items():
        assert abs(abs(force @ n) - 1.0) < 1e-12 and np.linalg.norm(np.cross(force, n)) < 1e-12, (method, force)
        assert abs(travel) < 1e-9, (method, travel)  # measured 4.46e-11 m (exact), 4.45e-11 m (penalty)
    assert np.array_equal(found["active-set"][0], found["dual"][0])  # measured: identical


def test_integers_longer_than_python_reads(run: InProcess, tmp_path: Path) -> None:
    """int() refuses more than 4300 digits (a ValueError inside tomllib, and in repr): bad input by name."""
    (tmp_path / "case.toml").write_text(edit(BASE, "nx = 2", "nx = " + "9" * 5000))
    r = run("run", "case.toml", "-o", "out")
    assert r.returncode == 2 and "Traceback" not in r.stderr, r.stderr
    assert "error: case: 'case.toml' holds an integer of more than 4300 digits" in r.stderr
    (tmp_path / "case.toml").write_text(BASE)
    r = run("run", "case.toml", "-o", "out", "--set", "mesh.nx=" + "9" * 5000)
    assert r.returncode == 2 and "error: --set mesh.nx: the value holds an integer of more than 4300" in r.stderr
    data = {"shell": {"radius": 10**5000, "length": 1.0, "full": True, "thickness": 0.1, "young": 1.0,
                      "poisson": 0.0}}
    from shellcontact import InputError, case_from_dict

    with pytest.raises(InputError, match="shell.radius: is too large for a floating-point number: an integer of"):
        case_from_dict(data)
