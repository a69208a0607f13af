"""Every kind of bad input gives one clear message naming the key and what is allowed, exit
status 2 and no traceback; a solver failure gives exit status 3 with the residuals.

Each case runs the command line as a subprocess (``python -m shellcontact.cli``).
"""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

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
