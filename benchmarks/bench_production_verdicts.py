"""Production verdicts as a statistical decision (issue 48, item 10): how often
``verify --production`` fails a batch of good parts, and how often it catches a change,
each over many batches, with Clopper–Pearson 95 % intervals beside the stated
false-alarm rate.

Every batch is judged against a golden file trained afresh on good parts, so the
false-alarm rate is the one a user meets over the golden files they could have trained.
Two lines:

1. **A photograph on a belt** (frames no one here drew): scikit-image's cameraman moved
   by up to 40 px and turned by up to 5° with 2 DN of noise, verified by a station of its
   frames alone (its classes the face, the coat, the sky and a shadow of about 5 DN);
   16 golden parts, 8 a batch; a light 5 % dimmer and 2 % brighter, and a lens out of
   focus.
2. **The simulated line** (``sample_images/line``, rendered in process by its simulated
   camera: every part another draw of its classes, EMVA noise): 40 golden parts, 10 a
   batch; the amber light 5 % and 1 % dimmer, the camera's gain 2 % up, a defocus of
   σ 1 px; and, with the parts held by a fixture (±5 px), the camera knocked by 4 px.

Each failing batch's likely cause is held to the case's (the light, the gain, the focus,
the camera or fixture): the last column counts the batches that name it, of those that
failed.

Run: ``python benchmarks/bench_production_verdicts.py [--batches 200]`` (about 12 minutes).
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
    "light +2 %": {"gain": 1.02},
    "defocus (blur σ 1 px)": {"blur": 1.0},
}
# What each case's likely cause must say.
NAMED = {
    "light −5 %": "the light is dimmer",
    "light +2 %": "the light is brighter",
    "light −1 %": "the light is dimmer",
    "gain +2 %": "the camera's gain is up",
    "defocus (blur σ 1 px)": "the focus measure fell",
    "fixture: camera knocked 4 px": "the camera or the fixture moved",
}


def shadowed(station):
    """``station`` with a fourth class in the photograph's darkest corner (about 5 DN,
    under a tenth of the sky): the class a blur's diagnosis once stumbled on."""
    import yaml

    from inspect_validate.station.file import read_station

    path = station.resolve(station.rois)
    rois = yaml.safe_load(path.read_text())
    rois["classes"]["shadow"] = [{"rect": [184, 376, 40, 40]}]
    path.write_text(yaml.safe_dump(rois))
    return read_station(station.path)


def batch(n: int, rng: np.random.Generator, **fault):
    for i in range(n):
        dx, dy, deg = rng.uniform(-40, 40), rng.uniform(-40, 40), rng.uniform(-5, 5)
        yield f"part {i}", moved_part(dx, dy, deg, seed=int(rng.integers(2**31)), **fault)


LINE_GOLDEN, LINE_BATCH = 40, 10
FIXTURE = {"shift": 0.01, "rotation_deg": 0.5}
LINE_CASES = {
    "good parts": ({}, {}),
    "light −5 %": ({"irradiance": {1: 0.95}}, {}),
    "light −1 %": ({"irradiance": {1: 0.99}}, {}),
    "gain +2 %": ({"gain_error": 0.02}, {}),
    "defocus (blur σ 1 px)": ({"blur_px": 1.0}, {}),
    "fixture: good parts": ({}, FIXTURE),
    "fixture: camera knocked 4 px": ({}, {**FIXTURE, "camera_shift_px": (4.0, 0.0)}),
}


def line_cameras(tmp: Path) -> tuple[object, dict]:
    """The simulated line's station and a camera for each case's world (frames at once:
    no frame interval), lit by the production light."""
    import json

    from inspect_validate.simulation.camera import scene_grabber
    from inspect_validate.station.file import read_station
    from inspect_validate.station.world import Line, World

    station = read_station(
        Path(__file__).resolve().parents[1] / "sample_images" / "line" / "station.yaml"
    )
    state = tmp / "state.json"
    state.write_text(json.dumps({"channels": {"1": 100}}))
    cameras = {}
    for case, (world, line) in LINE_CASES.items():
        base = station.camera.world
        w = World(
            **{**base.model_dump(), **world, "line": Line(**{**base.line.model_dump(), **line})}
        )
        camera = scene_grabber(station.model_copy(update={"camera": station.camera.model_copy(
            update={"world": w})}), state)  # fmt: skip
        camera.interval = 0.0
        cameras[case] = camera
    return station, cameras


def line_batch(camera, n: int):
    return ((f"part {i}", f.data) for i, f in enumerate(camera.grab(n)))


def line_rows(batches: int) -> tuple[dict[str, int], dict[str, int]]:
    """The simulated line's cases: batches failed of ``batches``, and of those how many
    named the case's cause."""
    from inspect_validate.verification.parts import measure_frames
    from inspect_validate.verification.parts_golden import golden_parts
    from inspect_validate.verification.production import verify_parts

    failed, named = dict.fromkeys(LINE_CASES, 0), dict.fromkeys(LINE_CASES, 0)
    with tempfile.TemporaryDirectory() as tmp:
        station, cameras = line_cameras(Path(tmp))
        for _ in range(batches):
            goldens = {
                key: golden_parts(
                    station, measure_frames(station, line_batch(cameras[case], LINE_GOLDEN))
                )
                for key, case in (("belt", "good parts"), ("fixture", "fixture: good parts"))
            }
            for case, camera in cameras.items():
                golden = goldens["fixture" if case.startswith("fixture") else "belt"]
                parts = measure_frames(station, line_batch(camera, LINE_BATCH))
                tally(verify_parts(station, parts, golden), case, failed, named)
    return failed, named


def tally(verdict, case: str, failed: dict[str, int], named: dict[str, int]) -> None:
    if not verdict.passed:
        failed[case] += 1
        named[case] += case in NAMED and NAMED[case] in (verdict.cause or "")


def table(failed: dict[str, int], named: dict[str, int], batches: int) -> None:
    print("| case | failed | rate | 95 % interval | cause named |")
    print("|---|---|---|---|---|")
    for case, k in failed.items():
        lo, hi = clopper_pearson(k, batches)
        cause = f"{named[case]} of {k}" if case in NAMED else "—"
        print(f"| {case} | {k} of {batches} | {100 * k / batches:.1f} % | "
              f"{100 * lo:.1f}–{100 * hi:.1f} % | {cause} |")  # fmt: skip


def main() -> None:
    from inspect_validate.verification.parts import measure_frames
    from inspect_validate.verification.parts_golden import golden_parts
    from inspect_validate.verification.production import verify_parts

    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--batches", type=int, default=200)
    args = parser.parse_args()
    started = time.perf_counter()
    with tempfile.TemporaryDirectory() as tmp:
        station = shadowed(production_station(Path(tmp), alone=True))
        rate = station.acceptance.false_alarm_rate
        rng = np.random.default_rng(0)
        failed, named = dict.fromkeys(CASES, 0), dict.fromkeys(CASES, 0)
        for _ in range(args.batches):
            golden = golden_parts(station, measure_frames(station, batch(GOLDEN_PARTS, rng)))
            for case, fault in CASES.items():
                parts = measure_frames(station, batch(BATCH_PARTS, rng, **fault))
                tally(verify_parts(station, parts, golden), case, failed, named)
    photograph = time.perf_counter() - started
    line, line_named = line_rows(args.batches)
    print(machine_line())
    rate = station.acceptance.false_alarm_rate
    print(f"{args.batches} batches a case; stated false-alarm rate {100 * rate:.2g} %\n")
    print(f"**A photograph on a belt** ({photograph:.0f} s):\n")
    table(failed, named, args.batches)
    print(f"\n**The simulated line** ({time.perf_counter() - started - photograph:.0f} s):\n")
    table(line, line_named, args.batches)


if __name__ == "__main__":
    main()
