"""Where the part is: its pose in a production frame against a reference frame of a good
part, so that the regions (drawn on the reference) follow it.

The anchors of the field do the same before they compare pixels: HALCON's variation model
aligns by shape-based matching, In-Sight fixtures its tools to the located part. Here, in
two stages on the template (a window of the reference holding the part):

1. **coarse:** normalised cross-correlation (``cv2.matchTemplate``, ``TM_CCOEFF_NORMED``)
   of the template in the frame, both averaged down by a power of two until the template
   is about :data:`COARSE_SIZE` px across, the frame widened by a quarter of the template
   with its median (a part the frame's edge cuts is found too); the peak is the
   translation to the pixel of that level. Where the unturned template scores below
   :data:`UNTURNED_ACCEPT` (a texture without an outline, turned: it no longer
   correlates with its unturned self), its central square is matched turned by each
   angle of a sweep over ± ``max_rotation_deg``, a step moving its corners by a pixel,
   and the best match starts ECC turned;
2. **fine:** ``cv2.findTransformECC`` (Evangelidis & Psarakis 2008) from that start, with
   the motion asked for (translation, euclidean: translation and rotation, or affine),
   level by level down the pyramid to the one where the template is at most
   :data:`FINE_SIZE` px across (full resolution for a smaller template): a 5 MP frame's
   part is placed to about a tenth of a pixel without an iteration over 5 MP. Its
   correlation coefficient at that level, over the template's pixels inside the frame,
   is the match score.

A pose maps reference coordinates to frame coordinates, in the pixel-corner convention
of :mod:`inspect_validate.roi.shapes` (pixel (x, y) covers [x, x + 1) × [y, y + 1)).
The frame itself is never resampled: the regions are moved
(:func:`~inspect_validate.roi.pose.moved_masks`), so a class's σ² is its pixels' own.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from typing import Literal

import numpy as np

from inspect_validate.errors import InputError
from inspect_validate.roi.roiset import bounding_box

__all__ = [
    "COARSE_SIZE",
    "FINE_SIZE",
    "MOTIONS",
    "Motion",
    "MovedRegions",
    "Pose",
    "TemplateSearch",
    "locate_part",
    "moved_masks",
]

Motion = Literal["translation", "euclidean", "affine"]
MOTIONS: tuple[Motion, ...] = ("translation", "euclidean", "affine")
COARSE_SIZE = 64
"""Pixels across the template at the coarse search's level (its smaller side)."""
FINE_SIZE = 512
"""Pixels across the template at the finest level ECC refines at (its smaller side)."""
_ECC_ITERATIONS = 100
_ECC_EPS = 1e-6
# Above the finest level ECC only starts the next one, whose basin is a few of its
# pixels wide: a thousandth of a pixel there is plenty.
_ECC_COARSE = (30, 1e-3)


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
    max_rotation_deg: float = 0.0,
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
    max_rotation_deg : float, keyword-only
        The most a part may be turned, degrees: the coarse search sweeps the template's
        rotation over ± this where it does not find the part unturned (a fine texture
        turned by 10° no longer correlates with its unturned self). 0: the coarse search
        finds shifts only (ECC still refines a rotation of a few degrees).

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

    See Also
    --------
    TemplateSearch : the same, its template prepared once for many frames.
    """
    return TemplateSearch.of(reference, template, max_rotation_deg=max_rotation_deg).locate(
        frame, motion=motion
    )


UNTURNED_ACCEPT = 0.9
"""A coarse match of the unturned template scoring this or more is taken without sweeping
its rotation (most parts of a line; the sweep costs a search per angle)."""


@dataclass(frozen=True, eq=False)
class TemplateSearch:
    """A reference's template prepared for searching frames: its pyramid, cut from the
    reference's around it, and its turned copies at the coarse level
    (:func:`locate_part`, made once for a batch of frames).

    Attributes
    ----------
    shape : (H, W)
        The reference's, and every frame's.
    template : (x, y, w, h)
    patches : list of ndarray
        The template at each level of the pyramid (level k 2**k times smaller), float32.
    coarse, fine : int
        The levels of the coarse search and of the finest ECC.
    turned : tuple of (float, ndarray, ndarray)
        Each swept rotation (degrees), the coarse template turned by it (its central
        square, whole at any angle) and its warp (coarse patch pixel centres → the turned
        square's).
    """

    shape: tuple[int, int]
    template: tuple[int, int, int, int]
    patches: list[np.ndarray]
    coarse: int
    fine: int
    turned: tuple[tuple[float, np.ndarray, np.ndarray], ...]

    @classmethod
    def of(
        cls,
        reference: np.ndarray,
        template: tuple[int, int, int, int],
        *,
        max_rotation_deg: float = 0.0,
    ) -> TemplateSearch:
        """Prepare the search of ``reference``'s ``template`` window (:func:`locate_part`).

        Raises
        ------
        InputError
            A reference not monochrome, a template outside it or without contrast.
        """
        import cv2

        reference = np.asarray(reference)
        if reference.ndim != 2:
            raise InputError("locating a part needs monochrome frames (one channel)")
        x, y, w, h = (int(v) for v in template)
        rows, cols = reference.shape
        if x < 0 or y < 0 or w < 8 or h < 8 or x + w > cols or y + h > rows:
            raise InputError(
                f"template [{x}, {y}, {w}, {h}] is not a window of at least 8 × 8 px inside "
                f"the {cols}×{rows} reference"
            )
        patch = reference[y : y + h, x : x + w].astype(np.float32)
        if not float(patch.std()) > 0:
            raise InputError(f"template [{x}, {y}, {w}, {h}] has no contrast: no part to find")
        coarse = max(0, math.floor(math.log2(min(w, h) / COARSE_SIZE)))
        fine = min(coarse, max(0, math.ceil(math.log2(min(w, h) / FINE_SIZE))))
        patches: list[np.ndarray] = [patch]
        # The template's levels are cut from the reference's around it: pyrDown of the
        # window alone would reflect the part's own edge into its border, where the
        # frame's pyramid has the belt, and bias the pose (0.03°, 0.6 px at a 1280 px
        # template's corners, even with the part at home).
        margin = 4 << coarse  # the 5-tap kernel reads 2 px of the level above, each level
        around = _window(reference, x - margin, y - margin, w + 2 * margin, h + 2 * margin)
        for level in range(coarse):
            around = cv2.pyrDown(around)
            ph, pw = (patches[-1].shape[0] + 1) // 2, (patches[-1].shape[1] + 1) // 2
            m = margin >> (level + 1)
            patches.append(np.ascontiguousarray(around[m : m + ph, m : m + pw]))
        return cls(
            (rows, cols),
            (x, y, w, h),
            patches,
            coarse,
            fine,
            _turned(patches[coarse], max_rotation_deg),
        )

    def locate(self, frame: np.ndarray, *, motion: Motion = "euclidean") -> Pose:
        """The pose of the template's part in ``frame`` (:func:`locate_part`)."""
        import cv2

        if motion not in MOTIONS:
            raise InputError(f"motion {motion!r}: one of {', '.join(MOTIONS)}")
        frame = np.asarray(frame)
        if frame.ndim != 2:
            raise InputError("locating a part needs monochrome frames (one channel)")
        if frame.shape != self.shape:
            raise InputError(
                f"the frame is {frame.shape[1]}×{frame.shape[0]}, the reference "
                f"{self.shape[1]}×{self.shape[0]}: give frames of the reference's size"
            )
        coarse, fine, patches = self.coarse, self.fine, self.patches
        # The frame's pyramid, in floats from the first level down, its full-resolution
        # copy only where ECC refines there.
        images: list[np.ndarray] = [frame.astype(np.float32) if fine == 0 else frame]
        for level in range(coarse):
            if level == 0 and fine >= 2 and frame.dtype in (np.uint8, np.uint16):
                # Level 1 only carries the pyramid down (ECC refines from level 2): made
                # in the frame's own integers, a quarter of the float path's time; its
                # rounding, 1/12 DN², is a small share of the noise by level 2.
                images.append(np.asarray(cv2.pyrDown(frame), np.float32))
                continue
            below = images[-1] if level else np.asarray(images[-1], np.float32)
            images.append(np.asarray(cv2.pyrDown(below)))

        # 1. Coarse: the translation (and, where the unturned template is not found, the
        # rotation) at the level where the template is ~COARSE_SIZE px. The frame is
        # widened by a quarter of the template on each side with its median (the belt,
        # mostly), so that a part the frame's edge cuts is still found there: ECC then
        # refines on the pixels inside the frame only.
        ph, pw = patches[coarse].shape
        py, px = ph // 4, pw // 4
        widened = cv2.copyMakeBorder(
            images[coarse], py, py, px, px, cv2.BORDER_CONSTANT,
            value=float(np.median(images[coarse])),
        )  # fmt: skip
        scores = cv2.matchTemplate(widened, patches[coarse], cv2.TM_CCOEFF_NORMED)
        _, best, _, (cx, cy) = cv2.minMaxLoc(scores)
        # ECC's warp: patch pixel centres → frame pixel centres, at the coarse level.
        warp = np.array([[1.0, 0.0, cx - px], [0.0, 1.0, cy - py]], np.float32)
        if best < UNTURNED_ACCEPT and motion != "translation":
            for _, image, turned in self.turned:
                scores = cv2.matchTemplate(widened, image, cv2.TM_CCOEFF_NORMED)
                _, score, _, (tx, ty) = cv2.minMaxLoc(scores)
                if score > best:
                    best = score
                    warp = turned.copy()
                    warp[:, 2] += (tx - px, ty - py)

        # 2. Fine: ECC level by level, the translation doubled on the way down.
        kind = {
            "translation": cv2.MOTION_TRANSLATION,
            "euclidean": cv2.MOTION_EUCLIDEAN,
            "affine": cv2.MOTION_AFFINE,
        }[motion]
        stop = cv2.TERM_CRITERIA_EPS | cv2.TERM_CRITERIA_COUNT
        score = 0.0
        x, y = self.template[:2]
        for level in range(coarse, fine - 1, -1):
            if level < coarse:
                warp = warp.copy()
                # cv2.pyrDown's pixel c is centred on pixel 2c of the level above (its
                # 5-tap kernel sits there; not 2c + ½, as a 2 × 2 block mean's would): the
                # linear part stays, the shift doubles (Evangelidis' next_level).
                warp[:, 2] *= 2.0
            try:
                # Every frame pixel is valid (a full mask: OpenCV's typing has no "none"
                # with a Gaussian size), and no pre-smoothing (size 1): the pyramid
                # smoothed already.
                everywhere = np.full(images[level].shape, 255, np.uint8)
                score, refined = cv2.findTransformECC(
                    patches[level],
                    images[level],
                    warp,
                    kind,
                    (stop, *((_ECC_ITERATIONS, _ECC_EPS) if level == fine else _ECC_COARSE)),
                    everywhere,
                    1,
                )
                warp = np.asarray(refined, np.float32)
            except cv2.error:  # no convergence (a frame without the part): no pose
                return Pose(_patch_to_reference(_at_full(warp, level), x, y), 0.0)
        return Pose(_patch_to_reference(_at_full(warp, fine), x, y), float(score))


def _turned(patch: np.ndarray, most: float) -> tuple[tuple[float, np.ndarray, np.ndarray], ...]:
    """The coarse ``patch`` turned by every angle of a sweep over ± ``most`` degrees: its
    central square (whole at any angle), in steps that move the square's corners by
    about a pixel, and each one's warp (patch pixel centres → square pixel centres, as
    ECC starts from it once the square is found)."""
    import cv2

    if not most > 0:
        return ()
    ph, pw = patch.shape
    side = max(8, int(min(ph, pw) / math.sqrt(2)))
    step = math.degrees(1.0 / (side / math.sqrt(2)))
    count = math.ceil(min(most, 180.0) / step)
    centre = ((pw - 1) / 2.0, (ph - 1) / 2.0)
    out = []
    for k in range(-count, count + 1):
        if k == 0:
            continue
        angle = k * min(most, 180.0) / count
        m = cv2.getRotationMatrix2D(centre, -angle, 1.0)  # turned by +angle (y down)
        image = cv2.warpAffine(patch, m, (pw, ph), flags=cv2.INTER_LINEAR)
        x0, y0 = (pw - side) // 2, (ph - side) // 2
        square = np.ascontiguousarray(image[y0 : y0 + side, x0 : x0 + side])
        warp = np.asarray(m, np.float32).copy()
        warp[:, 2] -= (x0, y0)  # a point of the patch → where it lies in the square
        out.append((angle, square, warp))
    return tuple(out)


def _window(image: np.ndarray, x: int, y: int, w: int, h: int) -> np.ndarray:
    """``image``'s window [x, x + w) × [y, y + h) in float32, what lies beyond its edge
    reflected as cv2.pyrDown would reflect it."""
    import cv2

    rows, cols = image.shape
    x0, y0, x1, y1 = max(x, 0), max(y, 0), min(x + w, cols), min(y + h, rows)
    inside = np.asarray(image[y0:y1, x0:x1], np.float32)
    return cv2.copyMakeBorder(
        inside, y0 - y, y + h - y1, x0 - x, x + w - x1, cv2.BORDER_REFLECT_101
    )


def _at_full(warp: np.ndarray, level: int) -> np.ndarray:
    """A warp between pixel centres of ``level`` as one at full resolution (the linear
    part unchanged: both images are scaled alike; the shift scaled by 2**level)."""
    if level == 0:
        return warp
    a = np.asarray(warp, dtype=np.float64)[:, :2]
    b = np.asarray(warp, dtype=np.float64)[:, 2]
    # full centre u ↦ level centre u/s (cv2.pyrDown samples every other pixel's centre)
    # ↦ warp ↦ full s·v
    return np.column_stack([a, b * 2.0**level])


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
    """The classes' regions moved onto a frame by a pose.

    Attributes
    ----------
    shape : (H, W)
        The frame's.
    boxes : dict of str to (y0, x0, y1, x1)
        Where each moved region lies in the frame (empty where it left the frame).
    local : dict of str to ndarray of float32
        Each region's weights within its box: the share of each pixel's area it covers, 0–1.
    outside : dict of str to int
        The region's pixels that fell beyond the frame.
    """

    shape: tuple[int, int]
    boxes: dict[str, tuple[int, int, int, int]]
    local: dict[str, np.ndarray]
    outside: dict[str, int]

    @functools.cached_property
    def weights(self) -> dict[str, np.ndarray]:
        """Each class's weights over the whole frame (H, W)."""
        out = {}
        for name, (y0, x0, y1, x1) in self.boxes.items():
            out[name] = np.zeros(self.shape, np.float32)
            out[name][y0:y1, x0:x1] = self.local[name]
        return out

    @functools.cached_property
    def masks(self) -> dict[str, np.ndarray]:
        """Each class's pixels at least half covered, over the whole frame (H, W)."""
        return {name: w > 0.5 for name, w in self.weights.items()}


def moved_masks(
    masks: dict[str, np.ndarray],
    pose: Pose,
    *,
    bounds: dict[str, tuple[int, int, int, int]] | None = None,
) -> MovedRegions:
    """The reference's class masks moved by ``pose`` onto a frame of the same size.

    Each frame pixel gets the share of its area the moved region covers, as aperture
    photometry weighs a pixel on an aperture's edge: the mask's bilinear warp, which for
    an edge moved by a fraction δ of a pixel is exactly δ. A region's statistics weighted
    so change smoothly with the part's pose; counted by whole pixels (nearest neighbour)
    a sub-pixel shift moves every edge pixel in or out at once, and a region on a textured
    part sees its μ jump with the shift's fraction (measured on the tests' photograph: μ's
    part-to-part spread 5–20 × that of the weighted regions, and heavy-tailed, as parts
    barely turned all share one rounding). The frame's pixels are untouched. A region's
    pixels that would land outside the frame are counted, not kept.

    Parameters
    ----------
    masks : dict of str to ndarray of bool
        Each class's pixels in the reference (:func:`~inspect_validate.roi.class_masks`),
        disjoint: a pixel on the border of two classes is then shared by its shares,
        and at most one of its shares reaches ½ (``masks`` never overlap).
    pose : Pose
    bounds : dict of str to (y0, x0, y1, x1), keyword-only, optional
        Each mask's :func:`~inspect_validate.roi.roiset.bounding_box`, where a caller
        moving the same masks part after part found them once (0.6 ms a 5 MP mask).

    Returns
    -------
    MovedRegions
    """
    import cv2

    boxes: dict[str, tuple[int, int, int, int]] = {}
    local: dict[str, np.ndarray] = {}
    outside: dict[str, int] = {}
    # The pose in pixel centres, as warpAffine takes it (dst = M · src).
    a, b = pose.matrix[:, :2], pose.matrix[:, 2]
    centres = np.column_stack([a, b + a @ np.array([0.5, 0.5]) - 0.5])
    shape: tuple[int, int] = (0, 0)
    weights: np.ndarray  # a region's, within its box
    for name, mask in masks.items():
        h, w = shape = mask.shape
        box, weights = (0, 0, 0, 0), np.zeros((0, 0), np.float32)
        sy, sx, sy1, sx1 = bounds[name] if bounds is not None else bounding_box(mask)
        corners = pose.apply(np.array([[sx, sy], [sx1, sy], [sx, sy1], [sx1, sy1]], float))
        if sy1 > sy:
            # Only the region's box is warped, into the box it lands in (a 5 MP frame's
            # mask in full cost 3 ms a class): source box origin (sx, sy), target (tx, ty).
            tx, ty = (max(0, int(np.floor(v)) - 1) for v in corners.min(axis=0))
            tx1 = min(w, int(np.ceil(corners[:, 0].max())) + 1)
            ty1 = min(h, int(np.ceil(corners[:, 1].max())) + 1)
            if tx1 > tx and ty1 > ty:
                local_pose = centres.copy()
                local_pose[:, 2] += a @ np.array([sx, sy], float) - np.array([tx, ty], float)
                box = (ty, tx, ty1, tx1)
                weights = cv2.warpAffine(
                    mask[sy:sy1, sx:sx1].astype(np.float32), local_pose, (tx1 - tx, ty1 - ty),
                    flags=cv2.INTER_LINEAR, borderMode=cv2.BORDER_CONSTANT, borderValue=0,
                )  # fmt: skip
        boxes[name], local[name] = box, weights
        outside[name] = _outside(mask, pose, corners) if sy1 > sy else 0
    return MovedRegions(shape, boxes, local, outside)


def _outside(mask: np.ndarray, pose: Pose, corners: np.ndarray) -> int:
    """How many of the region's pixel centres ``pose`` puts outside the frame: none where
    its bounding box's ``corners`` land inside (the usual part), else counted pixel by
    pixel."""
    h, w = mask.shape
    if corners.min() >= 0 and np.all(corners.max(axis=0) <= (w, h)):
        return 0
    ys, xs = np.nonzero(mask)
    landed = pose.apply(np.column_stack([xs + 0.5, ys + 0.5]))
    inside = (landed[:, 0] >= 0) & (landed[:, 0] < w) & (landed[:, 1] >= 0) & (landed[:, 1] < h)
    return int(np.count_nonzero(~inside))
