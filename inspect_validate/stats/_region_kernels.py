"""Compiled single-pass kernels behind :func:`inspect_validate.stats.region_statistics`.

Kept in their own module so that numba (≈0.5 s to import) is loaded only when a
region is actually measured, never at CLI start-up. ``cache=True`` stores the
compiled code next to this file, so the JIT cost is paid once per install.

The lattice code of a raw value x at pixel p is ``scale·x − dark_sum[p]``
(``scale`` = number of dark frames, or 1 and no dark): an integer, so every
accumulator is an exact int64.
"""

import numba as nb
import numpy as np


@nb.njit(cache=True, inline="always")
def _code(frames, dark_sum, has_dark, scale, f, i, j):
    c = np.int64(frames[f, i, j]) * scale
    if has_dark:
        c -= dark_sum[i, j]
    return c


@nb.njit(parallel=True, cache=True)
def _code_range(frames, mask, dark_sum, scale):
    n_frames, height, width = frames.shape
    has_dark = dark_sum.shape[0] == height and dark_sum.shape[1] == width
    lo = np.full(height, np.iinfo(np.int64).max, np.int64)
    hi = np.full(height, np.iinfo(np.int64).min, np.int64)
    for i in nb.prange(height):
        a = lo[i]
        b = hi[i]
        for j in range(width):
            if mask[i, j]:
                for f in range(n_frames):
                    c = _code(frames, dark_sum, has_dark, scale, f, i, j)
                    a = min(a, c)
                    b = max(b, c)
        lo[i] = a
        hi[i] = b
    return lo.min(), hi.max()


def masked_code_range(frames, mask, dark_sum, scale) -> tuple[int, int]:
    """Smallest and largest lattice code under the mask."""
    lo, hi = _code_range(frames, mask, dark_sum, np.int64(scale))
    return int(lo), int(hi)


@nb.njit(parallel=True, cache=True)
def _accumulate(frames, mask, dark_sum, scale, lo, nbins, ref, sat, n_chunks):
    n_frames, height, width = frames.shape
    has_dark = dark_sum.shape[0] == height and dark_sum.shape[1] == width
    hist = np.zeros((n_chunks, nbins), np.int64)
    rows = np.zeros((height, 3), np.int64)
    counts = np.zeros((n_chunks, 2), np.int64)
    chunk = (height + n_chunks - 1) // n_chunks
    for t in nb.prange(n_chunks):
        h = hist[t]
        n_sat = 0
        n_zero = 0
        for i in range(t * chunk, min(height, (t + 1) * chunk)):
            sum_s = 0
            sum_s2 = 0
            sum_t = 0
            for j in range(width):
                if mask[i, j]:
                    s = 0
                    q = 0
                    for f in range(n_frames):
                        x = np.int64(frames[f, i, j])
                        n_sat += x >= sat
                        n_zero += x <= 0
                        c = x * scale
                        if has_dark:
                            c -= dark_sum[i, j]
                        h[c - lo] += 1
                        c -= ref
                        s += c
                        q += c * c
                    sum_s += s
                    sum_s2 += s * s
                    sum_t += n_frames * q - s * s
            rows[i, 0] = sum_s
            rows[i, 1] = sum_s2
            rows[i, 2] = sum_t
        counts[t, 0] = n_sat
        counts[t, 1] = n_zero
    return hist.sum(axis=0), rows, counts[:, 0].sum(), counts[:, 1].sum()


@nb.njit(parallel=True, cache=True)
def _histogram(frames, mask, lo, nbins, n_chunks):
    n_frames, height, width = frames.shape
    hist = np.zeros((n_chunks, nbins), np.int64)
    chunk = (height + n_chunks - 1) // n_chunks
    for t in nb.prange(n_chunks):
        h = hist[t]
        for i in range(t * chunk, min(height, (t + 1) * chunk)):
            for j in range(width):
                if mask[i, j]:
                    for f in range(n_frames):
                        h[np.int64(frames[f, i, j]) - lo] += 1
    return hist.sum(axis=0)


def histogram(frames, mask, lo, nbins):
    """Pooled histogram of raw values ``lo .. lo + nbins - 1`` under the mask, all frames."""
    n_chunks = max(1, min(nb.get_num_threads(), frames.shape[1]))
    return _histogram(frames, mask, np.int64(lo), nbins, n_chunks)


def accumulate(frames, mask, dark_sum, scale, lo, nbins, ref, sat):
    """Pooled histogram, per-row exact moment sums and saturation counts in one pass.

    Returns
    -------
    hist : ndarray of int64, shape (nbins,)
        Counts of codes ``lo .. lo + nbins - 1`` over all frames.
    rows : ndarray of int64, shape (H, 3)
        Per row, over the masked pixels p with s_p = Σ_f (code − ref):
        Σ s_p, Σ s_p², Σ (F·Σ_f (code − ref)² − s_p²).
    n_sat, n_zero : int
        Raw values ≥ ``sat`` and ≤ 0.
    """
    n_chunks = max(1, min(nb.get_num_threads(), frames.shape[1]))
    return _accumulate(
        frames, mask, dark_sum, np.int64(scale), np.int64(lo), nbins, np.int64(ref), sat, n_chunks
    )
