"""Fixed-width text tables for the console, at most ``WIDTH`` characters wide (issue 23: 166–219).

A table wider than that is printed in blocks of columns, each block repeating the first column (the
swept parameter, the level) so that every line still says which row it is.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

WIDTH = 100


def cell(v: Any) -> str:
    """Numbers to 6 significant digits, None as —."""
    return "—" if v is None else (f"{v:.6g}" if isinstance(v, float) else str(v))


def text_table(head: Sequence[str], rows: Sequence[Sequence[Any]], width: int = WIDTH) -> str:
    """A right-aligned text table; beyond ``width`` characters, in blocks of columns led by the first."""
    cells = [[cell(v) for v in r] for r in rows]
    widths = [max(len(h), *(len(c[i]) for c in cells)) if cells else len(h) for i, h in enumerate(head)]
    blocks: list[list[int]] = [[]]
    used = widths[0] if widths else 0
    for i in range(1, len(head)):
        if blocks[-1] and used + 2 + widths[i] > width:
            blocks.append([])
            used = widths[0]
        blocks[-1].append(i)
        used += 2 + widths[i]
    out = []
    for block in blocks:
        cols = [0, *block] if head else []
        lines = ["  ".join(f"{head[i]:>{widths[i]}}" for i in cols)]
        lines += ["  ".join(f"{c[i]:>{widths[i]}}" for i in cols) for c in cells]
        out.append("\n".join(lines))
    return "\n\n".join(out)


def split_markdown(text: str, width: int = WIDTH) -> str:
    """A Markdown table (``| a | b |`` lines, the second a rule) for the console: in blocks of columns led by
    the first, each line at most ``width`` characters when the columns allow it; other lines unchanged."""
    lines = text.splitlines()
    if len(lines) < 2 or max(len(ln) for ln in lines) <= width or not all(ln.startswith("|") for ln in lines):
        return text
    bars = [i for i, ch in enumerate(lines[1]) if ch == "|"]  # the rule line: where the columns meet
    if any(len(ln) != len(lines[1]) for ln in lines):  # cells may hold "|" (max|w|): only aligned tables split
        return text
    rows = [[ln[a + 1:b] for a, b in zip(bars[:-1], bars[1:])] for ln in lines]
    widths = [len(c) for c in rows[0]]
    blocks: list[list[int]] = [[]]
    used = 2 + widths[0]
    for i in range(1, len(widths)):
        if blocks[-1] and used + 1 + widths[i] + 1 > width:
            blocks.append([])
            used = 2 + widths[0]
        blocks[-1].append(i)
        used += widths[i] + 1
    return "\n\n".join("\n".join("|" + "|".join(r[i] for i in [0, *b]) + "|" for r in rows) for b in blocks)
