"""Regions drawn over a frame: each class's outline in a colour of its own and its label
(name, pixels, μ ± σ), for a person to check that the regions cover the right objects
(``inspect-validate rois show`` and ``rois propose``)."""

from __future__ import annotations

import numpy as np

__all__ = ["draw_regions"]

# Tableau's ten colours (matplotlib's default cycle), as OpenCV's BGR.
_COLOURS = [
    (180, 119, 31), (14, 127, 255), (44, 160, 44), (40, 39, 214), (189, 103, 148),
    (75, 86, 140), (194, 119, 227), (127, 127, 127), (34, 189, 188), (207, 190, 23),
]  # fmt: skip


def draw_regions(
    image: np.ndarray,
    masks: dict[str, np.ndarray],
    *,
    labels: dict[str, str] | None = None,
    limits: tuple[float, float] | None = None,
) -> np.ndarray:
    """``image`` (H, W) as an 8-bit colour picture with every mask's outline and label.

    Parameters
    ----------
    image : ndarray
        The frame, DN; shown stretched from ``limits`` (default: its 0.5th to its 99.5th
        percentile) black to white.
    masks : dict of str to ndarray of bool
        Class name → its pixels.
    labels : dict of str to str, optional
        Class name → the text written at it (default: the name).

    Returns
    -------
    ndarray of uint8, (h, w, 3), BGR
        Enlarged by a whole factor where the frame is small, so that the text reads;
        averaged down to 1600 px where it is larger.
    """
    import cv2

    frame = np.asarray(image)
    low, high = limits if limits is not None else np.percentile(frame, [0.5, 99.5])
    scale = max(1, int(np.ceil(480 / min(frame.shape))))
    # A large frame is shown at most 1600 px wide (averaged down: a page of 5 MP frames
    # would weigh megabytes each), a small one enlarged by repeating pixels.
    shrink = max(1.0, max(frame.shape) / 1600)
    fitted = (round(frame.shape[1] / shrink), round(frame.shape[0] / shrink))

    def shown(plane: np.ndarray, interpolation) -> np.ndarray:
        if shrink > 1:
            return cv2.resize(plane, fitted, interpolation=interpolation)
        return np.repeat(np.repeat(plane, scale, axis=0), scale, axis=1)

    # Averaged down before the stretch: the arithmetic on the shown pixels only (a 5 MP
    # frame's stretch in float64 was 0.07 s a picture).
    small = shown(frame.astype(np.float32), cv2.INTER_AREA) if shrink > 1 else frame
    grey = np.clip((small - low) / max(high - low, 1e-12) * 255, 0, 255).astype(np.uint8)
    picture = cv2.cvtColor(grey if shrink > 1 else shown(grey, None), cv2.COLOR_GRAY2BGR)
    font = cv2.FONT_HERSHEY_SIMPLEX
    for i, (name, mask) in enumerate(masks.items()):
        colour = _COLOURS[i % len(_COLOURS)]
        big = shown(mask.astype(np.uint8), cv2.INTER_NEAREST)
        contours, _ = cv2.findContours(big, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_SIMPLE)
        cv2.drawContours(picture, contours, -1, colour, 2)
        # The label well inside the region: of the points at least half as far from its
        # edges as its deepest one, the one nearest its centre.
        inside = cv2.distanceTransform(np.pad(big, 1), cv2.DIST_L2, 3)[1:-1, 1:-1]
        ys, xs = np.nonzero(inside >= 0.5 * inside.max())
        m = cv2.moments(big, binaryImage=True)  # the centroid without listing the pixels
        centre = (m["m01"] / m["m00"], m["m10"] / m["m00"]) if m["m00"] else (0.0, 0.0)
        k = int(np.argmin((ys - centre[0]) ** 2 + (xs - centre[1]) ** 2))
        y, x = int(ys[k]), int(xs[k])
        # Hershey fonts are ASCII: the label's ± and σ are spelt out.
        text = (labels or {}).get(name, name).replace("±", "+/-").replace("μ", "mu")
        size, weight = (0.9, 2) if len(text) <= 8 else (0.5, 1)  # a class name reads from afar
        (w, h), base = cv2.getTextSize(text, font, size, weight)
        x0 = int(np.clip(x - w // 2, 2, max(picture.shape[1] - w - 2, 2)))
        y0 = int(np.clip(y + h // 2, h + 2, picture.shape[0] - base - 2))
        cv2.rectangle(picture, (x0 - 2, y0 - h - 2), (x0 + w + 2, y0 + base), (0, 0, 0), -1)
        cv2.putText(picture, text, (x0, y0), font, size, colour, weight, cv2.LINE_AA)
    return picture
