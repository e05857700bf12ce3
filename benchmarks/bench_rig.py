"""Several cameras on one trigger: what a capture of two cameras costs against each
camera's capture alone.

Run: ``python benchmarks/bench_rig.py [--camera simulated|pylon-emulator] [--frames 8]
[--size 512]`` (about a minute); ``--verdicts 200`` adds the verdict's error rates (below;
about five minutes).

The shipped station's illuminations and darks, ``--frames`` each, software-triggered,
devices open (opening them is paid once a capture and timed apart). Three captures:
camera A alone, camera B alone, and both as one station of two cameras (``cameras:``:
every round triggers both in turn, then fetches each frame). The target is the slowest
camera's time plus a small overhead, not the sum: a real camera exposes and transfers
in parallel with the others once triggered.

``--camera pylon-emulator``: two of pypylon's emulated cameras (``PYLON_CAMEMU=2``) at
``--fps``, their test pattern instead of the scene (times only). The simulated camera
renders every frame on the CPU and takes its frame interval (10 ms) to accept a
trigger, so two of them on 2 cores cost nearer the sum: what that measures is this
tool's overhead on top of two cameras that cannot work in parallel.

``--verdicts N``: the shipped two-camera station verified N times, each on a capture of
its own (in process: what ``verify`` does), counting the verdicts that fail it, against
the design (``acceptance.false_alarm``, 0.27 %, shared by the two cameras' verifications
and the checks across them); then N/4 times with the side camera changed alone — its
exposure a factor up (its gain would do the same) and, a real difference that should
pass, its lens transmitting 1 % less — counting the verdicts that fail, and which checks
failed them.
"""

from __future__ import annotations

import argparse
import os
import shutil
import tempfile
import time
from pathlib import Path

import yaml
from machine import machine_line

ROOT = Path(__file__).resolve().parents[1]


def stations(folder: Path, kind: str, size: int, frames: int) -> dict[str, Path]:
    """Station files: ``a`` and ``b`` of one camera each, ``rig`` of both."""
    shutil.copytree(ROOT / "sample_images/station", folder / "station", dirs_exist_ok=True)
    shutil.copytree(ROOT / "sample_images/scenes", folder / "scenes", dirs_exist_ok=True)
    doc = yaml.safe_load((folder / "station/station.yaml").read_text())
    if kind == "simulated":
        cameras = [
            {**doc["camera"], "width": size, "height": size, "name": name} for name in ("a", "b")
        ]
    else:
        cameras = [
            {"backend": "pylon", "serial": f"0815-000{i}", "name": name,
             "pixel_format": "Mono8", "exposure_us": 5000}
            for i, name in enumerate(("a", "b"))
        ]  # fmt: skip
        doc.pop("scene"), doc.pop("channels")
    for cam in cameras:
        cam["acquisition"] = "software-trigger"
    doc.pop("camera")
    doc.update(frames=frames, dark_frames=frames, acceptance={})
    paths = {}
    for name, cams in (("a", cameras[:1]), ("b", cameras[1:]), ("rig", cameras)):
        one = dict(doc)
        if len(cams) == 1:
            one["camera"] = {k: v for k, v in cams[0].items() if k != "name"}
        else:
            one["cameras"] = cams
        paths[name] = folder / f"station/{name}.yaml"
        paths[name].write_text(yaml.safe_dump(one, sort_keys=False))
    return paths


def timed(path: Path, out: Path) -> float:
    """Seconds of a capture with its devices open (opening them, which every capture
    pays once, is left out: it goes through ``open_rig`` for one camera or several)."""
    from contextlib import contextmanager

    from inspect_validate.station import capture as capture_module
    from inspect_validate.station import devices
    from inspect_validate.station.file import read_station

    station = read_station(path)
    opened: list[float] = []
    original = devices.open_rig

    @contextmanager
    def timed_open(*args, **kwargs):
        t0 = time.perf_counter()
        with original(*args, **kwargs) as opened_devices:
            opened.append(time.perf_counter() - t0)
            yield opened_devices

    devices.open_rig = timed_open
    try:
        t0 = time.perf_counter()
        capture_module.capture(station, out)
        return time.perf_counter() - t0 - sum(opened)
    finally:
        devices.open_rig = original


def pace_emulator(fps: float) -> None:
    """Every PylonGrabber configured from now on grabs at ``fps`` (its frame rate)."""
    os.environ["PYLON_CAMEMU"] = "2"  # read when pylon's transport layers start
    from inspect_validate.camera.grabbers.pylon import PylonGrabber

    configure = PylonGrabber.configure

    def paced(self, **options):
        configure(self, **options)
        self._write("AcquisitionFrameRateEnable", True, "frame rate")
        self._write("AcquisitionFrameRate", fps, "frame rate")

    PylonGrabber.configure = paced


def verdicts(runs: int) -> None:
    """The verdict's error rates (module text), printed as a table."""
    from inspect_validate.station.file import read_station
    from inspect_validate.verification.rig import verify_rig

    base = read_station(ROOT / "sample_images/station/two_cameras.yaml")

    def with_side(world: dict):
        side = base.cameras[1]
        changed = side.model_copy(update={"world": side.world.model_copy(update=world)})
        return base.model_copy(update={"cameras": [base.cameras[0], changed]})

    rows = [("unchanged", {}, runs)]
    rows += [
        (f"side exposure ×{f:g}", {"exposure": f}, runs // 4) for f in (1.01, 1.02, 1.03, 1.05)
    ]
    rows.append(("side lens transmission ×0.99", {"transmission": 0.99}, runs // 4))
    print()
    print("verdicts of the shipped two-camera station, each on its own capture")
    print()
    print(
        "| side camera | runs | verdicts failed | a camera's own checks failed | checks across failed | design |"
    )
    print("|---|---|---|---|---|---|")
    for label, world, n in rows:
        station = with_side(world)
        failed = own = across = 0
        with tempfile.TemporaryDirectory() as tmp:
            for k in range(n):
                v = verify_rig(station, out=Path(tmp) / f"r{k}")
                shutil.rmtree(Path(tmp) / f"r{k}")
                failed += not v.passed
                own += not all(c.passed for c in v.cameras.values())
                across += not all(c.passed for c in v.checks)
        design = (
            f"≤ {100 * base.acceptance.false_alarm_rate:.2g} %"
            if not world
            else ("pass (within the 2 % tolerance)" if "transmission" in world else "")
        )
        print(
            f"| {label} | {n} | {failed} ({100 * failed / n:.3g} %) | {own} | {across} | {design} |"
        )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--camera", choices=("simulated", "pylon-emulator"), default="simulated")
    parser.add_argument("--frames", type=int, default=8)
    parser.add_argument("--size", type=int, default=512)
    parser.add_argument("--fps", type=float, default=20.0)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--verdicts", type=int, default=0, help="verify the station N times")
    args = parser.parse_args()
    kind = "simulated" if args.camera == "simulated" else "pylon"
    if kind == "pylon":
        pace_emulator(args.fps)
    times: dict[str, list[float]] = {"a": [], "b": [], "rig": []}
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        paths = stations(tmp, kind, args.size, args.frames)
        for r in range(args.repeats):
            for name, path in paths.items():
                times[name].append(timed(path, tmp / f"{name}-{r}"))
    best = {name: min(t) for name, t in times.items()}
    slowest = max(best["a"], best["b"])
    print(machine_line())
    camera = (
        f"the simulated camera at {args.size} × {args.size}"
        if kind == "simulated"
        else f"pypylon's emulator at {args.fps:g} fps"
    )
    print(
        f"{camera}; 3 steps of {args.frames} frames, software-triggered, devices open; the "
        f"best of {args.repeats} runs"
    )
    print()
    print("| capture | time | against the slowest camera alone | against the sum |")
    print("|---|---|---|---|")
    for label, key in (
        ("camera a alone", "a"),
        ("camera b alone", "b"),
        ("both, one trigger", "rig"),
    ):
        print(
            f"| {label} | {best[key]:.2f} s | {best[key] / slowest:.2f} | "
            f"{best[key] / (best['a'] + best['b']):.2f} |"
        )
    if args.verdicts:
        verdicts(args.verdicts)


if __name__ == "__main__":
    main()
