"""Exact moments (38)-(39): compared with fractions.Fraction arithmetic, tolerance 0 (equality)."""

from fractions import Fraction

import numpy as np
import pytest

from inspect_validate.errors import InputError
from inspect_validate.stats import (
    LatticeSample,
    as_sample,
    merge_samples,
    sample_moments,
    weighted_moments,
)


def fraction_moments(values, denominator=1):
    xs = [Fraction(int(v), denominator) for v in values]
    n = len(xs)
    mean = sum(xs) / n
    return float(mean), float(sum((x - mean) ** 2 for x in xs) / (n - 1))


@pytest.mark.parametrize("dtype", [np.uint8, np.uint16, np.int16, np.int32])
def test_integer_moments_are_exact(dtype):
    rng = np.random.default_rng(1)
    hi = min(np.iinfo(dtype).max, 60_000)
    x = rng.integers(max(np.iinfo(dtype).min, -500), hi, 3000).astype(dtype)
    m = sample_moments(as_sample(x))
    assert (m.mean, m.variance) == fraction_moments(x)


def test_high_mean_unit_sigma_is_exact():
    # cv2.meanStdDev is 0.59 DN² off on such a region (issue #2); naive float32 worse.
    rng = np.random.default_rng(2)
    x = np.rint(rng.normal(60_000, 1, 20_000)).astype(np.uint16)
    m = sample_moments(x)
    assert (m.mean, m.variance) == fraction_moments(x)


def test_lattice_with_denominator():
    codes = np.array([7, 9, 9, 12, -3])
    m = sample_moments(as_sample(codes, denominator=4))
    assert (m.mean, m.variance) == fraction_moments(codes, 4)


def test_float_moments_two_pass():
    rng = np.random.default_rng(3)
    x = 1e9 + rng.normal(0, 1e-3, 10_000)
    m = sample_moments(x)
    exact = [Fraction(v) for v in x]
    mean = sum(exact) / len(exact)
    var = sum((v - mean) ** 2 for v in exact) / (len(exact) - 1)
    assert m.mean == pytest.approx(float(mean), rel=1e-15)
    assert m.variance == pytest.approx(float(var), rel=1e-6)


def test_integral_floats_go_on_the_lattice():
    assert isinstance(as_sample(np.array([1.0, 2.0, 2.0])), LatticeSample)
    assert isinstance(as_sample(np.array([1.5, 2.0])), np.ndarray)


@pytest.mark.parametrize("values", [[5], np.array([3.5])])
def test_fewer_than_two_values_is_an_error(values):
    with pytest.raises(InputError, match="at least 2 pixels"):
        sample_moments(values)


def test_nan_is_an_error():
    with pytest.raises(InputError, match="NaN"):
        as_sample(np.array([1.0, np.nan]))


def test_merge_is_the_union():
    a, b = np.array([1, 2, 2, 10]), np.array([0, 2, 30])
    merged = merge_samples([as_sample(a), as_sample(b)])
    assert sorted(merged.values()) == sorted(np.concatenate([a, b]))
    mixed = merge_samples([as_sample(a), as_sample(np.array([0.5, 1.5]))])
    assert sorted(mixed) == sorted([1, 2, 2, 10, 0.5, 1.5])


@pytest.mark.parametrize("scale", [5.5e153, 2.0**1000 / 7, 1e-152])
def test_float_moments_at_the_ends_of_the_doubles(scale):
    """Values near 1e308 overflowed the sum (mean NaN); at 5.5e153 the squares' sum
    overflowed (variance inf) though the variance is 8.7e307: both now match the exact
    rational moments to 1e-15, and a variance beyond the doubles is inf, not NaN."""
    x = np.array([1.1, 2.3, 2.9, 4.7, 0.3]) * scale
    exact = [Fraction(float(v)) for v in x]
    mean = sum(exact) / len(exact)
    variance = sum((v - mean) ** 2 for v in exact) / (len(exact) - 1)
    with np.errstate(all="raise"):
        got = sample_moments(x)
    assert got.mean == pytest.approx(float(mean), rel=1e-15)
    if variance < Fraction(np.finfo(float).max):
        assert got.variance == pytest.approx(float(variance), rel=1e-15)
    else:  # beyond the doubles: said as inf, not NaN
        assert got.variance == np.inf


def test_the_step_of_values_near_the_smallest_doubles_is_none_without_warnings():
    """Grey values of 1e-300 noise (the fuzz corpus's frame): their step underflowed to 0
    and the division leaked RuntimeWarnings to the user; they are continuous."""
    from inspect_validate.stats.sample import quantisation_step

    values = np.random.default_rng(0).standard_normal(3 * 24 * 32) * 1e-300
    with np.errstate(all="raise"):
        step = quantisation_step(values)
    assert step is None or step > 0


@pytest.mark.parametrize("bits", [8, 12, 16])
@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_a_scaled_float_frame_is_on_the_lattice_of_its_integer_frame(bits, dtype):
    """A uint8 frame and the same frame stored as float32 / 255 took different ε KDE
    decisions: the float32 values miss k/255 by their rounding (2⁻²⁴ of their size), so
    no step was found and their Gaussian misfit was that of a staircase. The step is the
    integer frame's, scaled: to 1e-9 from float64; from float32 to 1e-4, as float32
    holds it over a span of 20 codes near 0.5 (1/65535 and 1/65536 are the same there,
    to its 2⁻²⁵). The misfit is the integer frame's to 1e-4."""
    from inspect_validate.stats.sample import as_sample, gaussian_misfit, quantisation_step

    top = 2**bits - 1
    codes = np.clip(np.round(np.random.default_rng(bits).normal(top / 2, 3.0, 20000)), 0, top)
    scaled = (codes / top).astype(dtype)
    rel = 1e-4 if dtype == np.float32 else 1e-9
    assert quantisation_step(scaled) == pytest.approx(1 / top, rel=rel)
    lattice, floats = as_sample(codes.astype(np.uint16)), as_sample(scaled)
    m, mf = sample_moments(lattice), sample_moments(floats)
    assert gaussian_misfit(floats, mf.mean, mf.variance) == pytest.approx(
        gaussian_misfit(lattice, m.mean, m.variance), abs=1e-4
    )


def test_continuous_values_have_no_step():
    """Continuous float64 values found a 'step' of 1e-35 (the common multiple of the
    small denominators of their ratios), finer than float64 resolves across the span;
    float32 continuous values keep their representation's step, far below their spread."""
    from inspect_validate.stats.sample import quantisation_step

    rng = np.random.default_rng(2)
    assert quantisation_step(rng.normal(0.5, 0.01, 1000)) is None
    step = quantisation_step(rng.normal(0.5, 0.01, 100000).astype(np.float32))
    assert step is None or step <= 2.0**-24
    assert quantisation_step(np.arange(10) * 0.1 + 0.3) == pytest.approx(0.1, rel=1e-12)


def test_weights_of_zero_and_one_are_the_plain_moments():
    rng = np.random.default_rng(4)
    x = rng.normal(100, 7, 500)
    keep = rng.random(500) < 0.6
    got, want = weighted_moments(x, keep.astype(float)), sample_moments(x[keep])
    assert got.n == want.n
    assert got.mean == pytest.approx(want.mean, rel=1e-14)
    assert got.variance == pytest.approx(want.variance, rel=1e-12)


def test_the_weighted_variance_is_unbiased_whatever_the_weights():
    """Over 4000 regions of 50 normal values (σ² = 9) with random shares in (0, 1], the
    mean of σ² is 9 within four standard errors; divided by V₁ (the weighted mean square
    about μ), it is 9 · (1 − V₂/V₁²) on average, 2.7 % low here, and out of them."""
    rng = np.random.default_rng(5)
    got, plugin = [], []
    for _ in range(4000):
        x, w = rng.normal(20, 3, 50), rng.uniform(0.01, 1, 50)
        m = weighted_moments(x, w)
        got.append(m.variance)
        plugin.append(m.variance * (w.sum() - (w * w).sum() / w.sum()) / w.sum())
    se = np.std(got) / np.sqrt(len(got))
    assert abs(np.mean(got) - 9.0) < 4 * se < 0.15
    assert 9.0 - np.mean(plugin) > 5 * se


@pytest.mark.parametrize("weights", [[0.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, -1.0, 2.0]])
def test_fewer_than_two_weighted_values_is_an_error(weights):
    with pytest.raises(InputError, match="at least 2 pixels"):
        weighted_moments([1.0, 2.0, 3.0], weights)


def test_known_whole_values_add_to_the_weighted_ones():
    """A region's interior given by its exact moments and its edge by shares is the same
    as every value weighted, to 1e-12, at a mean far from zero (16-bit values near
    60000, σ 3 DN: no cancellation)."""
    rng = np.random.default_rng(6)
    inner = rng.integers(59990, 60010, 5000)
    edge, shares = rng.integers(59990, 60010, 300), rng.uniform(0.01, 0.99, 300)
    got = weighted_moments(edge, shares, whole=sample_moments(inner.astype(np.uint16)))
    want = weighted_moments(np.r_[inner, edge], np.r_[np.ones(inner.size), shares])
    assert got.n == want.n
    assert got.mean == pytest.approx(want.mean, rel=1e-14)
    assert got.variance == pytest.approx(want.variance, rel=1e-12)
