"""What a user waits for from the other commands: whole-CLI latency of ``predict``,
``analyze-spectra``, ``verify`` and ``design`` on the shipped samples, in fresh processes
(imports included), with peak memory and the heavy libraries each one loads, against
the floor every numpy tool pays in the same run (the interpreter importing numpy).

Run: ``python benchmarks/bench_cli.py [--runs 5]`` (about a minute).

``verify`` drives the built-in simulated station (camera and LED controller), so its
time includes the capture; ``--report`` adds the HTML page's seven figures.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
from pathlib import Path

from bench_measure import timed
from machine import compile_package, machine_line

ROOT = Path(__file__).resolve().parent.parent
SAMPLES = ROOT / "sample_images"
HEAVY = ("pydantic", "scipy", "scipy.stats", "numba", "cv2", "matplotlib")

# Runs the CLI, then prints which heavy libraries the command loaded.
PROBE = """
import runpy, sys
heavy = sys.argv[1].split(",")
sys.argv = ["inspect_validate", *sys.argv[2:]]
try:
    runpy.run_module("inspect_validate", run_name="__main__", alter_sys=True)
except SystemExit:
    pass
print("LOADED", ",".join(m for m in heavy if m in sys.modules), file=sys.stderr)
"""


def commands(out: Path) -> dict[str, list[str]]:
    station = str(SAMPLES / "station" / "station.yaml")
    return {
        "predict (paperboard scene)": ["predict", str(SAMPLES / "scenes/paperboard/scene.yaml")],
        "analyze-spectra (paperboard)": [
            "analyze-spectra",
            str(SAMPLES / "scenes/paperboard/scene.yaml"),
        ],
        "design (mix scene)": ["design", str(SAMPLES / "scenes/mix/scene.yaml")],
        "verify (shipped station)": ["verify", station, "--out", str(out / "v{run}")],
        "verify --report": ["verify", station, "--report", str(out / "r{run}")],
    }


def run_command(args: list[str], runs: int) -> tuple[float, float, str]:
    """Median time and peak RSS over ``runs`` fresh processes; the libraries it loaded."""
    # Each run needs fresh output folders: verify refuses to overwrite a report.
    fresh = [[a.replace("{run}", str(r)) for a in args] for r in range(runs)]
    times, peaks = [], []
    for argv in fresh:
        t, peak, _ = timed([sys.executable, "-m", "inspect_validate", *argv], 1)
        times.append(t)
        peaks.append(peak)
    argv = [a.replace("{run}", "probe") for a in args]
    proc = subprocess.run(
        [sys.executable, "-c", PROBE, ",".join(HEAVY), *argv],
        capture_output=True,
        text=True,
    )
    loaded = next(
        (line.split(" ", 1)[1] for line in proc.stderr.splitlines() if line.startswith("LOADED")),
        "?",
    ).strip()
    times.sort()
    return times[len(times) // 2], max(peaks), loaded or "—"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--runs", type=int, default=5)
    args = parser.parse_args()
    compile_package()
    print(machine_line())
    print(f"median of {args.runs} fresh processes each\n")
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp)
        (out / "floor.py").write_text("import numpy\n")
        floor, floor_peak, _ = timed([sys.executable, str(out / "floor.py")], args.runs)
        print("| command | time | / numpy floor | peak RSS | heavy libraries loaded |")
        print("|---|---|---|---|---|")
        print(f"| import numpy (floor) | {floor:.2f} s | 1.00 | {floor_peak:.0f} MB | — |")
        for label, argv in commands(out).items():
            t, peak, loaded = run_command(argv, args.runs)
            print(f"| {label} | {t:.2f} s | {t / floor:.2f} | {peak:.0f} MB | {loaded} |")


if __name__ == "__main__":
    main()
