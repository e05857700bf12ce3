"""`watch` on the shipped simulated station: false alarms, detection delay and cause, and
the time a cycle takes — measured through the CLI, against what the charts were designed
for in the same run.

Run: ``python benchmarks/bench_watch.py [--stable 200] [--repeats 3] [--goldens 40]
[--cycles 400] [--stops 20]`` (about 30 minutes on 2 cores at the defaults).

1. **In control.** A golden file is trained (5 repeats), then ``--stable`` cycles of
   an unchanged world are watched through the CLI. Reported: the cycles that alarmed.
   Then the in-control average run length *measured*: ``--goldens`` golden files (24), each
   of 5 repeats of its own world, each followed by ``--cycles`` in-control cycles in
   process (:func:`inspect_validate.simulation.watch_trials`: the same verification and
   charts as ``watch``, the charts restarting after an alarm), on an 80 × 60 frame of
   the shipped station (the statistics are those of any size; the frames are 16 ×
   cheaper). Cycles / alarms estimates the family's ARL₀ (exact Poisson 95 %
   interval), against the design (1000 cycles): for the steady station (its repeats
   vary by their noise alone, which floors σ₀), for one whose lights vary 0.5 %
   between captures (σ₀ is the spread, as on a real line), and for the paperboards on a
   12-bit camera (Mono12: another bit depth, gain and dark offset).
2. **Detection.** Each change starts at cycle 5 of a fresh history, ``--repeats``
   times: cycles from the onset to the first alarm (0: flagged in the onset cycle),
   and how often the first named cause is the right one.
3. **Cycle time.** The median time of a watched cycle (capture, verify, chart,
   commit) against a bare ``capture`` of the same station in the same process.
4. **Stop latency.** ``--stops`` watch processes, each sent SIGTERM at its own moment
   of start-up or cycling: the seconds until the process ended (the tests bound it
   only loosely, as a stop that hangs; the figure is here).
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
from scenes import twelve_bit_scene

from inspect_validate.cli import main as cli_main

ROOT = Path(__file__).resolve().parents[1]
STATION = ROOT / "sample_images" / "station"
SCENE = ROOT / "sample_images" / "scenes" / "paperboard" / "scene.yaml"
ONSET = 5

CHANGES = [
    ("amber LED −1 %/cycle (ageing)", {"percent_per_cycle": {1: -1.0}}, "LED ageing"),
    ("red LED +3 % step", {"irradiance": {2: 1.03}}, "red brighter by about 3.0 %"),
    ("exposure −3 %", {"exposure": 0.97}, "every illumination dimmer by about 3.0 %"),
    (
        "lens transmission −5 % (dust)",
        {"transmission": 0.95},
        "every illumination dimmer by about 5.0 %",
    ),
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
    from inspect_validate.watch.drift import DriftMonitor

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
    spreads = []
    for key, xs in values.items():
        target, sigma = monitor.targets[key]
        z = (np.array(xs, float) - target) / sigma
        spreads.append(float(np.nanstd(z, ddof=1)))
    return {
        "cycles": len(statuses),
        "alarmed": sum(s != "pass" for s in statuses),
        "spread": float(np.median(spreads)),
        "spread_max": float(np.max(spreads)),
        "seconds": float(np.median(seconds)),
        "charts": len(values),
        "limit": monitor.limit,
    }


def small_station(folder: Path, world: dict, *, twelve_bit: bool = False) -> Path:
    """The shipped station on an 80 × 60 frame, its ROI file drawn for it; ``twelve_bit``:
    on the 12-bit camera of :func:`scenes.twelve_bit_scene` (Mono12)."""
    from inspect_validate.model.render import class_bands

    folder.mkdir(parents=True, exist_ok=True)
    doc = yaml.safe_load((STATION / "station.yaml").read_text())
    doc["scene"] = str(twelve_bit_scene(folder) if twelve_bit else SCENE)
    doc["camera"].update(width=80, height=60, world=world)
    if twelve_bit:
        doc["camera"].update(pixel_format="Mono12", exposure_us=20000)
        # SNR_dB (36) divides by variances, so it falls with the gain: ε is the gain-free
        # limit (as bench_verdicts holds this camera)
        doc["acceptance"]["separation"] = [{"comparison": "A vs B,C", "max_error": 0.1}]
    bands = class_bands(["A", "B", "C"], height=60, width=80, gap=6)
    rois = {"erode": 1, "classes": {k: [{"rect": list(v)}] for k, v in bands.items()}}
    (folder / "rois.yaml").write_text(yaml.safe_dump(rois))
    path = folder / "station.yaml"
    path.write_text(yaml.safe_dump(doc, sort_keys=False))
    return path


def _watch_share(args):
    path, runs, cycles = args
    from inspect_validate.simulation import watch_trials
    from inspect_validate.station.file import read_station

    return list(watch_trials(read_station(path), runs=runs, repeats=5, cycles=cycles))


def measured_arl(
    tmp: Path, world: dict, goldens: int, cycles: int, jobs: int, *, twelve_bit: bool = False
) -> dict:
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor

    from scipy.stats import chi2

    path = small_station(tmp / f"small-{len(world)}-{twelve_bit}", world, twelve_bit=twelve_bit)
    parts = [(path, range(i, goldens, jobs), cycles) for i in range(jobs)]
    # Spawned, not forked: this process has run numba's OpenMP threads (the CLI above).
    with ProcessPoolExecutor(jobs, mp_context=multiprocessing.get_context("spawn")) as pool:
        trials = [t for part in pool.map(_watch_share, parts) for t in part]
    n = sum(t.cycles for t in trials)
    k = sum(t.alarms for t in trials)
    # Exact Poisson interval of the alarm count, as cycles per alarm.
    lo_rate = chi2.ppf(0.025, 2 * k) / 2 / n if k else 0.0
    hi_rate = chi2.ppf(0.975, 2 * k + 2) / 2 / n
    return {
        "cycles": n,
        "alarms": k,
        "failures": sum(t.failures for t in trials),
        "arl": n / k if k else math.inf,
        "arl_low": 1 / hi_rate,
        "arl_high": 1 / lo_rate if lo_rate else math.inf,
        "golden_alarms": sorted(t.alarms for t in trials),
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
    from inspect_validate.station.capture import capture
    from inspect_validate.station.file import read_station

    st = read_station(station(tmp / "capture"))
    times = []
    for k in range(5):
        t0 = time.perf_counter()
        capture(st, tmp / "capture" / f"run{k}")
        times.append(time.perf_counter() - t0)
    return float(np.median(times))


def stop_latency(tmp: Path, golden: Path, stops: int) -> list[float]:
    """Seconds from a SIGTERM to the end of a ``watch`` process, the signal sent at
    delays spread over its start-up and its cycles (the latency a service manager sees)."""
    import os
    import signal
    import subprocess

    path = station(tmp / "stops")
    took = []
    for k in range(stops):
        proc = subprocess.Popen(
            [
                sys.executable,
                "-m",
                "inspect_validate",
                "watch",
                str(path),
                "--golden",
                str(golden),
                "--db",
                str(tmp / "stops" / f"w{k}" / "h.sqlite"),
                "--interval",
                "0",
            ],
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
            env={**os.environ},
        )
        time.sleep(0.3 + 3.7 * k / max(stops - 1, 1))
        t0 = time.perf_counter()
        proc.send_signal(signal.SIGTERM)
        proc.wait()
        took.append(time.perf_counter() - t0)
    return took


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--stable", type=int, default=200, help="in-control cycles")
    parser.add_argument("--repeats", type=int, default=3, help="runs per change")
    parser.add_argument("--goldens", type=int, default=24, help="golden files, measured ARL")
    parser.add_argument("--cycles", type=int, default=400, help="cycles per golden file")
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--stops", type=int, default=20, help="watch runs stopped by SIGTERM")
    parser.add_argument(
        "--causes-only", action="store_true", help="only the changes' delays and causes"
    )
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        golden = tmp / "golden.json"
        cli("train", station(tmp / "train"), "--out", golden, "--repeats", 5)
        t0 = time.perf_counter()
        results = [
            (name, *detection(tmp, golden, change, cause, args.repeats))
            for name, change, cause in CHANGES
        ]
        if args.causes_only:
            print(machine_line())
            print(f"{time.perf_counter() - t0:.0f} s in all")
            _print_causes(results)
            return 0
        stable = in_control(tmp, golden, args.stable)
        bare = capture_time(tmp)
        stops = stop_latency(tmp, golden, args.stops)
        arls = {
            name: measured_arl(tmp, world, args.goldens, args.cycles, args.jobs, twelve_bit=twelve)
            for name, world, twelve in (
                ("steady", {}, False),
                ("lights ±0.5 % between captures", {"irradiance_jitter": 0.005}, False),
                ("12-bit camera (Mono12), steady", {}, True),
            )
        }
        elapsed = time.perf_counter() - t0
    print(machine_line())
    print(
        f"shipped simulated station: {stable['charts']} charts, L = {stable['limit']:.2f}, "
        f"golden from 5 repeats; {elapsed:.0f} s in all"
    )
    print()
    print("| in control | measured | design | ratio |")
    print("|---|---|---|---|")
    print(f"| cycles watched (CLI) | {stable['cycles']} | | |")
    print(
        f"| cycles alarmed (CLI) | {stable['alarmed']} | ≤ {stable['cycles'] / 1000:.2f} "
        "expected | |"
    )
    for name, r in arls.items():
        if r["alarms"]:
            arl = f"{r['arl']:.3g} ({r['arl_low']:.3g}–{r['arl_high']:.3g})"
            ratio = f"{r['arl'] / 1000:.2f}"
        else:
            arl, ratio = f"> {r['arl_low']:.3g} (no alarm)", f"> {r['arl_low'] / 1000:.2f}"
        print(
            f"| family ARL₀ measured, {name}: {r['cycles']} cycles of {args.goldens} golden "
            f"files, {r['alarms']} alarms [cycles] | {arl} | 1000 | {ratio} |"
        )
        print(
            f"| cycles failing a check, {name} | {r['failures']} of {r['cycles']} | "
            f"≤ 0.27 % ({0.0027 * r['cycles']:.3g}) | |"
        )
    print(
        f"| cycle-to-cycle spread / σ₀ (median, max over charts) | {stable['spread']:.2f}, "
        f"{stable['spread_max']:.2f} | ≤ 1 | |"
    )
    print(
        f"| cycle time [s] (watch against a bare capture) | {stable['seconds']:.2f} | "
        f"{bare:.2f} | {stable['seconds'] / bare:.2f} |"
    )
    print(
        f"| stop latency after SIGTERM [s] (median, max of {len(stops)}; against a cycle) | "
        f"{np.median(stops):.2f}, {max(stops):.2f} | {stable['seconds']:.2f} | "
        f"{max(stops) / stable['seconds']:.2f} |"
    )
    _print_causes(results)
    return 0


def _print_causes(results) -> None:
    print()
    print(f"| change at cycle {ONSET} | cycles to the alarm (each run) | right cause and size |")
    print("|---|---|---|")
    for name, delays, right in results:
        shown = ", ".join(
            "never" if d == math.inf else "false alarm" if d < 0 else str(d) for d in delays
        )
        print(f"| {name} | {shown} | {right}/{len(delays)} |")


if __name__ == "__main__":
    sys.exit(main())
