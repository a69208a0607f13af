"""report.html as a person sees it: rendered by headless Chromium in a 1200 px window.

Checks that the page never scrolls sideways (document scrollWidth ≤ clientWidth) and that every
figure loaded (naturalWidth > 0), on a run with two punches, warnings, probes, a yield stress and
every figure; and, so that the measurement itself is trusted, that it does see an overflow on a page
that has one. Needs the Debian package ``chromium`` (``.ci/run`` installs it); without it the test
skips, saying so.
"""

from __future__ import annotations

import json
import re
import shutil
import subprocess
from pathlib import Path

import pytest

from shellcontact.analysis.pipeline import solve
from shellcontact.outputs.run import write_outputs
from shellcontact.problem.case import load_case

ROOT = Path(__file__).resolve().parents[1]
CHROMIUM = next((p for p in map(shutil.which, ("chromium", "chromium-browser", "google-chrome")) if p), None)
pytestmark = pytest.mark.skipif(CHROMIUM is None, reason="headless Chromium is not installed "
                                "(Debian: apt-get install chromium; .ci/run installs it)")

#: written into the DOM once the page (and its images) has loaded; --dump-dom then prints it
MEASURE = """<script>
window.addEventListener("load", () => {
  const d = document.documentElement, imgs = Array.from(document.images);
  const wide = Array.from(document.querySelectorAll("table, figure, pre, p, div"))
    .filter(e => e.getBoundingClientRect().right > d.clientWidth + 0.5).map(e => e.tagName + ": "
      + e.textContent.slice(0, 60));
  const out = document.createElement("pre");
  out.id = "measured";
  out.textContent = JSON.stringify({scrollWidth: d.scrollWidth, clientWidth: d.clientWidth, images: imgs.length,
    loaded: imgs.filter(i => i.complete && i.naturalWidth > 0).length, wide: wide});
  document.body.appendChild(out);
});
</script>"""


def measure(page: Path, profile: Path) -> dict:
    """Render ``page`` at 1200 px width and return the measurements of MEASURE."""
    probe = page.with_name("measured.html")
    probe.write_text(page.read_text().replace("</body>", MEASURE + "\n</body>"))
    cmd = [CHROMIUM, "--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
           "--disable-background-networking", "--disable-component-update", "--disable-sync",
           f"--user-data-dir={profile}", "--window-size=1200,900", "--hide-scrollbars",
           "--virtual-time-budget=10000", "--dump-dom", probe.as_uri()]
    r = subprocess.run(cmd, capture_output=True, text=True, timeout=180)
    found = re.search(r'<pre id="measured">(.*?)</pre>', r.stdout, re.S)
    assert found, f"Chromium printed no measurement (exit {r.returncode}): {r.stderr[-2000:]}"
    return json.loads(found.group(1).replace("&quot;", '"').replace("&amp;", "&").replace("&lt;", "<")
                      .replace("&gt;", ">"))


def test_report_fits_1200px_and_shows_every_figure(tmp_path: Path) -> None:
    case = load_case(ROOT / "examples" / "saddle_support.toml", ["mesh.nx=8", "mesh.nphi=12",
                                                                 "material.yield_stress=1e6"])
    result = solve(case)
    summary = result.summary()
    # two punch columns, probes and a warnings box
    assert len(summary["contact"]) == 2 and summary["probes"] and summary["warnings"]
    write_outputs(result, tmp_path / "out", summary)
    report = tmp_path / "out" / "report.html"
    text = report.read_text()
    # warnings first (they change what every number means), then an engineering calculation: case, results,
    # figures, details
    heads = [text.index(f"<h2>{h}</h2>") for h in ("Warnings", "The case", "Results", "Figures", "Details")]
    assert heads == sorted(heads) and 'class="warnings"' in text[heads[0]:heads[1]]
    m = measure(report, tmp_path / "profile")
    assert m["scrollWidth"] <= m["clientWidth"], m
    assert not m["wide"], m
    pngs = len(re.findall(r'<img [^>]*src="data:image/png;base64,', text))
    assert m["images"] == pngs >= 4 and m["loaded"] == m["images"], m


def test_measurement_sees_an_overflow(tmp_path: Path) -> None:
    """The check above can fail: a 2000 px table and a broken image are seen."""
    page = tmp_path / "wide.html"
    page.write_text('<!DOCTYPE html><html><body><table style="width:2000px"><tr><td>x</td></tr></table>'
                    '<img src="data:image/png;base64,AAAA"></body></html>')
    m = measure(page, tmp_path / "profile")
    assert m["scrollWidth"] > m["clientWidth"] and m["wide"] and m["images"] == 1 and m["loaded"] == 0, m
