"""Capture sequencing: every step (a light setting), verified, saved before any analysis.

The device layer's capture: an open camera and controller, the steps, the camera
settings and a capture folder; what a station makes of it is
:func:`inspect_validate.station.capture.capture`. For each step (a station's
illuminations, and finally the dark frames, all lights off):

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

import math
import time
from collections import Counter
from collections.abc import Callable, Iterable, Iterator
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from inspect_validate.camera.health import step_health
from inspect_validate.camera.storage import settings_sha256
from inspect_validate.errors import DeviceError, FrameTimeout, IncompleteFrame, InputError
from inspect_validate.interruption import stop_if_requested

if TYPE_CHECKING:
    from inspect_validate.camera.controllers.base import LedController
    from inspect_validate.camera.frame import Frame
    from inspect_validate.camera.grabbers.base import Grabber
    from inspect_validate.camera.settings import CameraSettings, Pulse
    from inspect_validate.camera.storage import CaptureStore

__all__ = [
    "INCOMPLETE",
    "CaptureResult",
    "Progress",
    "Round",
    "Step",
    "arm_camera",
    "camera_step_health",
    "capture_steps",
    "configure_camera",
    "record_camera",
    "unlit_steps",
    "unstable_warning",
    "verified_frames",
    "verified_rounds",
]

Progress = Callable[[str, int, int], None]
"""``progress(step, done, total)``: called after every verified frame of a capture."""


@dataclass(frozen=True)
class CaptureResult:
    folder: Path
    steps: dict[str, int]  # step → frames saved in this run
    skipped: tuple[str, ...]  # steps already complete (resume)
    not_applied: tuple[str, ...] = ()  # station settings the camera has no node for
    warnings: tuple[str, ...] = ()  # e.g. a step no brighter than dark
    known: dict[str, Any] = field(default_factory=dict)  # step → the stopping rule's known()


@dataclass(frozen=True)
class Round:
    """One trigger of every camera (or one free-running frame of one): their frames (a
    camera's frame is None where it arrived incomplete), when each was triggered (host
    ns; absent: free-running), why a camera has no frame, and the frames drained before
    each camera's trigger."""

    frames: dict[str, Frame | None]
    sent: dict[str, int]
    missed: dict[str, str] = field(default_factory=dict)
    untriggered: dict[str, int] = field(default_factory=dict)

    @property
    def skew_us(self) -> float:
        """The spread of the trigger times over the cameras, µs."""
        times = list(self.sent.values())
        return (max(times) - min(times)) / 1e3 if times else 0.0


def verified_frames(
    grabber: Grabber,
    n: int,
    *,
    switched_ns: int,
    discard_max: int,
    tolerance: float,
    timeout_s: float,
    flush: int = 4,
    next_frame: Callable[[], tuple[Frame, int | None, int]] | None = None,
    chunk: dict[str, tuple[float, float]] | None = None,
) -> Iterator[tuple[Frame, dict[str, int]]]:
    """Yield ``n`` frames of one camera exposed after ``switched_ns`` with stable
    brightness, each once verified: :func:`verified_rounds` of rounds of one.

    ``next_frame()`` returns ``(frame, trigger_ns, untriggered)``: the trigger's time
    (host ns; None: free-running) and the frames drained before it (default: the camera's
    next free-running frame). Yields ``(frame, discarded)``: the frame and the frames
    dropped so far, by reason.
    """
    if next_frame is None:

        def next_frame():
            return grabber.grab(1, timeout_s=timeout_s)[0], None, 0

    name = grabber.name

    def next_round() -> Round:
        try:
            frame, sent, untriggered = next_frame()
        except IncompleteFrame:  # lost packets: this frame is unusable, the next one not
            return Round({name: None}, {})
        return Round({name: frame}, {} if sent is None else {name: sent}, {}, {name: untriggered})

    rounds = verified_rounds(
        (name,),
        n,
        next_round=next_round,
        switched_ns=switched_ns,
        discard_max=discard_max,
        tolerance=tolerance,
        chunks={name: chunk},
        flush=flush,
        who=str,
    )
    for r, _, discarded in rounds:
        frame = r.frames[name]
        assert frame is not None  # a round is kept only whole
        yield frame, discarded[name]


def verified_rounds(
    names: tuple[str, ...],
    n: int,
    *,
    next_round: Callable[[], Round],
    switched_ns: int,
    discard_max: int,
    tolerance: float,
    chunks: dict[str, dict | None],
    flush: int = 0,
    who: Callable[[str], str] = lambda name: f"cameras {name!r}",
) -> Iterator[tuple[Round, int, dict[str, dict[str, int]]]]:
    """Yield ``n`` rounds whose every camera's frame is verified, each with its number
    (from 1) and each camera's frames discarded so far, by reason: the one capture
    sequence, for one camera (a round of one: :func:`verified_frames`) and several.

    A frame is refused when it was exposed before its trigger or the switch (a frame
    whose timestamp is the exposure start on the host clock), carries a frame id seen
    before in the step (ids seen, not the largest: a GigE Vision block id wraps at 16
    bits), arrived incomplete, or its chunk (``chunks``: camera → chunk name
    (``ExposureTime``, ``Gain``) → ``(requested, increment)``) is off the request; a
    free-running frame on another clock cannot prove it followed the switch, so the
    first ``flush`` rounds are dropped. A round with any camera's frame refused is
    retaken for all (each camera counts why), so the k-th frame of every camera comes
    from the same trigger. A camera handing out the same structured pixels twice is an
    error (a stale frame).

    Kept frames must agree in brightness, each camera's with its own (mean within
    ``tolerance``, relative). While one round is kept, a disagreeing one means the light
    is still settling: the kept one is dropped. Once two agree the level is locked (both
    are yielded) and every later round is yielded as it agrees; a disagreeing frame is
    then a jump: an error, never recorded, except where the camera sends chunks: a frame
    off the level whose chunk agrees is dropped (a chunk that lags a frame must not pass
    a frame exposed otherwise). More than ``discard_max`` frames of a camera dropped
    end the step. ``who(name)`` names a camera in errors.
    """
    discarded: dict[str, Counter] = {name: Counter() for name in names}
    seen: dict[str, set[int]] = {name: set() for name in names}
    previous: dict[str, Frame | None] = dict.fromkeys(names)
    off_level = dict.fromkeys(names, False)  # off the level though its chunk agreed
    kept: list[tuple[Round, int, dict[str, Frame]]] = []
    done = number = flushed = 0
    while done < n:
        stop_if_requested()  # a stop whose exception something swallowed: at the next round
        number += 1
        r = next_round()
        problems = dict(r.missed)
        was_off, off_level = off_level, dict.fromkeys(names, False)
        flushing = False
        for name in names:
            if r.untriggered.get(name):
                discarded[name]["arrived untriggered (drained before the trigger)"] += (
                    r.untriggered[name]
                )
            frame = r.frames.get(name)
            if name in problems:
                continue
            if frame is None:
                problems[name] = INCOMPLETE
                continue
            sent = r.sent.get(name)
            if sent is not None:  # recorded with the frame: when it was triggered (host ns)
                frame.extra["trigger_ns"] = sent
            if _repeats(frame, previous[name]):
                raise _stale(who(name), frame)
            previous[name] = frame
            wrong = _chunk_disagrees(frame, chunks.get(name))
            if late := _early(frame, sent, seen[name], switched_ns):
                problems[name] = late
            elif sent is None and frame.clock != "exposure" and flushed < flush:
                problems[name] = "flushed after the switch"  # may predate the switch
                flushing = True
            elif wrong:
                # A lagging chunk shows as a pair: a frame off the level with a chunk as
                # requested, then a frame on the level carrying the first one's values.
                lag = (
                    was_off[name] and len(kept) >= 2 and _agrees(frame, _of(kept, name), tolerance)
                )
                problems[name] = f"{wrong}{_LAG if lag else ''}"
            seen[name].add(frame.frame_id)
        flushed += flushing
        if not problems:
            whole = {name: f for name, f in r.frames.items() if f is not None}
            off = [n_ for n_ in names if kept and not _agrees(whole[n_], _of(kept, n_), tolerance)]
            if not off:
                kept.append((r, number, whole))
                # One round alone is verified only when one is all that was asked for.
                ready = kept[done:] if len(kept) >= 2 or n == 1 else []
                for k, at, _ in ready[: n - done]:
                    yield k, at, {name: dict(c) for name, c in discarded.items()}
                    done += 1
            elif len(kept) == 1:
                for name in names:  # start again from this round
                    discarded[name]["settling (brightness changed)"] += 1
                kept = [(r, number, whole)]
            elif all(chunks.get(name) for name in off):
                for name in off:
                    problems[name] = "brightness off the step's level, chunk as requested"
                    off_level[name] = True
            else:
                name = next(n_ for n_ in off if not chunks.get(n_))
                means = [round(f.mean, 1) for f in (*_of(kept, name)[-3:], whole[name])]
                raise DeviceError(
                    f"{who(name)}: brightness jumps within a step (frame means {means}); "
                    "the light or exposure is unstable — check the controller and the "
                    "ambient light"
                )
        if problems:
            told = "; ".join(f"{k} {v}" for k, v in problems.items())
            for name in names:
                discarded[name][problems.get(name) or f"{_RETAKEN} ({told})"] += 1
        _give_up(discarded, discard_max, who)


_RETAKEN = "round retaken"


def _of(kept, name: str) -> list:
    """Camera ``name``'s frames of the rounds ``kept``."""
    return [k[2][name] for k in kept]


def _give_up(discarded: dict[str, Counter], discard_max: int, who: Callable[[str], str]) -> None:
    """The error ending a step whose camera had more than ``discard_max`` frames dropped."""
    total = max(sum(c.values()) for c in discarded.values())
    if total <= discard_max:
        return
    # The camera whose own frames were refused, not one retaken for another's.
    worst = max(
        discarded,
        key=lambda name: sum(v for k, v in discarded[name].items() if not k.startswith(_RETAKEN)),
    )
    why = ", ".join(f"{k}: {v}" for k, v in discarded[worst].items())
    if len(discarded) == 1:
        raise DeviceError(
            f"{who(worst)}: {total} frames were discarded ({why}); nothing stable arrived "
            "— check that the controller really switches this light, the camera's frame "
            "rate, its settings and (frames arriving incomplete) the network"
        )
    raise DeviceError(
        f"{who(worst)}: {total} rounds were retaken ({why}); no round of every camera's "
        "frames held — check the cameras' triggers, settings and (frames arriving "
        "incomplete) the network"
    )


INCOMPLETE = "arrived incomplete (data lost on the way)"
"""Why a frame that arrived with data missing was discarded (:class:`IncompleteFrame`)."""


def _stale(who: str, frame) -> DeviceError:
    """The error of a camera that hands out ``frame``'s pixels again."""
    return DeviceError(
        f"{who}: frame {frame.frame_id} is identical to the one before: the camera hands "
        "out a stale image (a hung driver or a stopped sensor) — restart it"
    )


def _early(frame, sent: int | None, seen_ids: set[int], switched_ns: int) -> str | None:
    """Why ``frame`` may predate what it is taken for — its trigger (``sent``, host ns),
    the light switch — or repeat a frame already fetched (``seen_ids``); None if none."""
    if sent is not None and frame.clock == "exposure" and frame.timestamp_ns < sent:
        return "exposed before its trigger"
    if sent is not None and frame.frame_id in seen_ids:
        return "not the triggered frame (frame id seen before)"
    if frame.clock == "exposure" and frame.timestamp_ns < switched_ns:
        return "exposed before the switch"  # camera pipeline
    return None


_LAG = " (its brightness agrees, the frame before's did not: the camera's chunks lag a frame)"


def _chunk_disagrees(frame, chunk) -> str | None:
    """Why ``frame``'s chunk values are not the requested settings, or None."""
    values = frame.extra.get("chunk") if chunk else None
    if not values:
        return None
    for name, (want, increment) in chunk.items():
        got = values.get(name)
        if got is not None and abs(float(got) - want) > max(increment, 1e-9 * abs(want)):
            return f"chunk {name} {float(got):g}, not the {want:g} requested"
    return None


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


@dataclass(frozen=True)
class Step:
    """One step of a capture: a light setting (channel → %), the frames to keep, and the
    exposure to take them at (µs; None: the settings' ``exposure_us``). A ``moving`` step
    looks at a running line, where every frame shows another part: its frames' brightness
    is not held to one level (a stale frame is still refused)."""

    name: str
    channels: dict
    frames: int
    exposure_us: float | None = None
    moving: bool = False


def capture_steps(
    controller: LedController,
    grabber: Grabber,
    steps: list[Step],
    store: CaptureStore,
    settings: CameraSettings,
    *,
    pulse: Pulse | None = None,
    discard_max: int = 20,
    brightness_tolerance: float = 0.02,
    source: str = "the station file",
    stopping: Callable[[str], Any] | None = None,
    progress: Progress | None = None,
    completed: Callable[[str], None] | None = None,
) -> CaptureResult:
    """Run ``steps`` on an open ``controller`` and ``grabber`` into ``store``.

    Parameters
    ----------
    controller, grabber
        An open :class:`~inspect_validate.camera.controllers.base.LedController` and
        :class:`~inspect_validate.camera.grabbers.base.Grabber`.
    steps : list of Step
    store : CaptureStore
        The capture folder (resumed steps that are complete are skipped).
    settings : CameraSettings
        What the camera is set to and how its frames start.
    pulse : Pulse, keyword-only, optional
        The controller's pulse mode, used where frames are strobed or hardware-triggered.
    discard_max, brightness_tolerance : keyword-only
        Frames a step may discard, and the relative agreement of its frames' means.
    source : str, keyword-only
        Where the settings come from, for messages.
    stopping : callable, keyword-only, optional
        ``stopping(step)`` → a rule with ``add(frame_data) -> bool`` (True: enough frames)
        and ``known()`` (what it found), or None for a step that takes all its frames.
    progress : callable, keyword-only, optional
        ``progress(step, done, total)`` after every verified frame (its save may still be
        under way; a step is complete only once all are written).
    completed : callable, keyword-only, optional
        ``completed(step)`` once a step's frames are all written and it is marked
        complete, while the next step is captured (a caller measures it meanwhile).
    """
    saved: dict[str, int] = {}
    skipped: list[str] = []
    known: dict[str, Any] = {}
    levels: dict[str, float] = {}  # mean grey value of each step captured in this run
    total = sum(s.frames for s in steps)
    done = 0
    not_applied = configure_camera(grabber, settings)
    # Refuses what the camera lacks, the lights untouched.
    mode, chunk = arm_camera(settings, grabber, source)
    if not (settings.strobe_line or mode == "hardware-trigger"):
        pulse = None
    # The manifest is written only now: a camera that fails to open leaves
    # nothing that would block a plain rerun.
    unstable = record_camera(store, grabber, settings, mode, chunk, not_applied)
    triggers: Counter = Counter()  # this step's, for its health record
    next_frame = _frame_source(grabber, controller, mode, pulse, settings.timeout_s, triggers)
    counted = triggers if mode != "free-run" else None  # free-running: no triggers to count
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
        if completed is not None:
            completed(step)

    def abort(step, exc) -> None:
        """Record why ``step`` failed once every frame grabbed before is written."""
        nonlocal pending
        unsaved = store.close()  # the frames grabbed before the failure are kept
        if unsaved is not None:
            pending = None  # which step's frame failed is in the message, not known here
        also = f"; saving its frames failed too: {unsaved}" if unsaved else ""
        store.fail(step, f"{exc}{also}")

    try:
        exposure = settings.exposure_us
        for step in steps:
            name, setting, n, step_exposure = (
                step.name,
                step.channels,
                step.frames,
                step.exposure_us,
            )
            if store.is_complete(name):
                skipped.append(name)
                done += n
                continue
            as_json = {str(k): v for k, v in setting.items()}  # JSON keys are strings
            want = settings.exposure_us if step_exposure is None else step_exposure
            if want != exposure:  # an exposure series: set before the light switches
                grabber.configure(exposure_us=want)
                exposure = want
                if chunk and "ExposureTime" in chunk:
                    chunk = {**chunk, "ExposureTime": (want, chunk["ExposureTime"][1])}
            try:
                if pulse is not None:
                    controller.apply_pulsed(
                        setting, width_us=pulse.width_us, delay_us=pulse.delay_us
                    )
                else:
                    controller.apply(setting)
                switched = time.monotonic_ns()
                # A camera that can restart its stream drops every queued buffer:
                # nothing exposed before the switch can arrive after it. A triggered
                # camera exposes nothing until triggered after the switch.
                fresh = mode != "free-run" or grabber.restart_stream()
            except (DeviceError, InputError) as exc:
                abort(name, exc)
                raise
            if pending is not None:
                complete(pending)  # its last saves end while this step's first frame exposes
            before = None
            try:
                store.begin(name, {"channels": as_json})
                triggers.clear()
                before = grabber.health()
                status = controller.status()
                if status:
                    store.note(name, "controller_status", status)
                info = {
                    "step": name,
                    "light_setting": as_json,
                    "light_switched_ns": switched,
                    "acquisition": mode,
                    # Triggered after the switch, or the stream restarted: no frame
                    # from before it can arrive (by construction, not by a check).
                    "stale_frames_possible": not fresh,
                    "stream_restarted": mode == "free-run" and fresh,
                    "light_pulsed": pulse is not None,
                    "controller": controller.name,
                }
                if mode != "free-run" and settings.settle_ms:
                    time.sleep(settings.settle_ms / 1000)
                frames = verified_frames(
                    grabber,
                    n,
                    switched_ns=switched,
                    discard_max=discard_max,
                    tolerance=math.inf if step.moving else brightness_tolerance,
                    timeout_s=settings.timeout_s,
                    flush=0 if fresh else max(settings.flush_frames, grabber.pipeline_frames),
                    next_frame=next_frame,
                    chunk=chunk,
                )
                stop = stopping(name) if stopping is not None else None
                total_mean, i = 0.0, 0
                discarded: dict[str, int] = {}
                for i, (frame, discarded) in enumerate(frames, start=1):
                    # Written on the writer thread while the next frame is grabbed.
                    store.save_later(
                        name,
                        i,
                        frame,
                        {
                            **info,
                            "discarded_before": sum(discarded.values()),
                            "discarded": discarded,
                        },
                    )
                    total_mean += frame.mean
                    enough = stop is not None and stop.add(frame.data)
                    done += 1 + (n - i if enough else 0)  # the frames not needed count as done
                    if progress:
                        progress(name, done, total)
                    if enough:
                        break
                store.note(name, "acquisition", mode)
                store.note(name, "discarded", discarded)
                store.note(name, "health", camera_step_health(grabber, before, counted))
                if stop is not None:
                    known[name] = stop.known()
                    store.note(name, "precision", asdict(known[name]))
            # InputError: ROIs off the frame, a full disk.
            except (DeviceError, InputError) as exc:
                if before is not None:  # the step begun: what the transport saw while
                    # it failed is often why it failed
                    store.note(name, "health", camera_step_health(grabber, before, counted))
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
    warnings = unlit_steps(levels, brightness_tolerance) + unstable_warning(grabber, unstable)
    if warnings:
        store.record("warnings", list(warnings))
    return CaptureResult(Path(store.folder), saved, tuple(skipped), not_applied, warnings, known)


def configure_camera(grabber: Grabber, settings: CameraSettings) -> tuple[str, ...]:
    """Apply ``settings``' exposure, gain and pixel format; the ones asked for that the
    camera has no node for (recorded as not applied)."""
    grabber.configure(
        exposure_us=settings.exposure_us,
        gain_db=settings.gain_db,
        pixel_format=settings.pixel_format,
    )
    asked = {
        "exposure": settings.exposure_us,
        "gain": settings.gain_db,
        "pixel_format": settings.pixel_format,
    }
    return tuple(sorted(m for m in grabber.missing if asked.get(m) is not None))


def record_camera(
    store: CaptureStore,
    grabber: Grabber,
    settings: CameraSettings,
    mode: str,
    chunk: dict | None,
    not_applied: tuple[str, ...],
) -> tuple[str, ...]:
    """The manifest's ``camera`` and ``settings`` records of an armed camera; the nodes
    that changed while its settings were read (left out of the snapshot)."""
    store.record(
        "camera",
        {
            "name": grabber.name,
            "missing": sorted(grabber.missing),
            "not_applied": not_applied,
            "acquisition": mode,
            "chunks": sorted(chunk or ()),
            "strobe_line": settings.strobe_line,
            "trigger_line": settings.trigger_line if mode == "hardware-trigger" else None,
        },
    )
    # What shapes the image as the camera has it now, our settings applied: a change
    # made by another program between captures shows in the next one's snapshot.
    snapshot = grabber.settings()
    unstable = tuple(getattr(grabber, "unstable_settings", ()))
    store.record(
        "settings",
        {
            "values": snapshot,
            "sha256": settings_sha256(snapshot),
            **({"unstable": list(unstable)} if unstable else {}),
        },
    )
    return unstable


def unstable_warning(grabber: Grabber, unstable: Iterable[str]) -> tuple[str, ...]:
    if not unstable:
        return ()
    return (
        f"{grabber.name}: {', '.join(unstable)} changed while the settings were read "
        "(another program setting the camera?); left out of the settings snapshot",
    )


def arm_camera(settings: CameraSettings, grabber: Grabber, source: str) -> tuple[str, dict | None]:
    """Resolve the settings' acquisition mode on ``camera`` and arm it.

    Returns the mode and the chunk check (chunk name → (requested, increment)), or
    None without chunks. Refuses, before any light is switched, a mode, line or
    chunk the camera lacks, naming the feature and the camera.
    """
    has = grabber.features()
    mode = settings.acquisition
    if mode == "auto":
        mode = "software-trigger" if has.software_trigger or settings.strobe_line else "free-run"
    lacks = []
    if mode == "software-trigger" and not has.software_trigger:
        why = "camera.strobe_line needs triggered frames" if settings.strobe_line else ""
        lacks.append(f"TriggerSoftware (camera.acquisition: software-trigger{why and '; ' + why})")
    if mode == "hardware-trigger" and settings.trigger_line not in has.trigger_lines:
        offered = ", ".join(has.trigger_lines) or "none"
        lacks.append(
            f"TriggerSource {settings.trigger_line} (camera.trigger_line; it offers {offered})"
        )
    if settings.strobe_line and settings.strobe_line not in has.strobe_lines:
        offered = ", ".join(has.strobe_lines) or "none"
        lacks.append(
            f"LineSource ExposureActive on {settings.strobe_line} (camera.strobe_line; it offers {offered})"
        )
    if settings.chunks and not {"ExposureTime", "Gain"} & set(has.chunks):
        lacks.append("exposure or gain chunks (camera.chunks: true)")
    if lacks:
        # Free-running frames are the way out, except for a strobed light: it needs them
        # triggered, so leaving out the strobe comes first.
        way = (
            "leave out camera.strobe_line and controller.pulse to light continuously "
            "(camera.acquisition: free-run then runs on every camera)"
            if settings.strobe_line
            else "camera.acquisition: free-run runs on every camera"
        )
        raise InputError(
            f"{grabber.name} lacks {'; '.join(lacks)}. Nothing was switched: choose what the "
            f"camera has ({way})",
            source=f"{source}: camera",
        )
    use_chunks = bool(has.chunks) if settings.chunks is None else settings.chunks
    grabber.arm(
        mode,
        trigger_line=settings.trigger_line if mode == "hardware-trigger" else None,
        strobe_line=settings.strobe_line,
        chunks=use_chunks,
        trigger_delay_us=settings.trigger_delay_us,
    )
    if not use_chunks:
        return mode, None
    step = grabber.increments()
    chunk = {}
    if settings.exposure_us is not None and "ExposureTime" in has.chunks:
        chunk["ExposureTime"] = (settings.exposure_us, step.get("exposure_us", 0.0))
    if settings.gain_db is not None and "Gain" in has.chunks:
        chunk["Gain"] = (settings.gain_db, step.get("gain_db", 0.0))
    return mode, chunk


def _frame_source(grabber, controller, mode: str, pulse, timeout_s: float, triggers: Counter):
    """``next_frame()`` for :func:`verified_frames`: the camera's next frame, triggered
    as ``mode`` says, spaced so that a pulsed light keeps its duty cycle.

    A trigger that brings no frame within ``timeout_s`` (a camera still reading out, a
    pulse lost on the wire) is sent once more; a second in a row is the error. Each trigger
    sent and each missed is counted in ``triggers`` (``triggers_sent``,
    ``triggers_missed``: :data:`~inspect_validate.camera.health.COUNTERS`)."""
    if mode == "free-run":
        return lambda: (grabber.grab(1, timeout_s=timeout_s)[0], None, 0)
    period_ns = pulse.width_us / pulse.max_duty * 1e3 if pulse is not None else 0.0
    last = [0]

    def next_frame():
        for again in (False, True):
            wait = last[0] + period_ns - time.monotonic_ns()
            if wait > 0:
                time.sleep(wait / 1e9)
            untriggered = grabber.drain()  # a queued frame was not triggered by what follows
            if mode == "software-trigger":
                sent = grabber.trigger()
            else:
                sent = time.monotonic_ns()
                controller.trigger(pulse.trigger_channel)
            triggers["triggers_sent"] += 1
            last[0] = sent
            try:
                return grabber.grab(1, timeout_s=timeout_s)[0], sent, untriggered
            except FrameTimeout:
                triggers["triggers_missed"] += 1
                if again:
                    raise

    return next_frame


def camera_step_health(grabber: Grabber, before: dict, triggers: Counter | None) -> dict:
    """A step's health (:mod:`~inspect_validate.camera.health`): what the camera reports
    now against ``before``, and the triggers the capture sent and missed (None: a
    free-running step, which sends none); a camera that no longer answers reports what
    the capture counted."""
    try:
        now = grabber.health()
    except DeviceError:
        now = {}
    counts = {}
    if triggers is not None:  # 0 is a count here, not "not offered"
        counts = {k: triggers[k] for k in ("triggers_sent", "triggers_missed")}
    return {**step_health(before, now), **counts}


def unlit_steps(levels: dict[str, float], tolerance: float) -> tuple[str, ...]:
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
