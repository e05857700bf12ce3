"""A station on its running line: in each production frame the part is located against the
station's reference frame (:mod:`inspect_validate.roi.pose`), the classes' regions are
moved with it, and the part is measured as a bench capture is (μ, σ², SNR_dB, ε of the
station's comparisons), with what only moving parts tell: the pose and the focus.

The station file's ``production:`` block (:class:`~inspect_validate.station.file.Production`)
says which illumination stays on, the reference, the template and the motion. A frame
whose match scores below ``min_score`` is counted as "no part found" with the score, and
a part whose moved regions leave a class fewer than ``min_pixels`` pixels (cut by the
frame's edge) is counted too: neither is measured.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from inspect_validate.errors import InputError

if TYPE_CHECKING:
    from inspect_validate.comparisons import Comparisons
    from inspect_validate.measurement import Measurement
    from inspect_validate.roi.pose import Motion, Pose
    from inspect_validate.station.file import Station

__all__ = ["PartLocator", "Placement", "focus_measure", "measure_part", "part_locator"]


@dataclass(frozen=True)
class Placement:
    """A part placed in a frame: its ``pose``, the classes' moved regions (``masks``,
    None where the part is not measured), the pixels each region lost beyond the frame
    (``outside``) and, where it is not measured, ``reason``."""

    pose: Pose
    masks: dict[str, np.ndarray] | None
    outside: dict[str, int]
    reason: str | None = None


@dataclass(frozen=True, eq=False)
class PartLocator:
    """What placing a part needs, made once before any frame: the reference frame, the
    classes' regions in it, the template window and the motion, and the floors.

    Attributes
    ----------
    reference : ndarray, (H, W)
        The reference frame, DN.
    masks : dict of str to ndarray of bool
        Each class's pixels in the reference.
    template : (x, y, w, h)
        The reference window searched for in each frame, px.
    motion : str
    min_score : float
    min_pixels : int
    """

    reference: np.ndarray
    masks: dict[str, np.ndarray]
    template: tuple[int, int, int, int]
    motion: Motion
    min_score: float
    min_pixels: int

    def place(self, frame: np.ndarray) -> Placement:
        """The part in ``frame`` (H, W) with the regions moved onto it.

        Raises
        ------
        InputError
            A frame of another size than the reference, or not monochrome (naming no
            file: the caller knows the frame's).
        """
        from inspect_validate.roi.pose import locate_part, moved_masks

        pose = locate_part(frame, self.reference, self.template, motion=self.motion)
        if pose.score < self.min_score:
            return Placement(
                pose, None, {}, f"no part found: match score {pose.score:.3f} below "
                f"production.min_score {self.min_score:g}",
            )  # fmt: skip
        regions = moved_masks(self.masks, pose)
        counts = {name: int(np.count_nonzero(mask)) for name, mask in regions.masks.items()}
        short = [name for name, n in counts.items() if n < self.min_pixels]
        if short:
            name = short[0]
            return Placement(
                pose, None, regions.outside,
                f"class {name!r} keeps {counts[name]} px on this part, below "
                f"production.min_pixels {self.min_pixels} ({regions.outside[name]} px of its "
                "region fall outside the frame)",
            )  # fmt: skip
        return Placement(pose, regions.masks, regions.outside)


def part_locator(station: Station) -> PartLocator:
    """The :class:`PartLocator` of a station with a ``production:`` block.

    Raises
    ------
    InputError
        No ``production:`` block, a reference that cannot be read or is in colour,
        regions that do not fit it, a template outside it (each naming the file and key).
    """
    from inspect_validate.images import read_image
    from inspect_validate.roi import class_masks, read_rois
    from inspect_validate.roi.roiset import bounding_box

    source = str(station.path)
    production = station.production
    if production is None or station.rois is None:
        raise InputError(
            "no 'production:' block: give one to verify the running line", source=source
        )
    path = station.resolve(production.reference)
    reference = read_image(path)  # a colour image is refused, naming the file
    masks = class_masks(read_rois(station.resolve(station.rois)), reference.shape)
    height, width = reference.shape
    if production.template is not None:
        x, y, w, h = production.template
        if x + w > width or y + h > height:
            raise InputError(
                f"production.template [{x}, {y}, {w}, {h}] reaches outside the "
                f"{width}×{height} reference; give a window inside it",
                source=source,
            )
        template = (x, y, w, h)
    else:
        y0, x0, y1, x1 = bounding_box(np.logical_or.reduce(list(masks.values())))
        m = production.margin
        x0, y0, x1, y1 = max(0, x0 - m), max(0, y0 - m), min(width, x1 + m), min(height, y1 + m)
        template = (x0, y0, x1 - x0, y1 - y0)
    return PartLocator(
        reference=reference,
        masks=masks,
        template=template,
        motion=production.motion,
        min_score=production.min_score,
        min_pixels=production.min_pixels,
    )


def measure_part(
    frame: np.ndarray,
    placement: Placement,
    comparisons: Comparisons,
    *,
    saturation_level: float | None = None,
) -> Measurement:
    """One placed part's classes (μ (38), σ² (39): spatial, within the part) and
    comparisons (SNR_dB (36), ε Gauss (37)), as :func:`~inspect_validate.measurement.compare`
    gives them; the frame's own pixels, never resampled."""
    from inspect_validate.measurement import compare, measure_classes

    if placement.masks is None:
        raise ValueError(f"this part is not measured: {placement.reason}")
    classes = measure_classes(
        np.asarray(frame)[None], placement.masks, saturation_level=saturation_level
    )
    return compare(classes, comparisons, kde="never")


def focus_measure(frame: np.ndarray, mask: np.ndarray) -> float:
    """The variance of the Laplacian (Pech-Pacheco et al. 2000) over a region, DN²: it
    falls as the lens loses focus (edges blur) while μ stays; compared with the golden
    part's, not read on its own."""
    import cv2

    from inspect_validate.roi.roiset import bounding_box

    y0, x0, y1, x1 = bounding_box(mask)
    if y1 == y0:
        return float("nan")
    # The region's box and a pixel around it: the Laplacian reads its neighbours.
    y0, x0 = max(0, y0 - 1), max(0, x0 - 1)
    y1, x1 = min(mask.shape[0], y1 + 1), min(mask.shape[1], x1 + 1)
    lap = cv2.Laplacian(np.asarray(frame[y0:y1, x0:x1], np.float32), cv2.CV_32F)
    _, sd = cv2.meanStdDev(lap, mask=mask[y0:y1, x0:x1].view(np.uint8))
    return float(sd[0, 0]) ** 2
