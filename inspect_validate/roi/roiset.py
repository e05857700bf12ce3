"""ROI sets: class names mapped to shapes, read from YAML or ImageJ files.

YAML (see the manual, "ROI files")::

    erode: 2                      # optional, pixels, all classes
    classes:
      A:                          # a list of shapes ...
        - rect: [40, 30, 200, 120]
      B:                          # ... or shapes with per-class options
        erode: 4
        shapes:
          - polygon: [[300, 30], [500, 30], [500, 150]]
          - ellipse: [400, 300, 60, 40]
      C:
        - mask: c_mask.png        # relative to the ROI file
        - imagej: RoiSet.zip      # every ROI in an ImageJ file

An ImageJ ``.roi`` file or ``RoiSet.zip`` can also be given directly: each ROI's
name gives its class, up to the first ``:`` (``A:1``, ``A:2`` → class ``A``).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from inspect_validate.errors import InputError
from inspect_validate.files import atomic_write, input_file
from inspect_validate.roi.shapes import (
    MAX_CLASSES,
    MAX_VERTICES,
    Ellipse,
    MaskImage,
    Polygon,
    Rect,
    Shape,
    rasterise,
)
from inspect_validate.strict_yaml import read_mapping

__all__ = [
    "ClassRoi",
    "RoiSet",
    "bounding_box",
    "class_masks",
    "read_rois",
    "write_rois",
]


@dataclass(frozen=True)
class ClassRoi:
    """The region of one class: a union of shapes, eroded by ``erode`` pixels."""

    name: str
    shapes: tuple[tuple[Shape, str], ...]  # (shape, where it was defined)
    erode: int = 0


@dataclass(frozen=True)
class RoiSet:
    """Classes in file order, with the file they came from and, where the file records
    it, the size of the frame they were drawn on: ``(width, height)`` [px]."""

    classes: tuple[ClassRoi, ...]
    source: str
    frame: tuple[int, int] | None = None


_SHAPE_KEYS = ("rect", "polygon", "ellipse", "mask", "imagej")


def read_rois(path: str | Path) -> RoiSet:
    """Read an ROI set from YAML (``.yaml``/``.yml``) or ImageJ (``.roi``/``.zip``)."""
    path = input_file(path, "ROI file", todo="give an ROI file (YAML, or ImageJ .roi or .zip)")
    if path.suffix.lower() in (".roi", ".zip"):
        by_class: dict[str, list] = {}
        for shape, name, where in _imagej_shapes(path):
            by_class.setdefault(name.split(":")[0].strip() or name, []).append((shape, where))
        if not by_class:
            raise InputError("the ImageJ file holds no ROI", source=str(path))
        return RoiSet(tuple(ClassRoi(n, tuple(s)) for n, s in by_class.items()), str(path))
    doc = read_mapping(path, what="ROI file")
    return _plain_rois(doc, str(path)) or _modelled_rois(doc, path)


def _plain_rois(doc: dict, source: str) -> RoiSet | None:
    """The ROI set of a file in the common form, rectangles only (``classes: {A:
    [{rect: [x, y, w, h]}]}``, with ``frame``, ``erode`` and ``version: 1`` optional), read
    without the file model; None for anything else, which the model then reads.

    What it accepts the model accepts as the same set (a property test holds the two
    together): ``measure`` starts without loading pydantic (125 ms of its 0.35 s).
    """

    def whole(value, least: int) -> bool:  # an int, not a bool or a float
        return type(value) is int and value >= least

    if not set(doc) <= {"version", "frame", "erode", "classes"}:
        return None
    frame, erode, classes = doc.get("frame"), doc.get("erode", 0), doc.get("classes")
    if not (whole(doc.get("version", 1), 1) and doc.get("version", 1) == 1 and whole(erode, 0)):
        return None
    if frame is not None and not (
        type(frame) is list and len(frame) == 2 and all(whole(v, 1) for v in frame)
    ):
        return None
    if type(classes) is not dict or not 1 <= len(classes) <= MAX_CLASSES:
        return None
    read = []
    for name, shapes in classes.items():
        if type(name) is not str or not 1 <= len(name) <= 100 or "," in name:
            return None
        if type(shapes) is not list or not shapes:
            return None
        rects = []
        for i, raw in enumerate(shapes):
            rect = raw.get("rect") if type(raw) is dict and len(raw) == 1 else None
            if not (
                type(rect) is list
                and len(rect) == 4
                and all(type(v) is int for v in rect)
                and rect[2] > 0
                and rect[3] > 0
            ):
                return None
            rects.append((Rect(*rect), f"{source}: classes.{name}[{i}] (rect)"))
        read.append(ClassRoi(name, tuple(rects), erode))
    return RoiSet(tuple(read), source, None if frame is None else (frame[0], frame[1]))


def _modelled_rois(doc: dict, path: Path) -> RoiSet:
    """The ROI set of a file's mapping, validated by the file model (every form)."""
    from inspect_validate.config import validate
    from inspect_validate.roi.file import ClassModel, FileModel

    model = validate(doc, FileModel, what="ROI file", source=str(path))
    if model.version != 1:
        raise InputError(
            f"ROI file version {model.version} is not supported (1 is)", source=str(path)
        )
    classes = []
    names = {str(n) for n in model.classes}
    for name, spec in model.classes.items():
        spec = spec if isinstance(spec, ClassModel) else ClassModel(shapes=spec)
        shapes = []
        for i, raw in enumerate(spec.shapes):
            where = f"{path}: classes.{name}[{i}]"
            shapes.extend(_parse_shape(raw, path.parent, where, str(name), names))
        erode = spec.erode if spec.erode is not None else model.erode
        classes.append(ClassRoi(str(name), tuple(shapes), erode))
    return RoiSet(tuple(classes), str(path), model.frame)


def write_rois(rois: RoiSet, path: str | Path, *, comment: str = "") -> RoiSet:
    """Write ``rois`` as a YAML ROI file (with its frame size, where known) and read it back.

    ``comment`` heads the file (one ``#`` line per line). Shapes are written as rectangles,
    polygons (vertices to 0.01 px) and ellipses; a mask image keeps its file, named
    relative to ``path``.
    """
    import os

    path = Path(path)

    def flow(shape: Shape) -> str:
        if isinstance(shape, Rect):
            return f"rect: [{shape.x}, {shape.y}, {shape.width}, {shape.height}]"
        if isinstance(shape, Ellipse):
            return f"ellipse: [{shape.cx:g}, {shape.cy:g}, {shape.rx:g}, {shape.ry:g}]"
        if isinstance(shape, Polygon):
            return "polygon: [" + ", ".join(f"[{x:.2f}, {y:.2f}]" for x, y in shape.vertices) + "]"
        return f"mask: {os.path.relpath(shape.path, path.parent.resolve())}"

    lines = [f"# {line}" for line in comment.splitlines()]
    if rois.frame is not None:
        lines.append(f"frame: [{rois.frame[0]}, {rois.frame[1]}]  # width, height it was drawn on")
    lines.append("classes:")
    for cls in rois.classes:
        name = yaml_text(cls.name)
        if cls.erode:
            lines += [f"  {name}:", f"    erode: {cls.erode}", "    shapes:"]
            lines += [f"      - {flow(shape)}" for shape, _ in cls.shapes]
        else:
            lines.append(f"  {name}:")
            lines += [f"    - {flow(shape)}" for shape, _ in cls.shapes]
    atomic_write(path, ("\n".join(lines) + "\n").encode())
    return read_rois(path)


def yaml_text(text: str) -> str:
    """``text`` as a YAML scalar that reads back as this string (quoted where needed)."""
    import yaml

    return yaml.safe_dump(text, default_style=None).strip().removesuffix("...").strip()


def _parse_shape(
    raw, base: Path, where: str, name: str, names: set[str]
) -> list[tuple[Shape, str]]:
    if not isinstance(raw, dict) or len(raw) != 1 or next(iter(raw)) not in _SHAPE_KEYS:
        raise InputError(
            f"unknown shape {raw!r}: a shape is one of "
            + ", ".join(f"'{k}:'" for k in _SHAPE_KEYS),
            source=where,
        )
    from pydantic import ValidationError

    from inspect_validate.config import explain
    from inspect_validate.roi.file import ShapeModel

    kind = next(iter(raw))
    try:
        m = ShapeModel.model_validate(raw)
    except ValidationError as exc:
        raise InputError(f"{kind}: {explain(exc)}", source=where) from None
    where = f"{where} ({kind})"
    if getattr(m, kind) is None:
        raise InputError(f"'{kind}:' needs its values (see the manual, 'ROI files')", source=where)
    if kind == "rect" and m.rect is not None:
        return [(Rect(*m.rect), where)]
    if kind == "polygon" and m.polygon is not None:
        return [(Polygon(tuple((float(x), float(y)) for x, y in m.polygon)), where)]
    if kind == "ellipse" and m.ellipse is not None:
        return [(Ellipse(*m.ellipse), where)]
    target = base / getattr(m, kind)
    if kind == "mask":
        return [(MaskImage(target), where)]
    found = []
    for shape, roi_name, w in _imagej_shapes(target):
        # "B:1" names class B; a bare "B" does when the file has a class B (ImageJ's own
        # names, "0123-0456", name none).
        named = roi_name.split(":")[0].strip()
        if named != name and (":" in roi_name or named in names):
            other = f"class {named!r}" + ("" if named in names else " (not in this file)")
            raise InputError(
                f"ROI {roi_name!r} is named for {other} but listed under class {name!r}; "
                f"give {target.name} itself as the ROI file (each ROI's name gives its "
                "class), or rename the ROI",
                source=f"{where} {w}",
            )
        found.append((shape, f"{where} {w}"))
    return found


def _imagej_shapes(path: Path):
    import roifile

    input_file(path, "ImageJ ROI file", todo="give an ImageJ .roi or RoiSet .zip")
    try:
        rois = roifile.roiread(path)
    except Exception as exc:  # roifile raises several types for corrupt files
        raise InputError(f"not a readable ImageJ ROI file: {exc}", source=str(path)) from None
    rois = rois if isinstance(rois, list) else [rois]
    for i, roi in enumerate(rois):
        name = roi.name or f"roi{i}"
        where = f"{path}: ROI {i} '{name}'"
        kind = roifile.ROI_TYPE(roi.roitype)
        shape: Rect | Ellipse | Polygon
        if roi.composite or roi.subtype not in (0, roifile.ROI_SUBTYPE.UNDEFINED):
            raise InputError("composite and text ROIs are not supported", source=where)
        if kind == roifile.ROI_TYPE.RECT:
            shape = Rect(roi.left, roi.top, roi.right - roi.left, roi.bottom - roi.top)
        elif kind == roifile.ROI_TYPE.OVAL:
            rx, ry = (roi.right - roi.left) / 2, (roi.bottom - roi.top) / 2
            shape = Ellipse(roi.left + rx, roi.top + ry, rx, ry)
        elif kind in (roifile.ROI_TYPE.POLYGON, roifile.ROI_TYPE.FREEHAND, roifile.ROI_TYPE.TRACED):
            points = np.asarray(roi.coordinates(), float).reshape(-1, 2)
            if len(points) < 3 or len(points) > MAX_VERTICES or not np.isfinite(points).all():
                raise InputError(
                    f"a polygon of {len(points)} vertices (3 to {MAX_VERTICES}, finite, are "
                    "needed)",
                    source=where,
                )
            shape = Polygon(tuple((float(x), float(y)) for x, y in points))
        else:
            raise InputError(
                f"{kind.name.lower()} ROIs have no area; use rectangles, ovals or polygons",
                source=where,
            )
        yield shape, name, where


def class_masks(rois: RoiSet, frame_shape: tuple[int, int]) -> dict[str, np.ndarray]:
    """Rasterise every class to a boolean mask of ``frame_shape`` (height, width).

    Raises
    ------
    InputError
        A frame of another size than the one the file records, a shape outside the
        frame, a class empty after erosion, or two classes sharing pixels (each message
        names the file, class and shape).
    """
    if rois.frame is not None and rois.frame != (frame_shape[1], frame_shape[0]):
        w, h = rois.frame
        raise InputError(
            f"the regions were drawn on a {w}×{h} frame (frame: [{w}, {h}]), this frame is "
            f"{frame_shape[1]}×{frame_shape[0]}: they would measure other objects; capture at "
            "the size they were drawn on (camera.region, binning) or draw them on this frame",
            source=rois.source,
        )
    masks: dict[str, np.ndarray] = {}
    boxes: dict[str, tuple[int, int, int, int]] = {}
    for cls in rois.classes:
        # A one-shape class keeps its shape's mask: no second frame-sized array.
        union: np.ndarray | None = (
            np.zeros(frame_shape, dtype=bool) if len(cls.shapes) != 1 else None
        )
        for shape, where in cls.shapes:
            mask = rasterise(shape, frame_shape, where=where)
            union = mask if union is None else np.logical_or(union, mask, out=union)
        assert union is not None  # a class has at least one shape
        if cls.erode:
            union = _erode(union, cls.erode)
            if not union.any():
                raise InputError(
                    f"class {cls.name!r} has no pixel left after eroding {cls.erode} px; "
                    "enlarge its shapes or reduce 'erode'",
                    source=rois.source,
                )
        box = bounding_box(union)
        for other, mask in masks.items():
            # Only where the two classes' boxes meet can they share a pixel.
            y0, x0 = max(box[0], boxes[other][0]), max(box[1], boxes[other][1])
            y1, x1 = min(box[2], boxes[other][2]), min(box[3], boxes[other][3])
            if y0 >= y1 or x0 >= x1:
                continue
            overlap = int(np.count_nonzero(union[y0:y1, x0:x1] & mask[y0:y1, x0:x1]))
            if overlap:
                raise InputError(
                    f"classes {other!r} and {cls.name!r} share {overlap} pixels; "
                    "a pixel can belong to one class only: draw them apart, or give both "
                    "an 'erode:' of a pixel or more (their edge pixels are mixed anyway)",
                    source=rois.source,
                )
        masks[cls.name] = union
        boxes[cls.name] = box
    return masks


def bounding_box(mask: np.ndarray) -> tuple[int, int, int, int]:
    """The rows and columns a mask's pixels span: (y0, x0, y1, x1), ends exclusive;
    (0, 0, 0, 0) for an empty mask."""
    rows, cols = np.flatnonzero(mask.any(axis=1)), np.flatnonzero(mask.any(axis=0))
    if rows.size == 0:
        return (0, 0, 0, 0)
    return int(rows[0]), int(cols[0]), int(rows[-1]) + 1, int(cols[-1]) + 1


def _erode(mask: np.ndarray, radius: int) -> np.ndarray:
    """Keep the pixels farther than ``radius`` px (Euclidean) from outside the region."""
    import cv2

    padded = np.pad(mask, 1).astype(np.uint8)
    dist = cv2.distanceTransform(padded, cv2.DIST_L2, cv2.DIST_MASK_PRECISE)[1:-1, 1:-1]
    return dist > radius
