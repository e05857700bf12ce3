"""Comparisons: which groups of classes are told apart, and how a group of several is weighted.

A comparison is a pair of groups of class names, ``(("A",), ("B", "C"))``,
written ``"A vs B,C"``. By default every pair of classes is compared and, with
three or more classes, each class against all the others (the chapter's
Tables 3–4). ``measure``, ``predict``, ``analyze-spectra`` and ``verify`` all
read one :class:`Comparisons`, so a label means the same numbers everywhere.

A group of several classes is a **mixture** of its classes, weighted by

* ``equal`` (default): each class counts the same, whatever its area;
* class **priors** (``{A: 0.7, B: 0.2, C: 0.1}``): how often each class occurs
  on the line, normalised within the group;
* ``pixels``: by the pixel count of each class's region — pooling the pixels,
  as the chapter does for its Table 3 (measurement only: a scene has no pixels).

Its mean and variance are the mixture's (μ = Σ πᵢμᵢ, σ² = Σ πᵢ(σᵢ² + μᵢ²) − μ²),
which SNR_dB (36), CNR and the Fisher ratio use; its classification error is
that of the mixture density itself — of the classes' Gaussians for ε Gauss,
of their kernel density estimates for ε KDE — never of one moment-matched
Gaussian (a bimodal "rest" around a class can be perfectly separable while
its moment-matched Gaussian overlaps the class). Between the two groups of a
comparison ε_tot (37) keeps equal priors, as in the chapter.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from itertools import combinations
from typing import TYPE_CHECKING, Annotated, Literal

import numpy as np
from numpy.typing import ArrayLike
from pydantic import Field

from inspect_validate.config import StrictModel
from inspect_validate.errors import InputError

if TYPE_CHECKING:
    from inspect_validate.stats.sample import EmpiricalCdf, LatticeSample

__all__ = [
    "Comparisons",
    "ComparisonsSpec",
    "CountedSeparation",
    "GaussianSeparation",
    "KdeSeparation",
    "RankBy",
    "counted_separation",
    "default_groups",
    "find_comparison",
    "gaussian_separation",
    "kde_separation",
    "label",
    "mixture_moments",
    "named_groups",
]

Group = tuple[int, ...]
Weighting = Literal["equal", "pixels"]
RankBy = Literal["error", "snr_db", "cnr_db"]
"""What combinations are ranked by: ε Gauss (lowest first), SNR_dB or CNR_dB (highest first)."""


class ComparisonsSpec(StrictModel):
    """The ``comparisons:`` section of a scene or station file."""

    # An empty list would leave nothing to rank or check: name one, or take "default".
    groups: (
        Literal["default", "pairs", "rest"]
        | Annotated[list[Annotated[str, Field(min_length=1)]], Field(min_length=1)]
    ) = "default"
    """``default``: every pair and, with three or more classes, each against the rest;
    ``pairs`` or ``rest`` alone; or a list of comparisons written ``"A vs B,C"``."""
    weights: Weighting | dict[str, Annotated[float, Field(gt=0, allow_inf_nan=False)]] = "equal"
    """How the classes of a group of several are weighted: ``equal``, ``pixels`` (by each
    class's pixel count; measurements only), or each class's prior, ``{A: 0.7, B: 0.3}``
    (normalised within the group)."""


def default_groups(n_classes: int) -> list[tuple[Group, Group]]:
    """Index groups: every pair, then (with three or more classes) each against the rest."""
    return _pairs(n_classes) + _rest(n_classes)


def _pairs(n):
    return [((a,), (b,)) for a, b in combinations(range(n), 2)]


def _rest(n):
    if n < 3:
        return []
    return [((i,), tuple(j for j in range(n) if j != i)) for i in range(n)]


def named_groups(names: Sequence[str]) -> tuple[tuple[tuple[str, ...], tuple[str, ...]], ...]:
    """:func:`default_groups` of ``names``, as groups of names."""
    return tuple(
        (tuple(names[i] for i in a), tuple(names[i] for i in b))
        for a, b in default_groups(len(names))
    )


def label(first: Iterable[str], second: Iterable[str]) -> str:
    """``"A vs B,C"``."""
    return f"{','.join(first)} vs {','.join(second)}"


def _parse(text: str) -> tuple[frozenset, frozenset] | None:
    parts = text.split(" vs ") if " vs " in text else text.split("vs")
    if len(parts) != 2:
        return None
    first, second = (frozenset(n.strip() for n in p.split(",") if n.strip()) for p in parts)
    return (first, second) if first and second else None


def find_comparison(comparisons: Iterable[tuple[Sequence[str], Sequence[str]]], text: str) -> int:
    """Index of the comparison written ``text`` (``"A vs B,C"``; spaces and order
    inside a group do not matter) in a sequence of ``(first, second)`` name groups.

    Raises
    ------
    InputError
        No such comparison; the message lists the ones there are.
    """
    want = _parse(text)
    for i, (a, b) in enumerate(comparisons):
        if (frozenset(a), frozenset(b)) == want:
            return i
    known = ", ".join(label(a, b) for a, b in comparisons)
    raise InputError(f"no comparison {text!r}; there are: {known}")


@dataclass(frozen=True)
class Comparisons:
    """The comparisons of a set of classes and the weighting of groups.

    Attributes
    ----------
    classes : tuple of str
        Class names, in the order of the class axis of every array.
    groups : tuple of (tuple of int, tuple of int)
        Class indices of the two sides of each comparison.
    weights : ``"equal"``, ``"pixels"`` or tuple of float
        Group weighting; a tuple holds one prior per class.
    """

    classes: tuple[str, ...]
    groups: tuple[tuple[Group, Group], ...]
    weights: str | tuple[float, ...] = "equal"

    @classmethod
    def of(
        cls,
        classes: Sequence[str],
        spec: ComparisonsSpec | None = None,
        *,
        source: str | None = None,
    ) -> Comparisons:
        """The comparisons a ``comparisons:`` section asks for (default: every pair and each
        class against the rest, equal weights); unknown class names are errors naming
        ``source``."""
        classes = tuple(classes)
        spec = spec or ComparisonsSpec()
        n = len(classes)
        if spec.groups == "default":
            groups = default_groups(n)
        elif spec.groups == "pairs":
            groups = _pairs(n)
        elif spec.groups == "rest":
            groups = _rest(n) or _pairs(n)
        else:
            groups = []
            for text in spec.groups:
                sides = _parse(text)
                if sides is None:
                    raise InputError(
                        f"comparisons.groups: {text!r} is not 'A vs B' or 'A vs B,C'", source=source
                    )
                unknown = sorted((sides[0] | sides[1]) - set(classes))
                if unknown or sides[0] & sides[1]:
                    why = (
                        f"no class {unknown[0]!r} (there are {', '.join(classes)})"
                        if unknown
                        else "a class is on both sides"
                    )
                    raise InputError(f"comparisons.groups: {text!r}: {why}", source=source)
                one, other = (tuple(i for i in range(n) if classes[i] in s) for s in sides)
                groups.append((one, other))
        weights: str | tuple[float, ...]
        if isinstance(spec.weights, dict):
            priors = spec.weights
            unknown = sorted(set(priors) - set(classes))
            missing = [c for c in classes if c not in priors]
            if unknown or missing:
                what = f"no class {unknown[0]!r}" if unknown else f"no prior for {missing[0]!r}"
                raise InputError(
                    f"comparisons.weights: {what}; give one prior per class ({', '.join(classes)})",
                    source=source,
                )
            weights = tuple(float(priors[c]) for c in classes)
        else:
            weights = spec.weights
        return cls(classes, tuple(groups), weights)

    @property
    def named(self) -> tuple[tuple[tuple[str, ...], tuple[str, ...]], ...]:
        """Each comparison as ``(first names, second names)``."""
        return tuple(
            (tuple(self.classes[i] for i in a), tuple(self.classes[i] for i in b))
            for a, b in self.groups
        )

    @property
    def pairs(self) -> tuple[int, ...]:
        """Positions of the comparisons of one class against one class (ε in closed form);
        the others compare a group, a Gaussian mixture."""
        return tuple(j for j, (a, b) in enumerate(self.groups) if len(a) == len(b) == 1)

    @property
    def labels(self) -> tuple[str, ...]:
        return tuple(label(a, b) for a, b in self.named)

    @property
    def weighting(self) -> str:
        """``"equal"``, ``"pixels"`` or ``"priors"``."""
        return self.weights if isinstance(self.weights, str) else "priors"

    def index(self, text: str) -> int:
        """Position of the comparison written ``text`` (see :func:`find_comparison`)."""
        return find_comparison(self.named, text)

    def subset(self, texts: Iterable[str]) -> Comparisons:
        """Only the comparisons written ``texts`` (each as :meth:`index` reads it), in that order."""
        return Comparisons(
            self.classes, tuple(self.groups[self.index(t)] for t in texts), self.weights
        )

    def with_pixels(self, pixels: ArrayLike) -> Comparisons:
        """These comparisons with ``pixels`` weighting turned into priors from the regions'
        pixel counts, for a prediction of the same regions; others unchanged."""
        if self.weights != "pixels":
            return self
        return Comparisons(self.classes, self.groups, tuple(np.asarray(pixels, float).tolist()))

    def class_weights(self, pixels: ArrayLike | None = None) -> np.ndarray:
        """Unnormalised weight of each class, (K,).

        Parameters
        ----------
        pixels : array_like, optional
            Pixel count of each class's region; needed for ``pixels`` weighting.
        """
        if self.weights == "equal":
            return np.ones(len(self.classes))
        if self.weights == "pixels":
            if pixels is None:
                raise InputError(
                    "comparisons.weights: 'pixels' weights classes by their region's pixel "
                    "count, which only a measurement has; use 'equal' or class priors "
                    "({A: 0.5, B: 0.5}) for a prediction"
                )
            return np.asarray(pixels, dtype=np.float64)
        return np.asarray(self.weights, dtype=np.float64)


def mixture_moments(
    means: ArrayLike, variances: ArrayLike, weights: ArrayLike
) -> tuple[np.ndarray, np.ndarray]:
    """Mean and variance of a mixture along the last axis: Σπμ and Σπ(σ² + μ²) − μ².

    The variance is summed as Σπσ² + Σπ(μ − μ̄)² (no cancellation).

    Parameters
    ----------
    means, variances : ndarray, (..., K)
        Component means (DN) and variances (DN²).
    weights : ndarray, (K,)
        Non-negative; normalised here.
    """
    w = np.asarray(weights, dtype=np.float64)
    w = w / w.sum()
    m = np.asarray(means, dtype=np.float64)
    mean = m @ w
    return mean, np.asarray(variances, dtype=np.float64) @ w + ((m - mean[..., None]) ** 2) @ w


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
    pixels : array_like, keyword-only, optional
        Per-class pixel counts (for ``pixels`` weighting).
    valid : ndarray of bool, (...), keyword-only, optional
        Where to compute the mixture errors (elsewhere they are NaN); all by default.
    mixtures : iterable of int, keyword-only, optional
        The comparisons between groups whose ε to compute: a group's density is
        a Gaussian mixture, its ε a root search per combination (about 1 ms).
        Every one by default; the others' ε are NaN.
    """
    from inspect_validate.stats import cnr_db, fisher_db, gaussian_error_and_log, snr_db
    from inspect_validate.stats.mixture_batch import gaussian_mixture_errors

    means = np.asarray(means, dtype=np.float64)
    variances = np.asarray(variances, dtype=np.float64)
    lead = means.shape[:-1]
    w = comparisons.class_weights(pixels)
    sides = [
        [mixture_moments(means[..., list(g)], variances[..., list(g)], w[list(g)]) for g in pair]
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
    for p in asked:
        g1, g2 = (list(g) for g in comparisons.groups[p])
        share1 = np.broadcast_to(w[g1] / w[g1].sum(), (rows_mean.shape[0], len(g1)))
        share2 = np.broadcast_to(w[g2] / w[g2].sum(), (rows_mean.shape[0], len(g2)))
        e = gaussian_mixture_errors(
            rows_mean[:, g1], share1, rows_sd[:, g1], rows_mean[:, g2], share2, rows_sd[:, g2]
        )
        flat_eps[keep, p] = e
        with np.errstate(divide="ignore"):
            flat_log[keep, p] = np.log(e)
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
    pixels : array_like, keyword-only, optional
        Per-class pixel counts (for ``pixels`` weighting).
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
    pixels : array_like, keyword-only, optional
        Per-class pixel counts (for ``pixels`` weighting).
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
