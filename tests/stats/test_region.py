"""Region statistics over frame stacks, against Fraction arithmetic (exact) and numpy float64."""

import sys
from fractions import Fraction

import numpy as np
import pytest

from inspect_validate.errors import InputError
from inspect_validate.stats import Shading, region_statistics, sample_moments


def test_single_uint16_frame_matches_fraction():
    rng = np.random.default_rng(4)
    frame = np.rint(rng.normal(60_000, 1, (120, 90))).astype(np.uint16)
    mask = np.zeros(frame.shape, bool)
    mask[10:100, 5:80] = True
    mask[50, :] = True
    r = region_statistics(frame, mask)
    xs = [Fraction(int(v)) for v in frame[mask]]
    mean = sum(xs) / len(xs)
    var = sum((x - mean) ** 2 for x in xs) / (len(xs) - 1)
    m = sample_moments(r.sample)
    assert (m.mean, m.variance) == (float(mean), float(var))
    assert r.spatial_variance == float(var)
    assert r.temporal_variance is None
    assert r.n_pixels == mask.sum() and r.n_frames == 1


def test_stack_with_dark_is_exact_emva_decomposition():
    rng = np.random.default_rng(5)
    frames = rng.integers(0, 4096, (4, 30, 40)).astype(np.uint16)
    dark = rng.integers(0, 60, (3, 30, 40)).astype(np.uint16)
    mask = np.zeros((30, 40), bool)
    mask[3:25, 4:33] = True
    r = region_statistics(frames, mask, dark=dark)
    # Exact reference: y = x - mean(dark) per pixel, as fractions.
    dk = [Fraction(int(s), 3) for s in dark[:, mask].sum(axis=0)]
    y = [[Fraction(int(v)) - d for v, d in zip(f[mask], dk, strict=True)] for f in frames]
    pooled = [v for f in y for v in f]
    n, nf = len(dk), len(y)
    mean = sum(pooled) / len(pooled)
    var = sum((v - mean) ** 2 for v in pooled) / (len(pooled) - 1)
    pix_mean = [sum(f[p] for f in y) / nf for p in range(n)]
    temporal = sum(sum((f[p] - pix_mean[p]) ** 2 for f in y) / (nf - 1) for p in range(n)) / n
    mm = sum(pix_mean) / n
    spatial = sum((m - mm) ** 2 for m in pix_mean) / (n - 1) - temporal / nf
    m = sample_moments(r.sample)
    assert (m.mean, m.variance) == (float(mean), float(var))
    assert r.temporal_variance == float(temporal)
    assert r.spatial_variance == float(spatial)


def test_float_frames_match_numpy():
    rng = np.random.default_rng(6)
    frames = rng.normal(100, 3, (3, 20, 20))
    mask = np.ones((20, 20), bool)
    r = region_statistics(frames, mask)
    v = frames.reshape(3, -1)
    assert sample_moments(r.sample).variance == pytest.approx(v.var(ddof=1), rel=1e-12)
    assert r.temporal_variance == pytest.approx(v.var(axis=0, ddof=1).mean(), rel=1e-12)
    expected = v.mean(axis=0).var(ddof=1) - r.temporal_variance / 3
    assert r.spatial_variance == pytest.approx(expected, rel=1e-12)


def test_saturated_and_zero_counts():
    frame = np.array([[0, 5, 255], [255, 7, 9]], np.uint8)
    r = region_statistics(frame, np.ones(frame.shape, bool))
    assert (r.saturated, r.zero) == (2, 1)
    assert r.saturated_fraction == pytest.approx(2 / 6)
    r = region_statistics(frame, np.ones(frame.shape, bool), saturation_level=9)
    assert r.saturated == 3


def test_errors():
    frame = np.zeros((4, 4), np.uint8)
    with pytest.raises(InputError, match="empty"):
        region_statistics(frame, np.zeros((4, 4), bool))
    with pytest.raises(InputError, match="does not match"):
        region_statistics(frame, np.ones((4, 5), bool))
    with pytest.raises(InputError, match="dark frame shape"):
        region_statistics(frame, np.ones((4, 4), bool), dark=np.zeros((5, 4), np.uint8))


@pytest.mark.parametrize("seed", range(12))
def test_numpy_blocks_equal_the_compiled_kernels(seed):
    # Both are exact int64 arithmetic: every output must be identical, for unsigned
    # and signed frames, with and without darks, masks with holes and empty rows,
    # and frames wide enough that a block holds a part of a row's worth of pixels.
    from inspect_validate.stats import _region_blocks as blocks
    from inspect_validate.stats import _region_kernels as compiled

    rng = np.random.default_rng(seed)
    dtype = [np.uint8, np.uint16, np.int16, np.uint32][seed % 4]
    n, h, w = int(rng.integers(2, 6)), int(rng.integers(1, 60)), int(rng.integers(1, 9000))
    info = np.iinfo(dtype)
    lo_v, hi_v = max(int(info.min), -3000), min(int(info.max), 70000)
    frames = rng.integers(lo_v, hi_v, (n, h, w), endpoint=True).astype(dtype)
    frames[:, 0, :2] = hi_v  # saturated values
    mask = rng.random((h, w)) < 0.4
    mask[h // 2] = False
    mask[0, 0] = True
    n_dark = int(rng.integers(0, 4))
    if n_dark:
        dark = rng.integers(0, 50, (n_dark, h, w)).astype(dtype)
        scale, dark_sum = n_dark, dark.sum(axis=0, dtype=np.int64)
    else:
        scale, dark_sum = 1, np.zeros((1, 1), np.int64)
    lo, hi = compiled.masked_code_range(frames, mask, dark_sum, scale)
    assert blocks.masked_code_range(frames, mask, dark_sum, scale) == (lo, hi)
    args = (frames, mask, dark_sum, scale, lo, hi - lo + 1, (lo + hi) // 2, np.int64(hi_v))
    for got, want in zip(blocks.accumulate(*args), compiled.accumulate(*args), strict=True):
        np.testing.assert_array_equal(got, want)
    if not n_dark:
        np.testing.assert_array_equal(
            blocks.histogram(frames, mask, lo, hi - lo + 1),
            compiled.histogram(frames, mask, lo, hi - lo + 1),
        )


def test_the_compiled_kernels_take_over_once_numpy_has_spent_their_load(monkeypatch):
    from inspect_validate.stats import region

    rng = np.random.default_rng(3)
    frames = rng.integers(0, 4096, (4, 64, 80)).astype(np.uint16)
    mask = np.zeros((64, 80), bool)
    mask[5:50, 3:70] = True
    values = int(mask.sum()) * 4
    monkeypatch.setattr(region, "_blocks_values", 0)
    monkeypatch.setattr(region, "_compiled", False)
    monkeypatch.setattr(region, "BLOCKS_VALUES_MAX", values)
    # Loaded before numba is hidden, so that the hand-over does not import numba again.
    from inspect_validate.stats import _region_kernels  # noqa: F401

    monkeypatch.delitem(sys.modules, "numba", raising=False)  # as if no part had loaded it
    with_numpy = region_statistics(frames, mask)
    assert region._blocks_values == values and not region._compiled  # numpy measured it
    compiled = region_statistics(frames, mask)
    assert region._blocks_values == values and region._compiled  # the budget was spent
    monkeypatch.setattr(region, "_blocks_values", 0)
    assert region._kernels(1).__name__.endswith("_region_kernels")  # bought: they stay
    np.testing.assert_array_equal(with_numpy.sample.counts, compiled.sample.counts)
    assert sample_moments(with_numpy.sample) == sample_moments(compiled.sample)
    assert (with_numpy.temporal_variance, with_numpy.spatial_variance) == (
        compiled.temporal_variance,
        compiled.spatial_variance,
    )


@pytest.mark.parametrize("seed", range(6))
def test_one_frame_histogram_over_any_mask_equals_bincount(seed):
    # Blocks the mask covers whole are counted without indexing: rectangles, a rectangle
    # with a hole, random blobs and one-pixel rows must all give the indexed count.
    from inspect_validate.stats.region import _masked_histogram

    rng = np.random.default_rng(seed)
    frame = rng.integers(0, 256, (700, 300), dtype=np.uint8)
    mask = np.zeros(frame.shape, bool)
    y0, x0 = rng.integers(0, 300), rng.integers(0, 150)
    mask[y0 : y0 + rng.integers(1, 400), x0 : x0 + rng.integers(1, 150)] = True
    if seed % 2:
        mask[rng.integers(0, 700), rng.integers(0, 300)] ^= True
    if seed % 3 == 0:
        mask |= rng.random(frame.shape) < 0.01
    expected = np.bincount(frame[mask], minlength=256)
    np.testing.assert_array_equal(_masked_histogram(frame, mask, 256), expected)


def test_a_shading_correction_divides_the_signal_above_dark_and_counts_the_raw():
    """x ↦ d + (x − d)/F on each pixel, the statistics of the corrected values; the
    saturated and zero counts are the raw values' (a pixel at 250 of 255 corrected to
    above 255 is not saturated); with dark frames, the dark-subtracted values divided."""
    rng = np.random.default_rng(2)
    field = np.linspace(0.8, 1.0, 12).reshape(3, 4)
    frames = np.clip(rng.normal(4 + 200 * field, 2, (5, 3, 4)), 0, 255).astype(np.uint8)
    frames[0, 0, 0], frames[1, 2, 3] = 255, 250
    mask = np.ones((3, 4), bool)
    got = region_statistics(frames, mask, shading=Shading(field, 4.0))
    want = (4.0 + (frames.astype(float) - 4.0) / field).ravel()
    m = sample_moments(got.sample)
    assert m.mean == pytest.approx(want.mean(), rel=1e-12)
    assert m.variance == pytest.approx(want.var(ddof=1), rel=1e-12)
    assert got.saturated == 1
    dark = np.full((2, 3, 4), 4, np.uint8)
    subtracted = region_statistics(frames, mask, dark=dark, shading=Shading(field, 99.0))
    assert sample_moments(subtracted.sample).mean == pytest.approx(
        ((frames.astype(float) - 4.0) / field).mean(), rel=1e-12
    )
    with pytest.raises(InputError, match="field"):
        region_statistics(frames, mask, shading=Shading(field[:2], 4.0))
