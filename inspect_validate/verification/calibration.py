"""Calibration of a station: its system gain K and the absolute scale of each illumination.

Photon transfer (EMVA 1288, §6.3): for every region and illumination, the
temporal variance of the grey value above the dark one grows with the mean
signal above dark as

    σ²_y − σ²_y.dark = K (μ_y − μ_y.dark),

K the system gain in DN/e⁻. The slope is fitted through the origin over every
class and illumination with a stack of at least two frames and no clipping.

Irradiance scale: a station's lights are rarely radiometrically calibrated, so
the prediction's signal μ − offset is tied to the measured μ − μ_dark by one
factor per illumination — fitted by least squares over all its classes
(``fit``), taken from one class of known reflectance (``reference``), or 1
(``absolute``). The factor times the illumination's stated irradiance is the
irradiance at the object the measurement implies.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from inspect_validate.errors import InputError

if TYPE_CHECKING:
    from collections.abc import Sequence

    from inspect_validate.measurement import ClassMeasurement, Measurement
    from inspect_validate.station.prediction import StationPrediction

__all__ = [
    "NO_LIGHT_REMEDY",
    "Gain",
    "IrradianceScale",
    "LightLevel",
    "fit_scales",
    "light_levels",
    "photon_transfer",
    "photon_transfer_gain",
]

MIN_SIGNAL_DN = 1.0  # a point needs at least this much signal above dark to count

#: What to check when an illumination's light does not reach the camera (verify's light
#: check, train's refusal, a calibration scale of no light).
NO_LIGHT_REMEDY = (
    "check the controller's channel wiring and the station's channels:, the strobe, the "
    "lens cap, the exposure"
)


@dataclass(frozen=True)
class LightLevel:
    """How far an illumination's frames rise above the dark ones, in the class where they
    rise most against their noise: μ and σ (all its pixels over the frames) lit and dark,
    DN. The light reaches the camera when the rise exceeds σ (:attr:`reaches`)."""

    illumination: str
    class_name: str
    lit: float
    lit_noise: float
    dark: float
    dark_noise: float

    @property
    def signal(self) -> float:
        """μ lit − μ dark, DN."""
        return self.lit - self.dark

    @property
    def noise(self) -> float:
        """The larger σ of the two, DN: a rise within it is no light a pixel shows."""
        return max(self.lit_noise, self.dark_noise)

    @property
    def reaches(self) -> bool:
        """The light shows above the dark level beyond a pixel's noise. A camera that
        returns the same picture whatever the lights do (a test pattern, a lens cap, a
        controller wired to other channels) does not; a station whose brightest class
        rises less than one σ could not tell its classes apart anyway."""
        return bool(self.signal > self.noise)

    @property
    def text(self) -> str:
        """``lit 143.2 ± 0.4 DN, dark 143.1 ± 0.4 DN in class 'A'``."""
        return (
            f"lit {self.lit:.1f} ± {self.lit_noise:.2g} DN, dark {self.dark:.1f} ± "
            f"{self.dark_noise:.2g} DN in class {self.class_name!r}"
        )


def light_levels(
    measurements: dict[str, Measurement], dark: Measurement | None, *, offset: float | None
) -> dict[str, LightLevel]:
    """Each illumination's :class:`LightLevel`.

    Parameters
    ----------
    measurements : dict of str to Measurement
        Illumination → its measurement, raw grey values.
    dark : Measurement or None
        The dark stack in the same regions; without it the dark level is ``offset``
        with no noise of its own.
    offset : float or None, keyword-only
        The camera's dark offset, DN; None with no dark stack: nothing is returned
        (there is no level to rise above).
    """
    if dark is None and offset is None:
        return {}
    dark_by = {c.name: c for c in dark.classes} if dark is not None else {}
    out = {}
    for name, m in measurements.items():
        levels = []
        for c in m.classes:
            d = dark_by.get(c.name)
            level = LightLevel(
                name,
                c.name,
                c.mean,
                float(np.sqrt(c.variance)),
                d.mean if d is not None else float(offset or 0.0),
                float(np.sqrt(d.variance)) if d is not None else 0.0,
            )
            levels.append(level)
        if levels:
            out[name] = max(levels, key=lambda v: v.signal / max(v.noise, 1e-300))
    return out


@dataclass(frozen=True)
class Gain:
    """System gain K from photon transfer, DN/e⁻, with its standard error and the points used."""

    value: float
    standard_error: float
    declared: float
    points: tuple[tuple[float, float], ...]  # (μ − μ_dark, σ²_temporal − σ²_dark), DN and DN²

    @property
    def relative_deviation(self) -> float:
        """(K_measured − K_declared) / K_declared."""
        return (self.value - self.declared) / self.declared


def photon_transfer_gain(
    measurements: Sequence[Measurement],
    dark: Measurement,
    *,
    declared: float,
    max_saturated: float = 1e-3,
    saturation_level: float | None = None,
) -> Gain | None:
    """K from the temporal variance against the mean over classes and illuminations.

    Parameters
    ----------
    measurements : sequence of Measurement
        One per illumination, stacks of ≥ 2 frames, raw grey values (no dark subtracted).
    dark : Measurement
        The dark stack measured in the same regions.
    declared : float
        The camera's K (DN/e⁻), for comparison.
    max_saturated : float, keyword-only
        Classes with more clipped pixels than this fraction are left out.
    saturation_level : float, keyword-only, optional
        The grey value of a saturated pixel (2^bits − 1 of the camera's pixel format),
        DN. Points above 70 % of it are left out, as EMVA 1288 (release 4.0, §6.3) fits
        the photon transfer there; so are points beyond the temporal variance's
        maximum, where the noise is already clipped.

    Returns
    -------
    Gain or None
        None when no usable point exists: :func:`photon_transfer` says why.
    """
    return photon_transfer(
        measurements,
        dark,
        declared=declared,
        max_saturated=max_saturated,
        saturation_level=saturation_level,
    )[0]


def _sampling_variance(c: ClassMeasurement) -> float:
    """The sampling variance of a temporal variance averaged over P pixels of N frames,
    2σ⁴ / (P (N − 1)) (the candidates of a fit all have one)."""
    variance = c.temporal_variance or 0.0
    return 2 * variance**2 / (c.n_pixels * (c.n_frames - 1))


def photon_transfer(
    measurements: Sequence[Measurement],
    dark: Measurement,
    *,
    declared: float,
    max_saturated: float = 1e-3,
    saturation_level: float | None = None,
) -> tuple[Gain | None, dict[str, int]]:
    """:func:`photon_transfer_gain`, and the points left out by reason (class and
    illumination pairs), which say why K could not be estimated when it is None."""
    dark_by = {c.name: c for c in dark.classes}
    left_out: dict[str, int] = {}

    def leave(reason) -> None:
        left_out[reason] = left_out.get(reason, 0) + 1

    candidates = []
    for m in measurements:
        for c in m.classes:
            d = dark_by.get(c.name)
            if d is None:
                leave("no dark frames for the region")
            elif c.temporal_variance is None or d.temporal_variance is None:
                leave("a single frame (no temporal variance)")
            elif c.saturated_fraction > max_saturated or c.zero_fraction > max_saturated:
                leave("clipped pixels in the region")
            elif d.zero_fraction > max_saturated:
                # Darks clipped at 0 (no black-level offset) understate σ²_dark and
                # overstate μ_dark: K would come out biased (+2 % at 1.3 DN dark noise).
                leave("dark frames clipped at 0 (the camera needs a black-level offset)")
            elif c.mean - d.mean < MIN_SIGNAL_DN:
                leave(f"signal below {MIN_SIGNAL_DN:g} DN above dark")
            elif saturation_level is not None and c.mean - d.mean > 0.7 * (
                saturation_level - d.mean
            ):
                leave("above 70 % of saturation")
            else:
                candidates.append(
                    (c.mean - d.mean, c.temporal_variance - d.temporal_variance, c, d)
                )
    # Beyond the variance's maximum the brightest pixels clip and the variance falls:
    # a brighter point whose variance lies significantly (3 sampling errors) below
    # the largest one's is left out, as emva1288 ends its fit at the maximum.
    candidates.sort(key=lambda p: p[0])
    points, peak, peak_se = [], -np.inf, 0.0
    for point in candidates:
        variance, c = point[1], point[2]
        se = np.sqrt(_sampling_variance(c))
        if variance < peak - 3 * np.hypot(se, peak_se):
            leave("beyond the temporal variance's maximum")
            continue
        if variance > peak:
            peak, peak_se = variance, se
        points.append(point)
    if not points:
        return None, left_out
    x = np.array([p[0] for p in points])
    y = np.array([p[1] for p in points])
    k = float(x @ y / (x @ x))
    if len(points) >= 3:
        resid = y - k * x
        se = float(np.sqrt(resid @ resid / (len(points) - 1) / (x @ x)))
    else:
        # The sampling errors of the two temporal variances, propagated to the slope.
        var_y = np.array([_sampling_variance(c) + _sampling_variance(d) for _, _, c, d in points])
        se = float(np.sqrt((x**2) @ var_y) / (x @ x))
    gain = Gain(
        k, se, float(declared), tuple((float(a), float(b)) for a, b in zip(x, y, strict=True))
    )
    return gain, left_out


@dataclass(frozen=True)
class IrradianceScale:
    """The factor tying one illumination's prediction to its measurement.

    ``residuals`` are (measured − scaled predicted) / scaled predicted signal
    per class used (``fit``), empty otherwise.
    """

    illumination: str
    method: str
    scale: float
    standard_error: float
    irradiance: float  # W/m² at the object implied by the measurement
    classes: tuple[str, ...]
    residuals: tuple[float, ...]


def fit_scales(
    prediction: StationPrediction,
    measurements: dict,
    *,
    method: str,
    offset: float,
    dark_means: dict | None,
    irradiance: dict,
    gain: float,
    reference: str | None = None,
    max_saturated: float = 1e-3,
) -> dict[str, IrradianceScale]:
    """One :class:`IrradianceScale` per illumination.

    Parameters
    ----------
    prediction : StationPrediction
        Of the station at its stated irradiances.
    measurements : dict of str to Measurement
        Illumination name → its measurement (raw grey values).
    method : {"fit", "reference", "absolute"}
    offset : float
        The camera model's dark offset, DN (the prediction's zero-signal level).
    dark_means : dict of str to float, optional
        Class → measured dark mean, DN (default: ``offset`` for every class).
    irradiance : dict of str to float
        Illumination → its stated irradiance, W/m².
    gain : float
        The model camera's system gain K, DN/e⁻: the predicted signal is K·μ_e,
        linear in the irradiance before any clipping, so a prediction that
        saturates at a stated irradiance ten times too high still calibrates.
    reference : str, optional
        The class of known reflectance (method ``reference``).
    """
    out: dict[str, IrradianceScale] = {}
    classes = list(prediction.classes)
    for name, m in measurements.items():
        by = {c.name: c for c in m.classes}
        predicted = gain * prediction.electrons[prediction.index(name)]
        measured = np.array(
            [by[c].mean - (dark_means or {}).get(c, offset) for c in classes], dtype=float
        )
        usable = np.array(
            [
                by[c].saturated_fraction <= max_saturated
                and by[c].zero_fraction <= max_saturated
                and predicted[k] > 0
                for k, c in enumerate(classes)
            ]
        )
        if method == "absolute":
            s, se = 1.0, 0.0
            used: tuple[str, ...] = ()
            resid: tuple[float, ...] = ()
        elif method == "reference":
            if reference not in classes:
                raise InputError(
                    f"calibration.reference: no class {reference!r} in the ROIs and scene "
                    f"(there are {', '.join(classes)})"
                )
            k = classes.index(reference)
            if not usable[k]:
                raise InputError(
                    f"illumination {name!r}: the reference class {reference!r} is clipped or "
                    "dark, so it cannot calibrate; lower the exposure or the light"
                )
            c = by[reference]
            s = measured[k] / predicted[k]
            se = abs(s) * np.sqrt(c.variance / (c.n_pixels * c.n_frames)) / abs(measured[k])
            used, resid = (str(reference),), ()
        else:
            if not usable.any():
                raise InputError(
                    f"illumination {name!r}: every class is clipped or dark, so no scale can be "
                    "fitted; lower the exposure or the light"
                )
            a, b = predicted[usable], measured[usable]
            s = float(a @ b / (a @ a))
            r = b - s * a
            se = float(np.sqrt(r @ r / max(a.size - 1, 1) / (a @ a))) if a.size > 1 else 0.0
            used = tuple(c for c, u in zip(classes, usable, strict=True) if u)
            resid = tuple(float(x) for x in r / (s * a)) if s > 0 else ()
        if not (np.isfinite(s) and s > 0):
            # The model cannot hold a light of no, negative or infinite power.
            raise InputError(
                f"illumination {name!r}: its {method} irradiance scale is {s:.3g}: the "
                f"measured signal above dark ({', '.join(f'{x:.3g}' for x in measured)} DN) "
                f"says no light of it reaches the camera; {NO_LIGHT_REMEDY}"
            )
        out[name] = IrradianceScale(
            name, method, float(s), float(se), float(s * irradiance[name]), used, resid
        )
    return out
