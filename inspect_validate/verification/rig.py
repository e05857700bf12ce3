"""A verification of a station of several cameras (``cameras:``): each camera verified as
a station of its own (:meth:`~inspect_validate.station.file.Station.view`), and the
cameras held to each other, for one verdict.

**Across cameras.** Every camera sees the same lights. Each camera's calibration ties the
prediction to its frames by one irradiance scale per illumination
(:mod:`.calibration`), which absorbs whatever scales that camera's signal alone — its
gain, its exposure, its lens's aperture. A change of one camera alone therefore passes
that camera's own checks, but moves its scale away from the others': the check
``amber: side against top`` holds the ratio of the two scales to 1 within
``acceptance.agreement.mean_relative``, widened by the ratio's standard error (basis
``tolerance``). The first camera is the reference.

**The false-alarm rate.** The station's rate is shared: each camera's verification and
the checks across them each get ``false_alarm / (cameras + 1)``, so the one verdict fails
an unchanged station at most ``false_alarm`` of the time (Bonferroni).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from inspect_validate.errors import InputError
from inspect_validate.verification.checks import Check, at_most, decide

if TYPE_CHECKING:
    from collections.abc import Callable

    from inspect_validate.station.file import Station
    from inspect_validate.verification.plan import Plan
    from inspect_validate.verification.results import Verification

__all__ = [
    "RigVerification",
    "across_cameras",
    "of_camera",
    "plan_rig",
    "rig_share",
    "verify_rig",
    "verify_rig_folder",
]


@dataclass(frozen=True)
class RigVerification:
    """Everything ``verify`` found of a station of several cameras: each camera's
    :class:`~.results.Verification` (its checks at its share of the rate), and the checks
    across them. :attr:`passed` is the station's one verdict."""

    station: Station
    cameras: dict[str, Verification]
    across: tuple[Check, ...]  # the checks across the cameras
    skipped: tuple[str, ...]
    false_alarm: float
    notes: tuple[str, ...] = ()

    @property
    def passed(self) -> bool:
        return all(c.passed for c in self.checks)

    @property
    def checks(self) -> tuple[Check, ...]:
        """Every camera's checks, each named ``camera: check``, then the checks across them
        (the verdict's, :class:`~.verdict.Verdict`)."""
        from dataclasses import replace

        named = (
            replace(c, name=f"{camera}: {c.name}")
            for camera, v in self.cameras.items()
            for c in v.checks
        )
        return (*named, *self.across)

    @property
    def cause(self) -> str | None:
        """Each camera's likely cause, named by the camera (None where none has one)."""
        causes = [f"{name}: {v.cause}" for name, v in self.cameras.items() if v.cause]
        return "; ".join(causes) or None

    @property
    def share(self) -> float:
        """The false-alarm rate each camera's verification and the checks across them get."""
        return rig_share(self.false_alarm, len(self.cameras))


def rig_share(rate: float, cameras: int) -> float:
    """``rate`` shared by ``cameras`` verifications and the checks across them (module
    text)."""
    return rate / (cameras + 1)


def verify_rig(
    station: Station,
    *,
    frames: Path | None = None,
    out: Path | None = None,
    progress: Callable[[str, int, int], None] | None = None,
) -> RigVerification:
    """Verify a station of several cameras end to end: every camera's plan first (a
    mistake in the station file costs no capture), one capture of all of them into
    ``out`` (``out/<camera>/``) unless ``frames`` holds one, each camera verified on its
    frames, and the checks across cameras (module text).

    Raises
    ------
    InputError
        Neither ``frames`` nor ``out``; a station file, capture or frame that cannot be
        used. DeviceError: a device that fails while capturing.
    """
    from inspect_validate.station.capture import capture

    if frames is None and out is None:
        raise InputError("give the frames to verify (a capture folder) or where to capture")
    plans = plan_rig(station)
    folder = Path(frames) if frames is not None else Path(out)  # type: ignore[arg-type]
    if frames is None:
        capture(station, folder, progress=progress)
    return verify_rig_folder(station, folder, plans)


def plan_rig(station: Station, *, drift_checks: bool = True) -> dict[str, tuple[Station, Plan]]:
    """Per camera, the station as it alone sees it deciding at its share of the rate,
    and its verification plan (:func:`~.plan.plan_verification`; ``drift_checks`` as
    there).

    Raises
    ------
    InputError
        A drift section and a camera without a golden file; whatever a plan refuses.
    """
    from inspect_validate.verification.plan import plan_verification, validate_trained

    views = {name: camera_view(station, name) for name in station.camera_names}
    for view in views.values():  # every camera's, before any golden file is read
        validate_trained(view)
    plans = {}
    for name, view in views.items():
        try:
            plans[name] = (view, plan_verification(view, drift_checks=drift_checks))
        except InputError as exc:
            raise of_camera(name, exc) from None
    return plans


def of_camera(name: str, exc: InputError) -> InputError:
    """``exc`` saying which camera of several it is about, its file kept."""
    said = str(exc).removeprefix(f"{exc.source}: ") if exc.source else str(exc)
    return InputError(f"cameras {name!r}: {said}", source=exc.source)


def verify_rig_folder(
    station: Station,
    folder: Path,
    plans: dict[str, tuple[Station, Plan]],
) -> RigVerification:
    """Verify the capture of several cameras in ``folder`` (``folder/<camera>/``) by the
    plans of :func:`plan_rig`: each camera on its frames, then the checks across them.

    Raises
    ------
    InputError
        A camera's folder missing; a frame or region that cannot be used (the camera
        named).
    """
    from inspect_validate.camera.storage import audit_rig
    from inspect_validate.verification.verify import verify_folder

    results = {}
    for name in plans:
        if not (folder / name).is_dir():
            raise InputError(
                f"no frames of camera {name!r} here (a capture of several cameras keeps each "
                f"in <folder>/<camera>/); capture the station into it",
                source=str(folder),
            )
    audit_rig(folder, list(plans))
    for name, (view, plan) in plans.items():
        try:
            results[name] = verify_folder(view, folder / name, plan=plan)
        except InputError as exc:  # which camera's frames or regions it is
            raise of_camera(name, exc) from None
    checks, skipped = across_cameras(station, results)
    rate = station.acceptance.false_alarm_rate
    share = rig_share(rate, len(plans))
    return RigVerification(station, results, decide(checks, share), tuple(skipped), rate)


def camera_view(station: Station, name: str) -> Station:
    """Camera ``name`` of ``station`` as its verification sees it: a station of that
    camera alone (:meth:`Station.view`) deciding at its share of the station's
    false-alarm rate (:func:`rig_share`)."""
    share = rig_share(station.acceptance.false_alarm_rate, len(station.camera_names))
    return _at_rate(station.view(name), share)


def _at_rate(view: Station, rate: float) -> Station:
    """``view`` whose acceptance decides at ``rate``."""
    acc = view.acceptance.model_copy(update={"false_alarm": rate})
    return view.model_copy(update={"acceptance": acc})


def across_cameras(
    station: Station, results: dict[str, Verification]
) -> tuple[list[Check], list[str]]:
    """The checks across ``results``' cameras (module text): per illumination that more
    than one camera measured, each camera's irradiance scale over the first's held to 1;
    and what could not be checked, and why."""
    if station.calibration.method == "absolute":
        return [], [
            "cameras against each other: calibration absolute ties no scale to the frames "
            "(each camera's agreement checks hold it to the prediction itself)"
        ]
    agreement = station.acceptance.agreement
    tolerance = agreement.mean_relative if agreement is not None else None
    if tolerance is None:
        return [], [
            "cameras against each other: no acceptance.agreement.mean_relative to hold the "
            "ratio of their irradiance scales to"
        ]
    names = list(results)
    reference = names[0]
    checks: list[Check] = []
    skipped: list[str] = []
    for ill in (i.name for i in station.illuminations):
        base = results[reference].scales.get(ill)
        for name in names[1:]:
            other = results[name].scales.get(ill)
            if base is None or other is None or not (base.scale > 0 and other.scale > 0):
                skipped.append(
                    f"{ill}: {name} against {reference}: not measured by both (no light "
                    "reached one of them, or it was left out)"
                )
                continue
            ratio = other.scale / base.scale
            se = ratio * math.hypot(
                base.standard_error / base.scale, other.standard_error / other.scale
            )
            checks.append(
                at_most(
                    f"{ill}: {name} against {reference}",
                    "cameras",
                    100 * abs(ratio - 1),
                    100 * tolerance,
                    "%",
                    f"irradiance scale {other.scale:.4g} against {base.scale:.4g} (ratio "
                    f"{ratio:.4f}): both cameras see the same light, so a ratio off 1 "
                    "is one camera's gain, exposure or lens",
                    basis="tolerance",
                    standard_error=100 * se,
                    illumination=ill,
                    subject=name,
                    quantity="irradiance_scale",
                )
            )
    return checks, skipped
