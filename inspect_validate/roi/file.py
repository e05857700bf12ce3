"""The ROI file's model: the YAML an ROI set is written in (see the manual, "ROI files"),
validated by pydantic; :func:`~inspect_validate.roi.roiset.read_rois` reads the common
form without it."""

from __future__ import annotations

from typing import Annotated, Any

from pydantic import Field, field_validator

from inspect_validate.config import StrictModel
from inspect_validate.roi.shapes import MAX_CLASSES, MAX_VERTICES

# The models keep their leading underscore: pydantic names a union's member in an error's
# path by its class name, and config.explain leaves such names out (the user wrote none).
# Other modules use them by the public names at the end.
__all__ = ["ClassModel", "FileModel", "ShapeModel"]

NonNegativeInt = Annotated[int, Field(ge=0)]
Coordinate = Annotated[float, Field(allow_inf_nan=False, ge=-1e7, le=1e7)]


class _ShapeModel(StrictModel):
    rect: tuple[int, int, Annotated[int, Field(gt=0)], Annotated[int, Field(gt=0)]] | None = None
    """``[x, y, width, height]``: the width × height pixels from column x, row y."""
    polygon: (
        Annotated[list[tuple[Coordinate, Coordinate]], Field(max_length=MAX_VERTICES)] | None
    ) = None
    """``[[x, y], ...]``, at least 3 vertices in pixel-corner coordinates."""
    ellipse: (
        tuple[
            Coordinate,
            Coordinate,
            Annotated[float, Field(gt=0, le=1e7, allow_inf_nan=False)],
            Annotated[float, Field(gt=0, le=1e7, allow_inf_nan=False)],
        ]
        | None
    ) = None
    """``[cx, cy, rx, ry]``: centre and semi-axes, px, axis-aligned."""
    mask: str | None = None
    """An image file of the frame's size whose non-zero pixels are the region (relative
    to the ROI file)."""
    imagej: str | None = None
    """An ImageJ ``.roi`` or ``RoiSet.zip`` (relative to the ROI file): every ROI in it,
    each named for this class (``A:1``) or not named for any."""

    @field_validator("polygon")
    @classmethod
    def _three_vertices(cls, v):
        if v is not None and len(v) < 3:
            raise ValueError("a polygon needs at least 3 vertices [[x, y], ...]")
        return v


class _ClassModel(StrictModel):
    shapes: list[dict[str, Any]] = Field(min_length=1)
    """The class's shapes; its region is their union."""
    erode: NonNegativeInt | None = None
    """Pixels to erode this class by (default: the file's ``erode``)."""


class _FileModel(StrictModel):
    version: int = 1
    """The file format's version (1)."""
    frame: tuple[Annotated[int, Field(gt=0)], Annotated[int, Field(gt=0)]] | None = None
    """The size of the frame the regions were drawn on, ``[width, height]`` px: a frame of
    another size is refused (a region drawn elsewhere would measure other objects)."""
    erode: NonNegativeInt = 0
    """Pixels to erode every class by (keeps edge pixels, blurred by the lens, out)."""
    classes: dict[
        Annotated[str, Field(min_length=1, max_length=100, pattern=r"^[^,]+$")],
        _ClassModel | Annotated[list[dict[str, Any]], Field(min_length=1)],
    ] = Field(min_length=1, max_length=MAX_CLASSES)
    """Class name → its shapes (a list), or ``{shapes: [...], erode: n}``."""


ShapeModel = _ShapeModel
"""One shape of a class (the public name of ``_ShapeModel``)."""
ClassModel = _ClassModel
"""A class's shapes and erosion (the public name of ``_ClassModel``)."""
FileModel = _FileModel
"""An ROI file (the public name of ``_FileModel``)."""
