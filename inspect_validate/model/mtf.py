"""The sharpest a station's lens and pixels can be: the in-focus MTF from the optics.

An aberration-free lens at f-number N passes, at wavelength λ, the diffraction MTF of a
circular pupil (Goodman, *Introduction to Fourier Optics*, eq. 6-32):

    MTF_d(ν) = (2/π) (arccos s − s √(1 − s²)),  s = ν λ N ≤ 1 (0 beyond),

which falls to ½ at s = 0.4040: MTF50 ≈ 0.404/(λN). Light of a spectrum passes the mean of
MTF_d over the wavelengths, weighted by the electrons each brings (the light's SPD, the
lens's transmission and the sensor's quantum efficiency, as the prediction integrates
them, on a white target). A pixel of pitch p integrates its area: |sinc(ν p)| (100 %
fill factor). In cycles per pixel (ν p), the in-focus MTF is their product; defocus and
the lens's aberrations only lower it, so a lens measured well below it is out of focus
or not as good as its f-number.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

__all__ = [
    "DIFFRACTION_MTF50",
    "blur_sigma",
    "diffraction_mtf",
    "falls_to",
    "focus_mtf",
    "texture_kernel",
    "texture_share",
]

DIFFRACTION_MTF50 = 0.40397
"""s = ν λ N where a circular pupil's diffraction MTF falls to ½."""


def diffraction_mtf(s: ArrayLike) -> np.ndarray:
    """The diffraction MTF of a circular pupil at normalised frequency ``s`` = ν λ N
    (eq. 6-32 of Goodman), 0 at and beyond the cut-off s = 1."""
    x = np.clip(np.abs(np.asarray(s, float)), 0.0, 1.0)
    return (2.0 / np.pi) * (np.arccos(x) - x * np.sqrt(1.0 - x * x))


def focus_mtf(
    frequencies: ArrayLike,
    *,
    wavelengths: ArrayLike,
    weights: ArrayLike,
    f_number: float,
    pixel_pitch: float,
) -> np.ndarray:
    """The in-focus MTF at ``frequencies`` (cycles/px): the diffraction MTF averaged over
    ``wavelengths`` (nm) with ``weights`` (the electrons each brings), times the pixel's
    aperture |sinc ν|.

    Parameters
    ----------
    frequencies : array_like
        cycles/px.
    wavelengths : array_like, (W,)
        nm.
    weights : array_like, (W,)
        Any non-negative scale; at least one above 0.
    f_number : float, keyword-only
        The lens's working f-number N.
    pixel_pitch : float, keyword-only
        µm.
    """
    f = np.asarray(frequencies, float)
    lam = np.asarray(wavelengths, float)
    w = np.clip(np.asarray(weights, float), 0.0, None)
    if not w.sum() > 0:
        raise ValueError("no wavelength brings light: the weights are all 0")
    # ν λ N with ν in cycles/µm: f / p
    s = (f[..., None] / pixel_pitch) * (lam * 1e-3) * f_number
    diffraction = diffraction_mtf(s) @ (w / w.sum())
    return diffraction * np.abs(np.sinc(f))


def falls_to(frequencies: ArrayLike, mtf: ArrayLike, modulation: float = 0.5) -> float:
    """The first frequency where ``mtf`` falls below ``modulation`` (½: MTF50),
    interpolated linearly between samples; NaN where it stays above."""
    f, m = np.asarray(frequencies, float), np.asarray(mtf, float)
    below = np.flatnonzero(m < modulation)
    if below.size == 0 or below[0] == 0:
        return float("nan")
    k = below[0]
    return float(f[k - 1] + (m[k - 1] - modulation) * (f[k] - f[k - 1]) / (m[k - 1] - m[k]))


def blur_sigma(mtf50: float) -> float:
    """The Gaussian blur σ (px) whose MTF times the pixel's aperture falls to ½ at
    ``mtf50`` (cycles/px): |sinc ν|·exp(−2π²σ²ν²) = ½ (0 where the pixel alone is that
    blurred; NaN for no MTF50). The lens's blur as one Gaussian, whatever made it."""
    if not (np.isfinite(mtf50) and mtf50 > 0):
        return float("nan")
    left = 2.0 * abs(float(np.sinc(mtf50)))
    return float(np.sqrt(np.log(left) / (2 * np.pi**2 * mtf50**2))) if left > 1 else 0.0


def texture_kernel(sigma: float) -> np.ndarray:
    """The share of a pixel-sized patch of the object that each pixel at offset −n…n
    collects through a Gaussian blur of ``sigma`` px (1-D, summing to 1): the patch's
    box, the blur and the pixel's box, (box ∗ box ∗ G)(d) = (triangle ∗ G)(d), in closed
    form from the normal CDF."""
    from scipy.special import ndtr

    n = int(np.ceil(6 * sigma)) + 2
    d = np.arange(-n, n + 1, dtype=float)
    if not sigma > 0:
        return (d == 0).astype(float)

    def ramp(x):  # (G ∗ max(x, 0)): the triangle is the second difference of max(x, 0)
        z = x / sigma
        return x * ndtr(z) + sigma * np.exp(-0.5 * z * z) / np.sqrt(2 * np.pi)

    return ramp(d + 1) - 2 * ramp(d) + ramp(d - 1)


def texture_share(sigma: float) -> float:
    """The share of a texture's variance that a Gaussian blur of ``sigma`` px leaves,
    where each pixel shows an independent sample (the model's texture): Σ c(d)² in each
    direction of :func:`texture_kernel`'s c, squared for the two (1 without blur)."""
    c = texture_kernel(sigma)
    return float(np.sum(c * c) ** 2)
