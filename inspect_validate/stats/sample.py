"""Grey-value samples of one class and their exact mean (38) and variance (39).

Integer grey values are kept as a histogram on an integer lattice
(:class:`LatticeSample`) rather than as a pixel array: a 20-megapixel region
becomes at most 65,536 counts, the moments are exact rational numbers, and the
kernel density estimate works on the same lattice (see
:mod:`inspect_validate.stats.bandwidth`). Floating-point grey values stay a
plain ``float64`` array.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass
from fractions import Fraction

import numpy as np
from numpy.typing import ArrayLike

from inspect_validate.errors import InputError

__all__ = [
    "EmpiricalCdf",
    "LatticeSample",
    "Moments",
    "Sample",
    "as_sample",
    "empirical_cdf",
    "gaussian_misfit",
    "merge_samples",
    "quantisation_step",
    "sample_moments",
    "weighted_moments",
]


LATTICE_SPAN_MAX = 2**24
"""Widest grey-value span kept as a histogram (128 MiB of counts); wider spans stay values."""


@dataclass(frozen=True, eq=False)
class LatticeSample:
    """Grey values on the lattice ``(origin + i) / denominator`` DN, ``counts[i]`` times each.

    Parameters
    ----------
    counts : ndarray of int64, shape (W,)
        Number of samples at each lattice point. The first and last entries are
        non-zero (the histogram is trimmed).
    origin : int
        Lattice code of ``counts[0]``.
    denominator : int
        Lattice points per DN: 1 for raw integer frames, the number of dark
        frames after dark subtraction (the mean dark is a multiple of
        ``1/denominator`` DN).
    """

    counts: np.ndarray
    origin: int
    denominator: int = 1

    def __post_init__(self):
        counts = np.asarray(self.counts, dtype=np.int64)
        nonzero = np.flatnonzero(counts)
        if nonzero.size == 0:
            raise InputError("a grey-value sample needs at least one value")
        counts = counts[nonzero[0] : nonzero[-1] + 1].copy()
        counts.flags.writeable = False
        object.__setattr__(self, "counts", counts)
        object.__setattr__(self, "origin", int(self.origin) + int(nonzero[0]))
        object.__setattr__(self, "denominator", int(self.denominator))

    @property
    def n(self) -> int:
        """Number of samples."""
        return int(self.counts.sum())

    @property
    def codes(self) -> np.ndarray:
        """Lattice code of every histogram bin, int64."""
        return np.arange(self.origin, self.origin + self.counts.size, dtype=np.int64)

    @property
    def points(self) -> np.ndarray:
        """Grey value of every histogram bin in DN, float64."""
        return self.codes / self.denominator

    def values(self) -> np.ndarray:
        """All samples in DN, expanded from the histogram (for small samples and tests)."""
        return np.repeat(self.points, self.counts)


@dataclass(frozen=True)
class EmpiricalCdf:
    """A sample's distribution function: ``cumulative[i + 1]`` of its ``n`` values are
    at or below ``points[i]`` DN (``cumulative[0]`` is 0); ``step`` is a lattice
    sample's spacing, DN, or a float sample's recovered :func:`~inspect_validate.stats.sample.quantisation_step`
    (None for continuous values). Made once per sample by
    :func:`~inspect_validate.stats.sample.empirical_cdf` (a float sample is sorted), read many times."""

    points: np.ndarray
    cumulative: np.ndarray
    step: float | None = None

    @property
    def n(self) -> int:
        """Number of values."""
        return int(self.cumulative[-1])

    def fraction_between(self, lower: ArrayLike, upper: ArrayLike) -> np.ndarray:
        """Fraction of the values in each interval (lower, upper], DN (±inf allowed;
        the ends broadcast together)."""
        below = [
            self.cumulative[np.searchsorted(self.points, x, side="right")] for x in (lower, upper)
        ]
        return (below[1] - below[0]) / self.n


def empirical_cdf(sample: Sample | EmpiricalCdf) -> EmpiricalCdf:
    """:class:`~inspect_validate.stats.sample.EmpiricalCdf` of a
    :class:`~inspect_validate.stats.LatticeSample` or float sample (an EmpiricalCdf is
    returned as it is)."""
    if isinstance(sample, EmpiricalCdf):
        return sample
    if isinstance(sample, LatticeSample):
        cumulative = np.concatenate([[0], np.cumsum(sample.counts)])
        return EmpiricalCdf(sample.points, cumulative, 1.0 / sample.denominator)
    points = np.sort(np.asarray(sample, dtype=np.float64).ravel())
    return EmpiricalCdf(points, np.arange(points.size + 1), quantisation_step(points))


_MISFIT_GRID = np.linspace(-6.0, 6.0, 241)  # z, in steps of 0.05σ


def gaussian_misfit(sample: Sample | EmpiricalCdf, mean: float, variance: float) -> float:
    """Kolmogorov distance between a sample (or its
    :class:`~inspect_validate.stats.sample.EmpiricalCdf`) and its
    Gaussian N(μ, σ²): the largest difference of their cumulative distributions over
    μ ± 6σ, on a 0.05σ grid.

    A quantised sample (a :class:`LatticeSample`, or float values on a lattice:
    :func:`~inspect_validate.stats.sample.quantisation_step`) is compared with its Gaussian quantised alike: P(X ≤ x) against Φ((x + q/2 − μ)/σ) at lattice points x, q the
    lattice step. For a Gaussian sample of n values, on average 0.87/√n (the mean of
    Kolmogorov's distribution) or less; NaN for σ = 0.
    """
    from inspect_validate.stats.gaussian_error import upper_tail

    if not variance > 0:
        return math.nan
    sd = math.sqrt(variance)
    cdf = empirical_cdf(sample)
    x, z = mean + sd * _MISFIT_GRID, _MISFIT_GRID
    if cdf.step is not None:
        # Half-way to the next lattice point: P(X ≤ x) is the same, and a float
        # sample's points (k/255 in float32) are not exactly where k·step puts them.
        origin = cdf.points[0]
        x = origin + (np.floor((x - origin) / cdf.step) + 0.5) * cdf.step
        z = (x - mean) / sd
    model = upper_tail(-z, np.zeros_like(z))[0]  # Φ(z) = Q(−z)
    return float(np.max(np.abs(cdf.fraction_between(-np.inf, x) - model)))


@dataclass(frozen=True)
class Moments:
    """Sample size, mean μ (38) in DN and unbiased variance σ² (39) in DN²."""

    n: int
    mean: float
    variance: float


Sample = LatticeSample | ArrayLike
"""Grey values, DN: a :class:`LatticeSample` (a histogram on integer codes) or an array."""


def as_sample(values: ArrayLike, *, denominator: int = 1) -> LatticeSample | np.ndarray:
    """Turn grey values into a sample: a :class:`LatticeSample` for integers, else float64.

    Parameters
    ----------
    values : array_like
        Grey values in DN (any shape; flattened). Integer dtypes, and floats that
        are all whole numbers, go on the integer lattice.
    denominator : int, keyword-only
        For integer input: the values are lattice codes in units of
        ``1/denominator`` DN.

    Returns
    -------
    LatticeSample or ndarray
    """
    x = np.asarray(values).ravel()
    if x.size == 0:
        raise InputError("a grey-value sample needs at least one value")
    if x.dtype.kind == "f":
        if not np.all(np.isfinite(x)):
            raise InputError("grey values contain NaN or infinity")
        if np.all(x == np.round(x)) and np.abs(x).max() < 2**52:
            x = x.astype(np.int64)
        else:
            return x.astype(np.float64, copy=False)
    if x.dtype.kind not in "iub":
        raise InputError(f"grey values must be numbers, got dtype {x.dtype}")
    x = x.astype(np.int64, copy=False)
    lo, hi = int(x.min()), int(x.max())
    if hi - lo > max(LATTICE_SPAN_MAX, 4 * x.size):
        # A histogram would be allocated by span, not by count: keep the values
        # (exact in float64 below 2⁵³) and let the statistics sort rather than bin.
        if max(abs(lo), abs(hi)) >= 2**53:
            raise InputError(
                f"grey values span {lo}..{hi}: beyond ±2⁵³ they cannot be held exactly; "
                "these are not a camera's grey values"
            )
        return x.astype(np.float64) / denominator
    return LatticeSample(np.bincount(x - lo), lo, denominator)


def merge_samples(samples: Iterable[Sample]) -> LatticeSample | np.ndarray:
    """Pool several samples into one (the union of their values), e.g. for "A vs B,C"."""
    samples = list(samples)
    lattices = [s for s in samples if isinstance(s, LatticeSample)]
    if len(lattices) == len(samples):
        den = lattices[0].denominator
        if all(s.denominator == den for s in lattices):
            lo = min(s.origin for s in lattices)
            hi = max(s.origin + s.counts.size for s in lattices)
            counts = np.zeros(hi - lo, dtype=np.int64)
            for s in lattices:
                counts[s.origin - lo : s.origin - lo + s.counts.size] += s.counts
            return LatticeSample(counts, lo, den)
    return np.concatenate([_float_values(s) for s in samples])


def _float_values(sample) -> np.ndarray:
    return sample.values() if isinstance(sample, LatticeSample) else np.asarray(sample, float)


def _exact_weighted_power_sum(counts: np.ndarray, k: np.ndarray, power: int) -> int:
    """Σ counts·k**power over int64 arrays as an exact Python int (no silent overflow)."""
    bound = float(counts.max(initial=0)) * float(np.abs(k).max(initial=0)) ** power * counts.size
    if bound < 2.0**62:
        return int(np.sum(counts * k**power))
    return sum(c * q**power for c, q in zip(counts.tolist(), k.tolist(), strict=True))


def lattice_power_sums(sample: LatticeSample) -> tuple[int, int, int]:
    """Exact (n, Σk, Σk²) of the codes k of a lattice sample.

    The sums are taken over codes relative to the first bin, which keeps the
    int64 products small, and shifted back with exact integer arithmetic.
    """
    rel = np.arange(sample.counts.size, dtype=np.int64)
    n = int(sample.counts.sum())
    r1 = _exact_weighted_power_sum(sample.counts, rel, 1)
    r2 = _exact_weighted_power_sum(sample.counts, rel, 2)
    o = sample.origin
    return n, r1 + n * o, r2 + 2 * o * r1 + n * o * o


def sample_moments(sample: Sample) -> Moments:
    """Mean μ (38) and unbiased variance σ² (39) of a grey-value sample.

    Parameters
    ----------
    sample : LatticeSample or array_like
        Grey values in DN.

    Returns
    -------
    Moments
        For a :class:`~inspect_validate.stats.LatticeSample` both moments are the exact rational values
        rounded once to float64 (no float accumulation, no E[x²]−E[x]²
        cancellation). For float data: compensated two-pass in float64.

    Raises
    ------
    InputError
        With fewer than two values: the unbiased variance (39) is undefined.
    """
    if not isinstance(sample, LatticeSample):
        sample = as_sample(sample)
    return converted_moments(sample)


def converted_moments(sample: LatticeSample | np.ndarray) -> Moments:
    """:func:`sample_moments` of a sample already made by :func:`as_sample`."""
    if isinstance(sample, LatticeSample):
        n, s1, s2 = lattice_power_sums(sample)
        if n < 2:
            raise InputError(f"a class needs at least 2 pixels for its variance (39), has {n}")
        d = sample.denominator
        exact_mean = Fraction(s1, n * d)
        exact_variance = Fraction(n * s2 - s1 * s1, n * (n - 1) * d * d)
        return Moments(n, float(exact_mean), float(exact_variance))
    x = sample
    n = x.size
    if n < 2:
        raise InputError(f"a class needs at least 2 pixels for its variance (39), has {n}")
    top = float(np.max(np.abs(x)))
    k = 0
    if not 1e-150 < top < 1e150 and top > 0:
        # Sums of values near 1e308 overflow and squares of 1e-200 underflow: computed
        # on the values scaled by a power of two (exact) that brings the largest near 1.
        k = int(np.frexp(top)[1])
        x = np.ldexp(x, -k)
    mean = float(np.mean(x))
    dev = x - mean
    # The second term removes the rounding error left in `mean` (Chan, Golub & LeVeque).
    variance = (float(np.dot(dev, dev)) - float(dev.sum()) ** 2 / n) / (n - 1)
    mean += float(dev.sum()) / n
    if k:
        with np.errstate(over="ignore", under="ignore"):  # beyond doubles: inf or 0, said
            mean, variance = float(np.ldexp(mean, k)), float(np.ldexp(variance, 2 * k))
    return Moments(n, mean, max(variance, 0.0))


def weighted_moments(
    values: ArrayLike, weights: ArrayLike, *, whole: Moments | None = None
) -> Moments:
    """Mean μ (38) and variance σ² (39) of grey values that count by a weight each: the
    share of a pixel's area inside a region whose edge cuts it
    (:func:`~inspect_validate.roi.pose.moved_masks`).

    μ = Σ wᵢxᵢ / V₁ and σ² = Σ wᵢ(xᵢ − μ)² / (V₁ − V₂/V₁), V₁ = Σ wᵢ, V₂ = Σ wᵢ²: the
    variance unbiased for independent values of one distribution whatever the weights
    (reliability weights), and with weights of 0 and 1 the plain (38) and (39).

    Parameters
    ----------
    values : array_like
        Grey values, DN.
    weights : array_like
        Each value's weight, ≥ 0, the same shape.
    whole : Moments, keyword-only, optional
        The moments of further values of weight 1 each, already known: a region's
        interior, exact from its histogram (:func:`sample_moments`), so that only the
        few pixels its edge cuts are summed here.

    Returns
    -------
    Moments
        ``n`` is V₁ rounded: the region's area, px.

    Raises
    ------
    InputError
        Weights whose V₁ − V₂/V₁ is not above 0 (fewer than two values weighted).
    """
    w = np.asarray(weights, dtype=np.float64).ravel()
    x = np.asarray(values, dtype=np.float64).ravel()
    keep = w > 0
    w, x = w[keep], x[keep]
    n, centre, spread = (0, 0.0, 0.0) if whole is None else (
        whole.n, whole.mean, (whole.n - 1) * whole.variance
    )  # fmt: skip
    v1 = n + float(w.sum())
    denominator = v1 - (n + float(np.dot(w, w))) / v1 if v1 > 0 else 0.0
    if not denominator > 0:
        raise InputError("a class needs at least 2 pixels for its variance (39), has fewer")
    mean = (n * centre + float(np.dot(w, x))) / v1
    dev = x - mean
    # The second term removes the rounding error left in `mean`, as for plain samples.
    mean += (n * (centre - mean) + float(np.dot(w, dev))) / v1
    dev = x - mean
    squares = spread + n * (centre - mean) ** 2 + float(np.dot(w, dev * dev))
    return Moments(round(v1), mean, squares / denominator)


def quantisation_step(sample: Sample) -> float | None:
    """The grey-value resolution of a sample, DN: the step all its values are multiples of.

    A lattice sample's step is the greatest common divisor of its occupied codes'
    distances (1 DN for raw integer frames, 16 DN for 12-bit data stored in the
    upper bits of 16, 1/n after subtracting the mean of n dark frames). For float
    values (e.g. 12-bit frames scaled to 0..1) the step is recovered when every
    distance is a small rational multiple (denominator ≤ 64) of the smallest one,
    to 1e-6 of the step; otherwise the data are continuous and the result is None.
    Values that are all single-precision numbers (a frame stored as float32) are
    allowed their rounding, 2⁻²⁴ of their size, where that is below 1 % of the step:
    ``k / 255`` in float32 is on the 1/255 lattice, as the uint8 frame it came from.
    A sample with a single distinct value has no step (None).
    """
    from fractions import Fraction
    from math import lcm

    if isinstance(sample, LatticeSample):
        offsets = np.flatnonzero(sample.counts)
        if offsets.size < 2:
            return None
        return int(np.gcd.reduce(offsets[1:])) / sample.denominator
    u = np.unique(np.asarray(sample, dtype=np.float64))
    if u.size < 2:
        return None
    gaps = np.diff(u)
    smallest = float(gaps.min())
    ratios = (u[1:] - u[0]) / smallest
    if not np.all(np.isfinite(ratios)) or ratios.max() > 2**40:
        return None
    denominators = {Fraction(float(r)).limit_denominator(64).denominator for r in ratios[:4096]}
    step = smallest / lcm(*denominators)
    # Finer than the smallest double (values near 1e-300), or so fine that float64 holds
    # no 1e-6 of a step across the span (the common multiple of many denominators of
    # continuous values): continuous.
    if not step > 0 or (u[-1] - u[0]) / step > 2**32:
        return None
    k = np.round((u - u[0]) / step)
    if np.all(np.abs((u - u[0]) / step - k) <= 1e-6):
        return step
    # Each float32 value is its lattice point to within half its unit in the last place,
    # 2⁻²⁴|u|: the smallest gap carries that error, the span does not (relatively).
    rounding = 2.0**-23 * np.maximum(np.abs(u), abs(u[0]))
    if not np.all(u.astype(np.float32) == u) or rounding.max() > 0.01 * step:
        return None
    step = float(u[-1] - u[0]) / float(k[-1])
    if np.all(np.abs((u - u[0]) - k * step) <= rounding + 1e-6 * step):
        return step
    return None
