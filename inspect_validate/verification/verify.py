"""Verify a station: measure its frames, predict the station as built, calibrate, compare, check.

Steps (each reported): the frames of every illumination and the darks (a
capture folder, or captured now); each measured in the station's ROIs with the
station's comparisons (raw grey values: the prediction includes the dark
level); the prediction of the station at its stated irradiances; the system
gain K by photon transfer; one irradiance scale per illumination
(:mod:`.calibration`); the calibrated prediction; per class and comparison,
predicted against measured; the measured ranking of the illuminations against
the predicted one; and the checks the ``acceptance:`` section asks for.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from inspect_validate.errors import InputError
from inspect_validate.verification.checks import Check, at_least, at_most, decide, not_run
from inspect_validate.verification.golden import drift_checks
from inspect_validate.verification.measured import measure_capture, station_regions

if TYPE_CHECKING:
    from inspect_validate.comparisons import Comparisons
    from inspect_validate.measurement import Limits, Measurement
    from inspect_validate.model import Prediction
    from inspect_validate.roi import RoiSet
    from inspect_validate.station.file import Station
    from inspect_validate.station.model import StationModel
    from inspect_validate.verification.calibration import Gain, IrradianceScale
    from inspect_validate.verification.golden import Golden
    from inspect_validate.verification.measured import Capture

__all__ = [
    "Plan",
    "Verification",
    "dominance_unconfirmed",
    "dominated_illuminations",
    "plan_verification",
    "planned_tests",
    "verify",
    "verify_capture",
    "verify_station",
]


@dataclass(frozen=True)
class PredictedClass:
    """A class as the calibrated prediction has it: μ (DN), σ² and its temporal and spatial
    (reflectance) parts (DN²), the saturated fraction."""

    mean: float
    variance: float
    temporal_variance: float
    spatial_variance: float
    saturated_fraction: float


@dataclass(frozen=True)
class NominalClass:
    """A class as predicted at the station's stated irradiances: μ (DN), σ² (DN²)."""

    mean: float
    variance: float


@dataclass(frozen=True)
class MeasuredClass:
    """A class as measured: μ (DN), σ² and its EMVA 1288 parts (DN², None where the frames
    cannot tell), saturated and zero fractions, and the dark level subtracted (DN)."""

    mean: float
    variance: float
    temporal_variance: float | None
    spatial_variance: float | None
    saturated_fraction: float
    zero_fraction: float
    dark_mean: float


@dataclass(frozen=True)
class ClassAgreement:
    """One class under one illumination, predicted against measured. ``mean_relative`` is
    (μ measured − μ predicted) over the predicted signal above the dark level,
    ``variance_relative`` (σ² measured − σ² predicted) over σ² predicted."""

    illumination: str
    class_name: str
    predicted: PredictedClass
    nominal: NominalClass
    measured: MeasuredClass
    mean_relative: float
    variance_relative: float


@dataclass(frozen=True)
class ComparisonValues:
    """A comparison's separation: SNR_dB (36), CNR_dB, ε Gauss and ε KDE (37), fractions
    (ε KDE None where not computed)."""

    snr_db: float
    cnr_db: float
    error_gaussian: float
    error_kde: float | None = None


@dataclass(frozen=True)
class ComparisonAgreement:
    """One comparison under one illumination, predicted (calibrated), nominal and measured;
    ``snr_db_difference`` is measured − predicted SNR_dB, dB."""

    illumination: str
    comparison: str
    predicted: ComparisonValues
    nominal: ComparisonValues
    measured: ComparisonValues
    snr_db_difference: float


@dataclass(frozen=True)
class RankingAgreement:
    """The illuminations ranked by the key ``comparison``, predicted against measured:
    each illumination's value ``by`` (``log_error_gaussian``, lowest best; ``snr_db`` or
    ``cnr_db``, highest best), the best of each, whether they agree, Kendall's τ."""

    comparison: str
    by: str
    predicted: dict[str, float]
    measured: dict[str, float]
    predicted_best: str
    measured_best: str
    agree: bool
    kendall_tau: float


@dataclass(frozen=True)
class Verification:
    """Everything ``verify`` found; :attr:`passed` is the verdict."""

    station: Station
    model: StationModel  # what the prediction used (its scene holds the ROI classes only)
    rois: RoiSet  # measured
    limits: Limits  # the saturated and zero fractions the measurements were held to
    inputs: dict
    measurements: dict[str, Measurement]  # illumination → its measurement
    dark: Measurement | None  # of the dark stack
    nominal: Prediction  # at the stated irradiances
    prediction: Prediction  # after calibration
    scales: dict[str, IrradianceScale]  # illumination → its scale
    gain: Gain | None
    classes: list[ClassAgreement]  # per illumination and class
    comparisons: list[ComparisonAgreement]  # per illumination and comparison
    ranking: RankingAgreement | None
    checks: tuple[Check, ...]
    skipped: tuple[str, ...] = ()
    notes: tuple[str, ...] = field(default=())
    acquisition: tuple[dict, ...] = ()  # per step: how its frames were taken (acquisition_steps)
    false_alarm: float = 0.0027  # the family-wise rate the checks share (acceptance)

    @property
    def passed(self) -> bool:
        return all(c.passed for c in self.checks)


@dataclass(frozen=True)
class Plan:
    """What a station's verification needs before any frame: its regions, comparisons and
    model, and the golden file. Made first, so that a mistake in the station file costs
    no capture."""

    rois: RoiSet
    comparisons: Comparisons
    model: StationModel
    golden: Golden | None  # for acceptance.drift
    dominated: dict[str, str] = field(default_factory=dict)
    """Illuminations left out of the capture as dominated (:func:`dominated_illuminations`):
    name → why; listed as skipped."""


def plan_verification(station, *, drift_checks: bool = True) -> Plan:
    """Check ``station``'s scene, channels, ROIs, comparisons, acceptance and golden file;
    ``drift_checks``: that the golden file's repeats can set the drift checks' limits at
    the acceptance's false-alarm rate (``watch`` charts drift instead, and checks its
    charts' bands itself).

    Raises
    ------
    InputError
        A station without scene, channels, ROIs or exposure; ROI classes the
        scene does not have; an acceptance section naming unknown comparisons or
        illuminations; an unreadable golden file (exit code 2).
    """
    from inspect_validate.station.model import station_model
    from inspect_validate.verification.golden import read_golden

    source = str(station.path)
    acc = station.acceptance
    if station.camera.exposure_us is None:
        raise InputError(
            "camera.exposure_us is needed to predict the station's grey values", source=source
        )
    rois, comparisons = station_regions(station)
    model = station_model(station)
    scene_classes = {c.name: c for c in model.scene.classes}
    names = [c.name for c in rois.classes]
    unknown = [n for n in names if n not in scene_classes]
    if unknown:
        raise InputError(
            f"ROI class {unknown[0]!r} is not a class of the scene "
            f"({', '.join(scene_classes)}); name the regions as the scene's classes",
            source=rois.source,
        )
    for sep in acc.separation:
        try:
            comparisons.index(sep.comparison)
        except InputError as exc:
            raise InputError(str(exc), source=f"{source}: acceptance.separation") from None
    names_of = [i.name for i in station.illuminations]
    if acc.illumination is not None and acc.illumination not in names_of:
        raise InputError(
            f"acceptance.illumination: no illumination {acc.illumination!r} "
            f"(there are {', '.join(names_of)})",
            source=source,
        )
    used_channels = {c for i in station.illuminations for c, v in i.channels.items() if v > 0}
    if station.calibration.method == "absolute" and used_channels & model.nominal:
        ch = min(used_channels & model.nominal)
        raise InputError(
            f"calibration 'absolute' needs every light's irradiance, and channel {ch} "
            f"({model.channels[ch].name}) has none; give channels.{ch}.irradiance or use "
            "calibration 'fit' or 'reference'",
            source=source,
        )
    golden = None
    if acc.drift:
        from inspect_validate.verification.golden import check_golden

        golden = read_golden(station.resolve(acc.drift.golden))
        check_golden(
            golden,
            station,
            acc.drift,
            classes=names,
            comparisons=comparisons.labels,
            source=str(station.resolve(acc.drift.golden)),
            share=acc.false_alarm_rate / planned_tests(station, names, comparisons.labels, golden)
            if drift_checks
            else None,
        )
    # Only the ROI classes are predicted.
    scene = replace(model.scene, classes=tuple(scene_classes[n] for n in names))
    return Plan(rois, comparisons, replace(model, scene=scene), golden)


def planned_tests(station, classes, comparisons, golden=None, *, drift: bool = False) -> int:
    """How many checks of ``station``'s acceptance will share its false-alarm rate
    (:func:`~.checks.decide`), counted before any frame: every statistical and tolerance
    check it asks for on the ROI ``classes`` and ``comparisons`` (labels), the drift
    checks on what ``golden`` holds above the drift floor. An upper bound where a check
    depends on the frames (agreement of comparisons below the SNR_dB floor is left out
    then), so that a share from it is never too large. ``drift``: count the drift checks
    of ``golden`` as the acceptance's default drift block would, where it has none (what
    ``train`` tells of a golden file before the station uses it)."""
    from inspect_validate.acceptance import Drift

    acc = station.acceptance
    if drift and acc.drift is None:
        acc = acc.model_copy(update={"drift": Drift(golden="-")})
    ills = len(station.illuminations)
    n = 0
    for sep in acc.separation:
        per = sum(x is not None for x in (sep.min_snr_db, sep.min_cnr_db, sep.max_error))
        n += per * (1 if acc.illumination else ills)
    if acc.agreement is not None:
        a = acc.agreement
        n += (
            ills
            * len(classes)
            * ((a.mean_relative is not None) + (a.variance_relative is not None))
        )
        n += ills * len(comparisons) * (a.snr_db is not None)
    n += bool(acc.ranking and ills > 1) + (acc.gain_relative is not None)
    if acc.drift is not None and golden is not None:
        for g in golden.illuminations.values():
            if acc.drift.mean_dn is None:
                n += len(classes)
            if acc.drift.snr_db is None:
                n += sum(
                    g.comparisons[c].snr_db.mean >= acc.drift.snr_floor_db
                    for c in comparisons
                    if c in g.comparisons
                )
    return max(n, 1)


def dominated_illuminations(station, model, comparisons) -> dict[str, str]:
    """Illuminations that need not be captured: no acceptance check needs them, and the
    prediction shows another illumination clearly better on every comparison.

    Illumination X is dominated by Y when, on every comparison, Y's predicted SNR_dB
    exceeds X's by at least twice the agreement tolerance ``acceptance.agreement.snr_db``
    (3 dB if not given) — so even if each measures that far from its prediction, in
    opposite directions, Y still measures better — or both are below
    ``snr_floor_db``, where SNR_dB says nothing (as in the agreement check); and on at
    least one comparison Y is ahead. Every illumination is needed (nothing is
    dominated) when the acceptance ranks them (``ranking``), compares them with a golden
    file (``drift``) or checks separation on all of them (no ``illumination``);
    ``acceptance.illumination`` itself is always needed.

    Returns
    -------
    dict
        Name → why, in station order.
    """
    acc = station.acceptance
    names = [i.name for i in station.illuminations]
    if len(names) < 2 or acc.ranking or acc.drift or (acc.separation and not acc.illumination):
        return {}
    tolerance, floor = _dominance_tolerance(acc)
    margin = 2.0 * tolerance
    if comparisons.weights == "pixels":  # no regions yet; only the groups' SNR_dB depend on it
        comparisons = replace(comparisons, weights="equal")
    snr = model.predict(station, comparisons=comparisons).snr_db[:, 0, 0, :]
    out: dict[str, str] = {}
    for x, name in enumerate(names):
        if name == acc.illumination:
            continue
        for y, other in enumerate(names):
            if y == x or other in out:
                continue
            lead = snr[y] - snr[x]
            ahead = lead >= margin
            silent = (snr[x] < floor) & (snr[y] < floor)
            if np.all(ahead | silent) and np.any(ahead):
                out[name] = (
                    f"predicted dominated by {other!r}: its SNR_dB is at least "
                    f"{lead[ahead].min():.1f} dB higher on every comparison above {floor:g} dB "
                    f"(margin {margin:g} dB, twice the agreement tolerance)"
                )
                break
    return out


def _dominance_tolerance(acc) -> tuple[float, float]:
    """How far (dB) each illumination's SNR_dB may miss its prediction for a dominance to
    stand (the agreement tolerance; its default when the station sets none), and the
    floor below which SNR_dB says nothing."""
    from inspect_validate.acceptance import Agreement

    agreement = acc.agreement or Agreement()
    default = Agreement.model_fields["snr_db"].default
    return agreement.snr_db or default, agreement.snr_floor_db


def dominance_unconfirmed(result: Verification) -> list[str]:
    """Where the captured illuminations miss their predicted SNR_dB by more than the
    tolerance :func:`dominated_illuminations` assumed when it left others out.

    The dominance is a prediction; the captured illuminations are the only evidence of
    how far the prediction holds on this station. When one of them misses by more than
    the tolerance, the margin no longer guarantees the order, and what was left out has
    to be captured after all. (A deviation of a left-out light alone leaves no trace
    in the others: only ``--all-illuminations`` shows it.)

    Returns
    -------
    list of str
        "illumination: comparison measured … dB from its prediction", worst first;
        empty when every captured comparison is within the tolerance (or both
        predicted and measured are below the floor).
    """
    tolerance, floor = _dominance_tolerance(result.station.acceptance)
    misses = [
        (abs(r.snr_db_difference), f"{r.illumination}: {r.comparison}")
        for r in result.comparisons
        if max(r.predicted.snr_db, r.measured.snr_db) >= floor
        and abs(r.snr_db_difference) > tolerance
    ]
    return [
        f"{where} measured {miss:.1f} dB from its prediction (more than {tolerance:g} dB)"
        for miss, where in sorted(misses, reverse=True)
    ]


def verify_station(
    station,
    *,
    frames: Path | None = None,
    out: Path | None = None,
    skip_dominated: bool = True,
    capture=None,
    notify=None,
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
    capture : callable, keyword-only
        ``capture(station, folder, resume=False)``; default
        :func:`~inspect_validate.camera.capture.capture`.
    notify : callable, keyword-only
        ``notify(message)``: what was left out, or captured after all, and why.

    Raises
    ------
    InputError
        Neither ``frames`` nor ``out``; a station file, capture or frame that cannot be
        used. DeviceError: a device that fails while capturing.
    """
    if capture is None:
        from inspect_validate.station.capture import capture
    notify = notify or (lambda message: None)
    plan = plan_verification(station)
    full = station
    if frames is None:
        if out is None:
            raise InputError("give the frames to verify (a capture folder) or where to capture")
        dominated = (
            dominated_illuminations(station, plan.model, plan.comparisons) if skip_dominated else {}
        )
        if dominated:
            kept = [i for i in station.illuminations if i.name not in dominated]
            station = station.model_copy(update={"illuminations": kept})
            plan = replace(plan, dominated=dominated)
            for name in dominated:
                notify(f"not capturing {name!r}: predicted dominated (see skipped:)")
        capture(station, Path(out))
        frames = out
    result = verify(station, Path(frames), plan=plan)
    misses = dominance_unconfirmed(result) if plan.dominated else []
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
        capture(full, Path(out), resume=True)
        result = verify(full, Path(out), plan=plan)
        result = replace(result, notes=(*result.notes, why))
    return result


def verify(station, frames_dir: Path, *, plan: Plan | None = None) -> Verification:
    """Verify ``station`` (a :class:`~inspect_validate.station.file.Station`) on the capture
    in ``frames_dir``; ``plan`` is :func:`plan_verification` of it, made here if not given.

    Raises
    ------
    InputError
        See :func:`plan_verification`; an unreadable or incomplete capture (exit code 2).
    """
    plan = plan or plan_verification(station)
    acc = station.acceptance
    capture = measure_capture(
        station,
        frames_dir,
        rois=plan.rois,
        comparisons=plan.comparisons,
        limits=acc.limits(),
        kde="always" if acc.needs_kde else "never",
        camera=plan.model.camera,
    )
    return verify_capture(station, capture, plan=plan, folder=frames_dir)


def verify_capture(
    station, capture: Capture, *, plan: Plan, folder: Path | None = None
) -> Verification:
    """Verify ``station`` on a capture already measured in its regions
    (:func:`~.measured.measure_capture`, with ``plan``'s regions and comparisons, the
    acceptance's limits, ε KDE where a check asks for it); ``folder`` is where it lies
    (None for frames that never were files: a simulation's)."""
    from inspect_validate.station.file import station_hash
    from inspect_validate.verification.calibration import fit_scales, photon_transfer

    acc = station.acceptance
    rois, comparisons, model, golden = plan.rois, plan.comparisons, plan.model, plan.golden
    need_kde = acc.needs_kde
    skipped = [
        *model.scene.skipped,
        *(
            f"illumination {name!r}: {why}; not captured (verify --all-illuminations captures it)"
            for name, why in plan.dominated.items()
        ),
    ]
    if not need_kde:
        skipped.append("ε KDE: no check asks for it (acceptance.separation[].max_error_kde)")
    limits = acc.limits()
    files, dark_files, manifest = capture.files, capture.dark_files, capture.manifest
    measurements, dark = capture.measurements, capture.dark
    # The prediction weights a group's classes as the measured regions do.
    predicted_comparisons = comparisons.with_pixels(
        [c.n_pixels for c in next(iter(measurements.values())).classes]
    )

    # The prediction at the stated irradiances.
    nominal = model.predict(station, comparisons=predicted_comparisons)
    method = station.calibration.method
    offset = model.camera.dark_offset
    dark_means = {c.name: c.mean for c in dark.classes} if dark else None
    if dark is None:
        skipped.append("dark level: no dark frames; the camera's dark offset is used")
    stated = {light.name: light.irradiance for light in model.lights(station)}
    scales = fit_scales(
        nominal,
        measurements,
        method=method,
        offset=offset,
        dark_means=dark_means,
        irradiance=stated,
        gain=model.camera.gain,
        reference=station.calibration.reference,
        max_saturated=limits.max_saturated,
    )
    prediction = model.predict(
        station,
        scale={k: v.scale for k, v in scales.items()},
        comparisons=predicted_comparisons,
    )

    # The frames read decide (a --frames folder need not have the station's counts).
    gain, left_out = (
        photon_transfer(
            list(measurements.values()),
            dark,
            declared=model.camera.gain,
            saturation_level=capture.saturation_level,
        )
        if dark is not None
        else (None, {"no dark frames": 1})
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
    if gain is None:
        gain_missing = "no photon-transfer point: " + "; ".join(
            f"{why} ({n})" for why, n in left_out.items()
        )
        if acc.gain_relative is None:  # nobody asked: a skip, not a failure
            skipped.append(f"system gain K: {gain_missing}")

    from inspect_validate.verification.uncertainty import measured_standard_errors

    # log ε's errors take a root search per class moved: only for the checks that use them.
    mixtures = {comparisons.index(s.comparison) for s in acc.separation if s.max_error is not None}
    if acc.ranking and len(measurements) > 1:
        mixtures.add(comparisons.index(_ranking_comparison(model.scene, acc, comparisons)))
    errors = {
        ill: measured_standard_errors(m, comparisons, mixtures=mixtures)
        for ill, m in measurements.items()
    }
    class_rows, comparison_rows = _compare(
        measurements, prediction, nominal, dark_means, offset, need_kde=need_kde
    )
    ranking, not_ranked = _ranking(measurements, prediction, model.scene, acc, comparisons)
    checks, unchecked = _checks(
        acc, measurements, class_rows, comparison_rows, ranking, gain, gain_missing, errors
    )
    skipped += [*not_ranked, *unchecked]
    if golden is not None:
        checks += drift_checks(golden, measurements, acc.drift, errors)
    rate = acc.false_alarm_rate
    checks = decide(checks, rate)
    notes += _uncertainty_notes(
        acc, checks, golden, prediction, predicted_comparisons, list(measurements)
    )
    inputs = {
        "station": str(station.path),
        "station_sha256": station_hash(station.path),
        "capture": None if folder is None else str(folder),
        "capture_station_sha256": manifest.get("station_sha256"),
        "frames": {k: [str(p) for p in v] for k, v in files.items()},
        "dark": [str(p) for p in dark_files],
        "rois": rois.source,
        "golden": str(station.resolve(acc.drift.golden)) if golden else None,
        "scene": str(station.resolve(station.scene)),
    }
    acquisition = acquisition_steps(manifest, {**files, "dark": dark_files})
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
        checks=tuple(checks),
        skipped=tuple(skipped),
        notes=tuple(notes),
        acquisition=acquisition,
        false_alarm=rate,
    )


def _uncertainty_notes(acc, checks, golden, prediction, comparisons, illuminations) -> list[str]:
    """What a reader should know of the checks' power: drift limits widened by a short
    training, and agreement tolerances within the model's own uncertainty."""
    from inspect_validate.verification.checks import quantile
    from inspect_validate.verification.golden import (
        GOOD_WIDENING,
        repeats_needed,
        widening,
    )
    from inspect_validate.verification.uncertainty import predicted_standard_errors

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
    for li, ill in enumerate(illuminations):
        se = predicted_standard_errors(prediction, li, comparisons, mixtures=()).snr_db
        for j, text in enumerate(comparisons.labels):
            row = f"{ill}: {text} SNR_dB deviation"
            if any(c.name == row for c in tested) and q * se[j] > agreement.snr_db:
                close.append(f"{ill}: {text} ±{se[j]:.2g} dB")
    if close:
        notes.append(
            f"agreement.snr_db {agreement.snr_db:g} dB is within {q:.2g} × the model's own "
            f"uncertainty from its reflectance samples for {', '.join(close)}: parts that are "
            "another draw of their classes than the spectra measured fail it more often than "
            "the false-alarm rate (measure more spectra per class, or widen the tolerance)"
        )
    return notes


def acquisition_steps(manifest: dict, files: dict[str, list[Path]]) -> tuple[dict, ...]:
    """How each step's frames were taken, from the manifest and the frames' sidecars:
    the acquisition mode, the exposure the frames verifiably had (their chunk values
    where the camera sent chunks, else the setting read back), and the frames discarded
    before them, by reason. Steps captured before modes were recorded say ``free-run``."""
    rows = []
    for step, paths in files.items():
        if not paths:
            continue
        entry = manifest.get("steps", {}).get(step, {})
        exposures, source = set(), "read back"
        for path in paths:
            try:
                meta = json.loads(path.with_suffix(".json").read_text())
            except (OSError, ValueError):
                continue  # a frame without its sidecar: the exposure is not known for it
            chunk = (meta.get("extra") or {}).get("chunk") or {}
            if "ExposureTime" in chunk:
                exposures.add(float(chunk["ExposureTime"]))
                source = "chunk"
            elif meta.get("exposure_us") is not None:
                exposures.add(float(meta["exposure_us"]))
        rows.append(
            {
                "step": step,
                "mode": entry.get("acquisition", "free-run"),
                "frames": len(paths),
                "exposure_us": sorted(exposures),
                "exposure_source": source if exposures else None,
                "discarded": dict(entry.get("discarded") or {}),
            }
        )
    return tuple(rows)


def _compare(measurements, p, nominal, dark_means, offset, *, need_kde):
    """Rows of predicted (calibrated; and ``nominal``, at the stated irradiances, as
    ``predict`` gives them) against measured, per illumination and class / comparison."""
    from inspect_validate.model import predicted_kde_error

    class_rows, comparison_rows = [], []
    temporal = p.variance - p.spectral_variance  # σ² = temporal (mean over samples) + spectral
    for li, (ill, m) in enumerate(measurements.items()):
        for k, c in enumerate(m.classes):
            pm, pv = float(p.mean[li, 0, 0, k]), float(p.variance[li, 0, 0, k])
            level = (dark_means or {}).get(c.name, offset)
            signal = pm - offset
            class_rows.append(
                ClassAgreement(
                    illumination=ill,
                    class_name=c.name,
                    predicted=PredictedClass(
                        mean=pm,
                        variance=pv,
                        temporal_variance=float(temporal[li, 0, 0, k]),
                        spatial_variance=float(p.spectral_variance[li, 0, 0, k]),
                        saturated_fraction=float(p.saturated_fraction[li, 0, 0, k]),
                    ),
                    nominal=NominalClass(
                        mean=float(nominal.mean[li, 0, 0, k]),
                        variance=float(nominal.variance[li, 0, 0, k]),
                    ),
                    measured=MeasuredClass(
                        mean=c.mean,
                        variance=c.variance,
                        temporal_variance=c.temporal_variance,
                        spatial_variance=c.spatial_variance,
                        saturated_fraction=c.saturated_fraction,
                        zero_fraction=c.zero_fraction,
                        dark_mean=level,
                    ),
                    # Relative to the signal above the dark level, which the model predicts.
                    mean_relative=(c.mean - pm) / signal if signal > 0 else float("nan"),
                    variance_relative=(c.variance - pv) / pv if pv > 0 else float("nan"),
                )
            )
        for j, comp in enumerate(m.comparisons):
            predicted_kde = predicted_kde_error(p, (li, 0, 0), j) if need_kde else None
            comparison_rows.append(
                ComparisonAgreement(
                    illumination=ill,
                    comparison=comp.label,
                    predicted=ComparisonValues(
                        snr_db=float(p.snr_db[li, 0, 0, j]),
                        cnr_db=float(p.cnr_db[li, 0, 0, j]),
                        error_gaussian=float(p.error_gaussian[li, 0, 0, j]),
                        error_kde=predicted_kde,
                    ),
                    nominal=ComparisonValues(
                        snr_db=float(nominal.snr_db[li, 0, 0, j]),
                        cnr_db=float(nominal.cnr_db[li, 0, 0, j]),
                        error_gaussian=float(nominal.error_gaussian[li, 0, 0, j]),
                    ),
                    measured=ComparisonValues(
                        snr_db=comp.snr_db,
                        cnr_db=comp.cnr_db,
                        error_gaussian=comp.error_gaussian,
                        error_kde=comp.error_kde,
                    ),
                    snr_db_difference=comp.snr_db - float(p.snr_db[li, 0, 0, j]),
                )
            )
    return class_rows, comparison_rows


def _ranking(
    measurements, p, scene, acc, comparisons
) -> tuple[RankingAgreement | None, tuple[str, ...]]:
    """The illuminations ranked by the key comparison, measured against predicted, and
    why not (None and the reason) with one illumination."""
    from inspect_validate.stats.ranking import kendall_tau

    if len(measurements) < 2:
        return None, ("ranking: one illumination, nothing to rank",)
    j = comparisons.index(_ranking_comparison(scene, acc, comparisons))
    by = scene.rank_by if scene.rank_by in ("snr_db", "cnr_db") else "error"
    names = list(measurements)
    if by == "error":
        predicted = np.array([p.log_error_gaussian[i, 0, 0, j] for i in range(len(names))])
        measured = np.array([measurements[n].comparisons[j].log_error_gaussian for n in names])
        best_p, best_m = names[int(np.argmin(predicted))], names[int(np.argmin(measured))]
    else:
        predicted = np.array([getattr(p, by)[i, 0, 0, j] for i in range(len(names))])
        measured = np.array([getattr(measurements[n].comparisons[j], by) for n in names])
        best_p, best_m = names[int(np.argmax(predicted))], names[int(np.argmax(measured))]
    tau = kendall_tau(predicted, measured)
    ranking = RankingAgreement(
        comparison=comparisons.labels[j],
        by="log_error_gaussian" if by == "error" else by,
        predicted=dict(zip(names, map(float, predicted), strict=True)),
        measured=dict(zip(names, map(float, measured), strict=True)),
        predicted_best=best_p,
        measured_best=best_m,
        agree=best_p == best_m,
        kendall_tau=tau,
    )
    return ranking, ()


def _ranking_comparison(scene, acc, comparisons) -> str:
    """The comparison the illuminations are ranked by: the first separation check's, else
    the scene's ``rank:`` comparison, else the first (the worst pair decides, as predict
    ranks by default)."""
    if acc.separation:
        return acc.separation[0].comparison
    if scene.rank_comparison in comparisons.labels:
        return scene.rank_comparison
    return comparisons.labels[0]


def _ranking_check(ranking: RankingAgreement, errors, j: int) -> Check:
    """Whether the predicted best illumination measures best, as a statistical check.

    Each illumination's "badness" is its measured log₁₀ ε (or −SNR_dB, −CNR_dB). The
    value is how far the predicted best measures behind the measured best (0 where it
    measures best); it may do so by up to what these frames resolve: the margin,
    a multiple of the standard error of the difference. When the prediction itself puts
    the two in question (the predicted best and the measured best, or the predicted
    runner-up where they agree) closer than the margin, the check is too close to call.
    """
    sign = 1.0 if ranking.by == "log_error_gaussian" else -1.0
    unit, quantity, field = _RANKED[ranking.by]
    names = list(ranking.measured)
    bad_m = {n: sign * ranking.measured[n] for n in names}
    bad_p = {n: sign * ranking.predicted[n] for n in names}
    se = {n: float(getattr(errors[n], field)[j]) for n in names}
    best_p, best_m = ranking.predicted_best, ranking.measured_best
    other = best_m
    if other == best_p:  # they agree: the question is the predicted runner-up
        other = min((n for n in names if n != best_p), key=lambda n: bad_p[n])
    behind = bad_m[best_p] - bad_m[best_m]
    return at_most(
        f"ranking by {ranking.comparison}: predicted best {best_p} measures best",
        "ranking",
        behind,
        0.0,
        unit,
        f"measured best {best_m}; {quantity} measured "
        + ", ".join(f"{n} {ranking.measured[n]:.3g}" for n in names)
        + ", predicted "
        + ", ".join(f"{n} {ranking.predicted[n]:.3g}" for n in names)
        + f"; predicted gap to {other} {bad_p[other] - bad_p[best_p]:.2g} {unit}; "
        f"Kendall τ {ranking.kendall_tau:.2f}",
        basis="statistical",
        standard_error=float(np.hypot(se[best_p], se[other])),
        predicted_gap=bad_p[other] - bad_p[best_p],
    )


_RANKED = {  # by → unit, what it is, the StandardErrors field
    "log_error_gaussian": ("decades", "log₁₀ ε", "log_error"),
    "snr_db": ("dB", "SNR_dB", "snr_db"),
    "cnr_db": ("dB", "CNR_dB", "cnr_db"),
}


def _checks(
    acc,
    measurements,
    class_rows,
    comparison_rows,
    ranking,
    gain,
    gain_missing=None,
    errors=None,
) -> tuple[list[Check], list[str]]:
    """The checks ``acc`` asks for, and the work left out (a skip: only what nobody asked
    for). A check that cannot be evaluated is :func:`not_run`, a failure that says why —
    never a skip. ``errors`` is illumination → the measurement's
    :class:`~.uncertainty.StandardErrors`: the tolerance checks' margins
    (:func:`~.checks.decide` sets them)."""
    checks, skipped = [], []
    targets = [acc.illumination] if acc.illumination else list(measurements)
    for sep in acc.separation:
        for ill in targets:
            m = measurements[ill]
            j = m.comparisons.index(m.comparison(sep.comparison))
            comp, se = m.comparisons[j], errors[ill]
            where = f"{ill}: {comp.label}"
            tolerance = {"basis": "tolerance"}
            if sep.min_snr_db is not None:
                checks.append(
                    at_least(
                        f"{where} SNR_dB",
                        "separation",
                        comp.snr_db,
                        sep.min_snr_db,
                        "dB",
                        standard_error=se.snr_db[j],
                        **tolerance,
                    )
                )
            if sep.min_cnr_db is not None:
                checks.append(
                    at_least(
                        f"{where} CNR_dB",
                        "separation",
                        comp.cnr_db,
                        sep.min_cnr_db,
                        "dB",
                        standard_error=se.cnr_db[j],
                        **tolerance,
                    )
                )
            if sep.max_error is not None:
                # SE(ε) = ε ln 10 SE(log₁₀ ε)
                checks.append(
                    at_most(
                        f"{where} ε Gauss",
                        "separation",
                        comp.error_gaussian,
                        sep.max_error,
                        standard_error=comp.error_gaussian * np.log(10.0) * se.log_error[j],
                        **tolerance,
                    )
                )
            if sep.max_error_kde is not None:
                checks.append(
                    at_most(
                        f"{where} ε KDE",
                        "separation",
                        comp.error_kde,
                        sep.max_error_kde,
                        detail="fixed limit: ε KDE has no standard error here",
                    )
                )
    for ill, m in measurements.items():
        for c in m.classes:
            for what, frac, limit in (
                ("saturated", c.saturated_fraction, acc.max_saturated),
                ("zero", c.zero_fraction, acc.max_zero),
            ):
                if limit is not None:
                    checks.append(
                        at_most(
                            f"{ill}: {c.name} {what}", "saturation", 100 * frac, 100 * limit, "%"
                        )
                    )
    agree = acc.agreement
    if agree is not None:
        class_index = {
            (ill, c.name): k for ill, m in measurements.items() for k, c in enumerate(m.classes)
        }
        for row in class_rows:
            where = f"{row.illumination}: {row.class_name}"
            pred = row.predicted
            k = class_index[row.illumination, row.class_name]
            se = errors[row.illumination]
            if agree.mean_relative is not None:
                signal = pred.mean - row.measured.dark_mean
                checks.append(
                    at_most(
                        f"{where} μ deviation",
                        "agreement",
                        100 * abs(row.mean_relative),
                        100 * agree.mean_relative,
                        "%",
                        f"predicted {pred.mean:.4g} DN, measured {row.measured.mean:.4g} DN",
                        basis="tolerance",
                        standard_error=100 * se.mean[k] / signal if signal > 0 else np.nan,
                    )
                )
            if agree.variance_relative is not None:
                checks.append(
                    at_most(
                        f"{where} σ² deviation",
                        "agreement",
                        100 * abs(row.variance_relative),
                        100 * agree.variance_relative,
                        "%",
                        f"predicted {pred.variance:.4g} DN², "
                        f"measured {row.measured.variance:.4g} DN²",
                        basis="tolerance",
                        standard_error=100 * se.variance[k] / pred.variance
                        if pred.variance > 0
                        else np.nan,
                    )
                )
        if agree.snr_db is not None:
            below = [
                f"{r.illumination}: {r.comparison}"
                for r in comparison_rows
                if max(r.predicted.snr_db, r.measured.snr_db) < agree.snr_floor_db
            ]
            if below:
                skipped.append(
                    f"SNR_dB agreement of {', '.join(below)}: predicted and measured below "
                    f"agreement.snr_floor_db ({agree.snr_floor_db:g} dB)"
                )
            index = {
                (ill, c.label): j
                for ill, m in measurements.items()
                for j, c in enumerate(m.comparisons)
            }
            for row in comparison_rows:
                if max(row.predicted.snr_db, row.measured.snr_db) < agree.snr_floor_db:
                    continue  # both unseparable: the dB values carry no agreement to check
                j = index[row.illumination, row.comparison]
                checks.append(
                    at_most(
                        f"{row.illumination}: {row.comparison} SNR_dB deviation",
                        "agreement",
                        abs(row.snr_db_difference),
                        agree.snr_db,
                        "dB",
                        f"predicted {row.predicted.snr_db:.2f} dB, "
                        f"measured {row.measured.snr_db:.2f} dB",
                        basis="tolerance",
                        standard_error=errors[row.illumination].snr_db[j],
                    )
                )
    if acc.ranking:
        if ranking is None:
            checks.append(
                not_run(
                    "ranking: measured best is predicted best",
                    "ranking",
                    0.0,
                    "",
                    "≤",
                    "one illumination measured, nothing to rank (leave out acceptance.ranking)",
                )
            )
        else:
            labels = [c.label for c in next(iter(measurements.values())).comparisons]
            checks.append(_ranking_check(ranking, errors, labels.index(ranking.comparison)))
    if acc.gain_relative is not None:
        if gain is None:
            checks.append(
                not_run(
                    "system gain K deviation from the camera's",
                    "gain",
                    100 * acc.gain_relative,
                    "%",
                    "≤",
                    gain_missing or "no photon-transfer estimate of K",
                )
            )
        else:
            # K from ≥ 3 points has the residuals' standard error (points − 1 degrees of
            # freedom); from fewer, the propagated sampling error (known).
            points = len(gain.points)
            checks.append(
                at_most(
                    "system gain K deviation from the camera's",
                    "gain",
                    100 * abs(gain.relative_deviation),
                    100 * acc.gain_relative,
                    "%",
                    f"K = {gain.value:.4g} ± {gain.standard_error:.2g} DN/e⁻, "
                    f"declared {gain.declared:.4g}",
                    basis="tolerance",
                    standard_error=100 * gain.standard_error / gain.declared,
                    df=points - 1 if points >= 3 else np.inf,
                )
            )
    return checks, skipped
