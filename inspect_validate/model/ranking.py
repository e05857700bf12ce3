"""Ranking hardware combinations by predicted class separation.

The key is one comparison's measure (e.g. ``"A vs B,C"``, the chapter's
objective in §4.2) or, by default, the worst pair: the largest ε of all class
pairs, or the smallest SNR_dB/CNR_dB — a station is only as good as its
hardest pair.

Clipping at saturation shrinks a class's variance and so flatters every
separation measure; a combination in which any class has more than
:data:`SATURATION_LIMIT` of its pixels saturated therefore ranks after every
combination that does not, whatever its key. Skipped combinations
(:attr:`~inspect_validate.model.Prediction.valid`) are not ranked.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Protocol

import numpy as np

from inspect_validate.comparisons import Comparisons, RankBy, find_comparison
from inspect_validate.model.acquisition import Prediction
from inspect_validate.stats import as_sample, lscv_bandwidth
from inspect_validate.stats.kde_error import mixture_error
from inspect_validate.stats.mixture import Mixture

__all__ = ["comparison_index", "predicted_kde_error", "rank", "rank_keys", "ranked"]

_MIN_SAMPLES_FOR_LSCV = 5
SATURATION_LIMIT = 1e-3
"""Fraction of a class's pixels at saturation above which a combination counts as saturated."""


def comparison_index(prediction: Prediction, label: str) -> int:
    """Index of a comparison given as ``"A vs B"`` or ``"A vs B,C"``."""
    return find_comparison(prediction.comparisons, label)


def rank_keys(
    prediction: Prediction, *, by: RankBy = "error", comparison: str | None = None
) -> tuple[tuple[np.ndarray, ...], np.ndarray, np.ndarray, np.ndarray]:
    """Each combination's sort keys, flat in ``[light, optics, camera]`` order.

    Returns
    -------
    keys : tuple of ndarray, shape (N,) each
        For :func:`numpy.lexsort`, least significant first: the tiebreak (log ε
        of the key comparison), the key (ε, or −dB: smaller is better) and
        ``saturated``. Sorting them stably ranks best first.
    key : ndarray, shape (N,)
        The ranking value (ε, or dB).
    column : ndarray of int, shape (N,)
        The key comparison: the named one, or that row's worst pair.
    saturated : ndarray of bool, shape (N,)
        Some class has more than :data:`SATURATION_LIMIT` of its pixels saturated.
    """
    values = {
        "error": prediction.error_gaussian,
        "snr_db": prediction.snr_db,
        "cnr_db": prediction.cnr_db,
    }[by]
    flat_values = values.reshape(-1, values.shape[-1])
    flat_log = prediction.log_error_gaussian.reshape(flat_values.shape)
    if comparison is not None:
        column = np.full(flat_values.shape[0], comparison_index(prediction, comparison))
    else:
        pairs = np.array(prediction.comparison_set.pairs)
        # The worst pair: largest ε (ties, e.g. ε underflowing to 0, by log ε), or lowest dB.
        sub = flat_log[:, pairs] if by == "error" else -flat_values[:, pairs]
        column = pairs[np.argmax(np.nan_to_num(sub, nan=-np.inf), axis=1)]
    rows = np.arange(flat_values.shape[0])
    key = flat_values[rows, column]
    tiebreak = flat_log[rows, column]
    saturated = (prediction.saturated_fraction.max(axis=-1) > SATURATION_LIMIT).ravel()
    keys = (tiebreak, key if by == "error" else -key, saturated)
    return keys, key, column, saturated


def ranked(keys: Sequence[np.ndarray], valid: np.ndarray) -> np.ndarray:
    """Flat indices of the ``valid`` combinations, best first, from :func:`rank_keys`'s
    ``keys`` (a stable sort: ties keep the order of the combinations)."""
    idx = np.flatnonzero(np.ravel(valid))
    return idx[np.lexsort(tuple(k[idx] for k in keys))]


def rank(
    prediction: Prediction, *, by: RankBy = "error", comparison: str | None = None
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Combinations best first: unsaturated before saturated, then by the key.

    Returns
    -------
    order : ndarray of int, shape (N, 3)
        (light, optics, camera) indices of the N predicted (not skipped)
        combinations, best first.
    key : ndarray, shape (N,)
        The ranking value of each row (ε, or dB).
    column : ndarray of int, shape (N,)
        Each row's key comparison: the named one, or that row's worst pair.
    saturated : ndarray of bool, shape (N,)
        Some class of the row has more than :data:`SATURATION_LIMIT` saturated.
    """
    keys, key, column, saturated = rank_keys(prediction, by=by, comparison=comparison)
    order = ranked(keys, prediction.valid)
    combos = np.stack(np.unravel_index(order, prediction.valid.shape), axis=1)
    return combos, key[order], column[order], saturated[order]


class SampleValues(Protocol):
    """What :func:`predicted_kde_error` reads: a :class:`Prediction`'s or a ranking's
    per-sample grey values and its comparisons."""

    @property
    def sample_mean(self) -> np.ndarray | None: ...
    @property
    def sample_variance(self) -> np.ndarray | None: ...
    @property
    def sample_class(self) -> np.ndarray: ...
    @property
    def comparison_set(self) -> Comparisons: ...


def predicted_kde_error(
    prediction: SampleValues, index: tuple[int, int, int] | int, column: int
) -> float:
    """Nonparametric ε (37) of one combination and comparison.

    ``prediction`` is a :class:`~inspect_validate.model.Prediction` (``index``
    a (light, optics, camera) tuple) or a :class:`~inspect_validate.model.Ranking`
    (``index`` a row).

    Each class's density is a mixture over its reflectance samples: a Gaussian
    at each sample's predicted grey value with the camera's temporal noise,
    widened by the LSCV bandwidth of the sample values (with ≥ 5 samples) —
    no assumption that a class is Gaussian.
    """
    if prediction.sample_mean is None or prediction.sample_variance is None:
        raise ValueError("the prediction holds no per-sample grey values (predict them first)")
    means = prediction.sample_mean[index]
    noise = prediction.sample_variance[index]
    class_weights = prediction.comparison_set.class_weights()
    parts = []
    for members in prediction.comparison_set.groups[column]:
        share = class_weights[list(members)] / class_weights[list(members)].sum()
        centres, weights, sigmas = [], [], []
        for k, pi in zip(members, share, strict=True):
            sel = prediction.sample_class == k
            m = means[sel]
            h2 = 0.0
            if m.size >= _MIN_SAMPLES_FOR_LSCV and np.ptp(m) > 0:
                h2 = lscv_bandwidth(as_sample(m), method="exact").h ** 2
            centres.append(m)
            weights.append(np.full(m.size, pi / m.size))
            sigmas.append(np.sqrt(noise[sel] + h2))
        parts.append(
            Mixture(np.concatenate(centres), np.concatenate(weights), np.concatenate(sigmas))
        )
    return mixture_error(*parts)
