"""Regions proposed from a frame: the uniform, lit objects in it, found with scikit-image,
as a draft ROI set whose classes the user names (``inspect-validate rois propose``).

A region is a connected area where the smoothed frame has no edge: its gradient stays
within what the frame's own noise gives. Areas no brighter than the unlit background,
smaller than a size floor, or cut to nothing by the margin kept from their edges (where
the lens blurs one object into the next) are left out. Each region becomes one class,
numbered in reading order (top to bottom, then left to right); a class name given twice
merges its regions.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from inspect_validate.errors import InputError
from inspect_validate.roi.roiset import ClassRoi, RoiSet, bounding_box
from inspect_validate.roi.shapes import Polygon, Rect, Shape, rasterise

__all__ = ["Region", "coverage", "draft_rois", "find_regions"]


@dataclass(frozen=True)
class Region:
    """One uniform object found in a frame.

    Attributes
    ----------
    number : int
        Its place in reading order, from 1.
    mask : ndarray of bool
        Its pixels (after the margin).
    shape : Rect or Polygon
        The shape written for it: its mask exactly where that is a rectangle, else its
        outline a quarter pixel inside its edge, staircases simplified to within an
        eighth of a pixel (:func:`coverage` says how much of the mask it takes in).
    mean, std : float
        Its pixels' grey value, DN.
    """

    number: int
    mask: np.ndarray
    shape: Shape
    mean: float
    std: float

    @property
    def pixels(self) -> int:
        return int(np.count_nonzero(self.mask))


def find_regions(
    image: np.ndarray,
    *,
    min_area: int | None = None,
    margin: int = 2,
    smoothing: float = 1.5,
    edge: float = 4.0,
    dark_level: float | None = None,
) -> list[Region]:
    """The uniform, lit regions of ``image`` (H, W), in reading order.

    Parameters
    ----------
    image : ndarray
        A frame, or the mean of several at one setting (less noise, cleaner edges).
    min_area : int, keyword-only
        Smallest region kept, pixels after the margin (default: 0.5 % of the frame).
    margin : int, keyword-only
        Pixels kept clear of a region's edge (erosion radius).
    smoothing : float, keyword-only
        Gaussian σ applied before the edges are found, px.
    edge : float, keyword-only
        A gradient above this many times its noise (the median absolute deviation of the
        gradient over the frame, scaled to σ) is an edge.
    dark_level : float, optional
        The unlit level, DN (dark frames' mean); a region within 5 noise σ of it is
        background. Default: the frame's 1st percentile.
    """
    from scipy import ndimage
    from skimage.filters import gaussian, sobel
    from skimage.measure import label
    from skimage.morphology import disk

    frame = np.asarray(image, dtype=np.float64)
    if frame.ndim != 2 or min(frame.shape) < 8:
        raise InputError(f"a frame of at least 8 × 8 pixels is needed, not {frame.shape}")
    if not np.all(np.isfinite(frame)):
        raise InputError("the frame holds NaN or infinite values")
    height, width = frame.shape
    min_area = max(1, int(0.005 * height * width)) if min_area is None else min_area
    floor = float(np.percentile(frame, 1)) if dark_level is None else float(dark_level)
    # Shot noise grows with the signal: on the square root of the signal above the dark
    # level (Anscombe's transform) it is about the same everywhere, so one edge threshold
    # fits a dim object and a bright one alike.
    stable = 2.0 * np.sqrt(np.maximum(frame - floor, 0.0) + 3.0 / 8.0)
    smooth = gaussian(stable, sigma=smoothing, preserve_range=True)
    gradient = sobel(smooth)
    # The gradient's spread inside uniform areas, robustly: most pixels are inside one.
    spread = 1.4826 * float(np.median(np.abs(gradient - np.median(gradient))))
    uniform = gradient <= np.median(gradient) + edge * max(spread, 1e-12)
    # Noise leaves notches and spurs along an edge: an opening by a small disc smooths
    # them, so that an outline has few vertices; then the margin.
    uniform = ndimage.binary_opening(uniform, structure=disk(2), border_value=1)
    if margin:
        uniform = ndimage.binary_erosion(uniform, structure=disk(margin), border_value=1)
    labels = label(uniform, connectivity=1)
    residual = frame - gaussian(frame, sigma=smoothing, preserve_range=True)
    noise = 1.4826 * float(np.median(np.abs(residual - np.median(residual))))
    found = []
    for index, box in enumerate(ndimage.find_objects(labels), start=1):
        if box is None:
            continue
        mask = np.zeros(frame.shape, dtype=bool)
        mask[box] = labels[box] == index
        area = int(np.count_nonzero(mask))
        if area < min_area:
            continue
        values = frame[mask]
        mean = float(values.mean())
        if mean <= floor + 5 * max(noise, 0.5):
            continue  # the unlit background
        std = float(values.std(ddof=1))
        if np.mean(values < floor + 0.5 * (mean - floor)) > 0.25:
            # Objects and background mixed: edges finer than the smoothing do not stand out
            # (a grid of small squares was one region of the whole frame, σ 78 DN). A
            # lit object, even a dim one at a coefficient of variation of 0.7, has less
            # than a quarter of its pixels below half its level.
            continue
        found.append((box[0].start, box[1].start, mask, mean, std))
    found.sort(key=lambda r: (r[0], r[1]))
    return [
        Region(n, mask, _shape_of(mask), mean, std)
        for n, (_, _, mask, mean, std) in enumerate(found, start=1)
    ]


def _shape_of(mask: np.ndarray) -> Shape:
    """A rectangle where the mask is one, else the outline of its largest part."""
    import cv2

    y0, x0, y1, x1 = bounding_box(mask)
    if mask[y0:y1, x0:x1].all():
        return Rect(x0, y0, x1 - x0, y1 - y0)
    # Traced on a grid twice as fine, the outline runs a quarter pixel inside the region's
    # edge: every boundary pixel's centre lies inside it, every outside pixel's outside.
    fine = np.repeat(np.repeat(mask.astype(np.uint8), 2, axis=0), 2, axis=1)
    contours, _ = cv2.findContours(fine, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_SIMPLE)
    outline = max(contours, key=cv2.contourArea)
    # Staircases simplified to within a half pixel (of the fine grid: a quarter of ours).
    outline = cv2.approxPolyDP(outline, 0.5, True)[:, 0, :]
    return Polygon(tuple(((x + 0.5) / 2, (y + 0.5) / 2) for x, y in outline.tolist()))


def draft_rois(
    regions: list[Region],
    *,
    frame: tuple[int, int],
    names: list[str] | None = None,
    source: str = "proposed",
) -> RoiSet:
    """The regions as an ROI set recording ``frame`` (width, height): class ``1``, ``2``, …
    in their order, or ``names`` (one per region; a name given twice merges its
    regions into one class)."""
    if not regions:
        raise InputError(
            "no uniform lit region found; lower --min-area or --margin, or give a frame with "
            "the objects lit (the mean of a capture step's frames is cleanest)",
            source=source,
        )
    if names is not None and len(names) != len(regions):
        raise InputError(
            f"{len(names)} names for {len(regions)} regions; give one name per region, in the "
            "order of the overlay's numbers (a name twice merges those regions)",
            source=source,
        )
    labels = names or [str(r.number) for r in regions]
    classes: dict[str, list] = {}
    for region, name in zip(regions, labels, strict=True):
        classes.setdefault(name, []).append((region.shape, f"region {region.number}"))
    return RoiSet(
        tuple(ClassRoi(name, tuple(shapes)) for name, shapes in classes.items()),
        source,
        frame,
    )


def coverage(region: Region) -> float:
    """The share of the region's pixels its written shape takes in (1: exact)."""
    drawn = rasterise(region.shape, region.mask.shape, where=f"region {region.number}")
    return float(np.count_nonzero(drawn & region.mask)) / region.pixels
