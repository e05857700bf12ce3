"""Standard errors of what a verification compares: a measurement's class statistics and
separations, from its pixels and frames, and a prediction's, from its spectral samples.

**Measured.** A class of n pixels over F frames with temporal variance σ²_t and spatial
variance σ²_s (EMVA 1288 components, :class:`~inspect_validate.stats.RegionStatistics`).
Repeated captures of the same parts differ by the temporal noise only, so

    SE(μ)  = √(σ²_t / (n F))
    SE(σ²) = √(2 σ²_t (σ²_t + 2 σ²_s) / (n F))

the second from σ² = σ²_s + (1/nF) Σ e² + (2/nF) Σ a e for fixed pixel values a and
Gaussian temporal noise e. A single frame cannot tell σ²_t from σ²_s: all of σ² is
taken as noise (what a capture of re-placed parts would vary by), the larger error.

**Predicted.** A class's μ and spectral variance come from its S reflectance samples:
SE(μ) = √(σ²_spectral / S) and SE(σ²) = σ²_spectral √(2 / (S − 1)) (normal theory).
Another draw of the parts than the spectra measured differs from the prediction by
about these.

**Separations.** SNR_dB (36), CNR_dB and log₁₀ ε (37) are functions of the classes' μ
and σ²; their standard errors follow by the delta method, each class's μ and σ² moved
by ± one standard error (a central difference: the secant over the interval the value
is uncertain by, where the function is not smooth), the classes independent.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike

if TYPE_CHECKING:
    from collections.abc import Iterable

    from inspect_validate.comparisons import Comparisons
    from inspect_validate.measurement import ClassMeasurement, Measurement
    from inspect_validate.station.prediction import StationPrediction

__all__ = [
    "StandardErrors",
    "class_standard_errors",
    "combined_standard_errors",
    "measured_standard_errors",
    "predicted_standard_errors",
    "separation_standard_errors",
]


@dataclass(frozen=True)
class StandardErrors:
    """Standard errors of one illumination's class statistics and separations.

    Attributes
    ----------
    mean, variance : ndarray, (K,)
        Per class, DN and DN².
    snr_db, cnr_db, log_error : ndarray, (P,)
        Per comparison: dB, dB and decades of ε Gauss.
    """

    mean: np.ndarray
    variance: np.ndarray
    snr_db: np.ndarray
    cnr_db: np.ndarray
    log_error: np.ndarray


def class_standard_errors(c: ClassMeasurement) -> tuple[float, float]:
    """SE(μ) in DN and SE(σ²) in DN² of a :class:`~inspect_validate.measurement.
    ClassMeasurement` from its pixels and frames (module description)."""
    values = c.n_pixels * c.n_frames
    temporal = c.temporal_variance
    if temporal is None or c.n_frames < 2 or not math.isfinite(temporal):
        temporal = c.variance
    temporal = max(float(temporal), 0.0)
    spatial = max(float(c.variance) - temporal, 0.0)
    return (
        math.sqrt(temporal / values),
        math.sqrt(2.0 * temporal * (temporal + 2.0 * spatial) / values),
    )


def separation_standard_errors(
    means: ArrayLike,
    variances: ArrayLike,
    se_means: np.ndarray,
    se_variances: np.ndarray,
    comparisons: Comparisons,
    *,
    pixels: ArrayLike | None = None,
    mixtures: Iterable[int] | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """SE of every comparison's SNR_dB, CNR_dB (dB) and log₁₀ ε Gauss (decades), by
    central differences over ± one standard error of each class's μ and σ².

    Parameters
    ----------
    means, variances, se_means, se_variances : array_like, (K,)
        The classes' μ (DN), σ² (DN²) and their standard errors.
    comparisons : Comparisons
    pixels : array_like, keyword-only, optional
        Per-class pixel counts (``pixels`` weighting).
    mixtures : iterable of int, keyword-only, optional
        The comparisons between groups whose log ε error to compute (a root search per
        class moved: most of the cost); every one by default, the others' NaN. Pairs
        always have theirs (a closed form).

    Returns
    -------
    snr_db, cnr_db, log_error : ndarray, (P,)
        NaN where a value is undefined.
    """
    from inspect_validate.separations import gaussian_separation

    means = np.asarray(means, float)
    variances = np.asarray(variances, float)
    k = means.size
    rows_m = np.repeat(means[None, :], 4 * k, axis=0)
    rows_v = np.repeat(variances[None, :], 4 * k, axis=0)
    # σ² may not reach 0: a step the variance cannot take is shortened, and the
    # difference scaled back up to one standard error.
    step_v = np.minimum(np.asarray(se_variances, float), 0.5 * variances)
    scale_v = np.divide(np.asarray(se_variances, float), step_v, out=np.zeros(k), where=step_v > 0)
    for i in range(k):
        rows_m[4 * i, i] += se_means[i]
        rows_m[4 * i + 1, i] -= se_means[i]
        rows_v[4 * i + 2, i] += step_v[i]
        rows_v[4 * i + 3, i] -= step_v[i]
    with np.errstate(all="ignore"):
        g = gaussian_separation(rows_m, rows_v, comparisons, pixels=pixels, mixtures=mixtures)
        out = []
        for values in (g.snr_db, g.cnr_db, g.log_error_gaussian):
            v = values.reshape(k, 4, -1)
            d_mean = (v[:, 0] - v[:, 1]) / 2.0
            d_var = (v[:, 2] - v[:, 3]) / 2.0 * scale_v[:, None]
            out.append(np.sqrt((d_mean**2).sum(axis=0) + (d_var**2).sum(axis=0)))
    return tuple(out)


def measured_standard_errors(
    measurement: Measurement, comparisons: Comparisons, *, mixtures: Iterable[int] | None = None
) -> StandardErrors:
    """:class:`StandardErrors` of a :class:`~inspect_validate.measurement.Measurement`
    from its pixels and frames; ``comparisons`` are the ones it was measured with,
    ``mixtures`` as in :func:`separation_standard_errors`."""
    classes = measurement.classes
    se = np.array([class_standard_errors(c) for c in classes]).reshape(-1, 2)
    snr, cnr, log_error = separation_standard_errors(
        [c.mean for c in classes],
        [c.variance for c in classes],
        se[:, 0],
        se[:, 1],
        comparisons,
        pixels=[c.n_pixels for c in classes],
        mixtures=mixtures,
    )
    return StandardErrors(se[:, 0], se[:, 1], snr, cnr, log_error)


def predicted_standard_errors(
    prediction: StationPrediction,
    light: int,
    comparisons: Comparisons,
    *,
    mixtures: Iterable[int] | None = None,
) -> StandardErrors:
    """:class:`StandardErrors` of a station prediction's classes under its illumination of
    row ``light``, from each class's reflectance samples; ``mixtures`` as in
    :func:`separation_standard_errors`."""
    counts = np.bincount(prediction.sample_class, minlength=len(prediction.classes))
    spectral = np.maximum(prediction.spectral_variance[light], 0.0)
    with np.errstate(divide="ignore", invalid="ignore"):
        se_mean = np.sqrt(spectral / counts)
        se_var = np.where(counts > 1, spectral * np.sqrt(2.0 / (counts - 1)), np.nan)
    snr, cnr, log_error = separation_standard_errors(
        prediction.mean[light],
        prediction.variance[light],
        se_mean,
        se_var,
        comparisons,
        mixtures=mixtures,
    )
    return StandardErrors(se_mean, se_var, snr, cnr, log_error)


def combined_standard_errors(a: StandardErrors, b: StandardErrors) -> StandardErrors:
    """The standard errors of a difference of two independent estimates: each field's
    √(a² + b²) (a measurement against a prediction of other parts); a NaN in ``b``
    (nothing known of it) counts as 0."""

    def both(x: np.ndarray, y: np.ndarray) -> np.ndarray:
        return np.hypot(x, np.where(np.isfinite(y), y, 0.0))

    return StandardErrors(
        both(a.mean, b.mean),
        both(a.variance, b.variance),
        both(a.snr_db, b.snr_db),
        both(a.cnr_db, b.cnr_db),
        both(a.log_error, b.log_error),
    )
