"""A station's capture: its illuminations and dark frames, through its own devices, into a
capture folder (the sequence itself is :mod:`inspect_validate.camera.capture`)."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

from inspect_validate.camera.capture import CaptureResult, Step, capture_steps
from inspect_validate.camera.storage import CaptureStore
from inspect_validate.station.file import station_hash

if TYPE_CHECKING:
    from collections.abc import Callable
    from contextlib import AbstractContextManager

    from inspect_validate.camera.capture import Progress
    from inspect_validate.camera.controllers.base import LedController
    from inspect_validate.camera.grabbers.base import Grabber
    from inspect_validate.station.file import Station

__all__ = ["capture", "production_steps", "station_steps"]


def station_steps(station: Station) -> list[Step]:
    """The station's illuminations, then its dark frames: what :func:`capture` takes."""
    steps = [Step(i.name, dict(i.channels), station.frames) for i in station.illuminations]
    if station.dark_frames:
        steps.append(Step("dark", {}, station.dark_frames))
    return steps


def production_steps(station: Station, *, parts: int | None = None) -> list[Step]:
    """The running line's one step: the production illumination on, ``parts`` frames
    (default ``production.parts``), each of another part, their brightness free to differ.

    Raises
    ------
    InputError
        A station without a ``production:`` block.
    """
    from inspect_validate.errors import InputError

    if station.production is None:
        raise InputError(
            "no 'production:' block: give one to capture the running line",
            source=str(station.path),
        )
    name = station.production.illumination
    (illumination,) = (i for i in station.illuminations if i.name == name)
    n = station.production.parts if parts is None else parts
    return [Step(name, dict(illumination.channels), n, moving=True)]


def capture(
    station: Station,
    out: Path,
    *,
    resume: bool = False,
    progress: Progress | None = None,
    completed: Callable[[str], None] | None = None,
    devices: AbstractContextManager[tuple[LedController, Grabber]] | None = None,
    steps: list[Step] | None = None,
    target: str = "scene",
) -> CaptureResult:
    """Run the station's capture sequence into ``out``.

    ``progress(step, done, total)`` is called after every verified frame (its
    save may still be under way; a step is complete only once all are written), and
    ``completed(step)`` once a step's frames are all written, while the next is captured.
    ``devices`` replaces the station's camera and controller with a context
    manager yielding ``(controller, grabber)`` (other setups, tests). ``steps``
    replaces :func:`station_steps` (``characterize``'s exposure series). With
    ``precision:`` each illumination ends once its classes are known that well
    (:class:`~inspect_validate.station.stopping.SequentialStop`). ``target``: what is in
    front of the camera (``"flat"``, ``"edge"``: a characterization target, every frame
    taken, recorded in the manifest; a simulated camera renders it).

    Raises
    ------
    InputError
        A capture folder of another station, an ROI file that cannot be read, a mode,
        line or chunk the camera lacks (nothing switched).
    DeviceError
        A device that fails (the frames saved so far are kept; ``resume`` continues).
    """
    from inspect_validate.station.devices import open_devices

    if station.cameras and devices is None:
        return _capture_rig(station, out, resume=resume, progress=progress, steps=steps)
    # A target has no classes to stop on: the frames the station asks for
    stopping = _stopping(station) if target == "scene" else None
    pulse = getattr(station.controller, "pulse", None)
    store = CaptureStore(
        out, station_path=station.file, station_sha256=station_hash(station), resume=resume
    )
    try:
        _record_target(store, target, out, station)
        opened = devices if devices is not None else open_devices(station, target=target)
        with opened as (controller, grabber):
            return capture_steps(
                controller,
                grabber,
                station_steps(station) if steps is None else steps,
                store,
                station.camera,
                pulse=pulse,
                discard_max=station.discard_max,
                brightness_tolerance=station.brightness_tolerance,
                source=str(station.path),
                stopping=stopping,
                progress=progress,
                completed=completed,
            )
    finally:
        store.release()


def _record_target(store: CaptureStore, target: str, out: Path, station: Station) -> None:
    """Write ``target`` into the manifest; a capture resumed with another target is refused
    (its frames would be of two things)."""
    from inspect_validate.errors import InputError

    before = store.manifest.get("target", "scene")
    if store.manifest.get("steps") and before != target:
        raise InputError(
            f"{out} holds frames of the {before} target, and this capture is of the {target} "
            "one: give another --out (or the same --target) to resume",
            source=str(station.path),
        )
    if target != "scene":
        store.record("target", target)


def _capture_rig(station, out, *, resume, progress, steps) -> CaptureResult:
    """:func:`capture` of a station of several cameras (:mod:`~inspect_validate.camera.rig`):
    each camera's frames in ``out/<camera>/``; the result's ``steps`` are the first
    camera's (every camera keeps as many, matched by round)."""
    import contextlib

    from inspect_validate.camera.rig import capture_rig
    from inspect_validate.errors import InputError
    from inspect_validate.station.devices import open_rig

    if station.precision is not None:
        raise InputError(
            "precision: stopping on the classes' precision takes one camera; several "
            "cameras take their frames: count",
            source=str(station.path),
        )
    names = station.camera_names
    digest = station_hash(station)
    with contextlib.ExitStack() as stack:
        stores = {}
        for name in names:
            store = CaptureStore(
                Path(out) / name, station_path=station.file, station_sha256=digest, resume=resume
            )
            stack.callback(store.release)
            stores[name] = store
        with open_rig(station) as (controller, grabbers):
            results = capture_rig(
                controller,
                grabbers,
                station_steps(station) if steps is None else steps,
                stores,
                {name: station.view(name).camera for name in names},
                pulse=getattr(station.controller, "pulse", None),
                discard_max=station.discard_max,
                brightness_tolerance=station.brightness_tolerance,
                source=str(station.path),
                progress=progress,
            )
    first = results[names[0]]
    warnings = tuple(f"cameras {n!r}: {w}" for n, r in results.items() for w in r.warnings)
    return CaptureResult(Path(out), first.steps, first.skipped, first.not_applied, warnings)


def _stopping(station: Station):
    """``stopping(step)`` for a station that stops on precision (its ROI file read before
    any device opens, so a bad one costs no capture), else None."""
    if station.precision is None:
        return None
    from inspect_validate.roi import read_rois
    from inspect_validate.station.stopping import SequentialStop

    if station.rois is None:  # the station file's validation requires it with precision
        return None
    rois = read_rois(station.resolve(station.rois))
    p = station.precision

    def stopping(step: str):
        if step == "dark":
            return None
        return SequentialStop(rois, mean=p.mean, variance=p.variance, min_frames=p.min_frames)

    return stopping
