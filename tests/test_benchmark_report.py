"""The run-time-against-error report runs from one command (here its quick sizes)."""

import re
import subprocess
import sys

import pytest
from conftest import ROOT


@pytest.mark.slow
def test_report_writes_every_knob_with_its_plot(tmp_path):
    import matplotlib.pyplot as plt

    done = subprocess.run(
        [sys.executable, str(ROOT / "benchmarks/report.py"), "--quick", "--out", str(tmp_path)],
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert done.returncode == 0, done.stderr
    text = (tmp_path / "report.md").read_text()
    assert text.startswith("# Run time against error\n\nmachine: ")
    for title, png in (
        ("Spectral grid step", "grid_step"),
        ("LSCV bandwidth, continuous data", "lscv"),
        ("ε KDE", "kde_error"),
        ("ε Gauss", "gaussian_error"),
        ("Region statistics", "region"),
        ("Frames per illumination", "frames_averaged"),
        ("Prediction size", "prediction"),
        ("Skipped work", "skipped_work"),
    ):
        section = text.split(f"## {title}\n", 1)[1].split("\n## ", 1)[0]
        table = [line for line in section.splitlines() if line.startswith("| ")]
        assert len(table) >= 3, title  # header and at least two rows
        assert f"]({png}.png)" in section
        assert plt.imread(tmp_path / f"{png}.png").shape[:2] == (400, 600)
    assert not re.search(r"\b(nan|inf|infinity)\b", text, re.IGNORECASE)
    assert "verdicts same" in text  # the dominated skip changes none of amber's verdicts
    skips = text.split("## Skipped work\n", 1)[1]
    for row in ("| wavelengths no light", "| comparisons not named", "| a camera blind"):
        assert row in skips
