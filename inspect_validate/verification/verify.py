"""Verify a station: measure its frames, predict the station as built, calibrate, compare, check.

Steps (each reported): the frames of every illumination and the darks (a
capture folder, or captured now); each measured in the station's ROIs with the
station's comparisons (raw grey values: the prediction includes the dark
level); the prediction of the station at its stated irradiances; the system
gain K by photon transfer; one irradiance scale per illumination
(:mod:`.calibration`); the calibrated prediction; per class and comparison,
predicted against measured (:mod:`.agreement`); the measured ranking of the
illuminations against the predicted one; and the checks the ``acceptance:`` section
asks for (:mod:`.acceptance_checks`), decided at its false-alarm rate
(:mod:`.checks`). The plan (:mod:`.plan`) comes first; illuminations not worth
capturing are left out (:mod:`.dominance`); what was found is a
:class:`~.results.Verification`.
"""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING

from inspect_validate.camera.storage import acquisition_record
from inspect_validate.errors import InputError
from inspect_validate.verification.acceptance_checks import acceptance_checks
from inspect_validate.verification.agreement import (
    agreement_rows,
    ranking_agreement,
    ranking_comparison,
)
from inspect_validate.verification.checks import Check, at_least, decide, normal_equivalent
from inspect_validate.verification.dominance import (
    dominance_unconfirmed,
    dominated_illuminations,
)
from inspect_validate.verification.golden_checks import (
    above_floor,
    drift_checks,
    settings_checks,
)
from inspect_validate.verification.health_checks import health_checks
from inspect_validate.verification.measured import StepMeasurer, measure_capture
from inspect_validate.verification.plan import Plan, plan_verification
from inspect_validate.verification.results import Verification

if TYPE_CHECKING:
    from collections.abc import Callable

    from inspect_validate.camera.capture import Progress
    from inspect_validate.station.file import Station
    from inspect_validate.verification.calibration import LightLevel
    from inspect_validate.verification.measured import MeasuredCapture

__all__ = ["verify_capture", "verify_folder", "verify_station"]


def verify_station(
    station: Station,
    *,
    frames: Path | None = None,
    out: Path | None = None,
    skip_dominated: bool = True,
    progress: Progress | None = None,
    notify: Callable[[str], None] | None = None,
) -> Verification:
    """Verify ``station`` end to end: plan (a mistake in the station file costs no
    capture), capture into ``out`` unless ``frames`` (an earlier capture) is given, and
    :func:`verify`. What ``inspect-validate verify`` does, without printing.

    Parameters
    ----------
    station : Station
    frames, out : path, keyword-only
        One of them: the capture to verify, or where to capture.
    skip_dominated : bool, keyword-only
        Leave out the illuminations the prediction finds dominated (the default, as
        ``inspect-validate verify`` does); capture them after all, into the same folder,
        where the measurement contradicts the prediction. False captures every one.
        With ``frames``, only the dominated illuminations the capture lacks are left out
        (a capture ``verify`` made holds none of them); where the measurement contradicts
        the prediction, it is refused, as they cannot be captured after all.
    progress : callable, keyword-only
        ``progress(step, frames done, frames in all)`` after every frame of a capture
        (:func:`~inspect_validate.station.capture.capture`'s).
    notify : callable, keyword-only
        ``notify(message)``: what was left out, or captured after all, and why.

    Raises
    ------
    InputError
        Neither ``frames`` nor ``out``; a station file, capture or frame that cannot be
        used. DeviceError: a device that fails while capturing.
    """
    from inspect_validate.station.capture import capture

    notify = notify or (lambda message: None)
    if station.cameras:
        raise InputError(
            "verify_station takes a station of one camera; verify_rig "
            "(inspect_validate.verification.rig) verifies one of several",
            source=str(station.path),
        )
    plan = plan_verification(station)
    full = station
    if frames is None and out is None:
        raise InputError("give the frames to verify (a capture folder) or where to capture")
    dominated = dominated_illuminations(station, plan.prediction) if skip_dominated else {}
    if frames is not None:  # an earlier capture: what it holds is measured
        held = _complete_steps(Path(frames))
        dominated = {n: why for n, why in dominated.items() if held is not None and n not in held}
    if dominated:
        kept = [i for i in station.illuminations if i.name not in dominated]
        station = station.model_copy(update={"illuminations": kept})
        how = (
            "not captured (verify --all-illuminations captures it)"
            if frames is None
            else "not in the capture (capture --resume into it adds it)"
        )
        plan = replace(plan, dominated={n: f"{why}; {how}" for n, why in dominated.items()})
        for name in dominated:
            doing = "not capturing" if frames is None else "not in the capture:"
            notify(f"{doing} {name!r}: predicted dominated (see skipped:)")
    if frames is None:
        assert out is not None
        # One pass: each step is measured while the camera takes the next.
        with StepMeasurer(Path(out), **plan.measuring(station.acceptance)) as measured:
            capture(station, Path(out), progress=progress, completed=measured)
            result = verify_folder(station, Path(out), plan=plan, measured=measured)
    else:
        result = verify_folder(station, Path(frames), plan=plan)
    misses = dominance_unconfirmed(result) if plan.dominated else []
    if misses and out is None:
        names = ", ".join(repr(n) for n in plan.dominated)
        raise InputError(
            f"the capture lacks {names}, which the prediction left out as dominated, but the "
            f"illuminations it holds do not bear the prediction out ({misses[0]}): capture "
            "the rest into this folder (inspect-validate capture STATION --out FOLDER "
            "--resume) or verify without --frames",
            source=str(frames),
        )
    if misses:
        # The skip rested on the prediction, which the captured lights contradict: the
        # left-out ones are added to the same capture (its complete steps are kept).
        names = ", ".join(repr(n) for n in plan.dominated)
        them = "them" if len(plan.dominated) > 1 else "it"
        why = (
            f"captured {names} after all: the prediction that left {them} out does not hold here "
            f"({misses[0]}{f', and {len(misses) - 1} more' if len(misses) > 1 else ''})"
        )
        notify(why)
        plan = replace(plan, dominated={})
        assert out is not None  # the capture above went there
        capture(full, Path(out), resume=True, progress=progress)
        result = verify_folder(full, Path(out), plan=plan)
        result = replace(result, notes=(*result.notes, why))
    return result


def _complete_steps(folder: Path) -> set[str] | None:
    """The steps a capture folder holds complete, by its manifest; None where it has no
    readable manifest (reading the capture then says what is wrong)."""
    from inspect_validate.camera.storage import read_manifest

    try:
        steps = read_manifest(folder / "manifest.json")["steps"]
    except InputError:
        return None
    return {name for name, record in steps.items() if record.get("complete")}


def verify_folder(
    station: Station,
    frames_dir: Path,
    *,
    plan: Plan | None = None,
    measured: StepMeasurer | None = None,
) -> Verification:
    """Verify ``station`` (a :class:`~inspect_validate.station.file.Station`) on the capture
    in ``frames_dir``; ``plan`` is :func:`plan_verification` of it, made here if not given;
    ``measured``, the steps measured while they were captured (:class:`~.measured.StepMeasurer`).

    Raises
    ------
    InputError
        See :func:`plan_verification`; an unreadable or incomplete capture (exit code 2).
    """
    plan = plan or plan_verification(station)
    capture = measure_capture(
        station, frames_dir, **plan.measuring(station.acceptance), measured=measured
    )
    return verify_capture(station, capture, plan=plan, folder=frames_dir)


def verify_capture(
    station: Station, capture: MeasuredCapture, *, plan: Plan, folder: Path | None = None
) -> Verification:
    """Verify ``station`` on a capture already measured in its regions
    (:func:`~.measured.measure_capture`, with ``plan``'s regions and comparisons, the
    acceptance's limits, ε KDE where a check asks for it); ``folder`` is where it lies
    (None for frames that never were files: a simulation's)."""
    from inspect_validate.verification.calibration import (
        fit_scales,
        light_levels,
        photon_transfer,
    )

    acc = station.acceptance
    rois, comparisons, model, golden = plan.rois, plan.comparisons, plan.model, plan.golden
    need_kde = acc.needs_kde
    skipped = [
        *model.scene.skipped,
        *(f"illumination {name!r}: {why}" for name, why in plan.dominated.items()),
    ]
    if not need_kde:
        skipped.append("ε KDE: no check asks for it (acceptance.separation[].max_error_kde)")
    limits = acc.limits()
    files, dark_files, manifest = capture.files, capture.dark_files, capture.manifest
    dark = capture.dark
    offset = model.sensor.dark_offset
    # An illumination whose light does not reach the camera is a finding about the
    # station (wiring, strobe, lens cap), not about its spectra: it fails its own check
    # and is neither calibrated nor compared with the model, which has no such light.
    levels = light_levels(capture.measurements, dark, offset=offset)
    light = [_light_check(level) for level in levels.values()]
    unlit = {name: level.text for name, level in levels.items() if not level.reaches}
    measurements = {k: m for k, m in capture.measurements.items() if k not in unlit}
    # The plan's prediction at the stated irradiances, its groups weighted as the
    # measured regions are.
    predicted_comparisons = comparisons.with_pixels(
        [c.n_pixels for c in next(iter(capture.measurements.values())).classes]
    )
    nominal = plan.prediction.compared(predicted_comparisons).select(
        list(measurements) or [i.name for i in station.illuminations]
    )
    dark_means = {c.name: c.mean for c in dark.classes} if dark else None
    if dark is None:
        skipped.append("dark level: no dark frames; the camera's dark offset is used")

    scales: dict = {}
    prediction = nominal
    if measurements:
        stated = {
            light.name: light.irradiance
            for light in model.illumination_lights(station)
            if light.name in measurements
        }
        scales = fit_scales(
            nominal,
            measurements,
            method=station.calibration.method,
            offset=offset,
            dark_means=dark_means,
            irradiance=stated,
            gain=model.sensor.gain,
            reference=station.calibration.reference,
            max_saturated=limits.max_saturated,
        )
        # The same prediction at the calibrated irradiances (no new spectral integration).
        prediction = nominal.calibrated({k: v.scale for k, v in scales.items()})

    # The frames read decide (a --frames folder need not have the station's counts).
    if not measurements:
        gain, left_out = None, {}
    elif dark is None:
        gain, left_out = None, {"no dark frames": 1}
    else:
        gain, left_out = photon_transfer(
            list(measurements.values()),
            dark,
            declared=model.sensor.gain,
            saturation_level=capture.saturation_level,
        )
    notes = []
    gain_missing = None
    quiet = [
        c.temporal_variance**0.5
        for c in (dark.classes if dark is not None else ())
        if c.temporal_variance is not None
    ]
    if gain is not None and quiet and min(quiet) < 0.5:
        notes.append(
            f"system gain K may be biased by a few %: the dark frames' temporal noise is "
            f"{min(quiet):.2g} DN, below the 0.5 DN EMVA 1288 needs for rounding to add "
            "1/12 DN² (more dark noise, or a higher gain, makes photon transfer exact)"
        )
    if gain is None and not measurements:
        gain_missing = "no light reaches the camera"
    elif gain is None:
        gain_missing = "no photon-transfer point: " + "; ".join(
            f"{why} ({n})" for why, n in left_out.items()
        )
        if acc.gain_relative is None:  # nobody asked: a skip, not a failure
            skipped.append(f"system gain K: {gain_missing}")

    from inspect_validate.verification.uncertainty import measured_standard_errors

    # log ε's errors take a root search per class moved: only for the checks that use them.
    mixtures = {comparisons.index(s.comparison) for s in acc.separation if s.max_error is not None}
    if acc.ranking and len(measurements) > 1:
        mixtures.add(comparisons.index(ranking_comparison(model.scene, acc, comparisons)))
    errors = {
        ill: measured_standard_errors(m, comparisons, mixtures=mixtures)
        for ill, m in measurements.items()
    }
    model_errors = _model_errors(acc, prediction, comparisons, measurements)
    class_rows, comparison_rows = agreement_rows(
        measurements, prediction, nominal, dark_means, offset, need_kde=need_kde
    )
    ranking, not_ranked = (
        ranking_agreement(measurements, prediction, model.scene, acc, comparisons)
        if measurements
        else (None, ())
    )
    checks, unchecked = acceptance_checks(
        acc,
        measurements,
        class_rows,
        comparison_rows,
        ranking,
        gain,
        gain_missing,
        errors,
        unlit=unlit,
        agreed=plan.agreed(acc),
        model_errors=model_errors if acc.agreement and acc.agreement.parts == "other" else None,
    )
    checks = [*light, *checks]
    skipped += [*not_ranked, *unchecked]
    if golden is not None and acc.health.settings:
        compared, why_not = settings_checks(golden, manifest)
        checks += compared
        notes += why_not
    unhealthy, unreported = health_checks(acc.health, manifest)
    checks += unhealthy
    skipped += unreported
    if plan.sharpness is not None:
        from inspect_validate.verification.sharpness_checks import sharpness_checks

        sharp, said = sharpness_checks(station, plan.model, plan.sharpness)
        checks += sharp
        notes += said
    if golden is not None and measurements:
        k = normal_equivalent(acc.false_alarm_rate)
        checks += drift_checks(golden, measurements, acc.drift, errors, k=k)
        if acc.drift is not None and acc.drift.snr_db is None:
            below = [
                f"{ill}: {label}"
                for ill in measurements
                for label, comp in golden.illuminations[ill].comparisons.items()
                if not above_floor(comp.snr_db, acc.drift.snr_floor_db, k=k)
            ]
            if below:
                skipped.append(
                    f"SNR_dB drift of {', '.join(below)}: below acceptance.drift.snr_floor_db "
                    f"({acc.drift.snr_floor_db:g} dB), or within {k:.2g} of the repeats' "
                    "spread above it, when trained: in every verification against this "
                    "golden file"
                )
    rate = acc.false_alarm_rate
    decided = decide(checks, rate)
    notes += _uncertainty_notes(acc, decided, golden, comparisons, model_errors)
    notes += _fixed_drift_notes(acc, decided, golden, measurements, errors)
    inputs = _inputs(station, capture, rois, folder, golden)
    acquisition = acquisition_record(manifest, {**files, "dark": dark_files}, capture.sidecars)
    if manifest.get("station_sha256") not in (None, inputs["station_sha256"]):
        notes.append(
            "the capture was made with another version of the station file "
            f"({manifest.get('station')}); its frames are used as they are"
        )
    return Verification(
        station=station,
        model=model,
        rois=rois,
        limits=limits,
        inputs=inputs,
        measurements=measurements,
        dark=dark,
        nominal=nominal,
        prediction=prediction,
        scales=scales,
        gain=gain,
        classes=class_rows,
        comparisons=comparison_rows,
        ranking=ranking,
        checks=decided,
        skipped=tuple(skipped),
        notes=tuple(notes),
        acquisition=acquisition,
        false_alarm=rate,
        golden=golden,
    )


def _light_check(level: LightLevel) -> Check:
    """Whether an illumination's light reaches the camera
    (:class:`~.calibration.LightLevel`): its rise above dark against a pixel's noise."""
    from inspect_validate.verification.calibration import NO_LIGHT_REMEDY

    detail = level.text
    if not level.reaches:
        detail = f"no light reaches the camera ({level.text}); {NO_LIGHT_REMEDY}"
    return at_least(
        f"{level.illumination}: light above dark", "light", level.signal, level.noise, "DN",
        detail, illumination=level.illumination, quantity="signal",
    )  # fmt: skip


def _inputs(station, capture, rois, folder, golden) -> dict:
    """What a verification read: files and their hashes."""
    from inspect_validate.station.file import station_hash

    acc = station.acceptance
    return {
        "station": str(station.path),
        "station_sha256": station_hash(station),
        "capture": None if folder is None else str(folder),
        "capture_station_sha256": capture.manifest.get("station_sha256"),
        "frames": {k: [str(p) for p in v] for k, v in capture.files.items()},
        "dark": [str(p) for p in capture.dark_files],
        "rois": rois.source,
        "golden": str(station.resolve(acc.drift.golden))
        if golden and acc.drift and acc.drift.golden
        else None,
        "scene": str(station.resolve(station.scene)),
    }


def _model_errors(acc, prediction, comparisons, measurements) -> dict:
    """The prediction's own standard errors per measured illumination, from its reflectance
    samples: what the agreement checks hold beside the measurement's (``agreement.parts:
    other``) and what the notes weigh the agreement tolerance against."""
    from inspect_validate.verification.uncertainty import predicted_standard_errors

    if acc.agreement is None:
        return {}
    if list(prediction.comparison_set.labels) != list(comparisons.labels):
        return {}  # not one set of rows: nothing to pair (never so from plan_verification)
    return {
        ill: predicted_standard_errors(
            prediction, prediction.index(ill), prediction.comparison_set, mixtures=()
        )
        for ill in measurements
    }


def _fixed_drift_notes(acc, checks, golden, measurements, errors) -> list[str]:
    """A fixed drift tolerance wider than the statistical limits the golden file would set
    at the station's false-alarm rate: by how much, and so what it lets pass unseen."""
    from inspect_validate.verification.checks import count_tests
    from inspect_validate.verification.golden_checks import drift_limit

    drift = acc.drift
    if golden is None or drift is None:
        return []
    fixed = [c for c in checks if c.kind == "drift" and c.basis == "fixed"]
    share = acc.false_alarm_rate / max(count_tests(checks) + len(fixed), 1)
    limits: dict[str, list[float]] = {"mean_dn": [], "snr_db": []}
    for ill, m in measurements.items():
        g, se = golden.illuminations[ill], errors[ill]
        refs = []
        if drift.mean_dn is not None:
            refs += [
                ("mean_dn", g.classes[c.name].mean, se.mean[k]) for k, c in enumerate(m.classes)
            ]
        if drift.snr_db is not None:
            refs += [
                ("snr_db", g.comparisons[c.label].snr_db, se.snr_db[j])
                for j, c in enumerate(m.comparisons)
                if above_floor(
                    g.comparisons[c.label].snr_db,
                    drift.snr_floor_db,
                    k=normal_equivalent(acc.false_alarm_rate),
                )
            ]
        for key, ref, error in refs:
            if ref.n < 2:
                continue  # no spread: no statistical limit to hold the tolerance against
            limit = drift_limit(
                ref, share, standard_error=float(error), confidence=drift.confidence
            )
            if math.isfinite(limit) and limit > 0:
                limits[key].append(limit)
    notes = []
    for key, unit, what in (("mean_dn", "DN", "a class's μ"), ("snr_db", "dB", "a SNR_dB")):
        tolerance = getattr(drift, key)
        narrower = sorted(x for x in limits[key] if x < tolerance) if tolerance else []
        if not narrower:
            continue
        notes.append(
            f"acceptance.drift.{key} {tolerance:g} {unit} is wider than the statistical limit "
            f"this golden file would set on {len(narrower)} of its {len(limits[key])} checks "
            f"({narrower[0]:.2g}–{narrower[-1]:.2g} {unit}, up to "
            f"{tolerance / narrower[0]:.2g} × narrower): a change of {what} smaller than "
            f"{tolerance:g} {unit} passes unseen there, and the false-alarm rate does not "
            f"describe these checks (leave out {key} for the statistical limits)"
        )
    return notes


def _uncertainty_notes(acc, checks, golden, comparisons, model_errors) -> list[str]:
    """What a reader should know of the checks' power: drift limits widened by a short
    training, and agreement tolerances within the model's own uncertainty
    (``model_errors``: :func:`_model_errors`)."""
    from inspect_validate.verification.checks import quantile
    from inspect_validate.verification.golden_checks import (
        GOOD_WIDENING,
        repeats_needed,
        widening,
    )

    notes = []
    drift = [c for c in checks if c.kind == "drift" and c.basis == "statistical" and c.ran]
    if drift and golden is not None:
        share = drift[0].false_alarm
        w = widening(golden.repeats, share)
        if w > GOOD_WIDENING:
            notes.append(
                f"the golden file's {golden.repeats} repeats make the drift limits {w:.1f} × as "
                f"wide as a well-known spread would (Student's t with {golden.repeats - 1} "
                f"degrees of freedom at {share:.2g} a check); train with --repeats "
                f"{repeats_needed(share)} for {GOOD_WIDENING:g} ×"
            )
    agreement = acc.agreement
    tested = [c for c in checks if c.false_alarm is not None]
    if agreement is None or agreement.snr_db is None or not tested:
        return notes
    q = quantile(tested[0].false_alarm, sided=1)
    close = []
    for ill, errors in model_errors.items():
        se = errors.snr_db
        for j, text in enumerate(comparisons.labels):
            row = f"{ill}: {text} SNR_dB deviation"
            if any(c.name == row for c in tested) and q * se[j] > agreement.snr_db:
                close.append(f"{ill}: {text} ±{se[j]:.2g} dB")
    if close and agreement.parts == "measured":
        notes.append(
            f"agreement.snr_db {agreement.snr_db:g} dB is within {q:.2g} × the model's own "
            f"uncertainty from its reflectance samples for {', '.join(close)}: parts that are "
            "another draw of their classes than the spectra measured fail it more often than "
            "the false-alarm rate (agreement.parts: measured says they are those parts; if "
            "not, leave it out, measure more spectra per class, or widen the tolerance)"
        )
    elif close:
        notes.append(
            f"agreement.snr_db {agreement.snr_db:g} dB is widened by the model's own "
            f"uncertainty from its reflectance samples for {', '.join(close)} (the parts are "
            "other draws of their classes: agreement.parts): a change of SNR_dB within that "
            "passes the agreement check, and drift against a golden file is what catches "
            "it (measure more spectra per class to narrow it)"
        )
    return notes
