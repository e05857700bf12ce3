"""Production verdicts as a statistical decision (issue 48, item 10): how often
``verify --production`` fails a batch of good parts, and how often it catches a light
5 % dimmer, a lens out of focus and a light 2 % brighter (a gain step), each over many
batches, with Clopper–Pearson 95 % intervals beside the stated false-alarm rate.

Every batch is judged against a golden file trained afresh on good parts, so the
false-alarm rate is the one a user meets over the golden files they could have trained.
The parts are scikit-image's photograph of a cameraman on a belt (the tests' line),
moved by up to 40 px and turned by up to 5° with 2 DN of noise; 16 golden parts and 8
parts a batch.

Run: ``python benchmarks/bench_production_verdicts.py [--batches 200]`` (about 5 minutes).
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from bench_verdicts import clopper_pearson
from machine import machine_line

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from conftest import moved_part, production_station

GOLDEN_PARTS = 16
BATCH_PARTS = 8
CASES = {
    "good parts": {},
    "light −5 %": {"gain": 0.95},
    "light +2 % (a gain step)": {"gain": 1.02},
    "defocus (blur σ 1 px)": {"blur": 1.0},
}


def batch(n: int, rng: np.random.Generator, **fault):
    for i in range(n):
        dx, dy, deg = rng.uniform(-40, 40), rng.uniform(-40, 40), rng.uniform(-5, 5)
        yield f"part {i}", moved_part(dx, dy, deg, seed=int(rng.integers(2**31)), **fault)


def main() -> None:
    from inspect_validate.verification.production import golden_parts, measure_frames, verify_parts

    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--batches", type=int, default=200)
    args = parser.parse_args()
    started = time.perf_counter()
    with tempfile.TemporaryDirectory() as tmp:
        station = production_station(Path(tmp))
        rate = station.acceptance.false_alarm_rate
        rng = np.random.default_rng(0)
        failed = dict.fromkeys(CASES, 0)
        for _ in range(args.batches):
            golden = golden_parts(station, measure_frames(station, batch(GOLDEN_PARTS, rng)))
            for case, fault in CASES.items():
                parts = measure_frames(station, batch(BATCH_PARTS, rng, **fault))
                failed[case] += not verify_parts(station, parts, golden).passed
    print(machine_line())
    print(f"{args.batches} batches a case, {time.perf_counter() - started:.0f} s; "
          f"stated false-alarm rate {100 * rate:.2g} %\n")  # fmt: skip
    print("| case | failed | rate | 95 % interval |")
    print("|---|---|---|---|")
    for case, k in failed.items():
        lo, hi = clopper_pearson(k, args.batches)
        print(f"| {case} | {k} of {args.batches} | {100 * k / args.batches:.1f} % | "
              f"{100 * lo:.1f}–{100 * hi:.1f} % |")  # fmt: skip


if __name__ == "__main__":
    main()
