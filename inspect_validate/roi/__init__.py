"""Regions of interest: which pixels belong to which object class."""

from inspect_validate.roi.roiset import ClassRoi, RoiSet, class_masks, read_rois, write_rois
from inspect_validate.roi.shapes import Ellipse, MaskImage, Polygon, Rect, rasterise

__all__ = [
    "ClassRoi",
    "Ellipse",
    "MaskImage",
    "Polygon",
    "Rect",
    "RoiSet",
    "class_masks",
    "rasterise",
    "read_rois",
    "write_rois",
]
