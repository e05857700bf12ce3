"""Where the part is: its pose in a production frame against a reference frame of a good
part, so that the regions (drawn on the reference) follow it.

The anchors of the field do the same before they compare pixels: HALCON's variation model
aligns by shape-based matching, In-Sight fixtures its tools to the located part. Here, in
two stages on the template (a window of the reference holding the part):

1. **coarse:** normalised cross-correlation (``cv2.matchTemplate``, ``TM_CCOEFF_NORMED``)
   of the template in the frame, both averaged down by a power of two until the template
   is about :data:`COARSE_SIZE` px across; the peak is the translation to the pixel of
   that level;
2. **fine:** ``cv2.findTransformECC`` (Evangelidis & Psarakis 2008) from that start, at
   full resolution, with the motion asked for: translation, euclidean (translation and
   rotation) or affine. Its correlation coefficient is the match score.

A pose maps reference coordinates to frame coordinates, in the pixel-corner convention
of :mod:`inspect_validate.roi.shapes` (pixel (x, y) covers [x, x + 1) × [y, y + 1)).
The frame itself is never resampled: the regions are moved
(:func:`~inspect_validate.roi.pose.moved_masks`), so a class's σ² is its pixels' own.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

import numpy as np

from inspect_validate.errors import InputError

__all__ = [
    "COARSE_SIZE",
    "MOTIONS",
    "Motion",
    "MovedRegions",
    "Pose",
    "locate_part",
    "moved_masks",
]

Motion = Literal["translation", "euclidean", "affine"]
MOTIONS: tuple[Motion, ...] = ("translation", "euclidean", "affine")
COARSE_SIZE = 64
"""Pixels across the template at the coarse search's level (its smaller side)."""
_ECC_ITERATIONS = 100
_ECC_EPS = 1e-6


@dataclass(frozen=True)
class Pose:
    """A part's pose: ``matrix`` (2 × 3) maps a reference point (x, y, pixel corners) to
    the frame, ``score`` is the match (ECC's correlation coefficient, 1: identical up to
    brightness and contrast)."""

    matrix: np.ndarray
    score: float

    @property
    def shift(self) -> tuple[float, float]:
        """Where the reference's origin lands, px (dx, dy)."""
        return float(self.matrix[0, 2]), float(self.matrix[1, 2])

    @property
    def angle_deg(self) -> float:
        """The rotation, degrees (counter-clockwise on the screen is negative: y points
        down)."""
        return math.degrees(math.atan2(self.matrix[1, 0], self.matrix[0, 0]))

    @property
    def scale(self) -> float:
        """The mean scale, √|det A|."""
        return math.sqrt(abs(float(np.linalg.det(self.matrix[:, :2]))))

    def apply(self, points: np.ndarray) -> np.ndarray:
        """Reference points (N, 2) in the frame."""
        points = np.asarray(points, dtype=np.float64)
        return points @ self.matrix[:, :2].T + self.matrix[:, 2]


def locate_part(
    frame: np.ndarray,
    reference: np.ndarray,
    template: tuple[int, int, int, int],
    *,
    motion: Motion = "euclidean",
) -> Pose:
    """The pose of the part of ``reference`` in ``frame``.

    Parameters
    ----------
    frame, reference : ndarray, (H, W)
        Monochrome images of one size, DN (any dtype).
    template : (x, y, w, h)
        The window of ``reference`` that holds the part, px.
    motion : {"translation", "euclidean", "affine"}, keyword-only
        What may change between parts: a shift; a shift and a rotation; any affine map.

    Returns
    -------
    Pose
        With the match score; a frame where the search does not converge gets score 0
        (no part: the caller counts it and never measures it).

    Raises
    ------
    InputError
        Images of different sizes or not monochrome, a template outside the reference or
        without contrast, an unknown motion.
    """
    import cv2

    if motion not in MOTIONS:
        raise InputError(f"motion {motion!r}: one of {', '.join(MOTIONS)}")
    frame, reference = np.asarray(frame), np.asarray(reference)
    if frame.ndim != 2 or reference.ndim != 2:
        raise InputError("locating a part needs monochrome frames (one channel)")
    if frame.shape != reference.shape:
        raise InputError(
            f"the frame is {frame.shape[1]}×{frame.shape[0]}, the reference "
            f"{reference.shape[1]}×{reference.shape[0]}: give frames of the reference's size"
        )
    x, y, w, h = (int(v) for v in template)
    if x < 0 or y < 0 or w < 8 or h < 8 or x + w > reference.shape[1] or y + h > reference.shape[0]:
        raise InputError(
            f"template [{x}, {y}, {w}, {h}] is not a window of at least 8 × 8 px inside the "
            f"{reference.shape[1]}×{reference.shape[0]} reference"
        )
    patch = reference[y : y + h, x : x + w].astype(np.float32)
    if not float(patch.std()) > 0:
        raise InputError(f"template [{x}, {y}, {w}, {h}] has no contrast: no part to find")
    image = frame.astype(np.float32)

    # 1. Coarse: the translation at the level where the template is ~COARSE_SIZE px.
    level = max(0, math.floor(math.log2(min(w, h) / COARSE_SIZE)))
    small_patch, small_image = patch, image
    for _ in range(level):
        small_patch, small_image = cv2.pyrDown(small_patch), cv2.pyrDown(small_image)
    scores = cv2.matchTemplate(small_image, small_patch, cv2.TM_CCOEFF_NORMED)
    _, _, _, (cx, cy) = cv2.minMaxLoc(scores)
    # The patch's origin in the frame, px (a level's pixel is 2**level of the frame's).
    start = np.array([[1.0, 0.0, cx * 2.0**level], [0.0, 1.0, cy * 2.0**level]], np.float32)

    # 2. Fine: ECC from there, patch coordinates (pixel centres) → frame.
    kind = {
        "translation": cv2.MOTION_TRANSLATION,
        "euclidean": cv2.MOTION_EUCLIDEAN,
        "affine": cv2.MOTION_AFFINE,
    }[motion]
    criteria = (cv2.TERM_CRITERIA_EPS | cv2.TERM_CRITERIA_COUNT, _ECC_ITERATIONS, _ECC_EPS)
    try:
        score, warp = cv2.findTransformECC(patch, image, start, kind, criteria, None, 1)
    except cv2.error:  # no convergence (a frame without the part): no pose
        return Pose(_patch_to_reference(start, x, y), 0.0)
    return Pose(_patch_to_reference(warp, x, y), float(score))


def _patch_to_reference(warp: np.ndarray, x: int, y: int) -> np.ndarray:
    """ECC's warp (patch pixel centres → frame pixel centres) as the pose's matrix
    (reference pixel corners → frame pixel corners)."""
    a = np.asarray(warp, dtype=np.float64)[:, :2]
    b = np.asarray(warp, dtype=np.float64)[:, 2]
    # corner c → centre c − ½ → patch centre c − ½ − (x, y) → frame centre → corner + ½
    offset = np.array([x + 0.5, y + 0.5])
    return np.column_stack([a, b - a @ offset + 0.5])


@dataclass(frozen=True)
class MovedRegions:
    """The classes' regions moved onto a frame by a pose: ``masks`` (class → pixels of the
    frame), and per class the pixels lost because the moved region reaches beyond the
    frame (``outside``)."""

    masks: dict[str, np.ndarray]
    outside: dict[str, int]


def moved_masks(masks: dict[str, np.ndarray], pose: Pose) -> MovedRegions:
    """The reference's class masks moved by ``pose`` onto a frame of the same size.

    Each frame pixel belongs to the class of the reference pixel its centre maps back to
    (nearest neighbour): the regions are moved, the frame's pixels untouched, and two
    classes never share a pixel. A region's pixels that would land outside the frame are
    counted, not kept.

    Parameters
    ----------
    masks : dict of str to ndarray of bool
        Each class's pixels in the reference (:func:`~inspect_validate.roi.class_masks`).
    pose : Pose

    Returns
    -------
    MovedRegions
    """
    import cv2

    out: dict[str, np.ndarray] = {}
    outside: dict[str, int] = {}
    # The pose in pixel centres, as warpAffine takes it (dst = M · src).
    a, b = pose.matrix[:, :2], pose.matrix[:, 2]
    centres = np.column_stack([a, b + a @ np.array([0.5, 0.5]) - 0.5])
    for name, mask in masks.items():
        h, w = mask.shape
        out[name] = cv2.warpAffine(
            mask.view(np.uint8), centres, (w, h), flags=cv2.INTER_NEAREST,
            borderMode=cv2.BORDER_CONSTANT, borderValue=0,
        ).astype(bool)  # fmt: skip
        outside[name] = _outside(mask, pose)
    return MovedRegions(out, outside)


def _outside(mask: np.ndarray, pose: Pose) -> int:
    """How many of the region's pixel centres ``pose`` puts outside the frame: none where
    its bounding box lands inside (the usual part), else counted pixel by pixel."""
    h, w = mask.shape
    rows, cols = np.flatnonzero(mask.any(axis=1)), np.flatnonzero(mask.any(axis=0))
    if rows.size == 0:
        return 0
    y0, y1, x0, x1 = rows[0], rows[-1] + 1, cols[0], cols[-1] + 1
    corners = pose.apply(np.array([[x0, y0], [x1, y0], [x0, y1], [x1, y1]], float))
    if corners.min() >= 0 and np.all(corners.max(axis=0) <= (w, h)):
        return 0
    ys, xs = np.nonzero(mask)
    landed = pose.apply(np.column_stack([xs + 0.5, ys + 0.5]))
    inside = (landed[:, 0] >= 0) & (landed[:, 0] < w) & (landed[:, 1] >= 0) & (landed[:, 1] < h)
    return int(np.count_nonzero(~inside))
