"""The table of benchmarks/RESULTS.md "Every example with --estimate": example × headline × value × estimate,
from the run directories of ``shellcontact run examples/NAME.toml --estimate -o ROOT/NAME`` (and, when present,
``ROOT/NAME.log`` holding GNU ``/usr/bin/time -v`` output: wall, CPU seconds and peak memory).

    for n in band_clamp paper_panel; do /usr/bin/time -v shellcontact run examples/$n.toml --estimate \\
        -o runs/$n > runs/$n.log 2>&1; done
    python benchmarks/accuracy_table.py runs band_clamp paper_panel
"""

from __future__ import annotations

import argparse
import json
import re
from pathlib import Path

#: summary paths left out: a probe's displacement vector repeats its components; a prescribed travel is exact
SKIP = re.compile(r"probes\.\d+\.displacement\.|punch_travel")


def cost(log: Path) -> str:
    """'wall, CPU s, peak GB' from a GNU time -v log, or '' without one."""
    if not log.exists():
        return ""
    text = log.read_text()
    wall = re.search(r"Elapsed \(wall clock\) time \(h:mm:ss or m:ss\): (\S+)", text)
    cpu = sum(float(x) for x in re.findall(r"(?:User|System) time \(seconds\): (\S+)", text))
    rss = re.search(r"Maximum resident set size \(kbytes\): (\d+)", text)
    if not (wall and rss):
        return ""
    return f"; {wall.group(1)} wall, {cpu:.0f} CPU s, {int(rss.group(1)) / 1e6:.2f} GB"


def rows(root: Path, name: str) -> list[str]:
    s = json.loads((root / name / "summary.json").read_text())
    out = []
    for path, e in s["accuracy"].items():
        if SKIP.search(path):
            continue
        est = e["estimate"]
        text = "not estimated" if est is None else f"{100 * est:.2g} %"
        if est is None or est > 0.01:
            text = f"**{text}**"
        order = "–" if e["order"] is None else f"{e['order']:.2g}"
        unit = s.get("units", {}).get(f"accuracy.{path}.value", "–")
        head = f"{name} ({s['dofs']} dofs{cost(root / f'{name}.log')})" if not out else ""
        out.append(f"| {head} | `{path}` | {e['value']:.6g} | {unit} | {text} | {order} | {e.get('refine', '')} |")
    return out


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("root", type=Path, help="directory holding one run directory per example")
    p.add_argument("names", nargs="+", help="example names (run directories under ROOT)")
    a = p.parse_args()
    print("| example (dofs; wall, CPU s, peak memory) | headline (summary path) | value | unit | estimate | observed "
          "order | what to refine (estimates above 1 %) |")
    print("|---|---|---|---|---|---|---|")
    for name in a.names:
        print("\n".join(rows(a.root, name)))


if __name__ == "__main__":
    main()
