"""`watch` on the shipped simulated station: false alarms, detection delay and cause, and
the time a cycle takes — measured through the CLI, against what the charts were designed
for in the same run.

Run: ``python benchmarks/bench_watch.py [--stable 200] [--repeats 3]`` (about 8 minutes
on 2 cores at the defaults).

1. **In control.** A golden file is trained (5 repeats), then ``--stable`` cycles of
   an unchanged world are watched. Reported: the cycles that alarmed, and the
   family's in-control ARL estimated from what the charts saw — per chart, the
   cycle values' mean m and spread s in units of its σ₀ give that chart's ARL by
   the Markov chain at limit L/s and shift m/s; the family's is 1/Σ 1/ARLᵢ
   (independent charts; the real ones are correlated, which lengthens it) —
   against the design target (1000 cycles).
2. **Detection.** Each change starts at cycle 5 of a fresh history, ``--repeats``
   times: cycles from the onset to the first alarm (0: flagged in the onset cycle),
   and how often the first named cause is the right one.
3. **Cycle time.** The median time of a watched cycle (capture, verify, chart,
   commit) against a bare ``capture`` of the same station in the same process.
"""

from __future__ import annotations

import argparse
import contextlib
import io
import math
import shutil
import sqlite3
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import yaml
from machine import machine_line

from inspect_validate.cli import main as cli_main

ROOT = Path(__file__).resolve().parents[1]
STATION = ROOT / "sample_images" / "station"
SCENE = ROOT / "sample_images" / "scenes" / "paperboard" / "scene.yaml"
ONSET = 5

CHANGES = [
    ("amber LED −1 %/cycle (ageing)", {"percent_per_cycle": {1: -1.0}}, "LED ageing"),
    ("red LED +3 % step", {"irradiance": {2: 1.03}}, "red brighter"),
    ("exposure −3 %", {"exposure": 0.97}, "every illumination"),
    ("lens transmission −5 % (dust)", {"transmission": 0.95}, "every illumination"),
    ("amber peak +8 nm", {"peak_shift_nm": {1: 8.0}}, "spectrum changed"),
    ("defocus 1 px", {"blur_px": 1.0}, "defocus"),
]


def cli(*args) -> int:
    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
        try:
            cli_main([str(a) for a in args])
        except SystemExit as exc:
            return int(exc.code or 0)
    return 0


def station(folder: Path, changes=()) -> Path:
    doc = yaml.safe_load((STATION / "station.yaml").read_text())
    doc["scene"] = str(SCENE)
    doc["camera"]["world"] = {"changes": list(changes)}
    folder.mkdir(parents=True, exist_ok=True)
    shutil.copy(STATION / "rois.yaml", folder / "rois.yaml")
    path = folder / "station.yaml"
    path.write_text(yaml.safe_dump(doc, sort_keys=False))
    return path


def in_control(tmp: Path, golden: Path, cycles: int):
    from inspect_validate.verification.golden import read_golden
    from inspect_validate.watch.drift import DriftMonitor, ewma_arl

    path = station(tmp / "stable")
    db = tmp / "stable" / "history.sqlite"
    cli("watch", path, "--golden", golden, "--db", db, "--interval", 0, "--cycles", cycles)
    with sqlite3.connect(db) as con:
        statuses = [s for (s,) in con.execute("SELECT status FROM cycles ORDER BY cycle")]
        points = con.execute(
            "SELECT illumination, kind, name, quantity, value FROM points ORDER BY cycle"
        ).fetchall()
        seconds = [s for (s,) in con.execute("SELECT seconds FROM cycles")]
    monitor = DriftMonitor(read_golden(golden), dark_offset=0.0)
    values: dict = {}
    for *key, value in points:
        values.setdefault(tuple(key), []).append(value)
    rate = 0.0
    spreads = []
    for key, xs in values.items():
        target, sigma = monitor.targets[key]
        z = (np.array(xs, float) - target) / sigma
        z = z[np.isfinite(z)]
        m, s = float(z.mean()), float(z.std(ddof=1))
        spreads.append(s)
        rate += 1.0 / ewma_arl(monitor.limit / s, shift=m / s)
    return {
        "cycles": len(statuses),
        "alarmed": sum(s != "pass" for s in statuses),
        "arl": 1.0 / rate,
        "spread": float(np.median(spreads)),
        "spread_max": float(np.max(spreads)),
        "seconds": float(np.median(seconds)),
        "charts": len(values),
        "limit": monitor.limit,
    }


def detection(tmp: Path, golden: Path, change: dict, cause: str, repeats: int):
    delays, right = [], 0
    for k in range(repeats):
        folder = tmp / f"change-{id(change)}-{k}"
        path = station(folder, [{"start": ONSET, **change}])
        db = folder / "history.sqlite"
        cli("watch", path, "--golden", golden, "--db", db, "--interval", 0, "--cycles", ONSET + 8)
        with sqlite3.connect(db) as con:
            rows = con.execute("SELECT cycle, status, cause FROM cycles ORDER BY cycle").fetchall()
        flagged = [r for r in rows if r[1] != "pass"]
        if flagged and flagged[0][0] >= ONSET:
            delays.append(flagged[0][0] - ONSET)
            right += bool(flagged[0][2] and cause in flagged[0][2])
        else:
            delays.append(math.inf if not flagged else -1)  # -1: a false alarm before it
    return delays, right


def capture_time(tmp: Path) -> float:
    from inspect_validate.camera.capture import capture
    from inspect_validate.camera.station import read_station

    st = read_station(station(tmp / "capture"))
    times = []
    for k in range(5):
        t0 = time.perf_counter()
        capture(st, tmp / "capture" / f"run{k}")
        times.append(time.perf_counter() - t0)
    return float(np.median(times))


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--stable", type=int, default=200, help="in-control cycles")
    parser.add_argument("--repeats", type=int, default=3, help="runs per change")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        golden = tmp / "golden.json"
        cli("train", station(tmp / "train"), "--out", golden, "--repeats", 5)
        t0 = time.perf_counter()
        stable = in_control(tmp, golden, args.stable)
        results = [
            (name, *detection(tmp, golden, change, cause, args.repeats))
            for name, change, cause in CHANGES
        ]
        bare = capture_time(tmp)
        elapsed = time.perf_counter() - t0
    print(machine_line())
    print(
        f"shipped simulated station: {stable['charts']} charts, L = {stable['limit']:.2f}, "
        f"golden from 5 repeats; {elapsed:.0f} s in all"
    )
    print()
    print("| in control | measured | design | ratio |")
    print("|---|---|---|---|")
    print(f"| cycles watched | {stable['cycles']} | | |")
    print(f"| cycles alarmed | {stable['alarmed']} | {stable['cycles'] / 1000:.2f} expected | |")
    arl, ratio = f"{stable['arl']:.3g}", f"{stable['arl'] / 1000:.2f}"
    if stable["arl"] > 1e6:  # beyond what the approximation (independent charts) can tell
        arl, ratio = "> 10⁶", "> 1000"
    print(f"| family ARL₀ from the charts' measured spread [cycles] | {arl} | 1000 | {ratio} |")
    print(
        f"| cycle-to-cycle spread / σ₀ (median, max over charts) | {stable['spread']:.2f}, "
        f"{stable['spread_max']:.2f} | ≤ 1 | |"
    )
    print(
        f"| cycle time [s] (watch against a bare capture) | {stable['seconds']:.2f} | "
        f"{bare:.2f} | {stable['seconds'] / bare:.2f} |"
    )
    print()
    print(f"| change at cycle {ONSET} | cycles to the alarm (each run) | right cause |")
    print("|---|---|---|")
    for name, delays, right in results:
        shown = ", ".join(
            "never" if d == math.inf else "false alarm" if d < 0 else str(d) for d in delays
        )
        print(f"| {name} | {shown} | {right}/{len(delays)} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
