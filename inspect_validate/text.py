"""Running text for the terminal, kept to a readable width."""

from __future__ import annotations

__all__ = ["LINE_WIDTH", "labelled", "terminal_width"]

LINE_WIDTH = 100
"""Longest line of running text the commands print (tables are as wide as their cells)."""


def terminal_width(stream) -> int | None:
    """The width to keep lines within on ``stream``: :data:`LINE_WIDTH` or a narrower
    terminal's; None into a file or a pipe (lines stay whole there)."""
    import shutil

    if not getattr(stream, "isatty", lambda: False)():
        return None
    return max(40, min(LINE_WIDTH, shutil.get_terminal_size((LINE_WIDTH, 24)).columns))


def labelled(label: str, text: str, *, stream=None) -> str:
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
