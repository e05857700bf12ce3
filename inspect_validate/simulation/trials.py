"""Verifications of a simulated station, many times over, in process: how often a verdict
errs, on a station that has not changed and on one that has.

A *run* is one world: the station's simulated camera with the parts placed by a seed of
the run's and a sensor (fixed pattern) of its own, and the station file's world
deviations. Its golden file is trained on ``repeats`` captures of it, each with fresh
sensor noise, and then each *case* verifies one more capture: of the world as it was
(``unchanged``: a failure is a false alarm) or changed (a light dimmer, an LED's peak
shifted, the lens soiled…: a failure is a detection). What varies from capture to
capture besides the noise is the world's (``irradiance_jitter``: lights that vary).

The frames are rendered by the station's own simulated camera
(:class:`~inspect_validate.simulation.camera.SimulatedGrabber`) under each
illumination's channels, measured by the one measuring path
(:func:`~inspect_validate.measurement.measure_stack`) and verified by
:func:`~inspect_validate.verification.verify.verify_capture`: the same code as
``train`` and ``verify``, without the controller process, the capture sequence and
the files, which decide nothing about the statistics (they are tested on their own).
"""

from __future__ import annotations

import os
from collections.abc import Iterable, Iterator
from dataclasses import dataclass, replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    from inspect_validate.simulation.camera import SimulatedGrabber
    from inspect_validate.station.file import Station
    from inspect_validate.station.model import StationModel
    from inspect_validate.station.world import World
    from inspect_validate.verification.measured import MeasuredCapture
    from inspect_validate.verification.plan import Plan

__all__ = ["Trial", "WatchTrial", "render_capture", "run_trials", "station_grabber", "watch_trials"]

IN_PROCESS = "trained in process"  # the drift block's golden file: none is written


@dataclass(frozen=True)
class Trial:
    """One verification of one run's world.

    Attributes
    ----------
    case : str
        ``unchanged`` or the change's name.
    run : int
        Which world.
    passed : bool
        The verdict.
    failed : tuple of str
        The failed checks' names.
    kinds : tuple of str
        Their kinds (``drift``, ``agreement``, ``separation``, ``ranking``…).
    undecided : int
        Checks too close to call.
    """

    case: str
    run: int
    passed: bool
    failed: tuple[str, ...]
    kinds: tuple[str, ...]
    undecided: int


@dataclass(frozen=True)
class WatchTrial:
    """One run's in-control cycles of ``watch``: how many, how many alarmed a drift chart
    (the charts restarting after each alarm), and how many failed a check."""

    run: int
    cycles: int
    alarms: int
    failures: int


def station_grabber(
    station: Station,
    *,
    world: World,
    seed: int,
    sensor_seed: int | None = None,
    noise_seed: Any = None,
    target: str = "scene",
    renderer_model: StationModel | None = None,
) -> SimulatedGrabber:
    """``station``'s simulated camera in ``world``, configured at the station's exposure
    and gain, showing ``target`` (the scene's objects, or a ``flat`` or ``edge`` target;
    :class:`~inspect_validate.simulation.camera.SimulatedGrabber`)."""
    from inspect_validate.simulation.camera import SimulatedGrabber
    from inspect_validate.station.model import station_model

    spec = station.camera
    camera = SimulatedGrabber(
        renderer_model or station_model(station),
        Path(os.devnull),
        world=world,
        width=spec.width,
        height=spec.height,
        seed=seed,
        sensor_seed=sensor_seed,
        noise_seed=noise_seed,
        target=target,
    )
    camera.configure(exposure_us=spec.exposure_us, gain_db=spec.gain_db)
    return camera


def render_capture(
    station: Station,
    plan: Plan,
    *,
    world: World,
    seed: int,
    sensor_seed: int | None = None,
    noise_seed: int | None = None,
    renderer_model: StationModel | None = None,
) -> MeasuredCapture:
    """One capture of ``station``'s simulated camera in ``world``, measured in ``plan``'s
    regions: ``station.frames`` frames per illumination and ``station.dark_frames`` darks,
    as ``capture`` takes them (the frames after the switch, settled).

    Parameters
    ----------
    station : Station
        A station whose camera renders its scene.
    plan : Plan
        :func:`~inspect_validate.verification.plan.plan_verification` of it.
    world : World
        What the camera renders (the station file's, or changed).
    seed, sensor_seed, noise_seed : keyword-only
        The parts' placement, the sensor's fixed pattern and the noise
        (:class:`~inspect_validate.simulation.camera.SimulatedGrabber`).
    renderer_model : StationModel, keyword-only, optional
        ``station_model(station)``, made here if not given (a caller rendering many
        captures makes it once).
    """
    from inspect_validate.measurement import measure_stack
    from inspect_validate.station.model import station_model
    from inspect_validate.verification.measured import MeasuredCapture, station_shading

    model = renderer_model or station_model(station)
    camera = station_grabber(
        station, world=world, seed=seed, sensor_seed=sensor_seed, noise_seed=noise_seed,
        renderer_model=model,
    )  # fmt: skip
    acc = station.acceptance
    level = float(2**model.sensor.bit_depth - 1)
    options: dict[str, Any] = {"comparisons": plan.comparisons, "saturation_level": level}

    def stack(state, n):
        return np.stack([camera.render(state) for _ in range(n)])

    # Rendered as a capture takes them, the darks last; measured first: a corrected
    # field needs their level, as measure_capture's does.
    lit = {ill.name: stack(dict(ill.channels), station.frames) for ill in station.illuminations}
    dark = (
        measure_stack(stack({}, station.dark_frames), plan.rois, kde="never", **options)
        if station.dark_frames
        else None
    )
    shadings = station_shading(station, dark, source=str(station.file))
    measurements = {
        name: measure_stack(
            frames,
            plan.rois,
            limits=acc.limits(),
            kde="always" if acc.needs_kde else "never",
            shading=shadings.get(name),
            **options,
        )
        for name, frames in lit.items()
    }
    return MeasuredCapture({}, [], {}, measurements, dark, level, {})


def _run_capture(station, plan, model, seed):
    """``capture(world, run, k)``: the k-th capture of run ``run``'s world: its parts
    placed once and its own camera (fixed pattern), fresh noise in every capture."""

    def capture(world, run, k):
        return render_capture(
            station,
            plan,
            world=world,
            seed=seed * 7919 + run,
            sensor_seed=1_000_003 + seed * 7919 + run,
            noise_seed=np.random.SeedSequence([seed, run, k]),
            renderer_model=model,
        )

    return capture


def run_trials(
    station: Station,
    *,
    runs: Iterable[int],
    repeats: int,
    changes: dict[str, dict] | None = None,
    seed: int = 0,
) -> Iterator[Trial]:
    """Train and verify ``station``'s simulated world once per run, for every case.

    Parameters
    ----------
    station : Station
        A station whose camera renders its scene; its acceptance section is what is
        verified. Without a ``drift:`` block, ``{golden: …}`` is added (the manual's:
        prediction intervals at the acceptance's false-alarm rate).
    runs : iterable of int, keyword-only
        The runs (worlds) to make; disjoint ranges split the work between processes.
    repeats : int, keyword-only
        Captures each golden file is trained on.
    changes : dict, keyword-only
        Case name → fields of the station's ``camera.world`` replaced in the verified
        capture (``{"irradiance": {1: 0.95}}``, ``{"gain_error": 0.05}``…).
    seed : int, keyword-only
        Offsets every seed: another set of worlds.

    Yields
    ------
    Trial
        Per run, the unchanged case first, then each change in order.

    Raises
    ------
    InputError
        A station whose golden files these repeats cannot check at its false-alarm rate
        (too few; :func:`~inspect_validate.verification.golden_checks.validate_golden`).
    """
    from inspect_validate import __version__
    from inspect_validate.acceptance import Drift
    from inspect_validate.station.model import station_model
    from inspect_validate.verification.golden import golden_of
    from inspect_validate.verification.golden_checks import validate_golden
    from inspect_validate.verification.plan import plan_verification, planned_tests
    from inspect_validate.verification.verify import verify_capture

    acc = station.acceptance
    drift = acc.drift or Drift(golden=IN_PROCESS)
    drift = drift.model_copy(update={"golden": IN_PROCESS})
    plain = station.model_copy(update={"acceptance": acc.model_copy(update={"drift": None})})
    checked = station.model_copy(update={"acceptance": acc.model_copy(update={"drift": drift})})
    plan = plan_verification(plain)
    model = station_model(station)
    base = station.camera.world
    worlds = {"unchanged": base}
    for name, change in (changes or {}).items():
        worlds[name] = base.model_copy(update=change)
    classes = [c.name for c in plan.rois.classes]

    capture = _run_capture(station, plan, model, seed)

    for run in runs:
        trained = [capture(base, run, k).measurements for k in range(repeats)]
        golden = golden_of(
            station,
            trained,
            plan.comparisons,
            captures=[f"run {run} repeat {k + 1}" for k in range(repeats)],
            tool_version=__version__,
            station_sha256="",
        )
        validate_golden(
            golden,
            checked,
            drift,
            classes=classes,
            comparisons=plan.comparisons.labels,
            source=f"run {run}'s golden",
            share=checked.acceptance.false_alarm_rate / planned_tests(checked, plan, golden),
        )
        trial_plan = replace(plan, golden=golden)
        for k, (case, world) in enumerate(worlds.items()):
            cap = capture(world, run, repeats + k)
            v = verify_capture(checked, cap, plan=trial_plan)
            failed = [c for c in v.checks if not c.passed]
            yield Trial(
                case=case,
                run=run,
                passed=v.passed,
                failed=tuple(c.name for c in failed),
                kinds=tuple(c.kind for c in failed),
                undecided=sum(c.undecided for c in v.checks),
            )


def watch_trials(
    station: Station, *, runs: Iterable[int], repeats: int, cycles: int, seed: int = 0
) -> Iterator[WatchTrial]:
    """``watch``'s per-cycle decisions on ``station``'s unchanged simulated world: per run
    a golden file from ``repeats`` captures, then ``cycles`` cycles, each verified as
    ``watch`` verifies them (the acceptance checks without the single-cycle drift checks)
    and charted by a :class:`~inspect_validate.watch.drift.DriftMonitor`; after an alarm
    the charts start again from their targets, so that the alarms count the run lengths
    (renewal: cycles / alarms estimates the in-control ARL)."""
    from inspect_validate import __version__
    from inspect_validate.station.model import station_model
    from inspect_validate.verification.golden import golden_of
    from inspect_validate.verification.plan import plan_verification
    from inspect_validate.verification.verify import verify_capture
    from inspect_validate.watch.drift import DriftMonitor, series_of

    acc = station.acceptance
    plain = station.model_copy(update={"acceptance": acc.model_copy(update={"drift": None})})
    plan = plan_verification(plain)
    model = station_model(station)
    world = station.camera.world
    floor = acc.drift.snr_floor_db if acc.drift else -20.0

    capture = _run_capture(station, plan, model, seed)

    for run in runs:
        trained = [capture(world, run, k).measurements for k in range(repeats)]
        golden = golden_of(
            station,
            trained,
            plan.comparisons,
            captures=[f"run {run} repeat {k + 1}" for k in range(repeats)],
            tool_version=__version__,
            station_sha256="",
        )
        monitor = DriftMonitor(golden, dark_offset=model.sensor.dark_offset, snr_floor_db=floor)
        alarms = failures = 0
        for c in range(cycles):
            v = verify_capture(plain, capture(world, run, repeats + c), plan=plan)
            failures += not v.passed
            if monitor.update(series_of(v)).drifting:
                alarms += 1
                for key, chart in monitor.charts.items():
                    monitor.restore(key, ewma=chart.target, n=0)
        yield WatchTrial(run, cycles, alarms, failures)
