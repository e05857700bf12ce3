"""Gaussian mixtures: a class's density as kernels (41), and its log-density.

A class's kernel density estimate is a Gaussian mixture: one kernel of bandwidth h
(LSCV, :mod:`inspect_validate.stats.bandwidth`) per lattice point, weighted by its
count (integer data), or per value (continuous data; linearly binned at h/2000 above
2¹⁴ values). A model class is one too (a kernel per reflectance sample). Its
log-density is summed stably (log-sum-exp), in windows of the components near each
point where there are many, or on a grid by FFT where the sign of a difference of two
is all that is needed (:mod:`inspect_validate.stats.kde_error` finds the crossings
of two densities with it).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from inspect_validate.stats.bandwidth import MAX_BINS
from inspect_validate.stats.sample import LatticeSample, Sample, as_sample

__all__ = [
    "TAIL_REACH",
    "Mixture",
    "binned_log_density",
    "density_parts",
    "kernel_density",
    "kernel_mixture",
    "log_density",
    "log_density_slope",
]

_EXACT_POINTS_MAX = 2**14


_BIN_FRACTION = 2000


TAIL_REACH = 40.0  # kernels are negligible beyond 40 h


_WINDOW_MIN = 256  # components above which a kernel density is summed in windows


_WINDOW_REACH = 20.0  # in h, beyond the nearest component


_WINDOW_WIDTHS_MAX = 16  # distinct kernel widths (classes in a group) summed part by part


_WINDOW_CHUNK = 64  # grid points per window (16 h at the crossing grid's step)


_LOG_SQRT_2PI = 0.5 * np.log(2.0 * np.pi)


_BINNED_FLOOR = 1e-10  # a tilt's FFT is used above this fraction of its maximum


_TILT_STEP = 6.0  # kernel widths between the peaks of successive tilts


_BINNED_ELEMENTS_MAX = 2**22  # tilts × FFT size (32 MB an array), else the exact grid


@dataclass(frozen=True)
class Mixture:
    """A Gaussian mixture: component means μ (DN), weights (summing to 1 within the
    mixture) and standard deviations σ (DN, one for all or one per component; 0: a
    point mass)."""

    centres: np.ndarray
    weights: np.ndarray
    sigmas: np.ndarray

    def __init__(self, centres: ArrayLike, weights: ArrayLike, sigmas: ArrayLike) -> None:
        c = np.asarray(centres, float)
        object.__setattr__(self, "centres", c)
        object.__setattr__(self, "weights", np.asarray(weights, float))
        object.__setattr__(self, "sigmas", np.broadcast_to(np.asarray(sigmas, float), c.shape))


def kernel_mixture(sample: Sample, h: float) -> tuple[np.ndarray, np.ndarray]:
    """Kernel centres (DN) and weights (summing to 1) of the density estimate (41)."""
    if not isinstance(sample, LatticeSample):
        sample = as_sample(sample)
    if isinstance(sample, LatticeSample):
        keep = sample.counts > 0
        return sample.points[keep], sample.counts[keep] / sample.n
    x = np.asarray(sample, dtype=np.float64)
    if h > 0.0 and x.size <= _EXACT_POINTS_MAX:
        return x, np.full(x.size, 1.0 / x.size)
    lo, hi = x.min(), x.max()
    step = h / _BIN_FRACTION
    if h == 0.0 or (hi - lo) / step > MAX_BINS:
        # A point mass per distinct value (h = 0: a constant float class), or, where
        # bins by span would not fit, one kernel per distinct value (sorting).
        values, counts = np.unique(x, return_counts=True)
        return values, counts / x.size
    from inspect_validate.stats._binning_kernels import linear_bin

    w, _, _ = linear_bin(x, lo, step, int(np.ceil((hi - lo) / step)) + 2)
    keep = w > 0
    return lo + np.flatnonzero(keep) * step, w[keep] / x.size


def kernel_density(sample: Sample, h: float, x: ArrayLike) -> np.ndarray:
    """The kernel density estimate (41) of ``sample`` with bandwidth ``h`` > 0 at grey values
    ``x``, 1/DN (what ε KDE integrates; for plots against a histogram)."""
    if not h > 0.0:
        raise ValueError(f"the bandwidth must be positive, not {h}")
    centres, weights = kernel_mixture(sample, h)
    parts = density_parts(centres, weights, np.full(centres.size, float(h)))
    return np.exp(log_density(x, parts))


def density_parts(centres: np.ndarray, weights: np.ndarray, sigma: np.ndarray) -> list:
    """A mixture as parts summed separately by :func:`log_density`.

    Many components of one width (a kernel density, or each class of a group's
    mixture of kernel densities) form a part evaluated in windows: each chunk
    of x sums only the components within ``d0 + 20 h`` of it, d0 the distance
    to the nearest component. The rest weigh less than e^{-200} relative to
    that nearest one (for weights ≥ 1e-70), so the sum is exact in float64 and
    its cost no longer grows as components × grid points. Anything else (a few
    Gaussians of their own widths) is one part summed in full.
    """
    # With return_counts np.unique does not import numpy.ma to look for a mask (7 ms).
    widths = np.unique(sigma, return_counts=True)[0]
    if centres.size <= _WINDOW_MIN or widths.size > _WINDOW_WIDTHS_MAX:
        return [(centres, np.log(weights) - np.log(sigma), sigma)]
    parts = []
    for h in widths:
        sel = sigma == h
        parts.append((centres[sel], np.log(weights[sel]) - np.log(h), float(h)))
    return parts


def log_density(x: ArrayLike, parts: list) -> np.ndarray:
    """log p(x) of a mixture given by :func:`density_parts`, for an array of x."""
    flat = np.ravel(np.asarray(x, dtype=np.float64))
    logs = []
    for centres, log_w, sigma in parts:
        out = np.empty(flat.shape)
        _summed(_log_density_all, flat, [out], centres, log_w, sigma)
        logs.append(out)
    total = logs[0] if len(logs) == 1 else np.logaddexp.reduce(np.stack(logs), axis=0)
    return total.reshape(np.shape(x)) - _LOG_SQRT_2PI


def _summed(kernel, x, outs, centres, log_w, sigma) -> None:
    """``kernel(x, *outs, centres, log_w, sigma)`` over a part's components: in full for a
    few components or one width each, else over the components near each chunk of x
    (sorted centres; the rest weigh nothing a double keeps, :func:`density_parts`)."""
    if np.ndim(sigma) or centres.size <= _WINDOW_MIN:
        kernel(x, *outs, centres, log_w, sigma)
        return
    order = np.argsort(x, kind="stable")
    xs = x[order]
    j = np.clip(np.searchsorted(centres, xs), 1, centres.size - 1)
    d0 = np.minimum(np.abs(xs - centres[j - 1]), np.abs(xs - centres[j]))
    values = [np.empty(xs.shape) for _ in outs]
    for part in _chunks(xs, sigma):
        reach = d0[part].max() + _WINDOW_REACH * sigma
        lo = np.searchsorted(centres, xs[part][0] - reach, side="left")
        hi = np.searchsorted(centres, xs[part][-1] + reach, side="right")
        kernel(xs[part], *(v[part] for v in values), centres[lo:hi], log_w[lo:hi], sigma)
    for out, v in zip(outs, values, strict=True):
        out[order] = v


def _chunks(xs, h):
    """Slices of sorted ``xs`` of at most :data:`_WINDOW_CHUNK` points spanning at most
    16 h each: a chunk's window is its span plus the reach, so scattered points (the
    crossings of two ragged densities, hundreds of h apart) are not summed over the
    components between them."""
    if not xs.size:
        return
    span = _WINDOW_CHUNK * 0.25 * h  # 64 points of the crossing grid's step
    cell = np.floor((xs - xs[0]) / span)
    starts = np.flatnonzero(np.diff(cell, prepend=-1.0))
    ends = np.append(starts[1:], xs.size)
    for start, end in zip(starts.tolist(), ends.tolist(), strict=True):
        for i in range(start, end, _WINDOW_CHUNK):
            yield slice(i, min(i + _WINDOW_CHUNK, end))


def _log_density_all(flat, out, centres, log_w, sigma) -> None:
    """Unnormalised log-density of every component at every point, in memory-bounded chunks."""
    if centres.size == 0:  # a window with no component in reach: a density of 0
        out[: flat.size] = -np.inf
        return
    chunk = max(1, 2**22 // max(1, centres.size))
    for i in range(0, flat.size, chunk):
        z = (flat[i : i + chunk, None] - centres[None, :]) / sigma
        v = log_w - 0.5 * z * z
        # logsumexp by hand: scipy's costs ~0.1 ms a call in the root searches' scalar calls.
        top = v.max(axis=1)
        safe = np.where(np.isfinite(top), top, 0.0)
        out[i : i + chunk] = safe + np.log(np.exp(v - safe[:, None]).sum(axis=1))


def log_density_slope(x: ArrayLike, parts: list) -> tuple[np.ndarray, np.ndarray]:
    """log p(x) (unnormalised as in :func:`log_density`) and d log p / dx.

    Each part is summed as :func:`log_density` sums it (:func:`_summed`: a root search
    over two classes of 65,536 distinct grey values summed every component at every step,
    minutes), and the parts are combined by their weights.
    """
    x = np.asarray(x, dtype=np.float64)
    logs, slopes = [], []
    for centres, log_w, sigma in parts:
        log_p, slope = np.empty(x.shape), np.empty(x.shape)
        _summed(_log_density_slope_all, x, [log_p, slope], centres, log_w, sigma)
        logs.append(log_p)
        slopes.append(slope)
    if len(logs) == 1:
        return logs[0], slopes[0]
    logs_, slopes_ = np.stack(logs), np.stack(slopes)
    total = np.logaddexp.reduce(logs_, axis=0)
    return total, (np.exp(logs_ - total) * slopes_).sum(axis=0)


def _log_density_slope_all(x, log_p, slope, centres, log_w, sigma) -> None:
    """log p and its slope at ``x`` summing every component given, into the outputs."""
    z = (x[:, None] - centres[None, :]) / sigma
    v = log_w - 0.5 * z * z
    top = v.max(axis=1, keepdims=True)
    e = np.exp(v - top)
    total = e.sum(axis=1)
    log_p[:] = top[:, 0] + np.log(total)
    slope[:] = (e * np.broadcast_to(-z / sigma, z.shape)).sum(axis=1) / total


def binned_log_density(grid: np.ndarray, parts: list) -> np.ndarray | None:
    """log p (as :func:`log_density`) of linearly binned ``parts`` on the regular ``grid``,
    NaN where no tilt (below) holds it above :data:`_BINNED_FLOOR` of its maximum; None
    when a part has a width per component (no single kernel to convolve with) or its
    tilts would exceed :data:`_BINNED_ELEMENTS_MAX` (classes hundreds of kernel widths
    apart, where the grid is long and the exact sums near each point are few).

    Each part's components are put on their two neighbouring grid points (linear
    binning) and convolved with the kernel sampled on the grid by FFT. An FFT is
    accurate only relative to its largest value, so the tails, which decide small
    errors, are computed tilted: e^{θ(x − x0)} p(x) = Σ_i w_i e^{θ(c_i − x0)} ·
    K(x − c_i) e^{θ(x − c_i)}, reweighted components convolved with the kernel shifted
    by θσ², whose peak lies out in the tail. Tilts θ = k · _TILT_STEP / σ place peaks
    about every 6σ out to the grid's ends; each grid point takes the tilt that holds it
    highest relative to that tilt's maximum, and the tilts are transformed together.
    """
    step = (grid[-1] - grid[0]) / (grid.size - 1)
    x0 = 0.5 * (grid[0] + grid[-1])
    logs = []
    for centres, log_w, sigma in parts:
        if np.ndim(sigma):
            return None
        pos = (centres - grid[0]) / step
        j = np.clip(np.floor(pos).astype(np.int64), 0, grid.size - 2)
        t = pos - j
        beyond = max(centres.min() - grid[0], grid[-1] - centres.max()) / sigma
        tilts = int(np.ceil(beyond / _TILT_STEP)) + 1
        reach = min(int(np.ceil((tilts * _TILT_STEP + TAIL_REACH) * sigma / step)), grid.size - 1)
        u = np.arange(-reach, reach + 1) * step
        size = 1 << int(np.ceil(np.log2(grid.size + u.size - 1)))
        if (2 * tilts + 1) * size > _BINNED_ELEMENTS_MAX:
            return None  # classes far apart: the exact windowed sums are cheaper
        theta = np.arange(-tilts, tilts + 1)[:, None] * (_TILT_STEP / sigma)  # (tilts, 1)
        a = log_w + theta * (centres - x0)
        a_max = a.max(axis=1, keepdims=True)
        w = np.exp(a - a_max)
        rows = np.arange(theta.size)[:, None] * grid.size + j  # flat (tilt, grid point)
        binned = np.bincount(rows.ravel(), (w * (1.0 - t)).ravel(), theta.size * grid.size)
        binned += np.bincount(rows.ravel() + 1, (w * t).ravel(), theta.size * grid.size)
        lk = theta * u - 0.5 * (u / sigma) ** 2
        lk_max = lk.max(axis=1, keepdims=True)
        spectrum = np.fft.rfft(binned.reshape(theta.size, grid.size), size)
        spectrum *= np.fft.rfft(np.exp(lk - lk_max), size)
        full = np.fft.irfft(spectrum, size)
        tilted = full[:, reach : reach + grid.size]
        with np.errstate(divide="ignore", invalid="ignore"):
            # The FFT rounds relative to a tilt's largest value, which may lie off the grid.
            relative = np.log(tilted / full.max(axis=1, keepdims=True))
            floor = np.log(_BINNED_FLOOR)
            k = np.argmax(np.where(relative > floor, relative, -np.inf), axis=0)
            at = np.arange(grid.size)
            value = np.log(tilted[k, at]) + a_max[k, 0] + lk_max[k, 0] - theta[k, 0] * (grid - x0)
        logs.append(np.where(relative[k, at] > floor, value, np.nan))
    if len(logs) > 1:
        with np.errstate(invalid="ignore"):  # NaN (not held by any tilt) stays NaN
            return np.logaddexp.reduce(np.stack(logs), axis=0) - _LOG_SQRT_2PI
    return logs[0] - _LOG_SQRT_2PI
