"""A station on its running line: in each production frame the part is located against the
station's reference frame (:mod:`inspect_validate.roi.pose`), the classes' regions are
moved with it, and the part is measured as a bench capture is (μ, σ², SNR_dB, ε of the
station's comparisons), with what only moving parts tell: the pose and the focus.

The station file's ``production:`` block (:class:`~inspect_validate.station.file.Production`)
says which illumination stays on, the reference, the template and the motion. A frame
whose match scores below ``min_score`` is counted as "no part found" with the score, and
a part whose moved regions leave a class fewer than ``min_pixels`` pixels (cut by the
frame's edge) is counted too, and so is a frame with a blank block on the part (one value
over runs of :data:`BLANK_RUN` pixels where the reference has none: a frame cut short,
packets lost): none is measured.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from inspect_validate.errors import InputError

if TYPE_CHECKING:
    from inspect_validate.comparisons import Comparisons
    from inspect_validate.measurement import ClassMeasurement, Measurement
    from inspect_validate.roi.pose import Motion, MovedRegions, Pose, TemplateSearch
    from inspect_validate.station.file import Station

__all__ = [
    "BLANK_RUN",
    "PartLocator",
    "Placement",
    "focus_measure",
    "measure_part",
    "part_classes",
    "part_focus",
    "part_locator",
]

BLANK_RUN = 32
"""Identical pixels in a row or a column that count as blank, px. On a flat region whose
mean lies on a whole DN (the worst case), noise of 0.5 DN leaves 10⁻⁴ of the pixels in
such runs, 0.7 DN none in 4·10⁶, 0.3 DN 29 %; a frame cut short or a lost packet leaves
whole rows of its fill value."""
BLANK_SHARE = 0.01
"""The share of a class's region in blank runs that makes a frame unusable, beyond twice
the reference's own share (a class flat to the DN, whose runs come and go with the
noise): 1 % of a class at 0 DN moves its μ by 1 % (1.5 DN at 150 DN), far beyond a part's
spread."""


@dataclass(frozen=True)
class Placement:
    """A part placed in a frame: its ``pose``, the classes' moved regions (``regions``,
    None where the part is not measured) and, where it is not measured, ``reason``; the
    pixels each region lost beyond the frame (``outside``)."""

    pose: Pose
    regions: MovedRegions | None
    outside: dict[str, int]
    reason: str | None = None

    @property
    def masks(self) -> dict[str, np.ndarray] | None:
        """Each class's pixels at least half inside its moved region (None where the part
        is not measured)."""
        return None if self.regions is None else self.regions.masks


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
    max_rotation_deg : float
        The most a part turns, degrees (the coarse search sweeps it where it must).
    """

    reference: np.ndarray
    masks: dict[str, np.ndarray]
    template: tuple[int, int, int, int]
    motion: Motion
    min_score: float
    min_pixels: int
    max_rotation_deg: float = 0.0

    @functools.cached_property
    def search(self) -> TemplateSearch:
        """The template prepared once for every frame (its pyramid, its turned copies)."""
        from inspect_validate.roi.pose import TemplateSearch

        return TemplateSearch.of(
            self.reference, self.template, max_rotation_deg=self.max_rotation_deg
        )

    def place(self, frame: np.ndarray) -> Placement:
        """The part in ``frame`` (H, W) with the regions moved onto it.

        Raises
        ------
        InputError
            A frame of another size or pixel type than the reference, not monochrome, or
            a stack of frames (naming no file: the caller knows the frame's).
        """
        if frame.ndim == 3:
            raise InputError(
                f"a stack of {frame.shape[0]} frames in one file (a multi-page TIFF or a 3-D "
                "array): give each part a frame of its own"
            )
        if frame.dtype != self.reference.dtype:
            # A part's μ in another pixel type is on another scale: a 16-bit frame among
            # 8-bit ones read as a light 2000 % brighter.
            raise InputError(
                f"the frame's pixels are {frame.dtype}, the reference's {self.reference.dtype}: "
                "give the frames as the line's camera writes them (the reference one of them)"
            )
        return self.place_at(frame, self.search.locate(frame, motion=self.motion))

    def place_at(self, frame: np.ndarray, pose: Pose) -> Placement:
        """The regions moved onto the part ``pose`` locates in ``frame`` (of the
        reference's size and pixel type), and the part's checks: a match score that
        counts as a part, every class's pixels kept, no blank block in a class."""
        from inspect_validate.roi.pose import moved_masks

        if pose.score < self.min_score:
            return Placement(
                pose, None, {}, f"no part found: match score {pose.score:.3f} below "
                f"production.min_score {self.min_score:g}",
            )  # fmt: skip
        regions = moved_masks(self.masks, pose, bounds=self.bounds)
        counts = {name: round(float(w.sum())) for name, w in regions.local.items()}
        short = [name for name, n in counts.items() if n < self.min_pixels]
        if short:
            name = short[0]
            return Placement(
                pose, None, regions.outside,
                f"class {name!r} keeps {counts[name]} px on this part, below "
                f"production.min_pixels {self.min_pixels} ({regions.outside[name]} px of its "
                "region fall outside the frame)",
            )  # fmt: skip
        for name, weights in regions.local.items():
            y0, x0, y1, x1 = regions.boxes[name]
            inside = weights > 0.5
            box = frame[y0:y1, x0:x1]
            blank = blank_runs(box)[inside]
            share = float(blank.mean()) if blank.size else 0.0
            if share > 2 * self.blank_shares[name] + BLANK_SHARE:
                why = _blank(box[inside][blank], share, f"class {name!r}", self.blank_shares[name])
                return Placement(pose, None, regions.outside, why)
        return Placement(pose, regions, regions.outside)

    @functools.cached_property
    def bounds(self) -> dict[str, tuple[int, int, int, int]]:
        """Each class's bounding box in the reference, (y0, x0, y1, x1)."""
        from inspect_validate.roi.roiset import bounding_box

        return {name: bounding_box(mask) for name, mask in self.masks.items()}

    @functools.cached_property
    def blank_shares(self) -> dict[str, float]:
        """Each class's share of its region in blank runs on the reference: where a class
        is flat to the DN (a clipped highlight, a quiet camera), those are its own."""
        blank = blank_runs(self.reference)
        return {n: float(blank[m].mean()) if m.any() else 0.0 for n, m in self.masks.items()}


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
    x, y, w, h = template
    if not float(reference[y : y + h, x : x + w].std()) > 0:
        raise InputError(
            f"the reference's template window [{x}, {y}, {w}, {h}] is flat (a frame without a "
            "part?); give a frame of a good part as production.reference",
            source=str(path),
        )
    return PartLocator(
        reference=reference,
        masks=masks,
        template=template,
        motion=production.motion,
        min_score=production.min_score,
        min_pixels=production.min_pixels,
        max_rotation_deg=production.max_rotation_deg,
    )


def measure_part(
    frame: np.ndarray,
    placement: Placement,
    comparisons: Comparisons,
    *,
    saturation_level: float | None = None,
) -> Measurement:
    """One placed part's classes (:func:`part_classes`) and comparisons (SNR_dB (36),
    ε Gauss (37)), as :func:`~inspect_validate.measurement.compare` gives them. A batch
    of parts compares them all at once
    (:func:`~inspect_validate.measurement.compare_many`)."""
    from inspect_validate.measurement import compare_many

    classes = part_classes(frame, placement, saturation_level=saturation_level)
    return compare_many([classes], comparisons)[0]


def part_classes(
    frame: np.ndarray, placement: Placement, *, saturation_level: float | None = None
) -> tuple[ClassMeasurement, ...]:
    """One placed part's classes: μ (38), σ² (39) (spatial, within the part), DN and
    DN²; the frame's own pixels, never resampled, each counted by its share of the moved
    region (:func:`~inspect_validate.stats.weighted_moments`); the saturated and zero
    fractions are those of the pixels wholly inside.

    Raises
    ------
    ValueError
        The part was not placed (``placement.reason``), or a class keeps too few pixels.
    """
    from dataclasses import replace

    from inspect_validate.measurement import measure_classes
    from inspect_validate.stats.sample import Moments, weighted_moments

    regions = placement.regions
    if regions is None:
        raise ValueError(f"this part is not measured: {placement.reason}")
    frame = np.asarray(frame)
    classes = []
    for name, weights in regions.local.items():
        y0, x0, y1, x1 = regions.boxes[name]
        values = frame[y0:y1, x0:x1]
        # The pixels wholly inside are summed exactly from their histogram (as a bench
        # region's), the few that the edge cuts by their shares; a region thinner than a
        # pixel has every pixel by its share.
        inside = weights >= 1.0
        thin = np.count_nonzero(inside) < 2
        (c,) = measure_classes(
            values[None], {name: weights > 0 if thin else inside},
            saturation_level=saturation_level, misfit=False,
        )  # fmt: skip
        edge = weights > 0 if thin else (weights > 0) & ~inside
        whole = None if thin else Moments(c.n_pixels, c.mean, c.variance)
        m = weighted_moments(values[edge], weights[edge], whole=whole)
        classes.append(replace(c, mean=m.mean, variance=m.variance, n_pixels=m.n))
    return tuple(classes)


def _blank(values: np.ndarray, share: float, place: str, reference: float) -> str:
    """Why a frame with a blank block is not measured: ``share`` of ``place`` in blank
    runs (the reference's ``reference``), whose commonest value is among ``values``."""
    found, tally = np.unique(values, return_counts=True)
    return (
        f"a blank block: {share:.0%} of {place} lies in runs of {BLANK_RUN} or more pixels "
        f"at one value ({found[tally.argmax()]:g} DN), the reference's {reference:.0%}: a "
        "frame cut short, packets lost on the way, or the class clipped (a light off or far "
        "from its level)"
    )


def blank_runs(image: np.ndarray, *, length: int = BLANK_RUN) -> np.ndarray:
    """The pixels of ``image`` (H, W) in a row or a column of ``length`` or more identical
    values: what a frame cut short, a lost packet or a dead readout leaves (bool, H, W)."""
    import cv2

    image = np.asarray(image)
    blank = np.zeros(image.shape, np.uint8)
    for axis in (0, 1):
        if image.shape[axis] < length:
            continue
        # Where a pixel equals the next along the axis (the last one has no next) ...
        equal = np.zeros(image.shape, np.uint8)
        this, after = [slice(None)] * 2, [slice(None)] * 2
        this[axis], after[axis] = slice(None, -1), slice(1, None)
        np.equal(image[tuple(after)], image[tuple(this)], out=equal[tuple(this)].view(bool))
        line = (1, length - 1) if axis == 1 else (length - 1, 1)
        # ... a run starts where the next length − 1 are so (erosion, its window from the
        # pixel on; beyond the image counts as unequal) and covers the length pixels from
        # its start (dilation, its window up to the pixel): OpenCV's, ten times numpy's.
        start = cv2.erode(equal, np.ones(line, np.uint8), anchor=(0, 0),
                          borderType=cv2.BORDER_CONSTANT, borderValue=0)  # fmt: skip
        end = (length - 1, 0) if axis == 1 else (0, length - 1)
        cover = (1, length) if axis == 1 else (length, 1)
        covered = cv2.dilate(start, np.ones(cover, np.uint8), anchor=end,
                             borderType=cv2.BORDER_CONSTANT, borderValue=0)  # fmt: skip
        np.bitwise_or(blank, covered, out=blank)
    return blank.view(bool)


def part_focus(frame: np.ndarray, regions: MovedRegions) -> dict[str, float]:
    """:func:`focus_measure` of each class's moved region (the pixels at least half in it)."""
    return {
        name: _box_focus(frame, weights > 0.5, *regions.boxes[name][:2])
        for name, weights in regions.local.items()
    }


def focus_measure(frame: np.ndarray, mask: np.ndarray) -> float:
    """The variance of the Laplacian (Pech-Pacheco et al. 2000) over a region, DN²: it
    falls as the lens loses focus (edges blur) while μ stays; compared with the golden
    part's, not read on its own."""
    from inspect_validate.roi.roiset import bounding_box

    y0, x0, y1, x1 = bounding_box(mask)
    return _box_focus(frame, mask[y0:y1, x0:x1], y0, x0)


def _box_focus(frame: np.ndarray, mask: np.ndarray, y0: int, x0: int) -> float:
    """:func:`focus_measure` of a region given within its box, whose corner is (y0, x0)."""
    import cv2

    if not mask.any():
        return float("nan")
    y1, x1 = y0 + mask.shape[0], x0 + mask.shape[1]
    # The region's box and a pixel around it: the Laplacian reads its neighbours.
    top, left = min(y0, 1), min(x0, 1)
    bottom, right = min(frame.shape[0] - y1, 1), min(frame.shape[1] - x1, 1)
    lap = cv2.Laplacian(
        np.asarray(frame[y0 - top : y1 + bottom, x0 - left : x1 + right], np.float32), cv2.CV_32F
    )
    lap = lap[top : top + mask.shape[0], left : left + mask.shape[1]]
    _, sd = cv2.meanStdDev(np.ascontiguousarray(lap), mask=mask.view(np.uint8))
    return float(sd[0, 0]) ** 2
