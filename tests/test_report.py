"""JSON number encoding shared by every report."""

import math

from inspect_validate.report.jsonfile import json_number


def test_json_numbers():
    assert json_number(1.5) == 1.5 and json_number(None) is None
    assert json_number(math.inf) == "inf" and json_number(-math.inf) == "-inf"
    assert json_number(math.nan) is None  # undefined, not "-inf"


def test_running_text_wraps_on_a_terminal_only():
    """A note on a terminal wraps at LINE_WIDTH with indented continuations; into a pipe
    or a file it stays one line, so grep and log collectors see whole messages."""
    import io

    from inspect_validate.text import LINE_WIDTH, labelled

    class Terminal(io.StringIO):
        def isatty(self):
            return True

    text = "the dark frames' temporal noise is 0.32 DN, below the 0.5 DN EMVA 1288 needs " * 3
    wrapped = labelled("note", text, stream=Terminal())
    lines = wrapped.splitlines()
    assert len(lines) > 2 and all(len(line) <= LINE_WIDTH for line in lines)
    assert all(line.startswith("  ") for line in lines[1:])
    assert " ".join(line.strip() for line in lines) == f"note: {text}".strip()
    assert labelled("note", text, stream=io.StringIO()) == f"note: {text}"
