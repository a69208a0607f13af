"""Issue 23, item 6: what a new user hit on a fresh clone, each checked as they would meet it."""

from __future__ import annotations

import os
import re
import subprocess
import sys
import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
README = (ROOT / "README.md").read_text()


def _block(after: str, lang: str) -> str:
    rest = README[README.index(after):]
    return re.search(rf"```{lang}\n(.*?)```", rest, re.S).group(1)


def test_the_readme_python_snippet_runs_after_its_command_block(tmp_path: Path) -> None:
    """Followed in order: the first command of "Using it" writes out/, then the Python snippet writes its own
    directory (it wrote out/ too, and was refused: the directory was not empty)."""
    (tmp_path / "examples").symlink_to(ROOT / "examples")
    first = _block("## Using it", "sh").splitlines()[0].split("#")[0].split()
    assert first[:2] == [".venv/bin/shellcontact", "run"]
    env = {**os.environ, "OPENBLAS_NUM_THREADS": "1"}
    run = [sys.executable, "-m", "shellcontact.cli", *first[1:], "--no-figures"]
    subprocess.run(run, cwd=tmp_path, env=env, check=True, capture_output=True, timeout=300)
    snippet = _block("A run directory holds", "python")
    r = subprocess.run([sys.executable, "-c", snippet], cwd=tmp_path, env=env, capture_output=True, text=True,
                       timeout=600)
    assert r.returncode == 0, r.stderr
    written = re.search(r'result\.write\("([^"]+)"\)', snippet).group(1)
    assert (tmp_path / written / "summary.json").is_file() and (tmp_path / "out" / "summary.json").is_file()


def test_the_license_is_an_spdx_string() -> None:
    """A TOML table made setuptools print its deprecation three times at install; the string needs
    setuptools >= 77 in the build environment."""
    data = tomllib.loads((ROOT / "pyproject.toml").read_text())
    assert data["project"]["license"] == "MIT"
    assert "setuptools>=77" in data["build-system"]["requires"]


def test_the_default_output_directories_are_ignored_by_git() -> None:
    """What the commands write when no -o is given (<case>-out, -sweep, -study, -convergence, demo-out) and
    what the README's commands write (out/, py-out/)."""
    names = ["paper_panel-out/", "paper_panel-sweep/", "paper_panel-study/", "scordelis_lo-convergence/",
             "demo-out/", "out/", "py-out/"]
    r = subprocess.run(["git", "check-ignore", "--no-index", *names], cwd=ROOT, capture_output=True, text=True)
    assert sorted(r.stdout.split()) == sorted(names), r.stdout


def test_getting_started_has_no_internal_section() -> None:
    assert "Proposed README" not in (ROOT / "docs" / "getting-started.md").read_text()


def test_the_console_summary_fits_100_characters(tmp_path: Path) -> None:
    """`run` printed its equilibrium and KKT lines 150–220 characters wide: now wrapped at 100, nothing lost."""
    env = {**os.environ, "OPENBLAS_NUM_THREADS": "1"}
    case = ROOT / "examples" / "ring_stiffness.toml"  # two punches, force control: the longest lines
    r = subprocess.run([sys.executable, "-m", "shellcontact.cli", "run", str(case), "--set", "mesh.nphi=32",
                        "-o", "out", "--no-figures", "--no-report"], cwd=tmp_path, env=env, capture_output=True,
                       text=True, timeout=300, check=True)
    assert max(len(line) for line in r.stdout.splitlines()) <= 100, r.stdout
    for word in ("reactions [", "residual [", "force_balance", "punch 1:", "zone area"):
        assert word in r.stdout


def test_a_sweep_table_fits_100_characters_and_its_report_has_units(tmp_path: Path) -> None:
    """A contact sweep has 13 columns (166 characters): printed in blocks of at most 100, each led by the swept
    parameter; report.html's table heads carry units, sits in a scrolling box on a 1360 px page."""
    env = {**os.environ, "OPENBLAS_NUM_THREADS": "1"}
    r = subprocess.run([sys.executable, "-m", "shellcontact.cli", "sweep", str(ROOT / "examples" / "paper_panel.toml"),
                        "--set", "mesh.nx=8", "--set", "mesh.nphi=8", "--param", "punch.0.indentation", "--values",
                        "0.001:0.003:3", "--no-figures", "-o", "sw"], cwd=tmp_path, env=env, capture_output=True,
                       text=True, timeout=300, check=True)
    table = [ln for ln in r.stdout.splitlines() if ln.strip() and not ln.startswith("wrote")]
    assert max(len(ln) for ln in table) <= 100, r.stdout
    heads = [ln for ln in table if ln.lstrip().startswith("punch.0.indentation [m]")]
    assert len(heads) >= 2 and len(table) == 4 * len(heads)  # blocks of a head and 3 rows
    columns = (tmp_path / "sw" / "sweep.csv").read_text().splitlines()[0].split(",")
    assert all(c in r.stdout for c in columns)
    page = (tmp_path / "sw" / "report.html").read_text()
    assert '<body class="wide">' in page and '<div class="scroll"><table class="study">' in page
    for head in ("force [N]", "peak_\u200bpressure [Pa]", "punch.\u200b0.\u200bindentation [m]"):
        assert f"<th>{head}</th>" in page


def test_deformed_png_keeps_axis_labels_off_the_tick_labels_and_drops_a_speck_of_contact() -> None:
    """deformed.png of the paper's panel: the X, Y and Z labels overlapped tick labels, and a second panel
    coloured by a contact pressure on 1 % of the shell was nearly empty (pressure.png shows the patch)."""
    import shellcontact as sc

    result = sc.solve(sc.load_case(ROOT / "examples" / "paper_panel.toml", ["mesh.nx=16", "mesh.nphi=16"]))
    fig = result.plot_deformed()
    panels = [ax for ax in fig.axes if ax.name == "3d"]
    assert len(panels) == 1
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    canvas = FigureCanvasAgg(fig)
    canvas.draw()
    renderer = canvas.get_renderer()
    for axis in (panels[0].xaxis, panels[0].yaxis, panels[0].zaxis):
        label = axis.label.get_window_extent(renderer)
        ticks = [t.get_window_extent(renderer) for t in axis.get_ticklabels() if t.get_text()]
        assert ticks and not any(label.overlaps(t) for t in ticks), axis.label.get_text()


def test_the_demo_table_fits_100_characters_on_the_console() -> None:
    """The demo's comparison (a Markdown table of 13 columns, 160 characters; comparison.md keeps it whole) is
    printed in blocks of columns led by the method, each line at most 100 characters, no column lost."""
    from shellcontact.demo import COLUMNS, format_table
    from shellcontact.outputs.tables import split_markdown

    rows = [{key: (method if key == "method" else 12 if "d}" in fmt else 1.234567e-5) for key, _, _, fmt in COLUMNS}
            for method in ("penalty", "active-set", "dual")]
    table = format_table(rows)
    assert max(len(line) for line in table.splitlines()) > 100
    console = split_markdown(table)
    assert max(len(line) for line in console.splitlines()) <= 100
    for title in table.splitlines()[0].strip("| ").split(" | "):
        assert title.strip() in console
    assert console.count("| active-set |") == console.count("|     method |") >= 2
    titles = [t.strip() for t in table.splitlines()[0].strip("| ").split(" | ")]
    counts = {"method", "active", "iter"}  # names and counts; every other column says its unit, [–] if none
    assert all(t.endswith("]") for t in titles if t not in counts), titles
