"""Capture: time per saved frame against the bare grab, saving overlapped or not.

Run: ``python benchmarks/bench_capture.py [--size 2048] [--frames 8]`` (about 40 s
on 2 cores).

The built-in simulated station at 2048 × 2048 (4 MP, uint16), 2 illuminations
and the dark step, ``--frames`` each. Three ways, each on freshly opened
devices:

* bare grab: the camera's ``grab`` in a loop, nothing verified or saved (the
  reference: what the camera and its driver cost);
* capture, saving in line: every frame written (TIFF + sidecar, fsynced) before
  the next is grabbed, as before this version;
* capture: the same, written on the writer thread while the next is grabbed.

A capture also grabs the frames it drops after each light switch (the
pipeline's ``latency``); the ratio is per *grabbed* frame, which is what saving
can hide behind, with the devices open: opening the camera and the controller
(pylon's device enumeration alone takes 0.25 s on its emulator) is paid once a
capture, and is shown in its own column.

The simulated camera renders every frame on the CPU, so its grab competes with
the writer for the two cores. ``--camera pylon-emulator`` grabs instead from
pypylon's camera emulator paced at ``--fps`` (AcquisitionFrameRate): its grab
waits for the next frame as a real camera's does, and the emulator's test
pattern replaces the scene (times only). Its captures restart the stream
after each switch (pylon drops its queued buffers) and drop no frame.

``--camera aravis-fake`` grabs from Aravis' fake GigE Vision camera on the loopback
interface (its own 512 × 512 Mono16 pattern at its default 25 fps, over GVCP/GVSP).

A second table times a whole capture step (switch, frames verified and saved) in
each acquisition mode the camera has, against free-run in the same run:
software-trigger (one ``TriggerSoftware`` per frame, waited for), and on the
simulated station hardware-trigger (one controller ``TR`` command per frame over
the pseudo-terminal, the pulse firing the camera).

A third times what a capture reads of the camera besides its frames, against the
software-triggered step of the same run: its health (``Grabber.health``, twice a
step) and its settings snapshot (``Grabber.settings``, read twice, once a capture).
"""

from __future__ import annotations

import argparse
import json
import shutil
import tempfile
import time
from contextlib import contextmanager
from functools import partial
from pathlib import Path

import yaml
from machine import machine_line

from inspect_validate.camera.storage import CaptureStore
from inspect_validate.station import capture as capture_module
from inspect_validate.station.devices import open_devices
from inspect_validate.station.file import read_station

ROOT = Path(__file__).resolve().parents[1]


def station_copy(
    folder: Path,
    size: int,
    frames: int,
    *,
    emulator: bool = False,
    aravis: str | None = None,
    acquisition="free-run",
) -> Path:
    shutil.copytree(ROOT / "sample_images/station", folder / "station", dirs_exist_ok=True)
    shutil.copytree(ROOT / "sample_images/scenes", folder / "scenes", dirs_exist_ok=True)
    path = folder / f"station/{acquisition}.yaml"
    doc = yaml.safe_load((folder / "station/station.yaml").read_text())
    doc["camera"].update(width=size, height=size, acquisition=acquisition)
    if acquisition == "hardware-trigger":
        doc["camera"]["trigger_line"] = "Line1"
        doc["controller"]["pulse"] = {"width_us": doc["camera"]["exposure_us"] + 100}
    if emulator:
        doc["camera"].update(backend="pylon", pixel_format="Mono16")
        del doc["camera"]["latency"]
    if aravis:  # Aravis' fake GigE camera: its own test pattern at its own 512 × 512
        doc["camera"] = {
            "backend": "aravis",
            "serial": aravis,
            "pixel_format": "Mono16",
            "exposure_us": doc["camera"]["exposure_us"],
            "acquisition": acquisition,
            **({"trigger_line": "Line0"} if acquisition == "hardware-trigger" else {}),
        }
        doc.pop("scene", None)
        doc.pop("channels", None)
    doc.update(frames=frames, dark_frames=frames)
    path.write_text(yaml.safe_dump(doc, sort_keys=False))
    return path


def bare_grab(station, n: int) -> float:
    """Seconds per frame of the camera's grab alone."""
    with open_devices(station) as (controller, camera):
        camera.configure(exposure_us=station.camera.exposure_us, gain_db=0)
        controller.apply({1: 100})
        camera.grab(2)  # the pipeline filled, as after a switch
        t0 = time.perf_counter()
        for _ in range(n):
            camera.grab(1)
        return (time.perf_counter() - t0) / n


def read_costs(station, n: int = 20) -> tuple[float, float, int, int]:
    """Median seconds of one ``health()`` and one ``settings()`` on the open camera, with
    how many health quantities and settings nodes it reports."""
    import statistics

    with open_devices(station) as (_, camera):
        camera.configure(exposure_us=station.camera.exposure_us)
        camera.arm("software-trigger")
        camera.trigger()
        camera.grab(1)  # the stream running, as during a step
        out = []
        for read in (camera.health, camera.settings):
            times = []
            for _ in range(n):
                t0 = time.perf_counter()
                values = read()
                times.append(time.perf_counter() - t0)
            out.append((statistics.median(times), len(values)))
        (health_s, n_health), (settings_s, n_settings) = out
        return health_s, settings_s, n_health, n_settings


@contextmanager
def timed_open(station, seconds: list):
    """``open_devices``, appending to ``seconds`` how long opening took."""
    t0 = time.perf_counter()
    with open_devices(station) as devices:
        seconds.append(time.perf_counter() - t0)
        yield devices


def timed_capture(station, out: Path, *, in_line: bool) -> tuple[float, float, int, int]:
    """Seconds of a whole capture, of opening its devices, the frames saved, and the frames
    grabbed (saved plus those dropped after each light switch, from the sidecars)."""
    original = CaptureStore.save_later
    if in_line:
        CaptureStore.save_later = CaptureStore.save  # the behaviour before the writer thread
    opening: list[float] = []
    try:
        t0 = time.perf_counter()
        result = capture_module.capture(station, out, devices=timed_open(station, opening))
        elapsed = time.perf_counter() - t0
    finally:
        CaptureStore.save_later = original
    saved = sum(result.steps.values())
    dropped = sum(
        json.loads(sorted((out / step).glob("frame_*.json"))[-1].read_text())["discarded_before"]
        for step in result.steps
    )
    return elapsed, opening[0], saved, saved + dropped


def fake_gige() -> str:
    """Start Aravis' fake GigE Vision camera in a process of its own (ended with this
    one); its serial number."""
    import atexit
    import subprocess
    import sys

    serial = "BENCH1"
    proc = subprocess.Popen(
        [sys.executable, "-m", "inspect_validate.simulation.fake_gige", serial],
        stdout=subprocess.PIPE,
        text=True,
    )
    if proc.stdout.readline().strip() != "ready":
        raise SystemExit("Aravis' fake camera did not start (is gir1.2-aravis-0.8 installed?)")
    atexit.register(proc.kill)
    return serial


def pace_emulator(size: int, fps: float) -> None:
    """Every PylonGrabber configured from now on grabs ``size``² frames at ``fps``: the
    emulator's frame rate, so that its grab waits like a real camera's."""
    import os

    os.environ["PYLON_CAMEMU"] = "1"  # read when pylon's transport layers start
    from inspect_validate.camera.grabbers.pylon import PylonGrabber

    configure = PylonGrabber.configure

    def paced(self, **options):
        configure(self, **{"region": (0, 0, size, size), **options})
        self._write("AcquisitionFrameRateEnable", True, "frame rate")
        self._write("AcquisitionFrameRate", fps, "frame rate")

    PylonGrabber.configure = paced


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--size", type=int, default=2048)
    parser.add_argument("--frames", type=int, default=8)
    parser.add_argument(
        "--camera", choices=("simulated", "pylon-emulator", "aravis-fake"), default="simulated"
    )
    parser.add_argument("--fps", type=float, default=20.0, help="the emulator's frame rate")
    args = parser.parse_args()
    emulator = args.camera == "pylon-emulator"
    if emulator:
        pace_emulator(args.size, args.fps)
    aravis = fake_gige() if args.camera == "aravis-fake" else None
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        copy = partial(station_copy, emulator=emulator, aravis=aravis)
        station = read_station(copy(tmp, args.size, args.frames))
        grab = bare_grab(station, 3 * args.frames)
        runs = {
            label: timed_capture(station, tmp / label, in_line=in_line)
            for label, in_line in (("in_line", True), ("overlapped", False))
        }
        # Only the simulated station's controller drives a camera's trigger line.
        hardware = [] if emulator or aravis else ["hardware-trigger"]
        by_mode = {}
        for mode in ["free-run", "software-trigger", *hardware]:
            moded = read_station(copy(tmp, args.size, args.frames, acquisition=mode))
            by_mode[mode] = timed_capture(moded, tmp / mode, in_line=False)
        triggered = read_station(copy(tmp, args.size, args.frames, acquisition="software-trigger"))
        costs = read_costs(triggered)
        frame = next((tmp / "overlapped" / "amber").glob("frame_*.tif"))
        size_mb = frame.stat().st_size / 2**20
        height, width = json.loads(frame.with_suffix(".json").read_text())["shape"]
    print(machine_line())
    _, _, saved, grabbed = runs["overlapped"]
    camera = {
        "simulated": "the simulated camera",
        "pylon-emulator": f"pypylon's emulator at {args.fps:g} fps",
        "aravis-fake": "Aravis' fake GigE Vision camera on lo",
    }[args.camera]
    print(
        f"{camera}, {width}×{height} uint16 ({size_mb:.1f} MB a frame), {saved} frames "
        f"saved a capture, {grabbed} grabbed"
    )
    print()
    print(
        "| task | capture | opening the devices | per saved frame | per grabbed frame, "
        "devices open | bare grab | ratio |"
    )
    print("|---|---|---|---|---|---|---|")
    for label, key in (
        ("capture, saving in line (before)", "in_line"),
        ("capture, saving on the writer thread", "overlapped"),
    ):
        elapsed, opening, saved, grabbed = runs[key]
        steps = (elapsed - opening) / grabbed
        print(
            f"| {label} | {elapsed:.2f} s | {opening:.2f} s | {1e3 * elapsed / saved:.0f} ms | "
            f"{1e3 * steps:.0f} ms | {1e3 * grab:.0f} ms | {steps / grab:.2f} |"
        )
    print()
    print("| acquisition | per step, devices open | frames grabbed a step | ratio to free-run |")
    print("|---|---|---|---|")
    reference = None
    for mode, (elapsed, opening, _, grabbed) in by_mode.items():
        step = (elapsed - opening) / 3  # two illuminations and the darks
        reference = reference or step
        print(f"| {mode} | {1e3 * step:.0f} ms | {grabbed / 3:.1f} | {step / reference:.2f} |")
    elapsed, opening, _, _ = by_mode["software-trigger"]
    step = (elapsed - opening) / 3
    health_s, settings_s, n_health, n_settings = costs
    print()
    print("| read of the camera | quantities | time | per software-triggered step | ratio |")
    print("|---|---|---|---|---|")
    for label, seconds, count, times in (
        ("health, twice a step", health_s, n_health, 2),
        (
            "settings snapshot, read twice, once a capture (÷ 3 steps)",
            settings_s,
            n_settings,
            2 / 3,
        ),
    ):
        print(
            f"| {label} | {count} | {1e6 * seconds:.0f} µs | {1e3 * step:.0f} ms | "
            f"{times * seconds / step:.2g} |"
        )


if __name__ == "__main__":
    main()
