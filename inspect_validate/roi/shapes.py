"""ROI shapes and their rasterisation to pixel masks.

Coordinates are in pixels, x the column and y the row, origin at the top-left
*corner* of the frame, so pixel (x, y) covers [x, x+1) × [y, y+1) and its centre
is (x + ½, y + ½) — the ImageJ convention. A pixel belongs to a shape when its
centre lies inside; ``rect: [x, y, w, h]`` is exactly the w × h pixels from
column x and row y, and the same rectangle written as a polygon gives the same
pixels.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from inspect_validate.errors import InputError

__all__ = [
    "MAX_CLASSES",
    "MAX_VERTICES",
    "Ellipse",
    "MaskImage",
    "Polygon",
    "Rect",
    "Shape",
    "rasterise",
]

#: The most vertices a polygon may have: a drawn outline has hundreds; a million would
#: take minutes to rasterise and is no hand-made region.
MAX_VERTICES = 100_000
#: The most classes an ROI set may have.
MAX_CLASSES = 1000


@dataclass(frozen=True)
class Rect:
    """Axis-aligned rectangle: ``x, y`` top-left pixel, ``width × height`` pixels."""

    x: int
    y: int
    width: int
    height: int

    def bounds(self) -> tuple[float, float, float, float]:
        return self.x, self.y, self.x + self.width, self.y + self.height


@dataclass(frozen=True)
class Polygon:
    """Closed polygon, vertices ``((x, y), ...)`` in pixel-corner coordinates."""

    vertices: tuple[tuple[float, float], ...]

    def bounds(self) -> tuple[float, float, float, float]:
        v = np.asarray(self.vertices)
        return v[:, 0].min(), v[:, 1].min(), v[:, 0].max(), v[:, 1].max()


@dataclass(frozen=True)
class Ellipse:
    """Axis-aligned ellipse with centre ``(cx, cy)`` and semi-axes ``rx, ry``, pixels."""

    cx: float
    cy: float
    rx: float
    ry: float

    def bounds(self) -> tuple[float, float, float, float]:
        return self.cx - self.rx, self.cy - self.ry, self.cx + self.rx, self.cy + self.ry


@dataclass(frozen=True)
class MaskImage:
    """The non-zero pixels of a monochrome image file of the frame's size."""

    path: Path


Shape = Rect | Polygon | Ellipse | MaskImage


def rasterise(shape: Shape, frame_shape: tuple[int, int], *, where: str) -> np.ndarray:
    """Boolean mask of the pixels of ``shape`` in a frame of ``(height, width)``.

    Raises
    ------
    InputError
        The shape reaches outside the frame, covers no pixel, or its mask file
        is unreadable or of another size. ``where`` names the shape in the message.
    """
    height, width = frame_shape
    if isinstance(shape, MaskImage):
        from inspect_validate.images import read_image

        image = read_image(shape.path)
        if image.ndim != 2 or image.shape != (height, width):
            raise InputError(
                f"mask image {shape.path} is {image.shape[-2:]} pixels, "
                f"the frame is {(height, width)}: use a mask of the frame's size",
                source=where,
            )
        mask = image != 0
    else:
        x0, y0, x1, y1 = shape.bounds()
        if x0 < 0 or y0 < 0 or x1 > width or y1 > height:
            raise InputError(
                f"{type(shape).__name__.lower()} spans x {x0:g}..{x1:g}, y {y0:g}..{y1:g}, "
                f"outside the {width}×{height} frame (x 0..{width}, y 0..{height}); "
                "move it inside the frame",
                source=where,
            )
        mask = np.zeros((height, width), dtype=bool)
        if isinstance(shape, Rect):
            mask[shape.y : shape.y + shape.height, shape.x : shape.x + shape.width] = True
        elif isinstance(shape, Polygon):
            from skimage.draw import polygon2mask

            v = np.asarray(shape.vertices, dtype=float) - 0.5  # to pixel-centre coordinates
            mask = polygon2mask((height, width), v[:, ::-1])
        else:
            # Only the bounding box's pixels can be inside: an ellipse's test costs its
            # box, not the frame (pixel indices kept absolute, so the arithmetic is the same).
            r0, r1 = int(np.floor(y0)), min(height, int(np.ceil(y1)) + 1)
            c0, c1 = int(np.floor(x0)), min(width, int(np.ceil(x1)) + 1)
            ys, xs = np.ogrid[r0:r1, c0:c1]
            mask[r0:r1, c0:c1] = ((xs + 0.5 - shape.cx) / shape.rx) ** 2 + (
                (ys + 0.5 - shape.cy) / shape.ry
            ) ** 2 <= 1.0
    if not mask.any():
        raise InputError("the shape covers no pixel centre; make it larger", source=where)
    return mask
