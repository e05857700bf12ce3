"""The separation of the two groups of each comparison (:mod:`inspect_validate.comparisons`).

A group's mean and variance are the mixture's (μ = Σ πᵢμᵢ, σ² = Σ πᵢ(σᵢ² + μᵢ²) − μ²),
which SNR_dB (36), CNR and the Fisher ratio use; its classification error is
that of the mixture density itself — of the classes' Gaussians for ε Gauss,
of their kernel density estimates for ε KDE — never of one moment-matched
Gaussian (a bimodal "rest" around a class can be perfectly separable while
its moment-matched Gaussian overlaps the class). Between the two groups of a
comparison ε_tot (37) keeps equal priors, as in the chapter. The error is also
counted: the Gaussians' decision rule applied to the measured pixels.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike

from inspect_validate.comparisons import Comparisons

if TYPE_CHECKING:
    from inspect_validate.stats.sample import EmpiricalCdf, LatticeSample

__all__ = [
    "CountedSeparation",
    "GaussianSeparation",
    "KdeSeparation",
    "counted_separation",
    "gaussian_separation",
    "kde_separation",
    "mixture_moments",
]


def mixture_moments(
    means: ArrayLike, variances: ArrayLike, weights: ArrayLike
) -> tuple[np.ndarray, np.ndarray]:
    """Mean and variance of a mixture along the last axis: Σπμ and Σπ(σ² + μ²) − μ².

    The variance is summed as Σπσ² + Σπ(μ − μ̄)² (no cancellation).

    Parameters
    ----------
    means, variances : ndarray, (..., K)
        Component means (DN) and variances (DN²).
    weights : ndarray, (K,) or (..., K)
        Non-negative; normalised here (per row where they have leading axes).
    """
    w = np.asarray(weights, dtype=np.float64)
    w = w / w.sum(axis=-1, keepdims=True)
    m = np.asarray(means, dtype=np.float64)
    mean = (m * w).sum(axis=-1)
    spread = ((m - mean[..., None]) ** 2 * w).sum(axis=-1)
    return mean, (np.asarray(variances, dtype=np.float64) * w).sum(axis=-1) + spread


@dataclass(frozen=True, eq=False)
class GaussianSeparation:
    """Separation of the two sides of each comparison, arrays (..., P).

    ``mean1``…``variance2`` are the two sides' (mixture) moments, DN and DN²;
    ``error_gaussian`` is ε_tot (37) of the sides' Gaussian mixtures.
    """

    mean1: np.ndarray
    variance1: np.ndarray
    mean2: np.ndarray
    variance2: np.ndarray
    snr_db: np.ndarray
    cnr_db: np.ndarray
    fisher_db: np.ndarray
    error_gaussian: np.ndarray
    log_error_gaussian: np.ndarray


def gaussian_separation(
    means: ArrayLike,
    variances: ArrayLike,
    comparisons: Comparisons,
    *,
    pixels: ArrayLike | None = None,
    valid: np.ndarray | None = None,
    mixtures: Iterable[int] | None = None,
) -> GaussianSeparation:
    """SNR_dB (36), CNR, Fisher ratio and ε Gauss (37) of every comparison.

    Parameters
    ----------
    means, variances : ndarray, (..., K)
        Per-class μ (DN) and σ² (DN²); leading axes are combinations.
    comparisons : Comparisons
    pixels : array_like, (K,) or (..., K), keyword-only, optional
        Per-class pixel counts (for ``pixels`` weighting), per combination where they
        differ (a batch of parts, each region moved with its part).
    valid : ndarray of bool, (...), keyword-only, optional
        Where to compute the mixture errors (elsewhere they are NaN); all by default.
    mixtures : iterable of int, keyword-only, optional
        The comparisons between groups whose ε to compute: a group's density is
        a Gaussian mixture, its ε a root search per combination (about 1 ms).
        Every one by default; the others' ε are NaN.
    """
    from inspect_validate.stats import cnr_db, fisher_db, gaussian_error_and_log, snr_db
    from inspect_validate.stats.mixture_batch import gaussian_mixture_errors, stacked_mixtures

    means = np.asarray(means, dtype=np.float64)
    variances = np.asarray(variances, dtype=np.float64)
    lead = means.shape[:-1]
    w = comparisons.class_weights(pixels)
    sides = [
        [
            mixture_moments(means[..., list(g)], variances[..., list(g)], w[..., list(g)])
            for g in pair
        ]
        for pair in comparisons.groups
    ]
    m1, v1, m2, v2 = (
        np.stack([s[i][j] for s in sides], axis=-1) if sides else np.zeros((*lead, 0))
        for i, j in ((0, 0), (0, 1), (1, 0), (1, 1))
    )
    # The closed form is ε of a Gaussian against a Gaussian: pairs of classes only (a
    # group's ε is its mixture's, below; NaN where not asked for or not valid).
    pairs = list(comparisons.pairs)
    eps = np.full(m1.shape, np.nan)
    log_eps = np.full(m1.shape, np.nan)
    if pairs:
        eps[..., pairs], log_eps[..., pairs] = gaussian_error_and_log(
            m1[..., pairs], v1[..., pairs], m2[..., pairs], v2[..., pairs]
        )
    valid = np.ones(lead, bool) if valid is None else np.asarray(valid, bool)
    sd = np.sqrt(variances)
    groups = [j for j in range(len(comparisons.groups)) if j not in pairs]
    asked = groups if mixtures is None else sorted(set(mixtures) & set(groups))
    if asked:
        # Every valid combination at once (a group's density is a small Gaussian
        # mixture), on the combinations flattened to rows.
        keep = np.broadcast_to(valid, lead).reshape(-1)
        k = means.shape[-1]
        rows_mean, rows_sd = means.reshape(-1, k)[keep], sd.reshape(-1, k)[keep]
        n_comparisons = len(comparisons.groups)
        flat_eps, flat_log = eps.reshape(-1, n_comparisons), log_eps.reshape(-1, n_comparisons)
        # And all asked comparisons as rows of one batch, each side padded to the widest
        # with components of weight 0.
        compared: list[list[tuple[np.ndarray, ...]]] = []
        for p in asked:
            pair: list[tuple[np.ndarray, ...]] = []
            for g in map(list, comparisons.groups[p]):
                share = w[..., g] / w[..., g].sum(axis=-1, keepdims=True)
                share = np.broadcast_to(share, (*lead, len(g))).reshape(-1, len(g))[keep]
                pair.append((rows_mean[:, g], share, rows_sd[:, g]))
            compared.append(pair)
        e = gaussian_mixture_errors(
            *stacked_mixtures([pair[0] for pair in compared]),
            *stacked_mixtures([pair[1] for pair in compared]),
        ).reshape(len(asked), -1)
        for p, ep in zip(asked, e, strict=True):
            flat_eps[keep, p] = ep
            with np.errstate(divide="ignore"):
                flat_log[keep, p] = np.log(ep)
    return GaussianSeparation(
        m1,
        v1,
        m2,
        v2,
        np.asarray(snr_db(m1, v1, m2, v2)),
        np.asarray(cnr_db(m1, v1, m2, v2)),
        np.asarray(fisher_db(m1, v1, m2, v2)),
        eps,
        log_eps,
    )


@dataclass(frozen=True)
class CountedSeparation:
    """How well the classes' Gaussians describe each comparison's overlap.

    ``error`` is the counted error of the Gaussians' Bayes rule: the fraction of
    each side's pixels that falls where the other side's Gaussian (mixture) is the
    higher density, ½·(side 1's + side 2's), each side a weighted mixture of its
    classes' fractions. Were the classes Gaussian, it would be ε Gauss up to
    counting noise: ``expected`` (ε Gauss of the same regions, from the Gaussians)
    with ``standard_error`` (binomial, ½·√Σ w² π(1 − π)/n over the classes).
    NaN for a comparison with a constant class (no Gaussian to check).
    """

    error: np.ndarray
    expected: np.ndarray
    standard_error: np.ndarray

    def fits(self, *, relative: float, sigmas: float = 3.0) -> np.ndarray:
        """Where the counted error agrees with the Gaussians' within ``relative`` of it,
        or within ``sigmas`` standard errors (where counts cannot tell more)."""
        gap = np.abs(self.error - self.expected)
        with np.errstate(invalid="ignore"):
            return (gap <= relative * self.expected) | (gap <= sigmas * self.standard_error)


def counted_separation(
    samples: Sequence[LatticeSample | np.ndarray | EmpiricalCdf],
    means: ArrayLike,
    variances: ArrayLike,
    comparisons: Comparisons,
    *,
    pixels: ArrayLike | None = None,
) -> CountedSeparation:
    """:class:`CountedSeparation` of every comparison.

    Parameters
    ----------
    samples : sequence of LatticeSample, ndarray or EmpiricalCdf
        Grey values of each class, DN (or their distribution functions, made once:
        :attr:`RegionStatistics.cdf <inspect_validate.stats.RegionStatistics.cdf>`).
    means, variances : sequence of float
        Per-class μ (38), DN, and σ² (39), DN².
    comparisons : Comparisons
    pixels : array_like, (K,) or (..., K), keyword-only, optional
        Per-class pixel counts (for ``pixels`` weighting), per combination where they
        differ (a batch of parts, each region moved with its part).
    """
    from inspect_validate.stats.kde_error import misclassified_regions
    from inspect_validate.stats.mixture import Mixture
    from inspect_validate.stats.sample import empirical_cdf

    means, sd = np.asarray(means, float), np.sqrt(np.asarray(variances, float))
    cdfs = [empirical_cdf(s) for s in samples]  # once per class: a float sample is sorted
    w = comparisons.class_weights(pixels)
    out = np.full((3, len(comparisons.groups)), np.nan)
    for p, groups in enumerate(comparisons.groups):
        sides = [list(g) for g in groups]
        if any(sd[g].min() == 0 for g in sides):
            continue
        shares = [w[g] / w[g].sum() for g in sides]
        regions = misclassified_regions(
            *(Mixture(means[g], share, sd[g]) for g, share in zip(sides, shares, strict=True))
        )
        counted = expected = variance = 0.0
        for g, share, (ends, masses) in zip(sides, shares, regions, strict=True):
            if not ends:
                continue
            a, b = np.array(ends).T
            for k, wk, mass in zip(g, share, np.minimum(masses, 1.0), strict=True):
                counted += 0.5 * wk * float(cdfs[k].fraction_between(a, b).sum())
                expected += 0.5 * wk * mass
                variance += 0.25 * wk * wk * mass * (1.0 - mass) / cdfs[k].n
        out[:, p] = counted, expected, np.sqrt(variance)
    return CountedSeparation(*out)


@dataclass(frozen=True)
class KdeSeparation:
    """ε KDE (37) of each comparison and the LSCV bandwidth of each class (DN)."""

    error: tuple[float, ...]
    bandwidth: tuple[float, ...]
    at_floor: tuple[bool, ...]


def kde_separation(
    samples: Sequence[LatticeSample | ArrayLike],
    comparisons: Comparisons,
    *,
    pixels: ArrayLike | None = None,
    quantum: float | None = None,
    only: Iterable[int] | None = None,
) -> KdeSeparation:
    """ε KDE (37) of every comparison: each side the weighted mixture of its classes'
    kernel density estimates (41), one LSCV bandwidth (42)–(43) per class.

    Parameters
    ----------
    samples : sequence of LatticeSample or array_like
        Grey values of each class, DN.
    comparisons : Comparisons
    pixels : array_like, (K,) or (..., K), keyword-only, optional
        Per-class pixel counts (for ``pixels`` weighting), per combination where they
        differ (a batch of parts, each region moved with its part).
    quantum : float, keyword-only, optional
        Quantisation step, the bandwidth floor.
    only : iterable of int, keyword-only, optional
        The comparisons to compute (the others' ε is NaN, and a class in none of
        them gets no bandwidth); every one by default.
    """
    from inspect_validate.stats import lscv_bandwidth
    from inspect_validate.stats.kde_error import mixture_errors
    from inspect_validate.stats.mixture import kernel_mixture

    w = comparisons.class_weights(pixels)
    wanted = sorted(set(range(len(comparisons.groups)) if only is None else only))
    used = sorted({k for p in wanted for g in comparisons.groups[p] for k in g})
    bandwidths, kernels = {}, {}
    for k in used:  # one bandwidth per class, shared by every comparison it is in
        bandwidths[k] = lscv_bandwidth(samples[k], quantum=quantum)
        kernels[k] = (*kernel_mixture(samples[k], bandwidths[k].h), bandwidths[k].h)
    errors = np.full(len(comparisons.groups), np.nan)
    errors[wanted] = mixture_errors(
        kernels,
        [[(list(g), w[list(g)] / w[list(g)].sum()) for g in comparisons.groups[p]] for p in wanted],
    )
    return KdeSeparation(
        tuple(errors.tolist()),
        tuple(bandwidths[k].h if k in bandwidths else np.nan for k in range(len(samples))),
        tuple(
            bool(bandwidths[k].at_floor) if k in bandwidths else False for k in range(len(samples))
        ),
    )
