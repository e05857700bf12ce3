"""Running text for the terminal, kept to a readable width."""

from __future__ import annotations

__all__ = ["LINE_WIDTH", "labelled"]

LINE_WIDTH = 100
"""Longest line of running text the commands print (tables are as wide as their cells)."""


def labelled(label: str, text: str, *, stream=None) -> str:
    """``label: text``, wrapped at :data:`LINE_WIDTH` (or a narrower terminal) with the
    continuation lines indented where ``stream`` (default: stderr) is a terminal: notes
    and skipped work read as paragraphs there, not as 250-character lines. Into a file
    or a pipe each message stays one line, for grep and log collectors."""
    import shutil
    import sys
    import textwrap

    stream = sys.stderr if stream is None else stream
    line = f"{label}: {text}"
    if not getattr(stream, "isatty", lambda: False)():
        return line
    width = min(LINE_WIDTH, shutil.get_terminal_size((LINE_WIDTH, 24)).columns)
    return textwrap.fill(
        line,
        width=max(width, 40),
        subsequent_indent="  ",
        break_long_words=False,
        break_on_hyphens=False,
    )
