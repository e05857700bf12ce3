"""A verification's plan: what a station's verification needs before any frame (its
regions, comparisons, model and golden file), checked first, so that a mistake in the
station file costs no capture; and how many checks will share the false-alarm rate."""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING

import numpy as np

from inspect_validate.errors import InputError
from inspect_validate.verification.measured import station_regions

if TYPE_CHECKING:
    from inspect_validate.acceptance import Acceptance
    from inspect_validate.characterization.sharpness_file import SharpnessFile
    from inspect_validate.comparisons import Comparisons
    from inspect_validate.roi import RoiSet
    from inspect_validate.station.file import Station
    from inspect_validate.station.model import StationModel
    from inspect_validate.station.prediction import StationPrediction
    from inspect_validate.verification.golden import Golden

__all__ = [
    "Plan",
    "plan_verification",
    "planned_tests",
    "station_field",
    "station_texture",
    "validate_trained",
]


@dataclass(frozen=True)
class Plan:
    """What a station's verification needs before any frame: its regions, comparisons and
    model, and the golden file. Made first, so that a mistake in the station file costs
    no capture."""

    rois: RoiSet
    comparisons: Comparisons
    model: StationModel
    golden: Golden | None  # for acceptance.drift
    prediction: StationPrediction
    """The station at its stated irradiances, every illumination: the one prediction of
    the spectra before calibration (a group of ``pixels`` weights is weighted equally
    until the regions are measured: :meth:`~StationPrediction.compared`)."""
    sharpness: SharpnessFile | None = None
    """The station's measured MTF (its ``sharpness:`` file), read before any frame."""
    dominated: dict[str, str] = field(default_factory=dict)
    """Illuminations left out of the capture as dominated (:func:`dominated_illuminations`):
    name → why, and how to add it; listed as skipped."""

    def agreed(self, acceptance: Acceptance) -> frozenset[tuple[str, str]]:
        """The (illumination, comparison) pairs whose SNR_dB agreement is checked: those
        the prediction puts above ``agreement.snr_floor_db`` by more than k of its own
        standard errors (k the normal equivalent of the false-alarm rate, 3 at the
        default; :func:`~.uncertainty.predicted_standard_errors`). Below the floor, SNR_dB
        is the log of a near-zero contrast and agrees with nothing; within k standard
        errors above it, parts that are another draw of their classes than the spectra
        measured fall either side of it. Decided from the prediction before any frame, so
        that every verification of the station checks the same set, and ``train`` counts
        it: a comparison near the floor would come and go with the noise of its
        measurement."""
        from inspect_validate.verification.checks import normal_equivalent
        from inspect_validate.verification.uncertainty import predicted_standard_errors

        if acceptance.agreement is None:
            return frozenset()
        floor = acceptance.agreement.snr_floor_db
        k = normal_equivalent(acceptance.false_alarm_rate)
        p = self.prediction
        labels = p.comparison_set.labels
        agreed = set()
        for i, ill in enumerate(p.illuminations):
            if ill in self.dominated:
                continue
            se = predicted_standard_errors(p, i, p.comparison_set, mixtures=()).snr_db
            se = np.where(np.isfinite(se), se, 0.0)  # no samples to tell: the value as it is
            agreed |= {
                (ill, label)
                for j, label in enumerate(labels)
                if p.snr_db[i, j] - k * se[j] >= floor
            }
        return frozenset(agreed)

    def measuring(self, acceptance: Acceptance) -> dict:
        """How the station's frames are measured for its verification: the options of
        :func:`~.measured.measure_capture` and :class:`~.measured.StepMeasurer` (ε KDE only
        where a check of ``acceptance`` asks for it)."""
        return {
            "rois": self.rois,
            "comparisons": self.comparisons,
            "limits": acceptance.limits(),
            "kde": "always" if acceptance.needs_kde else "never",
            "sensor": self.model.sensor,
        }


def validate_trained(station: Station) -> None:
    """Refuse a station (a camera of several's view) whose ``acceptance.drift`` has no
    golden file to hold it to, naming the camera; before any golden file is read."""
    drift = station.acceptance.drift
    if drift is not None and drift.golden is None:
        raise InputError(
            f"acceptance.drift: camera {station.camera.name!r} has no golden file; give it "
            "one (cameras[].golden, made by train --camera)",
            source=str(station.path),
        )


def plan_verification(station: Station, *, drift_checks: bool = True) -> Plan:
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
    from inspect_validate.verification.checks import normal_equivalent
    from inspect_validate.verification.golden import read_golden

    source = str(station.path)
    acc = station.acceptance
    if station.camera.backend == "none":
        raise InputError(
            "a bench verification captures each illumination and predicts it from the "
            "scene, and this station has no camera (a station of the line's frames "
            "alone): verify its parts with --production --frames FOLDER, or describe its "
            "camera, controller and scene",
            source=source,
        )
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
    # Only the ROI classes are predicted.
    scene = replace(model.scene, classes=tuple(scene_classes[n] for n in names))
    model = replace(model, scene=scene)
    unweighted = replace(comparisons, weights="equal") if comparisons.weights == "pixels" else None
    sharpness = None
    if station.sharpness is not None:
        from inspect_validate.characterization.sharpness_file import read_sharpness

        sharpness = read_sharpness(station.resolve(station.sharpness))
    prediction = model.predict(
        station,
        comparisons=unweighted or comparisons,
        field=station_field(station, rois, names),
        corrected=station.field is not None and station.field.corrected,
        texture_share=station_texture(station, sharpness),
    )
    plan = Plan(rois, comparisons, model, None, prediction, sharpness=sharpness)
    if acc.drift:
        from inspect_validate.verification.golden_checks import validate_golden

        validate_trained(station)
        assert acc.drift.golden is not None  # validate_trained refused a camera without
        golden = read_golden(station.resolve(acc.drift.golden))
        validate_golden(
            golden,
            station,
            acc.drift,
            classes=names,
            comparisons=comparisons.labels,
            source=str(station.resolve(acc.drift.golden)),
            share=acc.false_alarm_rate / planned_tests(station, plan, golden)
            if drift_checks
            else None,
            k=normal_equivalent(acc.false_alarm_rate),
        )
        plan = replace(plan, golden=golden)
    return plan


def station_field(station: Station, rois: RoiSet, classes: list[str]) -> np.ndarray | None:
    """Each class region's share of each illumination's light and its spread, (illumination,
    class, 2), from the station's ``field:`` file (None without one).

    Raises
    ------
    InputError
        An unreadable field file, one without an illumination of the station, or one
        measured on frames of another size than the regions are drawn on.
    """
    if station.field is None:
        return None
    from inspect_validate.characterization.field import field_factors
    from inspect_validate.characterization.field_file import read_field
    from inspect_validate.roi.roiset import class_masks

    path = station.resolve(station.field.file)
    read = read_field(path)
    missing = [i.name for i in station.illuminations if i.name not in read.illuminations]
    if missing:
        raise InputError(
            f"no field of illumination {missing[0]!r} (it has {', '.join(read.illuminations)}): "
            "capture the flat target under every illumination (capture --target flat) and "
            "measure it again (characterize --field)",
            source=str(path),
        )
    try:
        masks = class_masks(rois, (read.height, read.width))
        return field_factors(read.fields(), masks, [i.name for i in station.illuminations], classes)
    except InputError as exc:
        raise InputError(str(exc), source=str(path)) from None


def station_texture(station: Station, sharpness: SharpnessFile | None) -> np.ndarray | None:
    """The share of a class's texture each illumination's frames keep through the lens's
    blur, (illumination,): the blur as one Gaussian of the measured MTF50
    (:func:`~inspect_validate.model.mtf.blur_sigma`), the texture independent from pixel
    to pixel as the model's is (:func:`~inspect_validate.model.mtf.texture_share`); 1
    where the sharpness file has no edge of an illumination; None without one."""
    if sharpness is None:
        return None
    from inspect_validate.model.mtf import blur_sigma, texture_share

    out = np.ones(len(station.illuminations))
    for i, ill in enumerate(station.illuminations):
        edge = sharpness.illuminations.get(ill.name)
        sigma = blur_sigma(edge.mtf50) if edge is not None and edge.mtf50 is not None else 0.0
        out[i] = texture_share(sigma) if np.isfinite(sigma) else 1.0
    return out


def planned_tests(
    station: Station, plan: Plan, golden: Golden | None = None, *, drift: bool = False
) -> int:
    """How many checks of ``station``'s acceptance share its false-alarm rate
    (:func:`~.checks.decide`), counted before any frame from ``plan``: every statistical
    and tolerance check it asks for on the regions' classes and the comparisons of the
    illuminations it captures (not those left out as dominated), SNR_dB agreement on the
    comparisons :meth:`Plan.agreed` keeps, drift on what ``golden`` holds at or above the
    drift floor. The same set every verification of the station checks. ``drift``: count
    the drift checks of ``golden`` as the acceptance's default drift block would, where it
    has none (what ``train`` tells of a golden file before the station uses it)."""
    from inspect_validate.acceptance import Drift
    from inspect_validate.verification.checks import normal_equivalent
    from inspect_validate.verification.golden_checks import above_floor

    acc = station.acceptance
    if drift and acc.drift is None:
        acc = acc.model_copy(update={"drift": Drift(golden="-")})
    classes = [c.name for c in plan.rois.classes]
    comparisons = plan.comparisons.labels
    captured = [i.name for i in station.illuminations if i.name not in plan.dominated]
    ills = len(captured)
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
        n += len(plan.agreed(acc)) * (a.snr_db is not None)
    n += bool(acc.ranking and ills > 1) + (acc.gain_relative is not None)
    if acc.drift is not None and golden is not None:
        for name in captured:
            g = golden.illuminations.get(name)
            if g is None:
                continue
            if acc.drift.mean_dn is None:
                n += len(classes)
            if acc.drift.snr_db is None:
                k = normal_equivalent(acc.false_alarm_rate)
                n += sum(
                    above_floor(g.comparisons[c].snr_db, acc.drift.snr_floor_db, k=k)
                    for c in comparisons
                    if c in g.comparisons
                )
    return max(n, 1)
