"""The sharpness of lens and sensor from a slanted edge: the modulation transfer function
(MTF) as ISO 12233's edge method (e-SFR) measures it, as MTF Mapper and Burns' sfrmat do.

A straight edge between a dark and a light area, turned a few degrees from a pixel
column (or row), is sampled by every row at another phase: the rows together sample the
edge's profile, the edge spread function (ESF), far finer than a pixel. The steps:

1. each row's edge position, the centroid of its derivative (a Hamming window about
   the edge, from a first unwindowed pass);
2. a line fitted through the rows' centroids: the edge's position and angle;
3. every pixel's signed distance from that line, along the edge's normal, binned at a
   quarter pixel: the ESF, a mean per bin (empty bins interpolated);
4. its derivative, the line spread function (LSF), central differences, under a Hamming
   window centred on its peak;
5. the magnitude of its Fourier transform, normalised at 0: the MTF, over cycles per
   pixel along the normal, divided by the central difference's response
   sin(2πfΔ)/(2πfΔ), Δ the bin width (as ISO 12233 and sfrmat; dividing by the bins'
   averaging, sinc fΔ, too took drawn edges from within 0.7 % of their closed form to
   0.9 %).

Binning along the normal, not along the row, puts the frequencies on the normal's
scale without the 1/cos θ correction that ISO 12233:2023 applies to row-binned
profiles. MTF50, the frequency where the MTF falls to ½, summarises the curve; a lens in
focus at f-number N passes about 0.404/(λN) by diffraction alone.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from inspect_validate.errors import InputError

__all__ = ["EdgeMTF", "edge_mtf"]

MIN_ANGLE_DEG = 1.0
"""An edge closer than this to a pixel column or row samples too few phases."""
MAX_ANGLE_DEG = 30.0
"""An edge turned further is read along the other axis, or not an edge of this kind."""


@dataclass(frozen=True)
class EdgeMTF:
    """A slanted edge's MTF.

    Attributes
    ----------
    frequencies : ndarray
        Along the edge's normal, cycles/px, 0 to 1.
    mtf : ndarray
        The modulation transferred at each frequency, 1 at 0.
    angle_deg : float
        The edge's tilt from the pixel column (a vertical edge) or row, degrees.
    vertical : bool
        Whether the edge runs along the columns (else along the rows).
    contrast : float
        The light side's level less the dark side's, DN.
    """

    frequencies: np.ndarray
    mtf: np.ndarray
    angle_deg: float
    vertical: bool
    contrast: float

    @property
    def mtf50(self) -> float:
        """The frequency where the MTF first falls to ½, cycles/px (NaN where it never
        does below 1 cycle/px)."""
        return self.frequency_at(0.5)

    def frequency_at(self, modulation: float) -> float:
        """The frequency where the MTF first falls to ``modulation``, cycles/px,
        interpolated linearly between samples; NaN where it stays above."""
        from inspect_validate.model.mtf import falls_to

        return falls_to(self.frequencies, self.mtf, modulation)

    def at(self, frequency: float) -> float:
        """The MTF at ``frequency`` cycles/px, interpolated linearly."""
        return float(np.interp(frequency, self.frequencies, self.mtf))


def edge_mtf(image: ArrayLike, *, oversampling: int = 4) -> EdgeMTF:
    """The MTF of the slanted edge in ``image`` (module description).

    Parameters
    ----------
    image : array_like, (H, W)
        A region holding one straight edge between a dark and a light area, turned
        1–30° from a pixel column or row, DN (dark-subtracted or not: the MTF is of the
        step, whatever its offset).
    oversampling : int, keyword-only
        Bins per pixel of the edge spread function (ISO 12233: 4).

    Returns
    -------
    EdgeMTF

    Raises
    ------
    InputError
        No edge (a flat region), an edge closer than 1° to a pixel column or row or
        turned beyond 30°, or too few rows to sample every phase.
    """
    values = np.asarray(image, dtype=np.float64)
    if values.ndim != 2 or min(values.shape) < 8:
        raise InputError(
            f"an edge region is a 2-D image of 8 px or more a side, not {values.shape}"
        )
    if not np.all(np.isfinite(values)):
        raise InputError("the edge region holds NaN or infinite values")
    # Along which axis the values change: a vertical edge changes them along the rows.
    across_rows = np.abs(np.diff(values, axis=1)).mean()
    across_columns = np.abs(np.diff(values, axis=0)).mean()
    vertical = bool(across_rows >= across_columns)
    if not vertical:
        values = values.T
    rows, cols = values.shape
    derivative = np.diff(values, axis=1)  # at x = j + ½
    sign = 1.0 if derivative.sum() >= 0 else -1.0
    derivative *= sign
    x = np.arange(cols - 1) + 0.5
    centres = _centroids(derivative, x, None)
    if not np.all(np.isfinite(centres)):
        raise InputError("the region shows no edge: a row without a step across it")
    line = np.polyfit(np.arange(rows), centres, 1)
    # Again with a Hamming window about the fitted edge: the far pixels' noise out.
    centres = _centroids(derivative, x, np.polyval(line, np.arange(rows)))
    slope, offset = np.polyfit(np.arange(rows), centres, 1)
    angle = math.degrees(math.atan(slope))
    if not MIN_ANGLE_DEG <= abs(angle) <= MAX_ANGLE_DEG:
        raise InputError(
            f"the edge is turned {abs(angle):.2f}° from the pixel "
            f"{'columns' if vertical else 'rows'}; give an edge turned "
            f"{MIN_ANGLE_DEG:g}–{MAX_ANGLE_DEG:g}° (ISO 12233 uses about 5°)"
        )
    if rows * abs(slope) < 1.0:
        raise InputError(
            f"{rows} rows along an edge turned {abs(angle):.2f}° cross {rows * abs(slope):.2f} "
            "px: every phase needs a whole pixel; give a longer edge"
        )
    # Every pixel's distance from the edge along its normal, binned.
    yy, xx = np.mgrid[0:rows, 0:cols]
    normal = (xx - (offset + slope * yy)) * math.cos(math.atan(slope))
    step = 1.0 / oversampling
    index = np.floor(normal / step).astype(np.int64).ravel()
    index -= index.min()
    counts = np.bincount(index)
    sums = np.bincount(index, weights=values.ravel())
    filled = counts > 0
    bins = np.arange(counts.size)
    esf = np.interp(bins, bins[filled], sums[filled] / counts[filled])
    # Keep the bins that many rows reach (the region's corners hold few).
    full = counts >= max(1, int(0.5 * np.median(counts[filled])))
    first, last = np.flatnonzero(full)[[0, -1]]
    esf = esf[first : last + 1]
    lsf = np.zeros_like(esf)
    lsf[1:-1] = 0.5 * (esf[2:] - esf[:-2])
    lsf *= sign
    peak = float(np.sum(np.arange(lsf.size) * np.abs(lsf)) / np.sum(np.abs(lsf)))
    lsf *= _hamming(lsf.size, peak)
    spectrum = np.abs(np.fft.rfft(lsf))
    if not spectrum[0] > 0:
        raise InputError("the region shows no edge: its profile has no step")
    frequencies = np.fft.rfftfreq(lsf.size, d=step)
    keep = frequencies <= 1.0
    frequencies, mtf = frequencies[keep], spectrum[keep] / spectrum[0]
    # The central difference's own response, divided out.
    with np.errstate(invalid="ignore", divide="ignore"):
        w = 2.0 * np.pi * frequencies * step
        mtf = mtf / np.where(w > 0, np.sin(w) / w, 1.0)
    contrast = float(sign * (np.median(esf[-oversampling:]) - np.median(esf[:oversampling])))
    return EdgeMTF(frequencies, mtf, angle, vertical, contrast)


def _centroids(derivative: np.ndarray, x: np.ndarray, about: np.ndarray | None) -> np.ndarray:
    """Each row's centroid of ``derivative`` (at positions ``x``), under a Hamming window
    centred at ``about`` (per row) where given."""
    # Signed: noise's derivative averages out (clipped at 0 it pulled every centroid
    # towards the window's middle, and the fitted edge towards upright).
    weights = derivative
    if about is not None:
        width = x.size
        weights = (
            weights
            * (0.54 + 0.46 * np.cos(2 * np.pi * (x[None, :] - about[:, None]) / width))
            * (np.abs(x[None, :] - about[:, None]) <= width / 2)
        )
    total = weights.sum(axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(total > 0, (weights * x).sum(axis=1) / total, np.nan)


def _hamming(size: int, centre: float) -> np.ndarray:
    """A Hamming window over ``size`` samples centred at ``centre`` (ISO 12233's for the
    LSF: its whole width either side of the peak)."""
    k = np.arange(size)
    half = max(centre, size - 1 - centre)
    return 0.54 + 0.46 * np.cos(np.pi * (k - centre) / half)
