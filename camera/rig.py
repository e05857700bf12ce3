"""A capture of several cameras on one trigger: every illumination step switched once,
then taken in rounds, each round one trigger for every camera, and frames kept only as
whole rounds.

A round is triggered by software (``TriggerSoftware`` sent to each camera in turn; the
spread of the send times is the round's *skew*, recorded) or by one pulse of the
controller's trigger output wired to every camera's trigger line (no skew by wiring).
Each camera's frame of a round is checked by the one capture sequence, which one camera
runs as rounds of one (:func:`~inspect_validate.camera.capture.verified_rounds`): a
frame exposed before its trigger or the switch, a frame id seen before, a chunk off the
request, a stale frame, a frame arriving incomplete, a trigger that brought no frame. A
round with any camera's
frame refused is retaken for all (each camera counts why), so the k-th frame of every
camera comes from the same trigger: frames are matched by round, never mixed. As for one
camera, each camera's frames must agree in brightness (the first round is dropped while
the light settles), a second trigger in a row that brings a camera no frame is an error
naming it, and more than ``discard_max`` rounds retaken end the step.

Each camera's frames go to a capture folder of its own (``OUT/<camera>/``, the layout of
one camera's capture: :mod:`~inspect_validate.camera.storage`); each frame's sidecar says
its ``round`` and the round's ``trigger_skew_us``, and each step's manifest entry the
rounds kept.
"""

from __future__ import annotations

import math
import time
import uuid
from collections import Counter
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING

from inspect_validate.camera.capture import (
    CaptureResult,
    Round,
    Step,
    arm_camera,
    camera_step_health,
    configure_camera,
    record_camera,
    unlit_steps,
    unstable_warning,
    verified_rounds,
)
from inspect_validate.errors import DeviceError, FrameTimeout, IncompleteFrame, InputError

if TYPE_CHECKING:
    from inspect_validate.camera.controllers.base import LedController
    from inspect_validate.camera.frame import Frame
    from inspect_validate.camera.grabbers.base import Grabber
    from inspect_validate.camera.settings import CameraSettings, Pulse
    from inspect_validate.camera.storage import CaptureStore

__all__ = ["capture_rig"]


def _round_source(grabbers, controller, mode: str, pulse, timeout_s: float, triggers):
    """``next_round()``: every camera triggered (in turn, or by one controller pulse) and
    its frame fetched. A camera whose second trigger in a row brings no frame is an error
    naming it; one missed trigger is a round retaken."""
    period_ns = pulse.width_us / pulse.max_duty * 1e3 if pulse is not None else 0.0
    last = [0]
    missed_before: set[str] = set()

    def next_round() -> Round:
        wait = last[0] + period_ns - time.monotonic_ns()
        if wait > 0:
            time.sleep(wait / 1e9)
        for grabber in grabbers.values():
            grabber.drain()  # a queued frame was not triggered by what follows
        sent: dict[str, int] = {}
        if mode == "software-trigger":
            for name, grabber in grabbers.items():
                try:
                    sent[name] = grabber.trigger()
                except DeviceError as exc:
                    raise DeviceError(f"cameras {name!r}: {exc}") from None
        else:
            at = time.monotonic_ns()
            controller.trigger(pulse.trigger_channel)
            sent = dict.fromkeys(grabbers, at)
        last[0] = min(sent.values())
        frames: dict[str, Frame | None] = {}
        missed: dict[str, str] = {}
        for name, grabber in grabbers.items():
            triggers[name]["triggers_sent"] += 1
            try:
                frames[name] = grabber.grab(1, timeout_s=timeout_s)[0]
            except IncompleteFrame:
                frames[name] = None
            except FrameTimeout as exc:
                triggers[name]["triggers_missed"] += 1
                if name in missed_before:
                    raise DeviceError(
                        f"cameras {name!r}: {exc} (its trigger missed twice in a row)"
                    ) from None
                missed[name] = f"brought no frame within {timeout_s:g} s (missed trigger)"
            except DeviceError as exc:  # which camera of several it is
                raise DeviceError(f"cameras {name!r}: {exc}") from None
        missed_before.clear()
        missed_before.update(missed)
        return Round(frames, sent, missed)

    return next_round


def capture_rig(
    controller: LedController,
    grabbers: dict[str, Grabber],
    steps: list[Step],
    stores: dict[str, CaptureStore],
    settings: dict[str, CameraSettings],
    *,
    pulse: Pulse | None = None,
    discard_max: int = 20,
    brightness_tolerance: float = 0.02,
    source: str = "the station file",
    progress: Callable[[str, int, int], None] | None = None,
) -> dict[str, CaptureResult]:
    """Run ``steps`` on an open ``controller`` and the open cameras ``grabbers`` (name →
    grabber) into ``stores`` (name → its capture folder), each camera set up by its
    ``settings``; module text. Returns each camera's :class:`CaptureResult`.

    Raises
    ------
    InputError
        A camera set to free-run (frames are matched by trigger), a mode, line or chunk a
        camera lacks (nothing switched), a full disk.
    DeviceError
        A camera or the controller that fails (every whole round grabbed before is saved;
        the step is marked failed in every camera's folder).
    """
    names = tuple(grabbers)
    modes, chunks, not_applied, unstable = {}, {}, {}, {}
    for name, grabber in grabbers.items():
        not_applied[name] = configure_camera(grabber, settings[name])
        mode, chunk = arm_camera(settings[name], grabber, f"{source}: cameras {name!r}")
        if mode == "free-run":
            raise InputError(
                f"cameras {name!r}: {grabber.name} has no trigger; several cameras are "
                "matched by their trigger (give each a camera with TriggerSoftware, or wire "
                "the controller's trigger to every camera: acquisition: hardware-trigger)",
                source=source,
            )
        modes[name], chunks[name] = mode, chunk
    mode = next(iter(modes.values()))
    if not (any(s.strobe_line for s in settings.values()) or mode == "hardware-trigger"):
        pulse = None
    # One id for the capture of every camera, kept by a resume: a folder of another
    # capture, or another camera's, is told from this one's (storage.audit_rig).
    held = [s.manifest.get("rig") for s in stores.values()]
    rig_id = next(
        (r["id"] for r in held if isinstance(r, dict) and isinstance(r.get("id"), str)),
        uuid.uuid4().hex,
    )
    for name, grabber in grabbers.items():
        unstable[name] = record_camera(
            stores[name], grabber, settings[name], modes[name], chunks[name], not_applied[name]
        )
        stores[name].record(
            "rig", {"id": rig_id, "camera": name, "cameras": list(names), "trigger": mode}
        )
    triggers: dict[str, Counter] = {name: Counter() for name in names}
    timeout_s = max(settings[name].timeout_s for name in names)
    next_round = _round_source(grabbers, controller, mode, pulse, timeout_s, triggers)
    saved: dict[str, dict[str, int]] = {name: {} for name in names}
    skipped: list[str] = []
    levels: dict[str, dict[str, float]] = {name: {} for name in names}
    total, done = sum(s.frames for s in steps), 0
    try:
        for step in steps:
            if all(stores[name].is_complete(step.name) for name in names):
                skipped.append(step.name)
                done += step.frames
                continue
            channels = {str(k): v for k, v in step.channels.items()}
            try:
                if pulse is not None:
                    controller.apply_pulsed(
                        step.channels, width_us=pulse.width_us, delay_us=pulse.delay_us
                    )
                else:
                    controller.apply(step.channels)
            except (DeviceError, InputError) as exc:
                _fail_all(stores, step.name, exc)
                raise
            switched = time.monotonic_ns()
            before = {}
            try:
                for name in names:
                    stores[name].begin(step.name, {"channels": channels})
                    triggers[name].clear()
                    before[name] = grabbers[name].health()
                settle = max(settings[name].settle_ms for name in names)
                if settle:
                    time.sleep(settle / 1000)
                rounds_kept: list[int] = []
                skews: list[float] = []
                sums = dict.fromkeys(names, 0.0)
                discarded: dict[str, dict[str, int]] = {name: {} for name in names}
                i = 0
                for i, (r, number, discarded) in enumerate(
                    verified_rounds(
                        names,
                        step.frames,
                        next_round=next_round,
                        switched_ns=switched,
                        discard_max=discard_max,
                        tolerance=math.inf if step.moving else brightness_tolerance,
                        chunks=chunks,
                    ),
                    start=1,
                ):
                    rounds_kept.append(number)
                    skews.append(r.skew_us)
                    for name in names:
                        frame = r.frames[name]
                        assert frame is not None  # a round is kept only whole
                        stores[name].save_later(
                            step.name,
                            i,
                            frame,
                            {
                                "step": step.name,
                                "light_setting": channels,
                                "light_switched_ns": switched,
                                "acquisition": mode,
                                "stale_frames_possible": False,
                                "controller": controller.name,
                                "round": number,
                                "trigger_skew_us": r.skew_us,
                                "discarded_before": sum(discarded[name].values()),
                                "discarded": discarded[name],
                            },
                        )
                        sums[name] += frame.mean
                    done += 1
                    if progress:
                        progress(step.name, done, total)
                for name in names:
                    store = stores[name]
                    store.note(step.name, "acquisition", mode)
                    store.note(step.name, "discarded", discarded[name])
                    store.note(step.name, "rounds", rounds_kept)
                    store.note(step.name, "trigger_skew_us", skews)
                    store.note(
                        step.name,
                        "health",
                        camera_step_health(grabbers[name], before[name], triggers[name]),
                    )
                    store.flush()
                    store.finish(step.name)
                    saved[name][step.name] = i
                    levels[name][step.name] = sums[name] / i
            except (DeviceError, InputError) as exc:
                for name in names:
                    if name in before:
                        stores[name].note(
                            step.name,
                            "health",
                            camera_step_health(grabbers[name], before[name], triggers[name]),
                        )
                _fail_all(stores, step.name, exc)
                raise
    finally:
        try:
            controller.all_off()
        except DeviceError:
            pass  # the original error matters more; the frames are saved
        for store in stores.values():
            store.close()
    results = {}
    for name in names:
        warnings = unlit_steps(levels[name], brightness_tolerance) + unstable_warning(
            grabbers[name], unstable[name]
        )
        if warnings:
            stores[name].record("warnings", list(warnings))
        results[name] = CaptureResult(
            Path(stores[name].folder), saved[name], tuple(skipped), not_applied[name], warnings
        )
    return results


def _fail_all(stores, step: str, exc: Exception) -> None:
    """Mark ``step`` failed in every camera's folder once their frames are written."""
    for store in stores.values():
        unsaved = store.close()
        also = f"; saving its frames failed too: {unsaved}" if unsaved else ""
        store.fail(step, f"{exc}{also}")
