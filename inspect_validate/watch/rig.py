"""A watch of a station of several cameras (``cameras:``): every cycle one capture of all
of them, each camera verified and charted against its own golden file, the cameras held
to each other (:mod:`~inspect_validate.verification.rig`), for one status a cycle.

Each camera's charts are its own :class:`~.drift.DriftMonitor`; in the history, the status
file and ``/metrics`` their keys carry the camera's name. The charts of all cameras
together keep the false-alarm rate of one station's charts: each camera's monitor is
designed for ``cameras`` times the cycles between false alarms.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from inspect_validate.errors import InputError

if TYPE_CHECKING:
    from inspect_validate.station.file import Station
    from inspect_validate.verification.plan import Plan
    from inspect_validate.verification.rig import RigVerification
    from inspect_validate.watch.drift import Chart, DriftMonitor, DriftState

__all__ = ["RigMonitor", "RigWatch", "rig_batch", "rig_watch"]


class RigMonitor:
    """The drift charts of several cameras, keyed (illumination, kind, name, quantity,
    camera)."""

    def __init__(self, monitors: dict[str, DriftMonitor]) -> None:
        self.monitors = dict(monitors)

    @property
    def charts(self) -> dict[tuple, Chart]:
        return {(*k, name): c for name, m in self.monitors.items() for k, c in m.charts.items()}

    @property
    def limit(self) -> float:
        """The widest of the cameras' limits (each is designed for its own charts)."""
        return max(m.limit for m in self.monitors.values())

    def restore(self, key: tuple, *, ewma: float, n: int) -> None:
        """Continue a chart (key with the camera fifth) where an earlier run left it."""
        monitor = self.monitors.get(key[4]) if len(key) == 5 else None
        if monitor is not None:
            monitor.restore(key[:4], ewma=ewma, n=n)

    def update(self, values: dict[str, dict]) -> DriftState:
        """Each camera's charts updated with its ``values``; one state of them all, the
        first camera with a cause naming it."""
        from inspect_validate.watch.drift import DriftState

        states = {name: m.update(values.get(name, {})) for name, m in self.monitors.items()}
        cause = next((f"{n}: {s.cause}" for n, s in states.items() if s.cause), None)
        return DriftState(
            {(*k, n): p for n, s in states.items() for k, p in s.points.items()},
            tuple((*k, n) for n, s in states.items() for k in s.alarms),
            cause,
        )


@dataclass(frozen=True)
class RigWatch:
    """What a watch of several cameras verifies each cycle by: per camera, the station as
    it alone sees it (no single-cycle drift checks) and its plan (its golden file kept,
    so that its camera settings are held to the golden snapshot)."""

    plans: dict[str, tuple[Station, Plan]]


def rig_watch(
    station: Station, golden: dict[str, Path] | Path | None
) -> tuple[RigWatch, RigMonitor, str]:
    """The plans and charts of a watch of ``station``'s cameras, each against its own
    golden file (``golden``: camera name → file, else ``cameras[].golden``), and the
    golden files as the history's meta names them.

    Raises
    ------
    InputError
        One golden file for all cameras, a name no camera has, a camera without a golden
        file, one that does not fit, or too few repeats for the charts.
    """
    from inspect_validate.acceptance import Drift
    from inspect_validate.verification.diagnosis import Sensor
    from inspect_validate.verification.rig import of_camera, plan_rig
    from inspect_validate.watch.drift import FAMILY_ARL, DriftMonitor

    if golden is not None and not isinstance(golden, dict):
        raise InputError(
            "--golden: each camera of several is charted against its own golden file; give "
            "--golden NAME=PATH for each, or cameras[].golden (made by train --camera NAME)",
            source=str(station.path),
        )
    if golden:
        unknown = sorted(set(golden) - set(station.camera_names))
        if unknown:
            raise InputError(
                f"--golden {unknown[0]}=…: no camera {unknown[0]!r} (the station has "
                f"{', '.join(station.camera_names)})",
                source=str(station.path),
            )
        cameras = [
            c.model_copy(update={"golden": str(Path(golden[c.name]).resolve())})
            if c.name in golden
            else c
            for c in station.cameras
        ]
        station = station.model_copy(update={"cameras": cameras})
    untrained = [c.name for c in station.cameras if c.golden is None]
    if untrained:
        raise InputError(
            f"watch charts each camera against its golden file, and camera {untrained[0]!r} "
            f"has none: give --golden {untrained[0]}=PATH or cameras[].golden (made by "
            f"train --camera {untrained[0]})",
            source=str(station.path),
        )
    drift = station.acceptance.drift or Drift()
    charted = station.model_copy(
        update={"acceptance": station.acceptance.model_copy(update={"drift": drift})}
    )
    plans = plan_rig(charted, drift_checks=False)
    monitors = {}
    for name, (_, plan) in plans.items():
        assert plan.golden is not None  # plan_rig read every camera's golden file
        try:
            monitors[name] = DriftMonitor(
                plan.golden,
                dark_offset=plan.model.sensor.dark_offset,
                snr_floor_db=drift.snr_floor_db,
                family_arl=FAMILY_ARL * len(plans),
                sensor=Sensor.of(plan.model.sensor),
            )
        except InputError as exc:  # too few repeats for the charts: said of the camera's file
            golden_file = next(c.golden for c in station.cameras if c.name == name)
            said = InputError(str(exc), source=str(station.resolve(golden_file)))
            raise of_camera(name, said) from None
    # each cycle is verified without the single-cycle drift checks: the charts replace them
    watched = {
        name: (
            view.model_copy(
                update={"acceptance": view.acceptance.model_copy(update={"drift": None})}
            ),
            plan,
        )
        for name, (view, plan) in plans.items()
    }
    meta = "; ".join(f"{c.name}={station.resolve(c.golden)}" for c in station.cameras)
    return RigWatch(watched), RigMonitor(monitors), meta


def rig_batch(
    station: Station, rig: RigWatch, frames: Path, n: int, hours: float
) -> tuple[RigVerification, dict[str, dict], None]:
    """A cycle of a station of several cameras: all of them captured into
    ``frames/<camera>/`` and verified; the verification, each camera's charted values,
    and no note."""
    from inspect_validate.station.capture import capture
    from inspect_validate.station.file import simulated_at
    from inspect_validate.verification.rig import verify_rig_folder
    from inspect_validate.watch.drift import series_of

    capture(simulated_at(station, n, hours=hours), frames)
    verification = verify_rig_folder(station, frames, rig.plans)
    values = {name: series_of(v) for name, v in verification.cameras.items()}
    return verification, values, None
