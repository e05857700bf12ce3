"""Text for the terminal: running text kept to a readable width, tables padded to
their cells, and ε as every output writes it."""

from __future__ import annotations

import math
import re
from collections.abc import Collection
from typing import TextIO

__all__ = ["LINE_WIDTH", "format_error", "labelled", "render_table", "terminal_width"]

LINE_WIDTH = 100
"""Longest line of running text the commands print (tables are as wide as their cells)."""


def terminal_width(stream: TextIO | None) -> int | None:
    """The width to keep lines within on ``stream``: :data:`LINE_WIDTH` or a narrower
    terminal's; None into a file or a pipe (lines stay whole there)."""
    import shutil

    if not getattr(stream, "isatty", lambda: False)():
        return None
    return max(40, min(LINE_WIDTH, shutil.get_terminal_size((LINE_WIDTH, 24)).columns))


def labelled(label: str, text: str, *, stream: TextIO | None = None) -> str:
    """``label: text``, wrapped at :data:`LINE_WIDTH` (or a narrower terminal) with the
    continuation lines indented where ``stream`` (default: stderr) is a terminal: notes
    and skipped work read as paragraphs there, not as 250-character lines. Into a file
    or a pipe each message stays one line, for grep and log collectors."""
    import sys
    import textwrap

    stream = sys.stderr if stream is None else stream
    line = f"{label}: {text}"
    width = terminal_width(stream)
    if width is None:
        return line
    return textwrap.fill(
        line,
        width=width,
        subsequent_indent="  ",
        break_long_words=False,
        break_on_hyphens=False,
    )


def format_error(value: float | None, log_value: float | None = None) -> str:
    """ε as a fraction (0 to ½), the unit of every output and every limit, to three
    significant digits; powers of ten for tiny values."""
    if value is None:
        return "-"
    if value == 0.0 and log_value is not None and math.isfinite(log_value):
        return f"1e{log_value / math.log(10):.0f}"
    if value >= 1e-4:
        return f"{value:#.3g}"
    return f"{value:.2e}"


_NUMBER = re.compile(r"^[-+−]?(\d|\.\d|inf|nan)|^[-—]$")


def render_table(
    header: list[str], rows: list[list[str]], *, left: Collection[int] | None = None
) -> str:
    """Columns padded to their widest cell: text flush left, numbers flush right. A
    column is text (``left``: its indices, default: found) unless most of its cells
    begin as a number does (a dash: none)."""
    widths = [max(len(r[i]) for r in [header, *rows]) for i in range(len(header))]
    if left is None:
        left = set()
        for i in range(len(header)):
            cells = [r[i] for r in rows if r[i]]  # an empty cell is neither
            if 2 * sum(bool(_NUMBER.match(c)) for c in cells) < len(cells):
                left.add(i)

    def line(r):
        cells = (
            c.ljust(w) if i in left else c.rjust(w)
            for i, (c, w) in enumerate(zip(r, widths, strict=True))
        )
        return "  ".join(cells).rstrip()

    return "\n".join([line(header), line(["-" * w for w in widths]), *map(line, rows)])
