"""The light's field over the frame: how the irradiance reaching each pixel, through the
lens, falls off from its brightest point, measured on a flat target.

A uniform white card filling the frame is captured under an illumination and in the
dark; the mean of its frames less the mean dark frame is the field times the card's
(uniform) signal. Sensor noise and the pixels' own response (PRNU) are fine-grained;
vignetting (cos⁴ and the lens's aperture) and a light's falloff are smooth. So the
frame is averaged in blocks and a smooth surface is fitted to the block means: a
polynomial in the frame's centred coordinates (x, y scaled to ±1) of total degree
:data:`DEGREE`, which holds a radial falloff (r², r⁴) times a linear gradient across the
frame, as a bar light beside a vignetting lens gives (HALCON's ``fit_surface_second_order``
holds a gradient or a vignetting, not both at once). The surface, divided by its
maximum over the frame, is the field F(x, y) ≤ 1.

Each class's region then sees its own share of the light: its mean factor m = E[F] over
the region's pixels, and its spread v = Var[F]/m² (a pixel at F x of the signal S shows
F·S, so the region's variance gains v·(m S)²).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike

from inspect_validate.errors import InputError

if TYPE_CHECKING:
    from collections.abc import Mapping, Sequence

__all__ = [
    "BLOCK",
    "DEGREE",
    "Field",
    "RegionField",
    "degree_of",
    "field_factors",
    "fit_field",
    "lowest",
    "part_slopes",
    "region_field",
]

DEGREE = 4
"""Total degree of the fitted surface: r⁴ vignetting, and r² times a linear gradient."""
MIN_FIELD = 0.05
"""A field below this share of its brightest point anywhere in the frame is no lens's or
light's falloff: the card does not fill the frame, or lies in a shadow."""
BLOCK = 8
"""Pixels a side of the blocks averaged before the fit (a block's mean carries 1/64 of a
pixel's noise; the field moves by under 10⁻⁴ across a block of a 320 px frame)."""


@dataclass(frozen=True)
class RegionField:
    """The field over one region: its mean factor ``mean`` (E[F]), the relative variance
    ``spread`` (Var[F]/E[F]²), and the lowest and highest F in it."""

    mean: float
    spread: float
    low: float
    high: float


@dataclass(frozen=True)
class Field:
    """An illumination's field over a frame of ``width`` × ``height`` px.

    Attributes
    ----------
    coefficients : tuple of float
        Of the monomials xⁱ yʲ (i + j ≤ :data:`DEGREE`, in :func:`_exponents` order), x and
        y the pixel centre's coordinates scaled to ±1 at the frame's edge pixels, divided
        by the surface's maximum.
    residual : float
        RMS of the block means about the fitted surface, relative to the surface: what the
        smooth surface leaves (sensor noise, a card not quite uniform).
    signal : float
        The card's signal at the field's brightest point, DN above dark.
    """

    width: int
    height: int
    coefficients: tuple[float, ...]
    residual: float
    signal: float

    def at(self, x: ArrayLike, y: ArrayLike) -> np.ndarray:
        """F at pixel coordinates (``x`` along a row, ``y`` down; 0 the first pixel's
        centre), relative to the field's maximum."""
        u, v = _scaled(np.asarray(x, float), np.asarray(y, float), self.width, self.height)
        return _design(u, v, degree_of(len(self.coefficients))) @ np.asarray(self.coefficients)

    def map(self) -> np.ndarray:
        """F at every pixel, (height, width): Σᵢ uⁱ·(Σⱼ cᵢⱼ vʲ), an outer product for each
        power of u (the monomials of every pixel at once would take 15 × 8 bytes a pixel,
        0.6 GB at 5 MP)."""
        u, v = _scaled(
            np.arange(self.width, dtype=float), np.arange(self.height, dtype=float),
            self.width, self.height,
        )  # fmt: skip
        degree = degree_of(len(self.coefficients))
        columns = np.zeros((degree + 1, self.height))
        for c, (i, j) in zip(self.coefficients, _exponents(degree), strict=True):
            columns[i] += c * v**j
        out = np.zeros((self.height, self.width))
        for i in range(degree + 1):
            out += np.outer(columns[i], u**i)
        return out

    @property
    def corners(self) -> np.ndarray:
        """F at the four corner pixels (top left, top right, bottom left, bottom right)."""
        w, h = self.width - 1, self.height - 1
        return self.at(np.array([0, w, 0, w]), np.array([0, 0, h, h]))

    @property
    def corner_falloff(self) -> float:
        """1 − the corners' mean F: the light the corners lose against the brightest
        point."""
        return float(1.0 - self.corners.mean())

    @property
    def uniformity(self) -> float:
        """min F / max F over the frame."""
        f = self.map()
        return float(f.min() / f.max())


def fit_field(flat: ArrayLike, *, block: int = BLOCK, degree: int = DEGREE) -> Field:
    """Fit the field to a flat target's mean frame less the mean dark frame (DN).

    Parameters
    ----------
    flat : array_like, (height, width)
        The dark-subtracted mean of the flat target's frames, DN.
    block : int, keyword-only
        Pixels a side of the blocks averaged before the fit (edge blocks that do not fill
        are left out).
    degree : int, keyword-only
        The surface's total degree.

    Raises
    ------
    InputError
        A frame too small for the surface's coefficients, not finite, or with no light
        above dark.
    """
    image = np.asarray(flat, float)
    if image.ndim != 2:
        raise InputError(f"a flat target's frame is one 2-D image, not of shape {image.shape}")
    h, w = image.shape
    bh, bw = h // block, w // block
    n_terms = len(_exponents(degree))
    if bh * bw < 4 * n_terms:
        raise InputError(
            f"a {w}×{h} frame holds {bh * bw} blocks of {block} px: too few for a surface of "
            f"{n_terms} coefficients (it needs {4 * n_terms})"
        )
    blocks = image[: bh * block, : bw * block].reshape(bh, block, bw, block).mean(axis=(1, 3))
    if not np.isfinite(blocks).all():
        raise InputError("the flat target's frame holds values that are not finite")
    # each block's centre, in pixel coordinates
    yc = (np.arange(bh) * block + (block - 1) / 2)[:, None] * np.ones((1, bw))
    xc = (np.arange(bw) * block + (block - 1) / 2)[None, :] * np.ones((bh, 1))
    u, v = _scaled(xc.ravel(), yc.ravel(), w, h)
    design = _design(u, v, degree)
    coefficients, *_ = np.linalg.lstsq(design, blocks.ravel(), rcond=None)
    fitted = design @ coefficients
    xx, yy = _grid(w, h)
    gx, gy = _scaled(xx, yy, w, h)
    top = float((_design(gx, gy, degree) @ coefficients).max())
    if not top > 0:
        raise InputError(
            "the flat target shows no light above dark: is the card lit, and the dark "
            "frames taken with the light off?"
        )
    residual = float(np.sqrt(np.mean(((blocks.ravel() - fitted) / top) ** 2)))
    field = Field(w, h, tuple(float(c) for c in coefficients / top), residual, top)
    low = lowest(field)
    if not low > MIN_FIELD:
        raise InputError(
            f"the field falls to {low:.3g} of its brightest point within the frame: the "
            "card does not fill the frame evenly lit (a shadow, an edge of the card in "
            "view); fill the frame with it and capture it again"
        )
    return field


def lowest(field: Field) -> float:
    """The least F over the frame (on every 4th pixel and the frame's edges)."""
    return float(field.at(*_grid(field.width, field.height)).min())


def _grid(width: int, height: int) -> tuple[np.ndarray, np.ndarray]:
    """x, y of every 4th pixel and the frame's edge pixels: where a smooth surface's
    extremes over the frame are found (a polynomial's lie inside or on the edges)."""
    yy, xx = np.meshgrid(
        np.unique(np.r_[np.arange(0, height, 4), height - 1]),
        np.unique(np.r_[np.arange(0, width, 4), width - 1]),
        indexing="ij",
    )
    return xx.ravel(), yy.ravel()


def region_field(field: Field, mask: ArrayLike) -> RegionField:
    """The field over the pixels of ``mask`` (a boolean image of the field's frame size).

    Raises
    ------
    InputError
        A mask of another size than the field's frame, or of no pixel.
    """
    mask = np.asarray(mask, bool)
    if mask.shape != (field.height, field.width):
        raise InputError(
            f"the field was measured on {field.width}×{field.height} frames, and the "
            f"regions are drawn on {mask.shape[1]}×{mask.shape[0]}: measure the field with "
            "this camera's frames"
        )
    y, x = np.nonzero(mask)
    if not y.size:
        raise InputError("a region of no pixel has no field")
    f = field.at(x, y)
    m = float(f.mean())
    return RegionField(m, float(f.var() / (m * m)), float(f.min()), float(f.max()))


def field_factors(
    fields: Mapping[str, Field],
    masks: Mapping[str, np.ndarray],
    illuminations: Sequence[str],
    classes: Sequence[str],
) -> np.ndarray:
    """(illumination, class, 2): each region's mean factor m and spread v under each
    illumination (m = 1, v = 0 where the field of an illumination is not given)."""
    out = np.zeros((len(illuminations), len(classes), 2))
    out[..., 0] = 1.0
    for i, ill in enumerate(illuminations):
        if ill in fields:
            for k, name in enumerate(classes):
                r = region_field(fields[ill], masks[name])
                out[i, k] = r.mean, r.spread
    return out


def _exponents(degree: int = DEGREE) -> list[tuple[int, int]]:
    """(i, j) of the monomials xⁱ yʲ of total degree ≤ ``degree``, by degree."""
    return [(i, d - i) for d in range(degree + 1) for i in range(d, -1, -1)]


def _design(u: np.ndarray, v: np.ndarray, degree: int) -> np.ndarray:
    """The monomials of ``u``, ``v`` (any shape) as the last axis."""
    return np.stack([u**i * v**j for i, j in _exponents(degree)], axis=-1)


def _scaled(x: np.ndarray, y: np.ndarray, width: int, height: int) -> tuple[np.ndarray, np.ndarray]:
    """Pixel coordinates as ±1 at the frame's edge pixels' centres."""
    cx, cy = (width - 1) / 2, (height - 1) / 2
    return (x - cx) / max(cx, 0.5), (y - cy) / max(cy, 0.5)


def degree_of(n_coefficients: int) -> int:
    """The total degree a surface of ``n_coefficients`` monomials has."""
    d = (math.isqrt(8 * n_coefficients + 1) - 3) // 2
    if len(_exponents(d)) != n_coefficients:
        raise ValueError(f"{n_coefficients} coefficients are no polynomial surface's")
    return d


def part_slopes(means: ArrayLike, x: ArrayLike, y: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
    """The field as parts that move show it: a class's μ (signal above dark) of each part
    against where the part lies, fitted as a plane; its slopes along x and y relative to
    its mean, per 100 px, and their standard errors (ordinary least squares). NaN where
    fewer than 4 parts hold all three, or the parts do not move along an axis.

    Parameters
    ----------
    means : array_like, (m,)
        The class's μ of each part, DN above dark.
    x, y : array_like, (m,)
        Each part's position, px.
    """
    mu, xs, ys = (np.asarray(a, float) for a in (means, x, y))
    keep = np.isfinite(mu) & np.isfinite(xs) & np.isfinite(ys)
    mu, xs, ys = mu[keep], xs[keep], ys[keep]
    nan = np.full(2, np.nan)
    if mu.size < 4 or not mu.mean() > 0:
        return nan, nan
    design = np.column_stack([np.ones_like(xs), (xs - xs.mean()) / 100, (ys - ys.mean()) / 100])
    gram = design.T @ design
    if np.linalg.cond(gram) > 1e12:  # the parts lie along a line or in one place
        return nan, nan
    coef, *_ = np.linalg.lstsq(design, mu, rcond=None)
    residual = mu - design @ coef
    dof = mu.size - 3
    s2 = float(residual @ residual) / dof if dof > 0 else np.nan
    se = np.sqrt(np.diag(np.linalg.inv(gram)) * s2)
    return coef[1:] / coef[0], se[1:] / coef[0]
