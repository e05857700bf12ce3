"""``watch``: capture, verify and chart a running station cycle after cycle.

Each cycle captures the station's illuminations into its own folder, verifies
them as ``verify`` does (the acceptance checks and the golden file's drift
checks), updates the drift charts (:mod:`.drift`), commits the cycle to the
history (:mod:`.history`) and rewrites the status file atomically. A device
fault (a camera timeout, a controller answering ``Err`` or garbage, a port
that vanishes, a stale camera) is a cycle with status ``error`` and its reason:
the next cycle reopens the devices after a back-off (doubling from
``retry_delay``, at most 60 s), and ``max_failures`` in a row end the watch
with exit 3. SIGINT and SIGTERM end it at the next frame (exit 130): the cycle under
way is set aside uncommitted, a commit under way is finished first, and every
committed cycle is in the history.

Frames are kept for every cycle that did not pass and for every
``keep_every``-th passing one; the others are deleted once their cycle is
committed. A folder left by a cycle that never committed (a stop, a kill) is renamed
``…-uncommitted``, never reused or deleted.
"""

from __future__ import annotations

import shutil
import time
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import TYPE_CHECKING

from inspect_validate.errors import DeviceError
from inspect_validate.interruption import deferred, stop_if_requested

if TYPE_CHECKING:
    from collections.abc import Callable

    from inspect_validate.comparisons import Comparisons
    from inspect_validate.station.file import Station
    from inspect_validate.station.production import PartLocator
    from inspect_validate.verification.diagnosis import Sensor
    from inspect_validate.verification.golden import Golden
    from inspect_validate.verification.plan import Plan
    from inspect_validate.verification.production import ProductionVerification
    from inspect_validate.verification.results import Verification
    from inspect_validate.verification.rig import RigVerification
    from inspect_validate.watch.drift import DriftMonitor, DriftState
    from inspect_validate.watch.feed import FolderFeed
    from inspect_validate.watch.history import CycleRecord
    from inspect_validate.watch.history_writer import HistoryWriter
    from inspect_validate.watch.rig import RigMonitor, RigWatch

__all__ = ["CycleOutcome", "LineWatch", "WatchSettings", "status_document", "watch"]


@dataclass(frozen=True)
class WatchSettings:
    interval: float = 60.0  # s from the start of one cycle to the next
    cycles: int | None = None  # stop after this many (None: until stopped)
    max_failures: int = 5  # consecutive failed cycles that end the watch (exit 3)
    retry_delay: float = 1.0  # s before the first reconnect; doubles, at most 60 s
    keep_every: int = 10  # passing cycles whose frames are kept: every k-th


@dataclass(frozen=True)
class CycleOutcome:
    record: CycleRecord
    state: DriftState | None  # None for an error cycle
    verification: Verification | ProductionVerification | RigVerification | None
    failures: int  # consecutive failed cycles, this one included
    health: dict = field(default_factory=dict)  # what the camera reported (history.cycle_health)
    totals: dict = field(default_factory=dict)  # its counters summed over the history


def status_document(
    outcome: CycleOutcome, station: Station, *, interval: float | None = None
) -> dict:
    """The status file's content: the latest cycle's verdict for the line (``interval``:
    the watch's seconds between cycle starts, for a monitor to tell a stopped watch)."""
    r = outcome.record
    doc = {
        "schema": "inspect-validate/watch-status",
        "schema_version": 1,
        "station": str(station.path),
        "cycle": r.cycle,
        "time": r.started,
        "interval_s": interval,
        "status": r.status,
        "passed": r.passed,
        "reason": r.reason,
        "cause": r.cause,
        "consecutive_failures": outcome.failures,
        "frames": r.frames,
        # what the camera reported this cycle, and its counters over the whole history
        "health": dict(outcome.health),
        "health_totals": dict(outcome.totals),
    }
    values: list[dict] = []
    doc["values"] = values
    if outcome.state is not None:
        for key, (x, ewma, low, high) in outcome.state.points.items():
            ill, kind, name, quantity, *camera = key  # the camera's name, of several
            values.append(
                {
                    **({"camera": camera[0]} if camera else {}),
                    "illumination": ill,
                    "kind": kind,
                    "name": name,
                    "quantity": quantity,
                    "value": x,
                    "ewma": ewma,
                    "low": low,
                    "high": high,
                    "alarm": key in outcome.state.alarms,
                }
            )
    return doc


@dataclass(frozen=True)
class LineWatch:
    """What a watch of the running line (``watch --production``) verifies each cycle
    against: the golden parts, and where the frames come from (``feed``: a folder the
    line's program writes into; None: the station's camera under the production light)."""

    golden: Golden
    feed: FolderFeed | None = None
    locator: PartLocator | None = None  # built once for the watch, not once a cycle
    comparisons: Comparisons | None = None
    sensor: Sensor | None = None  # the camera model's EMVA values (None: frames alone)

    @property
    def dark_offset(self) -> float:
        """DN under the classes' signal: the camera model's, 0 without one."""
        return self.sensor.dark_offset if self.sensor is not None else 0.0


def watch(
    station: Station,
    plan: Plan | None,
    history: HistoryWriter,
    monitor: DriftMonitor | RigMonitor,
    *,
    folder: Path,
    settings: WatchSettings,
    on_cycle: Callable[[CycleOutcome], None] | None = None,
    line: LineWatch | None = None,
    rig: RigWatch | None = None,
) -> tuple[CycleOutcome | None, bool]:
    """Run cycles until ``settings.cycles`` are done or a signal stops the watch.

    ``station`` is verified by ``plan`` (:func:`~inspect_validate.verification.plan.
    plan_verification` of it) every cycle; ``history`` is a :class:`~.history_writer.HistoryWriter`,
    ``monitor`` a :class:`~.drift.DriftMonitor` (restored from the history here).
    ``on_cycle(outcome)`` is called after each committed cycle. With ``line``, each
    cycle is a batch of the running line's parts instead (``plan`` is not used): taken
    by the camera under the production light, or from ``line.feed``, located, measured
    and charted by their means (:func:`~.drift.series_of_parts`). With ``rig``, a station
    of several cameras: all captured each cycle, each verified by its own plan and charted
    by ``monitor`` (a :class:`~.rig.RigMonitor`), and the cameras held to each other.

    Returns
    -------
    last : CycleOutcome or None
        The last cycle's, None if none ran.
    stopped : bool
        A signal ended the watch (before ``settings.cycles``).

    Raises
    ------
    DeviceError
        ``max_failures`` consecutive cycles failed (exit 3); the last one is committed.
    """
    for key, (ewma, n) in history.chart_states().items():
        if ewma is not None:  # a chart of the station's one camera is keyed without it
            monitor.restore(key if key[4] else key[:4], ewma=ewma, n=n)
    folder.mkdir(parents=True, exist_ok=True)
    failures, done, last = 0, 0, None
    try:
        while settings.cycles is None or done < settings.cycles:
            stop_if_requested()
            t0 = time.monotonic()
            last = _cycle(station, plan, history, monitor, folder, settings, failures, line, rig)
            failures = last.failures
            done += 1
            if on_cycle:
                on_cycle(last)
            if failures >= settings.max_failures:
                raise DeviceError(
                    f"{failures} cycles in a row failed, the last: {last.record.reason}; "
                    f"the history is in {history.path}"
                )
            if settings.cycles is not None and done >= settings.cycles:
                break
            wait = settings.interval - (time.monotonic() - t0)
            if failures:
                wait = max(wait, min(settings.retry_delay * 2 ** (failures - 1), 60.0))
            _sleep(wait)
    except KeyboardInterrupt:
        # The cycle under way is not committed: its frames are set aside, as a restart
        # would set them aside, and the committed ones are the history.
        frames = folder / f"cycle-{history.next_cycle():06d}"
        if frames.exists():
            set_aside(frames)
        return last, True
    return last, False


def _sleep(seconds: float) -> None:
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        stop_if_requested()
        time.sleep(min(0.05, max(end - time.monotonic(), 0.0)))


def set_aside(frames: Path) -> Path:
    """Rename the folder of a cycle that never committed to ``…-uncommitted-<time>``,
    numbered when one of that second exists (killed twice within it); the new path."""
    from inspect_validate.files import unused_path

    stamp = time.strftime("%Y%m%dT%H%M%S")
    return frames.rename(unused_path(frames.with_name(f"{frames.name}-uncommitted-{stamp}")))


def _cycle(station, plan, history, monitor, folder, settings, failures, line=None, rig=None):
    from inspect_validate.watch.history import CAMERAS, RECONNECTS, CycleRecord

    n = history.next_cycle()
    frames = folder / f"cycle-{n:06d}"
    if frames.exists():  # a cycle that never committed (killed): keep its frames aside
        set_aside(frames)
    when, t0 = time.time(), time.monotonic()
    # hours since the history began: a restarted watch goes on ageing its simulated LEDs
    hours = (when - history.created) / 3600.0
    state = verification = None
    health: dict = {}
    if (line is None or line.feed is None) and history.last_status() == "error":
        health[RECONNECTS] = 1  # the devices are opened again after an error cycle
    try:
        if rig is not None:
            from inspect_validate.watch.rig import rig_batch

            verification, values, note = rig_batch(station, rig, frames, n, hours)
        elif line is None:
            verification, values, note = _station_batch(station, plan, frames, n, hours)
        else:
            verification, values, note = _line_batch(station, line, frames, n, hours)
    except DeviceError as exc:
        failures += 1
        status, passed, reason = "error", None, str(exc)
        cause = "stale camera: frames stopped changing" if "stale" in reason else None
    else:
        failures = 0
        state = monitor.update(values)
        passed = verification.passed
        status = "fail" if not passed else ("drift" if state.drifting else "pass")
        checks = verification.checks
        failed = [c for c in checks if not c.passed]
        reason = "; ".join([*(c.name for c in failed[:3]), *filter(None, [note])]) or None
        saturated = [c.name for c in failed if c.kind == "saturation"]
        apart = [c.name for c in failed if c.kind == "cameras"]
        if saturated:
            cause = f"a class clips: {saturated[0]}"
        elif apart:
            cause = f"one camera's gain, exposure or lens changed alone: {apart[0]}"
        elif failed and line is not None:
            cause = verification.cause  # the production verdict's own reading of them
        elif state.drifting and rig is None:
            # The cycle's own change, read as verify reads it: the charts' EWMA decides
            # that something drifts, and would name only its smoothed step.
            diagnosis = verification.diagnosis  # bench and line: the verdict's own reading
            cause = (diagnosis.text if diagnosis is not None else None) or state.cause
        else:
            cause = state.cause
    if rig is None:
        health.update(_cycle_health(frames))
    else:  # each camera's, under its name
        cameras = {c: h for c in rig.plans if (h := _cycle_health(frames / c))}
        if cameras:
            health[CAMERAS] = cameras
    keep = status != "pass" or n % max(settings.keep_every, 1) == 0
    if keep and line is not None and line.feed is not None and verification is not None:
        # The line's program owns its folder (and may clear it): the cycle keeps links
        # to (or copies of) the frames it judged, as a captured cycle keeps its own.
        _keep_frames(verification.parts, frames)
    record = CycleRecord(
        cycle=n,
        started=when,
        seconds=time.monotonic() - t0,
        status=status,
        passed=passed,
        reason=reason,
        cause=cause,
        frames=str(frames) if keep and frames.exists() else None,
    )
    with deferred():  # a stop asked for now comes after the commit, not within it
        history.commit(record, state.points if state else {}, health)
        if not keep:
            shutil.rmtree(frames, ignore_errors=True)
    return CycleOutcome(record, state, verification, failures, health, history.health_totals())


def _keep_frames(parts, folder: Path) -> None:
    """Hard links in ``folder`` to the files of ``parts`` (measured or not), copies where
    a link cannot be made (another file system); files gone since are left out."""
    import os

    folder.mkdir(parents=True, exist_ok=True)
    for name in [p.frame for p in parts.measured] + list(parts.not_measured):
        source = Path(name)
        target = folder / source.name
        try:
            os.link(source, target)
        except FileExistsError:
            continue
        except OSError:
            try:
                shutil.copy2(source, target)
            except OSError:
                continue  # removed by the line's program meanwhile


def _cycle_health(frames: Path) -> dict:
    """What the camera reported while the cycle's frames were taken (its capture's
    manifest, also of a capture that failed: :func:`~inspect_validate.camera.health.
    capture_health`); none where no capture was made (frames from the line's folder)."""
    from inspect_validate.camera.health import capture_health
    from inspect_validate.camera.storage import read_manifest
    from inspect_validate.errors import InputError

    path = frames / "manifest.json"
    if not path.is_file():
        return {}
    try:
        steps = read_manifest(path).get("steps") or {}
    except InputError:
        return {}
    return capture_health(steps.values() if isinstance(steps, dict) else ())


def _station_batch(station, plan, frames, n, hours):
    """A cycle of the station: every illumination captured into ``frames`` and verified
    (each step measured while the next is captured, as verify does); the verification,
    its charted values, and no note."""
    from inspect_validate.station.capture import capture
    from inspect_validate.station.file import simulated_at
    from inspect_validate.verification.measured import StepMeasurer
    from inspect_validate.verification.verify import verify_folder
    from inspect_validate.watch.drift import series_of

    with StepMeasurer(frames, **plan.measuring(station.acceptance)) as measured:
        capture(simulated_at(station, n, hours=hours), frames, completed=measured)
        verification = verify_folder(station, frames, plan=plan, measured=measured)
    return verification, series_of(verification), None


def _line_batch(station, line, frames, n, hours):
    """A cycle of the running line (``watch --production``): a batch of parts, from the
    camera into ``frames`` or from the line's folder, verified without the golden
    statistics' checks (the charts replace them); the verification, the batch's means,
    and how many frames were dropped, if any."""
    from inspect_validate.station.capture import capture, production_steps
    from inspect_validate.station.file import simulated_at
    from inspect_validate.verification.parts import capture_of, measure_frames
    from inspect_validate.verification.production import verify_parts
    from inspect_validate.watch.drift import series_of_parts

    name = station.production.illumination
    manifest = None
    if line.feed is None:
        at = simulated_at(station, n, hours=hours)
        capture(at, frames, steps=production_steps(at))
        files, dropped = sorted((frames / name).glob("*.tif")), 0
        manifest = capture_of(frames, audit=False)  # taken by this cycle, just now
    else:
        files, dropped = line.feed.take()
    unreadable: dict[str, str] = {}
    parts = measure_frames(
        station,
        _readable(files, unreadable),
        refuse=False,
        locator=line.locator,
        comparisons=line.comparisons,
    )
    parts = replace(parts, not_measured={**unreadable, **parts.not_measured})
    verification = verify_parts(station, parts, line.golden, drift=False, manifest=manifest)
    notes = [f"{dropped} frames dropped (they land faster than measured)"] if dropped else []
    if parts.unusable:  # in the cycle's reason (status and history) even where it passed
        notes.append(
            f"{len(parts.unusable)} frames not measured: {next(iter(parts.unusable.values()))}"
        )
    if line.feed is not None and line.feed.passed_over:
        notes.append(f"{line.feed.passed_over} files passed over so far (not frames)")
    values = series_of_parts(parts, name, dark_offset=line.dark_offset)
    return verification, values, "; ".join(notes) or None


def _readable(files, unreadable: dict[str, str]):
    """``(name, frame)`` of each file that can be read; each that cannot (cut short, not
    an image) is put in ``unreadable`` with why, and the watch goes on."""
    from inspect_validate.errors import InputError
    from inspect_validate.images import read_image

    for path in files:
        try:
            yield str(path), read_image(path)
        except InputError as exc:
            unreadable[str(path)] = f"cannot be read: {exc}"
