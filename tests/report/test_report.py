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


def test_a_check_shows_its_basis_and_a_ranking_too_close_to_call_fails_nothing():
    """The table's basis column says how each limit was set; a ranking whose predicted gap
    is within what the frames resolve reads TOO CLOSE, sorts after the failures, and the
    verdict line counts it apart."""
    from inspect_validate.report.verification import check_rows, count_failed
    from inspect_validate.verification.checks import at_least, at_most, decide

    ranking = at_most(
        "ranking by A vs B,C: predicted best amber measures best",
        "ranking",
        0.02,
        0.0,
        "decades",
        basis="statistical",
        standard_error=0.05,
        predicted_gap=0.1,
    )
    separation = at_least("amber: A vs B SNR_dB", "separation", -7.2, -7.0, "dB")
    checks = decide([ranking, separation], 0.0027)
    cells = [row for _, row in check_rows(checks)]
    assert [r[0] for r in cells] == ["FAIL", "TOO CLOSE"]
    assert [r[5] for r in cells] == ["fixed", "statistical"]
    assert cells[1][3] == f"≤ {checks[0].limit:.4g}" and checks[0].limit > 0.1
    assert count_failed(checks) == "1 of 2 checks failed (1 too close to call)"
    assert count_failed(checks[:1]) == "all 0 checks passed (1 too close to call)"


def test_verify_keeps_its_checks_table_within_a_terminal(tmp_path):
    # A real terminal (a pseudo-terminal): the checks table of the shipped station is 150
    # columns wide with its details; on a 100-column terminal the details go under their
    # rows. Into a pipe the table keeps its detail column (tests and logs grep it).
    import os
    import subprocess
    import sys

    from conftest import ROOT

    station = ROOT / "sample_images" / "station" / "station.yaml"
    master, slave = os.openpty()
    env = {**os.environ, "COLUMNS": "100", "LINES": "40"}
    proc = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "inspect_validate",
            "verify",
            station,
            "--frames-out",
            tmp_path / "f",
        ],
        stdout=slave,
        stderr=subprocess.DEVNULL,
        env=env,
    )
    os.close(slave)
    chunks = []
    while True:
        try:
            data = os.read(master, 65536)
        except OSError:  # EIO: the other end is closed
            break
        if not data:
            break
        chunks.append(data)
    os.close(master)
    assert proc.wait(timeout=120) == 0
    lines = b"".join(chunks).decode().replace("\r\n", "\n").splitlines()
    table = [line for line in lines if line.startswith(("pass ", "FAIL ", "         "))]
    assert len(table) > 20
    assert max(len(line) for line in table) <= 100
    assert any("predicted best amber" in line for line in table)  # a detail, on its own line
