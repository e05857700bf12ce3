"""One definition of a comparison: groups, weights, mixture moments and mixture ε.

References are independent of the code under test: closed-form mixture moments,
and ε_tot (37) of Gaussian mixtures from scipy's normal CDFs between crossings
found with brentq on the analytic densities (relative 1e-9).
"""

import itertools

import numpy as np
import pytest
from scipy import optimize, special, stats

from inspect_validate.comparisons import Comparisons
from inspect_validate.errors import InputError
from inspect_validate.separations import (
    counted_separation,
    gaussian_separation,
    kde_separation,
    mixture_moments,
)
from inspect_validate.stats import as_sample, kde_error, snr_db


def reference_error(m1, s1, w1, m2, s2, w2, lo, hi, *, count=None):
    """½∫min(p1, p2) of two Gaussian mixtures from their CDFs between crossings; with
    ``count`` = (values of each class of side 1, of side 2), instead the fraction of
    those values the mixtures' Bayes rule misclassifies (½ of the sides' weighted
    fractions)."""

    def logpdf(x, m, s, w):
        terms = [
            np.log(wi) + stats.norm.logpdf(x, mi, si) for mi, si, wi in zip(m, s, w, strict=True)
        ]
        return special.logsumexp(np.stack(terms), axis=0)

    def cdf_mass(a, b, m, s, w):
        return sum(
            wi * (stats.norm.sf(a, mi, si) - stats.norm.sf(b, mi, si))
            if a > mi
            else wi * (stats.norm.cdf(b, mi, si) - stats.norm.cdf(a, mi, si))
            for mi, si, wi in zip(m, s, w, strict=True)
        )

    grid = np.linspace(lo, hi, 20001)
    d = logpdf(grid, m1, s1, w1) - logpdf(grid, m2, s2, w2)
    idx = np.flatnonzero(np.sign(d[:-1]) != np.sign(d[1:]))
    roots = [
        optimize.brentq(
            lambda x: logpdf(x, m1, s1, w1) - logpdf(x, m2, s2, w2),
            grid[i],
            grid[i + 1],
            xtol=1e-12,
        )
        for i in idx
    ]
    edges = [-np.inf, *roots, np.inf]
    total = 0.0
    for a, b in itertools.pairwise(edges):
        x = (
            0.5 * (a + b)
            if np.isfinite(a) and np.isfinite(b)
            else (b - 1 if np.isfinite(b) else a + 1)
        )
        first_lower = logpdf(x, m1, s1, w1) < logpdf(x, m2, s2, w2)
        lower = (m1, s1, w1) if first_lower else (m2, s2, w2)
        if count is None:
            total += cdf_mass(a, b, *lower)
        else:
            values, w = (count[0], w1) if first_lower else (count[1], w2)
            total += sum(wi * np.mean((v > a) & (v <= b)) for v, wi in zip(values, w, strict=True))
    return 0.5 * total


def test_weights_change_a_group_as_the_issue_says():
    # A(100, 4) against B(120, 4) on 9,000 pixels and C(140, 4) on 1,000.
    means, variances, pixels = [100.0, 120.0, 140.0], [4.0, 4.0, 4.0], [5000, 9000, 1000]
    pooled = Comparisons.of("ABC", ["A vs B,C"], "pixels")
    equal = Comparisons.of("ABC", ["A vs B,C"])
    g_pix = gaussian_separation(means, variances, pooled, pixels=pixels)
    g_eq = gaussian_separation(means, variances, equal)
    # Closed forms: pixels → μ 122, σ² 4 + 0.9·4 + 0.1·324 = 40; equal → μ 130, σ² 104.
    assert g_pix.mean2[0] == pytest.approx(122.0) and g_pix.variance2[0] == pytest.approx(40.0)
    assert g_eq.mean2[0] == pytest.approx(130.0) and g_eq.variance2[0] == pytest.approx(104.0)
    assert g_pix.snr_db[0] == pytest.approx(float(snr_db(100, 4, 122, 40)), abs=1e-12)
    assert g_pix.snr_db[0] == pytest.approx(-6.0, abs=0.05)
    assert g_eq.snr_db[0] == pytest.approx(-11.1, abs=0.05)


def test_bimodal_rest_is_separable_though_its_moments_overlap():
    # A(100, 1) between B(80, 1) and C(120, 1): the rest's moment-matched
    # Gaussian (μ 100, σ² 401) overlaps A by ~6 %; the mixture does not at all.
    c = Comparisons.of("ABC", ["A vs B,C"])
    g = gaussian_separation([100.0, 80.0, 120.0], [1.0, 1.0, 1.0], c)
    ref = reference_error([100.0], [1.0], [1.0], [80.0, 120.0], [1.0, 1.0], [0.5, 0.5], 60, 140)
    assert 1e-30 < ref < 1e-18
    assert g.error_gaussian[0] == pytest.approx(ref, rel=1e-9)
    assert g.log_error_gaussian[0] == pytest.approx(np.log(ref), rel=1e-9)
    from inspect_validate.stats import gaussian_error

    assert gaussian_error(100, 1, 100, 401) > 0.05  # what one Gaussian would have said


@pytest.mark.parametrize("weights", [(0.5, 0.5), (0.9, 0.1), (0.2, 0.8)])
def test_mixture_error_of_overlapping_groups_matches_reference(weights):
    c = Comparisons.of(
        "ABC",
        ["A vs B,C"],
        {"A": 1.0, "B": weights[0], "C": weights[1]},
    )
    g = gaussian_separation([100.0, 104.0, 96.0], [9.0, 4.0, 25.0], c)
    ref = reference_error([100.0], [3.0], [1.0], [104.0, 96.0], [2.0, 5.0], list(weights), 40, 160)
    assert g.error_gaussian[0] == pytest.approx(ref, rel=1e-9)


def test_mixture_moments_closed_form_and_vectorised():
    m = np.array([[1.0, 3.0], [10.0, 20.0]])
    v = np.array([[1.0, 1.0], [4.0, 9.0]])
    mean, var = mixture_moments(m, v, [1.0, 3.0])
    assert mean.tolist() == pytest.approx([2.5, 17.5])
    assert var.tolist() == pytest.approx([1 + 0.75, 0.25 * 4 + 0.75 * 9 + 0.25 * 0.75 * 100])


def test_mixture_moments_with_weights_per_row_are_each_rows_own():
    m = np.array([[1.0, 3.0], [10.0, 20.0]])
    v = np.array([[1.0, 1.0], [4.0, 9.0]])
    w = np.array([[1.0, 3.0], [2.0, 2.0]])
    mean, var = mixture_moments(m, v, w)
    for row in range(2):
        want = mixture_moments(m[row], v[row], w[row])
        assert (mean[row], var[row]) == pytest.approx(want, rel=1e-15)


def test_a_batch_compared_at_once_is_each_part_compared_alone():
    """compare_many (a batch of parts, one root search for every group's ε) gives each
    row what compare gives it alone, to 1e-9, with pixel weights that differ per part."""
    from inspect_validate.measurement import ClassMeasurement, compare, compare_many

    rng = np.random.default_rng(4)
    comparisons = Comparisons.of("ABC", weights="pixels")
    rows = [
        tuple(
            ClassMeasurement(name, float(mu), float(var), int(n), 1, 0.0, 0.0, None, None, None)
            for name, mu, var, n in zip(
                "ABC",
                rng.uniform(80, 120, 3),
                rng.uniform(4, 40, 3),
                rng.integers(500, 5000, 3),
                strict=True,
            )
        )
        for _ in range(6)
    ]
    for alone, together in zip(
        (compare(row, comparisons, kde="never", counted=False) for row in rows),
        compare_many(rows, comparisons),
        strict=True,
    ):
        assert together.classes == alone.classes
        for a, t in zip(alone.comparisons, together.comparisons, strict=True):
            assert t.label == a.label
            for quantity in ("snr_db", "cnr_db", "fisher_db", "error_gaussian"):
                assert getattr(t, quantity) == pytest.approx(getattr(a, quantity), rel=1e-9)
    assert compare_many([], comparisons) == ()


def test_single_class_groups_reduce_to_the_two_sample_kde_error():
    rng = np.random.default_rng(5)
    a, b = rng.integers(90, 110, 3000), rng.integers(100, 125, 2000)
    c = Comparisons.of("AB")
    k = kde_separation([a, b], c)
    assert k.error[0] == kde_error(a, b).error


def test_group_kde_is_the_weighted_mixture_of_class_densities():
    # Rest = B around 60 and C around 140, A around 100: as separable as the
    # pair errors say, whatever the pooled sample's single bandwidth would do.
    rng = np.random.default_rng(6)
    a = np.rint(rng.normal(100, 3, 4000))
    b = np.rint(rng.normal(60, 3, 4000))
    c_ = np.rint(rng.normal(140, 3, 400))
    comps = Comparisons.of("ABC", ["A vs B,C", "A vs B", "A vs C"])
    k = kde_separation([a, b, c_], comps)
    assert k.error[0] <= 0.5 * (k.error[1] + k.error[2]) + 1e-15
    assert k.error[0] < 1e-12


@pytest.mark.parametrize(
    ("spec", "message"),
    [
        ({"groups": ["A vs D"]}, "no class 'D'"),
        ({"groups": ["A vs A,B"]}, "on both sides"),
        ({"groups": ["A B"]}, "is not 'A vs B'"),
        ({"weights": {"A": 1, "B": 2}}, "no prior for 'C'"),
        ({"weights": {"A": 1, "B": 2, "C": 1, "D": 1}}, "no class 'D'"),
        ({"weights": "pixel"}, "not 'equal', 'pixels' or class priors"),
        ({"groups": "A vs D"}, "no class 'D'"),
    ],
)
def test_bad_comparison_specs_are_named(spec, message):
    with pytest.raises(InputError, match=message):
        Comparisons.of("ABC", **spec, source="station.yaml")


def test_pixels_weighting_needs_pixels():
    c = Comparisons.of("ABC", weights="pixels")
    with pytest.raises(InputError, match="only a measurement has"):
        gaussian_separation([1.0, 2.0, 3.0], [1.0, 1.0, 1.0], c)


@pytest.mark.parametrize("weights", ["equal", "pixels"])
def test_counted_error_is_the_gaussians_rule_applied_to_the_pixels(weights):
    """The counted error against pixels counted with numpy in the regions between
    brentq crossings of the analytic densities (exact up to a pixel on a crossing:
    1e-12); the Gaussians' own error of those regions is ε Gauss (1e-12)."""
    rng = np.random.default_rng(3)
    sizes = (40_000, 25_000, 60_000)
    values = [
        np.round(rng.normal(1000, 40, sizes[0])),  # Gaussian
        np.round(rng.gamma(4.0, 25.0, sizes[1]) + 900),  # skewed
        np.round(np.concatenate([rng.normal(950, 15, 30_000), rng.normal(1100, 20, 30_000)])),
    ]
    means = [v.mean() for v in values]
    variances = [v.var(ddof=1) for v in values]
    comps = Comparisons.of(["A", "B", "C"], "default", weights)
    pixels = list(sizes)
    counted = counted_separation(
        [as_sample(v) for v in values], means, variances, comps, pixels=pixels
    )
    gauss = gaussian_separation(means, variances, comps, pixels=pixels)
    w = comps.class_weights(pixels)
    for p, (g1, g2) in enumerate(comps.groups):
        share = [w[list(g)] / w[list(g)].sum() for g in (g1, g2)]
        sd = np.sqrt(variances)
        expected = reference_error(
            [means[k] for k in g1],
            sd[list(g1)],
            share[0],
            [means[k] for k in g2],
            sd[list(g2)],
            share[1],
            600,
            1500,
            count=([values[k] for k in g1], [values[k] for k in g2]),
        )
        assert counted.error[p] == pytest.approx(expected, rel=1e-12, abs=1e-12)
        assert counted.expected[p] == pytest.approx(gauss.error_gaussian[p], rel=1e-12)
        assert 0 < counted.standard_error[p] < 0.01
    fits = counted.fits(relative=0.1)
    # Every comparison with the bimodal C misses; A vs B (B skewed) and the other groups
    # pass this check alone, which is why measure also checks each class's shape.
    labels = dict(zip(comps.labels, fits, strict=True))
    assert not labels["A vs C"] and not labels["B vs C"] and not labels["C vs A,B"]


def test_counted_error_of_a_constant_class_is_not_checked():
    comps = Comparisons.of(["A", "B"])
    counted = counted_separation(
        [as_sample(np.full(50, 7)), as_sample(np.arange(50))], [7.0, 24.5], [0.0, 212.5], comps
    )
    assert np.isnan(counted.error).all() and not counted.fits(relative=0.1).any()
