"""What the pictures add to the commands that draw them, through the CLI in fresh
processes (imports included), each against the same command without its pictures in the
same run.

1. ``verify`` and ``verify --report`` against ``capture`` of the same station (what verify
   adds to taking the frames: planning, measuring, predicting, checking), and
   ``verify --report`` against ``verify``, on the shipped station and on a 5 MP station of
   four illuminations, interleaved; with the page's weight. Targets: verify ≤ 1.2 ×
   capture, with and without ``--report``; the report ≤ 1.3 × verify, and the page no
   heavier than before the charts (1.54 MB on the shipped station, seven matplotlib PNGs).
2. ``predict --plot``, ``history --plot`` and ``characterize --report`` against the same
   command without: the pictures' share of the run. Target: ≤ 30 % (the matplotlib
   figures of ``--plot-format png``, written only when asked, are exempt and shown).

Run: ``python benchmarks/bench_report.py [--runs 3]`` (about three minutes).
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import yaml
from machine import machine_line

ROOT = Path(__file__).resolve().parent.parent
STATION = ROOT / "sample_images" / "station"
TARGET = 1.3
OVER_CAPTURE = 1.2
SHARE = 0.30
WEIGHT_BEFORE = 1_543_379  # bytes: report.html of the shipped station, matplotlib figures


def big_station(folder: Path) -> Path:
    """The shipped station at 2592 × 1944 (5 MP) with four illuminations; its ROIs scaled
    to the frame (the simulated world scales its class bands with the frame)."""
    doc = yaml.safe_load((STATION / "station.yaml").read_text())
    doc["scene"] = str((STATION / doc["scene"]).resolve())
    doc["camera"].update(width=2592, height=1944)
    doc["illuminations"] = [
        {"name": "amber", "channels": {1: 100}},
        {"name": "red", "channels": {2: 100}},
        {"name": "both", "channels": {1: 60, 2: 60}},
        {"name": "amber_half", "channels": {1: 50}},
    ]
    scale = 2592 / 320
    rois = yaml.safe_load((STATION / "rois.yaml").read_text())
    for shapes in rois["classes"].values():
        for shape in shapes:
            shape["rect"] = [round(v * scale) for v in shape["rect"]]
    rois["erode"] = 3
    (folder / "rois.yaml").write_text(yaml.safe_dump(rois))
    doc["rois"] = str(folder / "rois.yaml")
    doc["acceptance"].pop("ranking", None)
    path = folder / "big.yaml"
    path.write_text(yaml.safe_dump(doc, sort_keys=False))
    return path


def seconds(args: list[str]) -> float:
    # As a user's install runs: its modules' bytecode cached (not compiled every run).
    env = {k: v for k, v in os.environ.items() if k != "PYTHONDONTWRITEBYTECODE"}
    start = time.perf_counter()
    run = subprocess.run(
        [sys.executable, "-m", "inspect_validate", *args], capture_output=True, text=True, env=env
    )
    elapsed = time.perf_counter() - start
    if run.returncode not in (0, 1):
        raise SystemExit(f"{' '.join(args)} failed ({run.returncode}): {run.stderr[-500:]}")
    return elapsed


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--runs", type=int, default=3)
    args = parser.parse_args()
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        stations = {
            "shipped station (320 × 240, 2 illuminations)": STATION / "station.yaml",
            "5 MP, 4 illuminations": big_station(tmp),
        }
        # compile caches, warm the disk (into tmp: without --out, verify keeps its capture
        # in the working directory)
        seconds(["verify", str(STATION / "station.yaml"), "--out", str(tmp / "warm")])
        for name, station in stations.items():
            taken, plain, report, weight = [], [], [], 0
            for run in range(args.runs):
                stem = f"{name[:3]}{run}"
                taken.append(seconds(["capture", str(station), "--out", str(tmp / f"c{stem}")]))
                # Every illumination, as capture takes them: the same plan (verify leaves
                # out those predicted dominated, which made it faster than capture).
                every = ["--all-illuminations"]
                plain.append(
                    seconds(["verify", str(station), "--out", str(tmp / f"v{stem}"), *every])
                )
                out = tmp / f"r{stem}"
                report.append(seconds(["verify", str(station), "--report", str(out), *every]))
                weight = (out / "report.html").stat().st_size
            rows.append((name, *map(statistics.median, (taken, plain, report)), weight))
    print(machine_line())
    print(f"medians of {args.runs} interleaved runs each, fresh processes\n")
    print(
        "| station | capture [s] | verify [s] | ÷ capture | verify --report [s] | ÷ capture "
        "| ÷ verify | report.html [kB] |"
    )
    print("|---|---|---|---|---|---|---|---|")
    for name, taken, plain, report, weight in rows:
        print(
            f"| {name} | {taken:.2f} | {plain:.2f} | {plain / taken:.2f} (≤ {OVER_CAPTURE}) | "
            f"{report:.2f} | {report / taken:.2f} (≤ {OVER_CAPTURE}) | {report / plain:.2f} "
            f"(≤ {TARGET}) | {weight / 1000:.0f} |"
        )
    print(f"\nreport.html of the shipped station before the charts: {WEIGHT_BEFORE / 1000:.0f} kB")
    print()
    print("| command | without pictures [s] | with [s] | pictures' share | target |")
    print("|---|---|---|---|---|")
    for name, plain, drawn in others(args.runs):
        share = (drawn - plain) / drawn
        print(
            f"| {name} | {plain:.2f} | {drawn:.2f} | {100 * share:.0f} % | ≤ {100 * SHARE:.0f} % |"
        )


def _filled(args: list[str], tmp: Path, stem: str) -> list[str]:
    """``args`` with ``{out}`` and ``{dir}`` as fresh folders of their own."""
    return [
        a.replace("{out}", str(tmp / f"out{stem}")).replace("{dir}", str(tmp / f"dir{stem}"))
        for a in args
    ]


def others(runs: int) -> list[tuple[str, float, float]]:
    """(command, median seconds without its pictures, with them) for the other drawers."""
    scene = str(ROOT / "sample_images" / "scenes" / "paperboard" / "scene.yaml")
    station = str(STATION / "station.yaml")
    out = []
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        db = tmp / "history.sqlite"
        seconds(["train", station, "--out", str(tmp / "golden.json"), "--repeats", "5"])
        seconds(["watch", station, "--golden", str(tmp / "golden.json"), "--db", str(db),
                 "--cycles", "5", "--interval", "0"])  # fmt: skip
        png = ["--plot-format", "png"]
        cases = {
            "predict --plot (paperboard scene)": (["predict", scene], ["--plot", "{dir}"]),
            "history --plot (5 cycles)": (["history", str(db)], ["--plot", "{dir}"]),
            "predict --plot --plot-format png (exempt)": (
                ["predict", scene],
                ["--plot", "{dir}", *png],
            ),
            "history --plot --plot-format png (exempt)": (
                ["history", str(db)],
                ["--plot", "{dir}", *png],
            ),
            "characterize --report (shipped station)": (
                ["characterize", station, "--out", "{out}"],
                ["--report", "{dir}"],
            ),
        }
        for name, (command, drawing) in cases.items():
            plain, drawn = [], []
            for run in range(runs):
                stem = f"{len(out)}-{run}"
                plain.append(seconds(_filled(command, tmp, f"p{stem}")))
                drawn.append(seconds(_filled([*command, *drawing], tmp, f"d{stem}")))
            out.append((name, statistics.median(plain), statistics.median(drawn)))
    return out


if __name__ == "__main__":
    main()
