"""numpy versions of :mod:`~inspect_validate.stats._region_kernels`, for small stacks.

The same results, exactly (int64 throughout), from blocks of rows: a few hundred
thousand values at a time, so memory stays bounded. The compiled kernels are
faster per value, but loading numba costs about 0.5 s per process, far more than a
small stack takes here (a 280 × 80 px region of 4 frames of 320 × 240, the shipped
station's size: 1.7 ms); see :data:`~inspect_validate.stats.region.BLOCKS_VALUES_MAX`
for where the choice falls.
"""

from __future__ import annotations

import numpy as np

_BLOCK_VALUES = 2**18


def _blocks(frames, mask, dark_sum, scale):
    """Per block of rows: (first row, the block's mask, its codes as (F, k) int64)."""
    n_frames, height, width = frames.shape
    has_dark = dark_sum.shape == (height, width)
    step = max(1, _BLOCK_VALUES // (width * n_frames))
    used = np.flatnonzero(mask.any(axis=1))
    for i in range(used[0], used[-1] + 1, step) if used.size else ():
        m = mask[i : i + step]
        raw = frames[:, i : i + step][:, m]
        codes = raw.astype(np.int64)
        codes *= scale
        if has_dark:
            codes -= dark_sum[i : i + step][m]
        yield i, m, raw, codes


def masked_code_range(frames, mask, dark_sum, scale) -> tuple[int, int]:
    """Smallest and largest lattice code under the mask."""
    lo, hi = np.iinfo(np.int64).max, np.iinfo(np.int64).min
    for _, _, _, codes in _blocks(frames, mask, dark_sum, scale):
        lo, hi = min(lo, int(codes.min())), max(hi, int(codes.max()))
    return lo, hi


def _count(hist, codes, lo) -> None:
    """Add the codes' counts to ``hist`` (bin 0 is code ``lo``)."""
    if hist.size <= 4 * codes.size:
        hist += np.bincount((codes - lo).ravel(), minlength=hist.size)
    else:  # a wide histogram: counting by sorting costs the block, not the bins
        values, counts = np.unique(codes, return_counts=True)
        hist[values - lo] += counts


def histogram(frames, mask, lo, nbins):
    """Pooled histogram of raw values ``lo .. lo + nbins - 1`` under the mask, all frames."""
    hist = np.zeros(nbins, np.int64)
    for _, _, _, codes in _blocks(frames, mask, np.zeros((1, 1), np.int64), 1):
        _count(hist, codes, lo)
    return hist


def accumulate(frames, mask, dark_sum, scale, lo, nbins, ref, sat):
    """As :func:`inspect_validate.stats._region_kernels.accumulate`, the same numbers."""
    n_frames, height, _ = frames.shape
    hist = np.zeros(nbins, np.int64)
    rows = np.zeros((height, 3), np.int64)
    n_sat = n_zero = 0
    for i, m, raw, codes in _blocks(frames, mask, dark_sum, scale):
        n_sat += int(np.count_nonzero(raw >= sat))
        n_zero += int(np.count_nonzero(raw <= 0))
        _count(hist, codes, lo)
        codes -= ref
        s = codes.sum(axis=0)
        t = n_frames * np.einsum("fk,fk->k", codes, codes) - s * s
        # Masked pixels come row by row (C order): each row's sums are one segment.
        per_row = np.count_nonzero(m, axis=1)
        present = np.flatnonzero(per_row)
        starts = np.concatenate(([0], np.cumsum(per_row[present])[:-1]))
        rows[i + present, 0] = np.add.reduceat(s, starts)
        rows[i + present, 1] = np.add.reduceat(s * s, starts)
        rows[i + present, 2] = np.add.reduceat(t, starts)
    return hist, rows, n_sat, n_zero
