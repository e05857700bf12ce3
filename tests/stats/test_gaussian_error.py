"""Two-Gaussian ε_tot (37) against mpmath (60 digits). Stated tolerance: 1e-13 relative for ε ≥ 1e-300.

Every test runs twice: on the numpy implementation and on the compiled kernel that
takes over from ``COMPILED_MIN`` pairs.
"""

import importlib

import mpmath as mp
import numpy as np
import pytest
from scipy import special

from inspect_validate.stats import gaussian_error, log_gaussian_error

implementation = importlib.import_module("inspect_validate.stats.gaussian_error")


@pytest.fixture(autouse=True, params=["numpy", "compiled"])
def kernel(request, monkeypatch):
    threshold = 0 if request.param == "compiled" else 2**62
    monkeypatch.setattr(implementation, "COMPILED_MIN", threshold)
    monkeypatch.setattr(implementation, "LOAD_MIN", threshold)
    return request.param


def test_special_functions_against_mpmath():
    """The arrays' erfcx (table and asymptotic series) and Φ, log Φ against mpmath
    (50 digits) over x ≥ 0, across every interval of the table and both sides of
    x = 12: erfcx within 1e-15 relative (measured 7.8e-16; scipy's 8.9e-16), Φ 1e-15
    (4.4e-16), log Φ 2e-15 (8.9e-16; scipy's log_ndtr 2.2e-13)."""
    rng = np.random.default_rng(5)
    x = np.concatenate(
        [
            [0.0, 1e-300, 5e-324, 11.999, 12.0, 12.001, 26.0, 38.5, 1e3, 1e154],
            np.arange(0, 12, 1 / 16),  # interval edges
            np.abs(rng.normal(0, 8, 2000)),
            10 ** rng.uniform(-20, 20, 1000),
            rng.uniform(0, 12, 2000),
        ]
    )
    with mp.workdps(50):
        expected = np.array([float(mp.exp(mp.mpf(v) ** 2) * mp.erfc(v)) for v in x])
        tail = [mp.ncdf(-mp.mpf(v)) if v < 40 else mp.mpf(0) for v in x]
        phi_expected = np.array([float(1 - t) for t in tail])
        log_phi_expected = np.array([float(mp.log1p(-t)) for t in tail])
    ours = implementation._erfcx(x)
    assert np.allclose(ours, expected, rtol=1e-15, atol=0)
    phi, log_phi = implementation._lower_tail(x)
    assert np.allclose(phi, phi_expected, rtol=1e-15, atol=0)
    assert np.allclose(log_phi, log_phi_expected, rtol=2e-15, atol=0)
    ends = implementation._erfcx(np.array([np.inf, 1e300, np.nan]))
    assert ends[0] == 0.0 and 0 < ends[1] < 1e-300 and np.isnan(ends[2])
    assert np.isnan(implementation._lower_tail(np.array([np.nan]))).all()


def reference(m1, v1, m2, v2, *, digits=60):
    """ε_tot from the crossings, all in 60-digit arithmetic, tails taken on the far side."""
    with mp.workdps(digits):
        m1, v1, m2, v2 = map(mp.mpf, (m1, v1, m2, v2))
        if v1 > v2:
            m1, v1, m2, v2 = m2, v2, m1, v1
        s1, s2 = mp.sqrt(v1), mp.sqrt(v2)
        q = lambda z: mp.ncdf(-z)  # noqa: E731
        a = 1 / (2 * v2) - 1 / (2 * v1)
        b = m1 / v1 - m2 / v2
        c = m2**2 / (2 * v2) - m1**2 / (2 * v1) + mp.log(s2 / s1)
        if a == 0:
            x = -c / b
            lo, hi = (-mp.inf, x) if m1 < x else (x, mp.inf)
        else:
            root = mp.sqrt(b * b - 4 * a * c)
            lo, hi = sorted([(-b - root) / (2 * a), (-b + root) / (2 * a)])
        below = 0 if lo == -mp.inf else q((m1 - lo) / s1)
        above = 0 if hi == mp.inf else q((hi - m1) / s1)
        zl = -mp.inf if lo == -mp.inf else (lo - m2) / s2
        zh = mp.inf if hi == mp.inf else (hi - m2) / s2
        if zl >= 0:
            inside = q(zl) - q(zh)
        elif zh <= 0:
            inside = q(-zh) - q(-zl)
        else:
            inside = 1 - q(zh) - q(-zl)
        return (below + above + inside) / 2


def cases():
    rng = np.random.default_rng(0)
    out = []
    for _ in range(300):
        m1 = rng.normal(0, 100)
        s1 = 10 ** rng.uniform(-3, 2)
        ratio = rng.choice([1.0, 10 ** rng.uniform(-8, 8), 1 + rng.uniform(-1e-6, 1e-6)])
        s2 = s1 * ratio
        gap = 10 ** rng.uniform(-3, 2.5) * max(s1, s2)
        out.append((m1, s1 * s1, m1 + gap, s2 * s2))
    # Equal and nearly equal variances, huge gaps, tiny gaps, ε near 1e-300.
    out += [(0, 1, 1e-9, 1), (0, 1, 74, 1), (0, 1, 73.9, 1.0000001), (0, 1, 0, 4)]
    out += [
        (0, 1, 1, 1 + 1e-15),
        (100, 4, 100, 4.000001),
        (0, 1e-12, 1, 1),
        (-40, 0.1, 9.5e6, 6.6e10),
    ]
    return out


def test_relative_error_against_mpmath():
    worst = 0.0
    for case in cases():
        ref = reference(*case)
        if ref < mp.mpf("1e-300"):
            continue
        got = float(gaussian_error(*case))
        worst = max(worst, abs(got - float(ref)) / float(ref))
    assert worst <= 1e-13


def test_log_error_beyond_underflow():
    for case in [(0, 1, 80, 1), (0, 1, 1000, 4), (51.3, 57.1, 583.0, 4.4e-5)]:
        ref = mp.log(reference(*case))
        got = float(log_gaussian_error(*case))
        assert got == pytest.approx(float(ref), rel=1e-14)
    assert float(gaussian_error(0, 1, 80, 1)) == 0.0  # underflows; the log does not
    assert np.isfinite(log_gaussian_error(0, 1, 1e6, 1))


@pytest.mark.parametrize(
    "case",
    [
        (0, 1e-315, 3.5e-157, 1e-315),  # subnormal variances (ε was NaN)
        (0, 1e-320, 3, 1),  # a subnormal against a unit variance
        (0, 1e-320, 1e-157, 1),
        (0, 1e300, 1e150, 1e300),  # huge variances
        (0, 1e300, 3e150, 4e300),
        (-1e300, 1e298, 1e300, 1e298),
        (1e-300, 1e-310, 3e-300, 2e-310),
    ],
)
def test_extreme_scales_against_mpmath(case):
    """Within 1e-12 of mpmath where the variances are subnormal or near 1e300: ε depends
    on lengths in σ only, and the computation scales them to σ near 1 (by a power of
    two, exactly)."""
    # 400 digits: the crossings of σ 1e-160 and σ 1 lie 1e-159 apart around 3, which
    # 60 digits cannot tell from one point.
    ref = reference(*case, digits=400)
    eps, log_eps = implementation.gaussian_error_and_log(*case)
    assert float(eps) == pytest.approx(float(ref), rel=1e-12, abs=0)
    assert float(log_eps) == pytest.approx(float(mp.log(ref)), rel=1e-12, abs=0)


def test_separation_beyond_doubles():
    """Apart by more than 10¹⁵⁰ σ: ε 0, its log the crossing's exponent or −inf where
    that passes the doubles; never NaN."""
    for case in [(0, 1e-315, 1, 1e-315), (0, 1, 1e300, 1), (-1e308, 1e-300, 1e308, 1e-300)]:
        eps, log_eps = implementation.gaussian_error_and_log(*case)
        assert float(eps) == 0.0 and float(log_eps) == -np.inf
    eps, log_eps = implementation.gaussian_error_and_log(0, 1e-300, 1, 1e-300)  # Δ = 10¹⁵⁰ σ
    assert float(eps) == 0.0 and float(log_eps) == pytest.approx(-1.25e299, rel=1e-12)


def test_power_of_two_scaling_changes_no_bit():
    """The rescaling is exact: usual inputs scaled by 2¹⁰⁰ give the same ε and log ε."""
    m1, v1, m2, v2 = (np.array(c, float) for c in zip(*cases(), strict=True))
    base = implementation.gaussian_error_and_log(m1, v1, m2, v2)
    for k in (-100, 100):
        c = 2.0**k
        scaled = implementation.gaussian_error_and_log(m1 * c, v1 * c * c, m2 * c, v2 * c * c)
        assert np.array_equal(base[0], scaled[0]) and np.array_equal(base[1], scaled[1])


def test_equal_variance_closed_form():
    d = np.linspace(0, 30, 31)
    got = gaussian_error(0.0, 4.0, d, 4.0)
    expected = special.ndtr(-d / 4)  # Φc(|Δμ| / 2σ), σ = 2
    assert np.allclose(got, expected, rtol=1e-13, atol=0)


def test_symmetric_and_vectorised():
    a = gaussian_error([0, 5], [1, 2], [3, 1], [2, 9])
    b = gaussian_error([3, 1], [2, 9], [0, 5], [1, 2])
    assert np.array_equal(a, b) and a.shape == (2,)


def test_degenerate_cases():
    assert gaussian_error(3, 2, 3, 2) == 0.5  # identical classes
    assert gaussian_error(3, 0, 4, 1) == 0.0  # a constant class vs a spread one
    assert gaussian_error(3, 0, 4, 0) == 0.0
    assert gaussian_error(3, 0, 3, 0) == 0.5
    assert log_gaussian_error(3, 0, 4, 1) == -np.inf
    # Equal means, unequal variances: two crossings around the common mean.
    assert float(gaussian_error(0, 1, 0, 4)) == pytest.approx(
        float(reference(0, 1, 0, 4)), rel=1e-13
    )
    with pytest.raises(ValueError, match="non-negative"):
        gaussian_error(0, -1, 1, 1)
    with pytest.raises(ValueError, match="finite"):
        gaussian_error(np.nan, 1, 1, 1)


def test_gradient_matches_central_differences_and_the_mixture_gradient():
    from inspect_validate.stats.gaussian_error import gaussian_error_gradient
    from inspect_validate.stats.kde_error import mixture_error_gradient
    from inspect_validate.stats.mixture import Mixture

    rng = np.random.default_rng(12)
    m1, m2 = rng.normal(0, 3, (2, 400))
    s1, s2 = np.exp(rng.normal(0, 1, (2, 400)))
    s2[::5] = s1[::5]  # equal widths: one crossing
    s2[1::7] = s1[1::7] * (1 + 1e-9)  # nearly equal: the far crossing at −∞ in effect
    e, log_e, *grad = gaussian_error_gradient(m1, s1, m2, s2)
    np.testing.assert_allclose(e, gaussian_error(m1, s1**2, m2, s2**2), rtol=1e-15)
    np.testing.assert_allclose(log_e, np.log(e), rtol=1e-13)
    args = [m1, s1, m2, s2]
    for i, g in enumerate(grad):
        h = 1e-6 * np.maximum(np.abs(args[i]), 1.0)
        up, down = list(args), list(args)
        up[i], down[i] = args[i] + h, args[i] - h
        fd = (
            gaussian_error(up[0], up[1] ** 2, up[2], up[3] ** 2)
            - gaussian_error(down[0], down[1] ** 2, down[2], down[3] ** 2)
        ) / (2 * h)
        np.testing.assert_allclose(g, fd, rtol=1e-5, atol=1e-9)
    for j in range(0, 400, 37):  # the general mixture path, independently derived
        ref = mixture_error_gradient(Mixture([m1[j]], [1.0], s1[j]), Mixture([m2[j]], [1.0], s2[j]))
        np.testing.assert_allclose(
            [g[j] for g in grad], [r[0] for r in ref[1:]], rtol=1e-10, atol=1e-300
        )


def test_gradient_of_degenerate_pairs_is_zero():
    from inspect_validate.stats.gaussian_error import gaussian_error_gradient

    e, _, *grad = gaussian_error_gradient([1.0, 1.0], [0.0, 2.0], [3.0, 1.0], [1.0, 2.0])
    np.testing.assert_array_equal(e, [0.0, 0.5])
    assert all(np.all(g == 0) for g in grad)


def test_compiled_kernel_agrees_with_numpy_on_a_hostile_corpus(monkeypatch):
    """Means over 6 decades, variances over 8, equal and nearly equal variances, equal
    means, constant classes: the two implementations within 2e-14 relative (each is
    within 1e-13 of mpmath above), logs within 2e-15, the same zeros and infinities."""
    rng = np.random.default_rng(7)
    n = 200_000
    m1 = rng.normal(0, 1, n) * 10 ** rng.uniform(-3, 3, n)
    m2 = m1 + rng.normal(0, 1, n) * 10 ** rng.uniform(-3, 3, n)
    v1 = 10 ** rng.uniform(-4, 4, n)
    v2 = 10 ** rng.uniform(-4, 4, n)
    v2 = np.where(rng.random(n) < 0.2, v1 * (1 + rng.normal(0, 1e-9, n)), v2)
    v2 = np.where(rng.random(n) < 0.05, v1, v2)
    m2 = np.where(rng.random(n) < 0.05, m1, m2)
    v1 = np.where(rng.random(n) < 0.02, 0.0, v1)
    results = {}
    for name, threshold in (("numpy", 2**62), ("compiled", 0)):
        monkeypatch.setattr(implementation, "COMPILED_MIN", threshold)
        monkeypatch.setattr(implementation, "LOAD_MIN", threshold)
        results[name] = implementation.gaussian_error_and_log(m1, v1, m2, v2)
    (e_np, l_np), (e_c, l_c) = results["numpy"], results["compiled"]
    normal = e_np > 1e-300
    assert np.max(np.abs(e_c[normal] / e_np[normal] - 1)) <= 2e-14
    assert np.array_equal(e_c[~normal] == 0, e_np[~normal] == 0)
    finite = np.isfinite(l_np)
    assert np.array_equal(finite, np.isfinite(l_c)) and not np.isnan(l_c).any()
    assert np.max(np.abs(l_c[finite] - l_np[finite]) / np.maximum(1, np.abs(l_np[finite]))) <= 2e-15


def test_normal_cdf_pair_against_mpmath():
    # Φ(z) and Φ(−z) for the clipped-moment model, each to full relative precision:
    # within 2e-15 of 40-digit mpmath on [−37, 37] (scipy.special.ndtr: 2e-13 there).
    import mpmath

    from inspect_validate.stats.gaussian_error import normal_cdf_pair

    z = np.linspace(-37.0, 37.0, 741)
    cdf, upper = normal_cdf_pair(z)
    with mpmath.workdps(40):
        for x, c, u in zip(z, cdf, upper, strict=True):
            for got, want in ((c, mpmath.ncdf(x)), (u, mpmath.ncdf(-x))):
                assert abs((mpmath.mpf(float(got)) - want) / want) < 2e-15, x
    cdf, upper = normal_cdf_pair([np.inf, -np.inf, np.nan])
    np.testing.assert_array_equal(cdf, [1.0, 0.0, np.nan])
    np.testing.assert_array_equal(upper, [0.0, 1.0, np.nan])
    # ½ at ±0 to an ulp (erfcx(0) is 1 − 2⁻⁵² from its polynomial), and a pair
    np.testing.assert_allclose(normal_cdf_pair([0.0, -0.0]), 0.5, rtol=2.3e-16, atol=0)


def test_the_compiled_loop_leaves_what_it_cannot_take_to_numpy(monkeypatch):
    """Through the compiled path: pairs it cannot take as they stand (subnormal and huge
    variances, means 1e300 apart) among usual ones come out as numpy's; a NaN or a
    negative variance anywhere is refused as on the numpy path."""
    monkeypatch.setattr(implementation, "COMPILED_MIN", 0)
    monkeypatch.setattr(implementation, "LOAD_MIN", 0)
    cases = [(0, 1e-315, 3.5e-157, 1e-315), (0, 1, 1e300, 1), (0, 1e300, 1e150, 1e300),
             (0.0, 1.0, 2.0, 1.5)]  # fmt: skip
    m1, v1, m2, v2 = (np.array([c[k] for c in cases] * 50, float) for k in range(4))
    eps, log_eps = implementation.gaussian_error_and_log(m1, v1, m2, v2)
    for k, case in enumerate(cases):
        want = implementation._numpy_error(*(np.array([x], float) for x in case))
        assert eps[k] == pytest.approx(want[0][0], rel=1e-14, abs=0)
        assert log_eps[k] == pytest.approx(want[1][0], rel=1e-14)
    for bad, message in ((np.nan, "finite"), (-1.0, "non-negative")):
        v = v2.copy()
        v[77] = bad
        with pytest.raises(ValueError, match=message):
            implementation.gaussian_error_and_log(m1, v1, m2, v)


def test_the_compiled_loop_is_cached_with_the_functions_it_calls():
    """numba keys a compiled function's cache on its own source file: the loop lives in
    the scalar module beside the functions it calls, so editing them recompiles it (a loop
    in the kernel's module kept running the cached old code)."""
    kernel = implementation.load_kernel()
    assert kernel.py_func.__code__.co_filename.endswith("_gaussian_error_scalar.py")
