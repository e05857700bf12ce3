"""Numerical stress: properties of the public functions over extreme and degenerate input.

No NaN and no silent infinity escapes; every degenerate case has a defined value
(or a clear InputError); invariances hold exactly where the transformation is
exact in floating point (integer offsets, powers of two, permutations).
"""

import importlib
import math
import warnings

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from inspect_validate.components import builtin_sensor, ideal_lens, led
from inspect_validate.components.lights import planck
from inspect_validate.errors import InputError
from inspect_validate.model import ObjectClass, predict
from inspect_validate.spectra import Spectrum
from inspect_validate.stats import (
    as_sample,
    cnr_db,
    fisher_db,
    gaussian_error_and_log,
    lscv_bandwidth,
    region_statistics,
    sample_moments,
    snr_db,
)
from inspect_validate.stats.kde_error import mixture_error
from inspect_validate.stats.mixture import Mixture

implementation = importlib.import_module("inspect_validate.stats.gaussian_error")
STEFAN_BOLTZMANN = 5.670374419e-8  # W·m⁻²·K⁻⁴ (CODATA 2018, exact from h, c, k)

variances = st.one_of(st.just(0.0), st.floats(1e-12, 1e12), st.integers(1, 2**20).map(float))
means = st.one_of(st.floats(-1e6, 1e6), st.integers(-(2**20), 2**20).map(float))
pairs = st.lists(st.tuples(means, variances, means, variances), min_size=1, max_size=40)


def no_warnings():
    """Turn numpy's RuntimeWarnings (an overflow, an invalid value) into failures."""
    ctx = warnings.catch_warnings()
    ctx.__enter__()
    warnings.simplefilter("error", RuntimeWarning)
    return ctx


def both_implementations(m1, v1, m2, v2):
    """ε and log ε from the numpy path and the compiled kernel, which must agree."""
    out = []
    saved = implementation.COMPILED_MIN, implementation.LOAD_MIN
    try:
        for threshold in (2**62, 0):
            implementation.COMPILED_MIN = implementation.LOAD_MIN = threshold
            out.append(gaussian_error_and_log(m1, v1, m2, v2))
    finally:
        implementation.COMPILED_MIN, implementation.LOAD_MIN = saved
    (e1, l1), (e2, l2) = out
    normal = e1 > 1e-300
    np.testing.assert_allclose(e2[normal], e1[normal], rtol=2e-14, atol=0)
    np.testing.assert_array_equal(e1[~normal] == 0, e2[~normal] == 0)
    np.testing.assert_allclose(l2, l1, rtol=2e-15, atol=0)
    return e1, l1


@settings(max_examples=150, deadline=None)
@given(pairs)
# Means 4e-98 apart at equal variances: the parts summed to ½ + 1 ulp (found by hypothesis).
@example([(0.0, 1.0, 4.214554807959968e-98, 1.0)])
def test_gaussian_error_is_a_probability_symmetric_and_its_log_consistent(cases):
    m1, v1, m2, v2 = (np.array(c, float) for c in zip(*cases, strict=True))
    ctx = no_warnings()
    try:
        eps, log_eps = both_implementations(m1, v1, m2, v2)
        swapped, log_swapped = gaussian_error_and_log(m2, v2, m1, v1)
    finally:
        ctx.__exit__(None, None, None)
    assert not np.isnan(eps).any() and not np.isnan(log_eps).any()
    assert ((eps >= 0) & (eps <= 0.5)).all()
    assert (log_eps <= math.log(0.5) + 1e-15).all()
    assert np.array_equal(eps, swapped) and np.array_equal(log_eps, log_swapped)
    normal = eps >= 1e-300
    np.testing.assert_allclose(np.log(eps[normal]), log_eps[normal], rtol=1e-13, atol=1e-13)
    identical = (m1 == m2) & (v1 == v2)
    assert (eps[identical] == 0.5).all()
    constant = ((v1 == 0) | (v2 == 0)) & ~identical
    assert (eps[constant] == 0.0).all() and (log_eps[constant] == -np.inf).all()
    # Every non-degenerate pair has a finite log ε, however small ε (ε down to
    # 1e-300 and below is carried by the log).
    assert np.isfinite(log_eps[~constant]).all()


@settings(max_examples=100, deadline=None)
@given(
    st.lists(
        st.tuples(
            st.integers(-(2**30), 2**30),
            st.integers(0, 2**20),
            st.integers(-(2**30), 2**30),
            st.integers(0, 2**20),
        ),
        min_size=1,
        max_size=20,
    ),
    st.integers(-(2**40), 2**40),
    st.integers(-60, 60),
)
def test_separation_is_invariant_under_a_common_offset_and_a_power_of_two_scale(cases, offset, k):
    """Integer means moved by an integer offset, or means × 2^k and variances × 4^k, are
    exact in floating point: SNR_dB moves by exactly −20·log10(2^k) under the scale
    (its variance denominator is not a standard deviation), CNR, Fisher and ε not at all."""
    m1, v1, m2, v2 = (np.array(c, float) for c in zip(*cases, strict=True))
    base = [f(m1, v1, m2, v2) for f in (snr_db, cnr_db, fisher_db)]
    eps = gaussian_error_and_log(m1, v1, m2, v2)
    shifted = [f(m1 + offset, v1, m2 + offset, v2) for f in (snr_db, cnr_db, fisher_db)]
    for a, b in zip(base, shifted, strict=True):
        np.testing.assert_array_equal(a, b)
    for a, b in zip(eps, gaussian_error_and_log(m1 + offset, v1, m2 + offset, v2), strict=True):
        np.testing.assert_array_equal(a, b)
    s, s2 = 2.0**k, 4.0**k
    scaled = [f(m1 * s, v1 * s2, m2 * s, v2 * s2) for f in (snr_db, cnr_db, fisher_db)]
    np.testing.assert_allclose(scaled[0], base[0] - 20 * k * math.log10(2), rtol=0, atol=1e-9)
    np.testing.assert_allclose(scaled[1], base[1], rtol=0, atol=1e-12)
    np.testing.assert_allclose(scaled[2], base[2], rtol=0, atol=1e-12)
    e_scaled, _ = gaussian_error_and_log(m1 * s, v1 * s2, m2 * s, v2 * s2)
    np.testing.assert_allclose(e_scaled, eps[0], rtol=1e-13, atol=0)
    for value in (*base, *scaled):
        assert not np.isnan(value).any()  # Δμ = 0 is −inf dB, σ = 0 is +inf: defined


@settings(max_examples=60, deadline=None)
@given(
    st.lists(st.floats(-50, 50), min_size=1, max_size=6),
    st.lists(st.floats(-50, 50), min_size=1, max_size=6),
    st.lists(st.floats(0.05, 20), min_size=6, max_size=6),
    st.randoms(use_true_random=False),
)
def test_union_error_does_not_depend_on_the_order_of_components_or_sides(c1, c2, s, rnd):
    w1, w2 = np.full(len(c1), 1 / len(c1)), np.full(len(c2), 1 / len(c2))
    s1, s2 = np.array(s[: len(c1)]), np.array(s[: len(c2)])[::-1]
    eps = mixture_error(Mixture(c1, w1, s1), Mixture(c2, w2, s2))
    order1, order2 = list(range(len(c1))), list(range(len(c2)))
    rnd.shuffle(order1)
    rnd.shuffle(order2)
    shuffled = mixture_error(
        Mixture(np.array(c1)[order1], w1[order1], s1[order1]),
        Mixture(np.array(c2)[order2], w2[order2], s2[order2]),
    )
    swapped = mixture_error(Mixture(c2, w2, s2), Mixture(c1, w1, s1))
    assert 0 <= eps <= 0.5
    assert shuffled == pytest.approx(eps, rel=1e-12, abs=1e-300)
    assert swapped == pytest.approx(eps, rel=1e-12, abs=1e-300)


@pytest.mark.parametrize("temperature", [1.0, 300.0, 2856.0, 6504.0, 50_000.0])
def test_planck_over_1_nm_to_20_um(temperature):
    """Finite and non-negative from 1 nm to 20 µm (underflowing to 0, never NaN); the
    peak where Wien's law puts it; where the band holds nearly all the power, the
    integral is Stefan–Boltzmann's σT⁴/π (radiance)."""
    lam = np.geomspace(1.0, 20_000.0, 200_001)
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        u = planck(lam, temperature)
    assert np.isfinite(u).all() and (u >= 0).all()
    wien = 2.897771955e6 / temperature  # nm
    if 1.0 < wien < 20_000.0:
        assert lam[np.argmax(u)] == pytest.approx(wien, rel=1e-4)
    if 800 <= temperature <= 30_000:
        power = np.trapezoid(u, lam)  # W·sr⁻¹·m⁻²
        assert power == pytest.approx(STEFAN_BOLTZMANN * temperature**4 / np.pi, rel=2e-3)
    with pytest.raises(ValueError, match="positive"):
        planck(0.0, temperature)


@pytest.mark.parametrize(("bits", "dtype"), [(8, np.uint8), (12, np.uint16), (16, np.uint16)])
def test_frames_at_full_saturation_and_constant_regions(bits, dtype):
    top = 2**bits - 1
    frames = np.full((3, 40, 50), top, dtype=dtype)
    mask = np.zeros((40, 50), bool)
    mask[5:30, 10:40] = True
    r = region_statistics(frames, mask, saturation_level=top)
    m = sample_moments(r.sample)
    assert (m.mean, m.variance) == (top, 0.0)
    assert r.saturated_fraction == 1.0 and r.temporal_variance == 0.0
    assert r.spatial_variance == 0.0
    # The same region one below saturation: constant, nothing saturated.
    r = region_statistics(frames - 1, mask, saturation_level=top)
    assert sample_moments(r.sample).variance == 0.0 and r.saturated_fraction == 0.0


def test_float32_frames_give_the_statistics_of_their_values():
    rng = np.random.default_rng(3)
    frames = rng.normal(1000.0, 3.0, (4, 60, 70)).astype(np.float32)
    mask = np.ones((60, 70), bool)
    m = sample_moments(region_statistics(frames, mask).sample)
    values = frames.astype(np.float64).ravel()
    assert m.mean == pytest.approx(values.mean(), rel=1e-15)
    assert m.variance == pytest.approx(values.var(ddof=1), rel=1e-12)


def test_n_equals_2_and_n_equals_10_million():
    m = sample_moments(as_sample(np.array([3, 7], np.uint16)))
    assert (m.mean, m.variance) == (5.0, 8.0)
    rng = np.random.default_rng(4)
    big = rng.integers(0, 65536, 10_000_000, dtype=np.uint16)
    m = sample_moments(as_sample(big))
    n = big.size
    s1 = int(big.sum(dtype=np.uint64))
    s2 = int((big.astype(np.uint64) ** 2).sum())
    assert m.mean == s1 / n  # exact sums, one rounding
    assert m.variance == pytest.approx((n * s2 - s1 * s1) / (n * (n - 1)), rel=1e-15)


@pytest.mark.parametrize(
    "values",
    [
        [5, 5],  # n = 2, tied
        [4, 9],  # n = 2, distinct
        [7] * 1000,  # one value
        [0, 1] * 500,  # two values
        list(range(3)) * 4000,  # heavily tied integers
    ],
)
def test_lscv_on_tied_integer_data_is_a_defined_bandwidth(values):
    sample = as_sample(np.array(values, np.uint16))
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        bw = lscv_bandwidth(sample, quantum=1.0)
    assert np.isfinite(bw.h) and bw.h >= 1.0
    assert bw.at_floor or bw.h > 1.0


def flat(name, levels, lo=380.0, hi=780.0):
    g = np.arange(lo, hi + 1.0, 5.0)
    return ObjectClass(
        name,
        Spectrum(g, [np.full(g.size, v) for v in levels], "reflectance", name, f"{name}.csv"),
    )


@pytest.mark.parametrize(
    ("a", "b"),
    [([0.0], [1.0]), ([0.0, 0.0], [0.0, 0.0]), ([1.0], [1.0]), ([0.0, 1e-300], [1.0, 1.0])],
)
def test_predict_with_reflectance_0_and_1_and_one_sample_classes(a, b):
    """Black against white, black against black, one sample per class: every value
    defined (an identical pair is ε = ½, not NaN), or a clear refusal."""
    light, lens, cam = led(550, 30), ideal_lens(), builtin_sensor("cmos-visible")
    grid = np.arange(380.0, 781.0, 1.0)
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("error", RuntimeWarning)
            p = predict([light], [lens], [cam], [flat("A", a), flat("B", b)], grid=grid)
    except InputError as exc:
        assert "no class reflects anything" in str(exc)
        return
    for field in ("mean", "variance", "snr_db", "error_gaussian", "log_error_gaussian"):
        assert not np.isnan(getattr(p, field)).any(), field
    assert (p.spectral_variance == 0.0).all()  # samples equal (or 1e-300 apart)
    if a == b:
        assert (p.error_gaussian == 0.5).all()
