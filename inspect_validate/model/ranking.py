"""Ranking hardware combinations by predicted class separation.

The key is one comparison's measure (e.g. ``"A vs B,C"``, the chapter's
objective in §4.2) or, by default, the worst pair: the largest ε of all class
pairs, or the smallest SNR_dB/CNR_dB — a station is only as good as its
hardest pair.
"""

from __future__ import annotations

import numpy as np

from inspect_validate.errors import InputError
from inspect_validate.model.acquisition import Prediction
from inspect_validate.stats import as_sample, lscv_bandwidth
from inspect_validate.stats.kde_error import mixture_error

__all__ = ["comparison_index", "predicted_kde_error", "rank"]

_MIN_SAMPLES_FOR_LSCV = 5


def comparison_index(prediction: Prediction, label: str) -> int:
    """Index of a comparison given as ``"A vs B"`` or ``"A vs B,C"``."""
    for i, (a, b) in enumerate(prediction.comparisons):
        if label.replace(" ", "") == f"{','.join(a)}vs{','.join(b)}".replace(" ", ""):
            return i
    known = ", ".join(f"{','.join(a)} vs {','.join(b)}" for a, b in prediction.comparisons)
    raise InputError(f"no comparison {label!r}; the scene has: {known}")


def rank(prediction: Prediction, *, by: str = "error", comparison: str | None = None):
    """Combinations best first.

    Returns
    -------
    order : ndarray of int, shape (L·O·C, 3)
        (light, optics, camera) indices, best first.
    key : ndarray
        The ranking value of each row (ε, or dB).
    column : int or None
        The comparison index used, or None for the worst pair.
    """
    values = {
        "error": prediction.error_gaussian,
        "snr_db": prediction.snr_db,
        "cnr_db": prediction.cnr_db,
    }[by]
    pairs = [i for i, (a, b) in enumerate(prediction.comparisons) if len(a) == 1 and len(b) == 1]
    if comparison is not None:
        column = comparison_index(prediction, comparison)
        key = values[..., column]
    else:
        column = None
        key = values[..., pairs].max(axis=-1) if by == "error" else values[..., pairs].min(axis=-1)
    flat = key.ravel()
    # Ties (e.g. ε underflowing to 0) are broken by the log-error, smaller first.
    tiebreak = (
        prediction.log_error_gaussian[..., column if column is not None else pairs]
        .reshape(flat.size, -1)
        .max(axis=-1)
    )
    order = np.lexsort((tiebreak, flat if by == "error" else -flat))
    return np.stack(np.unravel_index(order, key.shape), axis=1), flat[order], column


def predicted_kde_error(prediction: Prediction, index, column: int) -> float:
    """Nonparametric ε (37) of one combination and comparison.

    Each class's density is a mixture over its reflectance samples: a Gaussian
    at each sample's predicted grey value with the camera's temporal noise,
    widened by the LSCV bandwidth of the sample values (with ≥ 5 samples) —
    no assumption that a class is Gaussian.
    """
    first, second = prediction.comparisons[column]
    names = list(prediction.classes)
    li, oi, ci = index
    means = prediction.sample_mean[li, oi, ci]
    noise = prediction.sample_variance[li, oi, ci]
    parts = []
    for group in (first, second):
        members = [names.index(n) for n in group]
        centres, weights, sigmas = [], [], []
        for k in members:
            sel = prediction.sample_class == k
            m = means[sel]
            h2 = 0.0
            if m.size >= _MIN_SAMPLES_FOR_LSCV and np.ptp(m) > 0:
                h2 = lscv_bandwidth(as_sample(m), method="exact").h ** 2
            centres.append(m)
            weights.append(np.full(m.size, 1.0 / (m.size * len(members))))
            sigmas.append(np.sqrt(noise[sel] + h2))
        parts += [np.concatenate(centres), np.concatenate(weights), np.concatenate(sigmas)]
    return mixture_error(*parts)
