"""Grey-value statistics of one image region over a stack of frames.

One pass over the frames under a mask gives everything the measurement needs:

* the pooled sample of all pixel values of all frames (what a classifier sees on
  single frames; μ (38) and σ² (39) of the class come from it), kept as an exact
  lattice histogram for integer frames;
* EMVA 1288-style noise components for a stack of N ≥ 2 frames: the temporal
  variance (mean over the region of each pixel's variance across frames) and the
  spatial variance (variance over the region of the per-pixel mean, less the
  temporal part that is left in a mean of N frames);
* the number of saturated and zero pixel values.

Dark frames are subtracted as their per-pixel mean. For integer frames the
result stays on the lattice ``1/n_dark`` DN, so every number remains exact. A
:class:`Shading` correction divides each pixel's signal by the light's field there
before the statistics (the raw values still decide what is saturated or zero).
"""

from __future__ import annotations

import functools
import sys
from dataclasses import dataclass
from fractions import Fraction

import numpy as np

from inspect_validate.errors import InputError
from inspect_validate.stats.sample import (
    EmpiricalCdf,
    LatticeSample,
    converted_moments,
    empirical_cdf,
)

__all__ = ["RegionStatistics", "Shading", "region_statistics"]


@dataclass(frozen=True, eq=False)
class Shading:
    """A shading correction: each pixel's signal above ``dark_level`` (DN) divided by
    ``field`` (H, W), the light's share at that pixel (1 at its maximum), as a camera's
    flat-field correction or HALCON's ``shading_correction`` do: a uniform object then
    shows one grey value over the frame, x ↦ d + (x − d)/F."""

    field: np.ndarray
    dark_level: float

    def correct(self, values: np.ndarray, mask: np.ndarray, *, dark_subtracted: bool) -> np.ndarray:
        """``values`` (N, n) of the pixels of ``mask``, corrected (float64, DN); values
        already ``dark_subtracted`` are divided as they are."""
        f = np.asarray(self.field, np.float64)[mask]
        if dark_subtracted:
            return values / f
        return self.dark_level + (values - self.dark_level) / f


@dataclass(frozen=True, eq=False)
class RegionStatistics:
    """Statistics of one region over a stack of frames.

    Attributes
    ----------
    sample : LatticeSample or ndarray
        Pooled grey values of the region over all frames, in DN (dark-subtracted).
    n_pixels : int
        Pixels in the region.
    n_frames : int
        Frames in the stack.
    temporal_variance : float or None
        Mean over the region of the per-pixel unbiased variance across frames,
        DN²; None for a single frame.
    spatial_variance : float or None
        Variance over the region of the per-pixel temporal mean, less
        ``temporal_variance / n_frames`` (EMVA 1288 s²_y.spatial), DN²; for a
        single frame the plain spatial variance, which then still contains the
        temporal noise.
    saturated : int
        Raw pixel values at or above the saturation level, over all frames.
    zero : int
        Raw pixel values at or below zero, over all frames.
    """

    sample: LatticeSample | np.ndarray
    n_pixels: int
    n_frames: int
    temporal_variance: float | None
    spatial_variance: float | None
    saturated: int
    zero: int

    @functools.cached_property
    def cdf(self) -> EmpiricalCdf:
        """The pooled values' distribution function, made once (a float sample is
        sorted) for the misfit check and the counted error alike."""
        return empirical_cdf(self.sample)

    @property
    def saturated_fraction(self) -> float:
        return self.saturated / (self.n_pixels * self.n_frames)

    @property
    def zero_fraction(self) -> float:
        return self.zero / (self.n_pixels * self.n_frames)


def region_statistics(
    frames: np.ndarray,
    mask: np.ndarray,
    *,
    dark: np.ndarray | None = None,
    saturation_level: float | None = None,
    shading: Shading | None = None,
) -> RegionStatistics:
    """Measure one region of a frame stack.

    Parameters
    ----------
    frames : ndarray, shape (N, H, W) or (H, W)
        Frames in DN: unsigned or signed integers, or floats.
    mask : ndarray of bool, shape (H, W)
        The region.
    dark : ndarray, shape (M, H, W) or (H, W), keyword-only, optional
        Dark frames at the same exposure and gain; their per-pixel mean is
        subtracted.
    saturation_level : float, keyword-only, optional
        Raw value counted as saturated; default the dtype's maximum for integer
        frames, none for float frames.
    shading : Shading, keyword-only, optional
        The frames' shading corrected before the statistics (the field of the frames'
        size); saturated and zero values are counted on the raw ones.

    Returns
    -------
    RegionStatistics
    """
    frames = _as_stack(frames)
    mask = np.ascontiguousarray(mask, dtype=np.bool_)
    if mask.shape != frames.shape[1:]:
        raise InputError(f"mask shape {mask.shape} does not match frame shape {frames.shape[1:]}")
    n_pixels = int(np.count_nonzero(mask))
    if n_pixels == 0:
        raise InputError("the region is empty")
    if dark is not None:
        dark = _as_stack(dark)
        if dark.shape[1:] != frames.shape[1:]:
            raise InputError(
                f"dark frame shape {dark.shape[1:]} does not match frame shape {frames.shape[1:]}"
            )
    if saturation_level is None and frames.dtype.kind in "ui":
        saturation_level = np.iinfo(frames.dtype).max
    if shading is not None and np.shape(shading.field) != frames.shape[1:]:
        raise InputError(
            f"the field is {np.shape(shading.field)[::-1]} px, the frames "
            f"{frames.shape[1:][::-1]}: measure the field with this camera's frames"
        )
    integer = frames.dtype.kind in "ui" and (dark is None or dark.dtype.kind in "ui")
    if integer and shading is None:
        return _integer_region(frames, mask, dark, saturation_level, n_pixels)
    return _float_region(frames, mask, dark, saturation_level, n_pixels, shading)


def _as_stack(frames) -> np.ndarray:
    a = np.asarray(frames)
    if a.ndim == 2:
        a = a[np.newaxis]
    if a.ndim != 3:
        raise InputError(f"expected a frame (H, W) or a stack (N, H, W), got shape {a.shape}")
    if a.dtype.kind not in "uif":
        raise InputError(f"frames must be numeric, got dtype {a.dtype}")
    return np.ascontiguousarray(a)


def _integer_region(frames, mask, dark, saturation_level, n_pixels) -> RegionStatistics:
    n_frames = frames.shape[0]
    sat = (
        np.int64(min(saturation_level, 2**62)) if saturation_level is not None else np.int64(2**62)
    )
    narrow = frames.dtype.itemsize <= 2 and frames.dtype.kind == "u"
    if n_frames == 1 and dark is None and narrow:
        # One raw 8/16-bit frame: its histogram holds everything, and numpy's bincount
        # is within 2x of the compiled pass, without numba's 0.5 s of import and cache
        # load (most of a `measure` run).
        return _histogram_region(
            _masked_histogram(frames[0], mask, 1 << (8 * frames.dtype.itemsize)), 0, sat, n_pixels
        )
    kern = _kernels(n_pixels * n_frames)
    if dark is None:
        scale, dark_sum = 1, np.zeros((1, 1), np.int64)
        if narrow:
            lo, hi = 0, int(np.iinfo(frames.dtype).max)
        else:
            lo, hi = kern.masked_code_range(frames, mask, dark_sum, 1)
    else:
        scale = dark.shape[0]
        dark_sum = dark.sum(axis=0, dtype=np.int64)
        lo, hi = kern.masked_code_range(frames, mask, dark_sum, scale)
    nbins = hi - lo + 1
    if nbins > 2**24:
        # A histogram this wide would not fit the cache; such data are better
        # treated as continuous.
        return _float_region(frames, mask, dark, saturation_level, n_pixels)
    if n_frames == 1 and dark is None:
        return _histogram_region(kern.histogram(frames, mask, lo, nbins), lo, sat, n_pixels)
    ref = (lo + hi) // 2
    # Per-row int64 partial sums stay exact while a row's Σ s² fits in 63 bits.
    span = max(hi - ref, ref - lo) * n_frames
    if float(span) ** 2 * frames.shape[2] * 2 >= 2.0**63:
        return _float_region(frames, mask, dark, saturation_level, n_pixels)
    hist, rows, n_sat, n_zero = kern.accumulate(frames, mask, dark_sum, scale, lo, nbins, ref, sat)
    sample = LatticeSample(hist, lo, scale)
    temporal = spatial = None
    # Exact sums over the region of s_p = Σ_f c and of F·Σ_f c² − s_p², with
    # c = code − ref; summed over rows as Python ints.
    sum_s, sum_s2, sum_t = (sum(int(v) for v in rows[:, j].tolist()) for j in range(3))
    n, f, d2 = n_pixels, n_frames, scale * scale
    mean_image_var = (
        Fraction(n * sum_s2 - sum_s * sum_s, n * (n - 1) * f * f * d2) if n > 1 else None
    )
    if f > 1:
        t = Fraction(sum_t, n * f * (f - 1) * d2)
        temporal = float(t)
        spatial = float(mean_image_var - t / f) if mean_image_var is not None else None
    elif mean_image_var is not None:
        spatial = float(mean_image_var)
    return RegionStatistics(sample, n_pixels, n_frames, temporal, spatial, int(n_sat), int(n_zero))


BLOCKS_VALUES_MAX = 2**25
"""Values (pixels × frames, summed over a process's regions) measured with numpy before
the compiled kernels take over. Loading numba costs about 0.5 s; numpy spends about as
long on 2²⁵ values (17 ns a value against 2 ns compiled, on this project's 2-core
benchmark machine). Renting until the rent reaches the price of buying keeps any
process within twice its best choice in hindsight: a ``verify`` of small frames never
loads numba, a long ``watch`` of large ones soon does."""

_blocks_values = 0  # values measured with numpy so far in this process
_compiled = False  # bought: the compiled kernels from now on


def _kernels(values: int):
    """The module whose kernels measure a region of ``values`` values (same results)."""
    global _blocks_values, _compiled
    # numba already loaded by another part (ε Gauss sweeps) leaves only the kernels' cache.
    _compiled = _compiled or "numba" in sys.modules or _blocks_values + values > BLOCKS_VALUES_MAX
    if _compiled:
        from inspect_validate.stats import _region_kernels

        return _region_kernels
    from inspect_validate.stats import _region_blocks

    _blocks_values += values
    return _region_blocks


def _masked_histogram(frame, mask, nbins) -> np.ndarray:
    """Counts of the values 0 … nbins − 1 of an unsigned frame under the mask, in blocks of
    rows of the mask's bounding box (a few hundred kB each: cache-resident, and no copy of
    the region); a block the mask covers whole is counted without indexing (a rectangle's
    pixels in half the time)."""
    hist = np.zeros(nbins, np.int64)
    rows = np.flatnonzero(mask.any(axis=1))
    cols = np.flatnonzero(mask[rows[0] : rows[-1] + 1].any(axis=0))
    x0, x1 = cols[0], cols[-1] + 1
    step = max(1, 2**18 // int(x1 - x0))
    for i in range(rows[0], rows[-1] + 1, step):
        block, inside = frame[i : i + step, x0:x1], mask[i : i + step, x0:x1]
        values = block.ravel() if inside.all() else block[inside]
        hist += np.bincount(values, minlength=nbins)
    return hist


def _histogram_region(hist, lo, sat, n_pixels) -> RegionStatistics:
    """One raw frame from its histogram of codes lo … : σ² is the spatial variance, and
    saturated and zero pixels are its end bins."""
    sample = LatticeSample(hist, lo, 1)
    nbins = hist.size
    n_sat = int(hist[max(0, int(sat) - lo) :].sum()) if sat - lo < nbins else 0
    n_zero = int(hist[: max(0, 1 - lo)].sum())
    spatial = float(converted_moments(sample).variance) if n_pixels > 1 else None
    return RegionStatistics(sample, n_pixels, 1, None, spatial, n_sat, n_zero)


def _float_region(frames, mask, dark, saturation_level, n_pixels, shading=None):
    raw = frames[:, mask]
    if raw.dtype.kind == "f" and not np.all(np.isfinite(raw)):
        k, i = (int(v[0]) for v in np.nonzero(~np.isfinite(raw)))
        y, x = (int(v[i]) for v in np.nonzero(mask))
        raise InputError(
            f"pixel ({x}, {y}) of frame {k + 1} in the region is NaN or infinite; grey "
            "values inside the regions must be numbers"
        )
    values = raw.astype(np.float64)
    if dark is not None:
        values -= dark[:, mask].astype(np.float64).mean(axis=0)
    if shading is not None:
        values = shading.correct(values, mask, dark_subtracted=dark is not None)
    n_frames = frames.shape[0]
    n_sat = int(np.count_nonzero(raw >= saturation_level)) if saturation_level is not None else 0
    n_zero = int(np.count_nonzero(raw <= 0))
    temporal = spatial = None
    pixel_mean = values.mean(axis=0)
    if n_frames > 1:
        temporal = float(values.var(axis=0, ddof=1).mean())
    if n_pixels > 1:
        spatial = float(pixel_mean.var(ddof=1)) - (temporal / n_frames if temporal else 0.0)
    return RegionStatistics(values.ravel(), n_pixels, n_frames, temporal, spatial, n_sat, n_zero)
