"""Capture sequencing: every illumination of a station, verified, saved before any analysis.

For each illumination (and finally the dark frames, all lights off):

1. switch the controller and wait for its acknowledgement;
2. discard frames exposed before the switch: frames whose exposure timestamp
   (host clock) precedes the acknowledgement or, for cameras whose timestamps
   cannot show that, the station's ``flush_frames`` after the switch;
3. verify the kept frames are stable: their means agree within
   ``brightness_tolerance`` (relative); a frame at the start that disagrees
   with the next (the light still settling) is dropped and replaced, a jump
   after two agreeing frames is an error; a frame identical to the one before
   (sensor noise makes that impossible for a live image with any structure)
   is a stale camera, an error;
4. save each frame (16-bit TIFF + JSON sidecar, atomically) as soon as it is
   verified, on a writer thread while the next is grabbed, so a failure later
   in the step loses none of them. A step is marked complete once its last
   frame is on disk, which the capture waits for after the next switch, while
   the camera exposes that step's first frame.

A camera that can restart its stream (GenICam and pylon: stop and start the
acquisition, which discards every queued buffer) does so after the switch; then
no frame from before the switch can arrive, however many buffers the driver
queues.

After the dark frames, a step no brighter than dark is reported as a warning
(manifest ``warnings``): its light never reached the camera.

Up to ``discard_max`` frames are dropped per step; beyond that the capture fails
loudly rather than record a frame exposed under the wrong light. A failure or
interruption keeps every frame saved so far, and ``resume`` continues with the
first unfinished step.
"""

from __future__ import annotations

import time
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np
from inspect_validate.camera.station import Station, station_hash
from inspect_validate.camera.stopping import Known, SequentialStop
from inspect_validate.camera.storage import CaptureStore

from inspect_validate.errors import DeviceError, InputError

__all__ = ["CaptureResult", "capture", "verified_frames"]


@dataclass(frozen=True)
class CaptureResult:
    folder: Path
    steps: dict[str, int]  # step → frames saved in this run
    skipped: tuple[str, ...]  # steps already complete (resume)
    not_applied: tuple[str, ...] = ()  # station settings the camera has no node for
    warnings: tuple[str, ...] = ()  # e.g. a step no brighter than dark
    known: dict[str, Known] = field(default_factory=dict)  # step → precision (precision:)


def verified_frames(
    camera,
    n: int,
    *,
    switched_ns: int,
    discard_max: int,
    tolerance: float,
    timeout_s: float,
    flush: int = 4,
):
    """Yield ``n`` frames exposed after ``switched_ns`` with stable brightness, each once verified.

    Frames whose timestamp is the exposure start on the host clock are kept
    only if exposed after ``switched_ns``; frames on other clocks cannot prove
    that, so the first ``flush`` frames after the switch are dropped.
    Kept frames must agree with each other (mean within ``tolerance``, relative).
    While only one frame is kept, a disagreeing frame means the light is still
    settling: the kept frame is dropped. Once two frames agree the level is
    locked — both are yielded — and every later frame is yielded as it agrees;
    a disagreeing frame is then a jump: an error, never recorded.

    Yields ``(frame, discarded)``: the frame and the frames dropped so far.
    """
    discarded = 0
    kept: list = []
    flushed = 0
    done = 0
    previous = None
    while done < n:
        frame = camera.grab(1, timeout_s=timeout_s)[0]
        if _repeats(frame, previous):
            raise DeviceError(
                f"{camera.name}: frame {frame.frame_id} is identical to the one before: the "
                "camera hands out a stale image (a hung driver or a stopped sensor) — restart it"
            )
        previous = frame
        if frame.clock == "exposure" and frame.timestamp_ns < switched_ns:
            discarded += 1  # exposed before the switch (camera pipeline)
        elif frame.clock != "exposure" and flushed < flush:
            flushed += 1
            discarded += 1  # may still be in the pipeline from before the switch
        elif not kept or _agrees(frame, kept, tolerance):
            kept.append(frame)
            # One frame alone is verified only when one is all that was asked for.
            ready = kept[done:] if len(kept) >= 2 or n == 1 else []
            for f in ready[: n - done]:
                yield f, discarded
                done += 1
        elif len(kept) == 1:
            discarded += 1  # still settling: start again from this frame
            kept = [frame]
        else:
            means = [round(f.mean, 1) for f in (*kept[-3:], frame)]
            raise DeviceError(
                f"{camera.name}: brightness jumps within a step (frame means {means}); "
                "the light or exposure is unstable — check the controller and the ambient light"
            )
        if discarded > discard_max:
            raise DeviceError(
                f"{camera.name}: {discarded} frames were exposed before the light switch or while it settled; "
                "nothing stable arrived — check that the controller really switches this light and the camera's frame rate"
            )


def _repeats(frame, previous) -> bool:
    """``frame`` has the very pixels of ``previous`` though the image has structure (a
    constant frame — all dark, all saturated — may legitimately repeat)."""
    if previous is None or frame.data.shape != previous.data.shape:
        return False
    a, b = frame.data.reshape(-1), previous.data.reshape(-1)
    # Every frame passes here: a sparse sample tells two live frames apart at once (the
    # noise differs almost everywhere); only a repeat pays for the full comparison.
    if not np.array_equal(a[::1021], b[::1021]):
        return False
    return bool(a.min() != a.max() and np.array_equal(a, b))


def _agrees(frame, kept, tolerance) -> bool:
    ref = float(np.mean([f.mean for f in kept]))
    return abs(frame.mean - ref) <= tolerance * max(abs(ref), 1.0)


def capture(
    station: Station, out: Path, *, resume: bool = False, progress=None, devices=None
) -> CaptureResult:
    """Run the station's capture sequence into ``out``.

    ``progress(step, done, total)`` is called after every verified frame (its
    save may still be under way; a step is complete only once all are written).
    ``devices`` replaces the station's camera and controller with a context
    manager yielding ``(controller, camera)`` (other setups, tests).
    """
    from inspect_validate.camera.devices import open_devices

    store = CaptureStore(
        out, station_path=station.path, station_sha256=station_hash(station.path), resume=resume
    )
    steps = [(i.name, dict(i.channels), station.frames) for i in station.illuminations]
    if station.dark_frames:
        steps.append(("dark", {}, station.dark_frames))
    saved, skipped, known = {}, [], {}
    levels: dict[str, float] = {}  # mean grey value of each step captured in this run
    rois = _precision_rois(station)
    total = sum(n for _, _, n in steps)
    done = 0
    with devices if devices is not None else open_devices(station) as (controller, camera):
        cam = station.camera
        camera.configure(
            exposure_us=cam.exposure_us, gain_db=cam.gain_db, pixel_format=cam.pixel_format
        )
        asked = {"exposure": cam.exposure_us, "gain": cam.gain_db, "pixel_format": cam.pixel_format}
        not_applied = tuple(sorted(m for m in camera.missing if asked.get(m) is not None))
        # The manifest is written only now: a camera that fails to open leaves
        # nothing that would block a plain rerun.
        store.record(
            "camera",
            {"name": camera.name, "missing": sorted(camera.missing), "not_applied": not_applied},
        )
        pending = None  # a step whose frames are grabbed; their saves may still run

        def complete(step):
            """Mark ``step`` complete once all its frames are on disk; a failed save fails it."""
            nonlocal pending
            pending = None
            try:
                store.flush()
            except InputError as exc:
                store.fail(step, str(exc))
                raise
            store.finish(step)

        def abort(step, exc):
            """Record why ``step`` failed once every frame grabbed before is written."""
            nonlocal pending
            unsaved = store.close()  # the frames grabbed before the failure are kept
            if unsaved is not None:
                pending = None  # which step's frame failed is in the message, not known here
            also = f"; saving its frames failed too: {unsaved}" if unsaved else ""
            store.fail(step, f"{exc}{also}")

        try:
            for name, setting, n in steps:
                if store.is_complete(name):
                    skipped.append(name)
                    done += n
                    continue
                as_json = {str(k): v for k, v in setting.items()}  # JSON keys are strings
                try:
                    controller.apply(setting)
                    switched = time.monotonic_ns()
                    # A camera that can restart its stream drops every queued buffer:
                    # nothing exposed before the switch can arrive after it.
                    fresh = camera.restart_stream()
                except (DeviceError, InputError) as exc:
                    abort(name, exc)
                    raise
                if pending is not None:
                    complete(pending)  # its last saves end while this step's first frame exposes
                try:
                    store.begin(name, {"channels": as_json})
                    status = controller.status()
                    if status:
                        store.note(name, "controller_status", status)
                    info = {
                        "step": name,
                        "light_setting": as_json,
                        "light_switched_ns": switched,
                        "stream_restarted": fresh,
                        "controller": controller.name,
                    }
                    frames = verified_frames(
                        camera,
                        n,
                        switched_ns=switched,
                        discard_max=station.discard_max,
                        tolerance=station.brightness_tolerance,
                        timeout_s=cam.timeout_s,
                        flush=0 if fresh else max(cam.flush_frames, camera.pipeline_frames),
                    )
                    stop = None
                    if rois is not None and name != "dark":
                        p = station.precision
                        stop = SequentialStop(
                            rois, mean=p.mean, variance=p.variance, min_frames=p.min_frames
                        )
                    total_mean, i = 0.0, 0
                    for i, (frame, discarded) in enumerate(frames, start=1):
                        # Written on the writer thread while the next frame is grabbed.
                        store.save_later(name, i, frame, {**info, "discarded_before": discarded})
                        total_mean += frame.mean
                        enough = stop is not None and stop.add(frame.data)
                        done += 1 + (n - i if enough else 0)  # the frames not needed count as done
                        if progress:
                            progress(name, done, total)
                        if enough:
                            break
                    if stop is not None:
                        known[name] = stop.known()
                        store.note(name, "precision", asdict(known[name]))
                # InputError: ROIs off the frame, a full disk.
                except (DeviceError, InputError) as exc:
                    abort(name, exc)
                    raise
                pending = name
                saved[name] = i
                levels[name] = total_mean / i
            if pending is not None:
                complete(pending)
        finally:
            try:
                controller.all_off()
            except DeviceError:
                pass  # the original error matters more; the frames are saved
            # An interruption (Ctrl-C) or an error still writes every frame grabbed before
            # it; a step whose every frame was grabbed is then complete.
            if store.close() is None and pending is not None:
                store.finish(pending)
    warnings = _unlit_steps(levels, station.brightness_tolerance)
    if warnings:
        store.record("warnings", list(warnings))
    return CaptureResult(Path(out), saved, tuple(skipped), not_applied, warnings, known)


def _precision_rois(station: Station):
    """The station's ROI set when its steps stop on precision (read before any device
    opens, so a bad ROI file costs no capture), else None."""
    if station.precision is None:
        return None
    from inspect_validate.roi import read_rois

    return read_rois(station.resolve(station.rois))


def _unlit_steps(levels: dict[str, float], tolerance: float) -> tuple[str, ...]:
    """Steps whose frames are no brighter than the dark frames: the light never showed.

    A warning, not an error: a light the lens or sensor cannot see (UV behind
    glass) is a legitimate finding, but a wrong channel or a loose cable looks
    the same and should not pass unnoticed.
    """
    if "dark" not in levels:
        return ()
    dark = levels["dark"]
    return tuple(
        f"step {name!r}: mean {level:.1f} DN is no brighter than the dark frames ({dark:.1f} DN); "
        "check that this illumination's channel drives a light the camera sees"
        for name, level in levels.items()
        if name != "dark" and level - dark <= tolerance * max(abs(dark), 1.0)
    )
