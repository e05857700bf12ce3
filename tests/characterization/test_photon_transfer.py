"""Photon transfer (EMVA 1288 release 4.0, §6.3) on made-up region statistics: which
points the fit of K takes, and why it leaves the others out."""

from types import SimpleNamespace

import numpy as np
import pytest

from inspect_validate.verification.calibration import photon_transfer, photon_transfer_gain

K, DARK_MEAN, DARK_VAR = 0.5, 100.0, 2.0


def _region(name, mean, variance, *, saturated=0.0, zero=0.0, pixels=10_000, frames=16):
    return SimpleNamespace(
        name=name,
        mean=mean,
        temporal_variance=variance,
        saturated_fraction=saturated,
        zero_fraction=zero,
        n_pixels=pixels,
        n_frames=frames,
    )


def chart_series(signals, *, variance=lambda x: K * x):
    """One measurement per signal level above dark (DN), one region each, with the dark
    stack measured in the same region."""
    lit = [
        SimpleNamespace(classes=[_region("A", DARK_MEAN + x, DARK_VAR + variance(x))])
        for x in signals
    ]
    dark = SimpleNamespace(classes=[_region("A", DARK_MEAN, DARK_VAR)])
    return lit, dark


def test_the_slope_through_the_origin_is_k():
    lit, dark = chart_series([100.0, 400.0, 900.0, 1600.0])
    gain = photon_transfer_gain(lit, dark, declared=0.4)
    assert gain.value == pytest.approx(K, rel=1e-12)
    assert gain.relative_deviation == pytest.approx(0.25, rel=1e-12)


def test_points_above_70_percent_of_saturation_are_left_out():
    """A 12-bit camera (4095 DN): the point at 3500 DN (86 % of the range above dark)
    is already compressed; fitting it would pull K down."""
    signals = [500.0, 1000.0, 2000.0, 3400.0]
    compressed = {3400.0: 0.4 * K * 3400.0}
    lit, dark = chart_series(signals, variance=lambda x: compressed.get(x, K * x))
    gain, left_out = photon_transfer(lit, dark, declared=K, saturation_level=4095.0)
    assert gain.value == pytest.approx(K, rel=1e-12) and len(gain.points) == 3
    assert left_out == {"above 70 % of saturation": 1}
    # Without knowing the level, the point is left out as beyond the variance's maximum
    # only if its variance fell significantly — here it did (0.4 × K × 3400 < K × 2000).
    gain, left_out = photon_transfer(lit, dark, declared=K)
    assert gain.value == pytest.approx(K, rel=1e-12)
    assert left_out == {"beyond the temporal variance's maximum": 1}


def test_a_variance_within_its_sampling_error_of_the_maximum_is_kept():
    """Sampling noise can make a brighter point's variance a little lower: that is no
    maximum, and the point stays in the fit."""
    lit, dark = chart_series([1000.0, 1001.0], variance=lambda x: K * 1000.0 - (x - 1000.0) * 0.5)
    gain, left_out = photon_transfer(lit, dark, declared=K)
    assert len(gain.points) == 2 and left_out == {}


@pytest.mark.parametrize(
    ("region", "dark_region", "reason"),
    [
        (dict(variance=None), {}, "a single frame (no temporal variance)"),
        (dict(saturated=0.01), {}, "clipped pixels in the region"),
        ({}, dict(zero=0.2), "dark frames clipped at 0 (the camera needs a black-level offset)"),
        (dict(mean=DARK_MEAN + 0.5), {}, "signal below 1 DN above dark"),
    ],
)
def test_no_usable_point_says_why(region, dark_region, reason):
    spec = {"mean": DARK_MEAN + 500.0, "variance": DARK_VAR + K * 500.0, **region}
    lit = [SimpleNamespace(classes=[_region("A", **spec)])]
    dark = SimpleNamespace(classes=[_region("A", DARK_MEAN, DARK_VAR, **dark_region)])
    gain, left_out = photon_transfer(lit, dark, declared=K)
    assert gain is None and left_out == {reason: 1}
    assert photon_transfer_gain(lit, dark, declared=K) is None


def test_two_points_get_the_sampling_error_of_their_variances():
    lit, dark = chart_series([200.0, 800.0])
    gain = photon_transfer_gain(lit, dark, declared=K)
    x = np.array([200.0, 800.0])
    var_y = np.array(
        [2 * (DARK_VAR + K * s) ** 2 / (10_000 * 15) + 2 * DARK_VAR**2 / (10_000 * 15) for s in x]
    )
    assert gain.standard_error == pytest.approx(np.sqrt(x**2 @ var_y) / (x @ x), rel=1e-12)
