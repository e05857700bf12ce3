"""Other tools' annotations read as ROI sets (``inspect-validate rois import``): label
images, labelme JSON, COCO polygons and RLE, napari shapes CSV.

Coordinates follow each format's convention and are converted to this tool's (origin at
the top-left *corner*, pixel (x, y) covering [x, x+1) × [y, y+1)): labelme and COCO use
the same; napari puts pixel centres on whole numbers (its (row, column) is our
(column + ½, row + ½)). Pixel masks (label images, COCO RLE) stay exact: they are written
as one mask image per class beside the ROI file.
"""

from __future__ import annotations

import json
from collections.abc import Callable, Mapping
from pathlib import Path

import numpy as np

from inspect_validate.errors import InputError
from inspect_validate.files import input_file
from inspect_validate.roi.roiset import ClassRoi, RoiSet
from inspect_validate.roi.shapes import Ellipse, MaskImage, Polygon, Shape

__all__ = ["FORMATS", "read_annotations"]


def read_annotations(
    path: str | Path,
    *,
    masks: Path,
    names: Mapping[str, str] | None = None,
    image: str | None = None,
) -> RoiSet:
    """The ROI set in ``path``, by its format (:data:`FORMATS`, told by its suffix and,
    for JSON, its keys).

    Parameters
    ----------
    path : path
        The annotation file.
    masks : Path
        Where pixel masks are written: ``<masks>.<class>.png`` (the ROI file's path
        without its suffix, so that they lie beside it).
    names : mapping, optional
        A label, category or shape number → the class name to give it (default: the
        file's own names, or its numbers).
    image : str, optional
        COCO: the image whose annotations to take (its ``file_name`` or id; default: the
        only one).

    Raises
    ------
    InputError
        Not a file of a known format, or a shape this tool cannot use (a line, a point),
        naming the file and the annotation.
    """
    path = input_file(
        path,
        "annotation file",
        todo="give a label image, or a labelme, COCO or napari shapes file",
    )
    reader = _reader(path)
    by_class, frame = reader(path, masks=masks, image=image)
    if not by_class:
        raise InputError("the file holds no annotation with an area", source=str(path))
    renamed: dict[str, list] = {}
    for label, shapes in by_class.items():
        renamed.setdefault((names or {}).get(label, label), []).extend(shapes)
    unknown = sorted(set(names or {}) - set(by_class))
    if unknown:
        raise InputError(
            f"--names gives {', '.join(unknown)}, which the file does not have (it has "
            f"{', '.join(by_class)})",
            source=str(path),
        )
    return RoiSet(
        tuple(ClassRoi(name, tuple(shapes)) for name, shapes in renamed.items()), str(path), frame
    )


Found = tuple[dict[str, list[tuple[Shape, str]]], tuple[int, int] | None]


def _reader(path: Path) -> Callable[..., Found]:
    suffix = path.suffix.lower()
    if suffix in (".png", ".tif", ".tiff"):
        return _label_image
    if suffix == ".csv":
        return _napari_csv
    if suffix == ".json":
        try:
            doc = json.loads(path.read_text())
        except (UnicodeDecodeError, json.JSONDecodeError) as exc:
            raise InputError(f"not valid JSON ({exc})", source=str(path)) from None
        if isinstance(doc, dict) and "shapes" in doc:
            return _labelme
        if isinstance(doc, dict) and "annotations" in doc and "categories" in doc:
            return _coco
        raise InputError(
            "a JSON file that is neither labelme (shapes) nor COCO (annotations, categories)",
            source=str(path),
        )
    raise InputError(
        f"unknown annotation format {suffix!r}; one of: "
        + "; ".join(f"{k} ({v})" for k, v in FORMATS.items()),
        source=str(path),
    )


#: What ``rois import`` reads, by file type.
FORMATS = {
    ".png, .tif": "an integer label image, 0 the background (napari, ilastik, QuPath, CVAT's "
    "instance masks)",
    ".json": "labelme (polygon, rectangle, circle) or COCO (polygons and RLE)",
    ".csv": "napari's shapes layer (polygon, rectangle, ellipse)",
}


def _write_mask(mask: np.ndarray, masks: Path, name: str) -> MaskImage:
    import cv2

    safe = "".join(c if c.isalnum() or c in "-_." else "_" for c in name)
    target = masks.parent / f"{masks.name}.{safe}.png"
    if not cv2.imwrite(str(target), mask.astype(np.uint8) * 255):
        raise InputError("cannot write the class's mask image", source=str(target))
    return MaskImage(target.resolve())


def _label_image(path: Path, *, masks: Path, image: str | None) -> Found:
    from inspect_validate.images import read_image

    labels = read_image(path)
    if labels.ndim != 2:
        raise InputError("a label image is one plane of integer labels", source=str(path))
    if labels.dtype.kind not in "ui":
        raise InputError(
            f"labels are {labels.dtype}, not integers; export the labels as an integer image",
            source=str(path),
        )
    found: dict[str, list[tuple[Shape, str]]] = {}
    for value in np.unique(labels):
        if value == 0:
            continue
        name = str(int(value))
        found[name] = [(_write_mask(labels == value, masks, name), f"{path}: label {name}")]
    return found, (labels.shape[1], labels.shape[0])


def _points(raw, where: str) -> np.ndarray:
    try:
        pts = np.asarray(raw, dtype=float).reshape(-1, 2)
    except (TypeError, ValueError):
        raise InputError("points are not [x, y] pairs", source=where) from None
    if not np.all(np.isfinite(pts)):
        raise InputError("a point is not a finite number", source=where)
    return pts


def _labelme(path: Path, *, masks: Path, image: str | None) -> Found:
    doc = json.loads(path.read_text())
    found: dict[str, list[tuple[Shape, str]]] = {}
    for i, shape in enumerate(doc.get("shapes") or []):
        label = str(shape.get("label", "")).strip()
        kind = shape.get("shape_type") or "polygon"
        where = f"{path}: shapes[{i}] '{label}' ({kind})"
        if not label:
            raise InputError("a shape without a label", source=where)
        pts = _points(shape.get("points"), where)
        drawn: Shape
        if kind == "polygon" and len(pts) >= 3:
            drawn = Polygon(tuple(map(tuple, pts)))
        elif kind == "rectangle" and len(pts) == 2:
            (x0, y0), (x1, y1) = pts.min(axis=0), pts.max(axis=0)
            drawn = Polygon(((x0, y0), (x1, y0), (x1, y1), (x0, y1)))
        elif kind == "circle" and len(pts) == 2:
            r = float(np.hypot(*(pts[1] - pts[0])))
            drawn = Ellipse(float(pts[0][0]), float(pts[0][1]), r, r)
        else:
            raise InputError(
                f"a {kind} of {len(pts)} points has no area; use polygons, rectangles or circles",
                source=where,
            )
        found.setdefault(label, []).append((drawn, where))
    width, height = doc.get("imageWidth"), doc.get("imageHeight")
    frame = (
        (int(width), int(height)) if isinstance(width, int) and isinstance(height, int) else None
    )
    return found, frame


def _coco(path: Path, *, masks: Path, image: str | None) -> Found:
    doc = json.loads(path.read_text())
    images = doc.get("images") or []
    if image is not None:
        chosen = [i for i in images if image in (str(i.get("id")), str(i.get("file_name")))]
    else:
        chosen = images
    if len(chosen) != 1:
        listing = ", ".join(str(i.get("file_name", i.get("id"))) for i in images) or "none"
        raise InputError(
            ("no image " + repr(image) if image is not None else f"{len(images)} images")
            + f" in the file ({listing}); give --image with the one whose regions to take",
            source=str(path),
        )
    picked = chosen[0]
    width, height = int(picked["width"]), int(picked["height"])
    categories = {c["id"]: str(c["name"]) for c in doc["categories"]}
    found: dict[str, list[tuple[Shape, str]]] = {}
    pixels: dict[str, np.ndarray] = {}
    for i, ann in enumerate(doc["annotations"]):
        if ann.get("image_id") != picked.get("id"):
            continue
        name = categories.get(ann.get("category_id"))
        where = f"{path}: annotations[{i}] ({name})"
        if name is None:
            raise InputError(f"category {ann.get('category_id')} is not listed", source=where)
        segmentation = ann.get("segmentation")
        if isinstance(segmentation, list):
            for polygon in segmentation:
                pts = _points(polygon, where)
                if len(pts) < 3:
                    raise InputError("a polygon of fewer than 3 points", source=where)
                found.setdefault(name, []).append((Polygon(tuple(map(tuple, pts))), where))
        elif isinstance(segmentation, dict):
            mask = _decode_rle(segmentation, (height, width), where)
            pixels[name] = pixels[name] | mask if name in pixels else mask
        else:
            raise InputError("no segmentation (a bounding box alone is not a region)", source=where)
    for name, mask in pixels.items():
        found.setdefault(name, []).append((_write_mask(mask, masks, name), f"{path}: {name} (RLE)"))
    return found, (width, height)


def _decode_rle(rle: dict, shape: tuple[int, int], where: str) -> np.ndarray:
    """A COCO run-length encoding (counts as a list, or pycocotools' compressed text)."""
    try:
        from pycocotools import mask as coco_mask
    except ImportError:
        raise InputError(
            "COCO RLE needs pycocotools: pip install 'inspect-validate[coco]'", source=where
        ) from None
    size = rle.get("size")
    if list(size or ()) != [shape[0], shape[1]]:
        raise InputError(
            f"RLE size {size} is not the image's [{shape[0]}, {shape[1]}]", source=where
        )
    counts = rle.get("counts")
    if isinstance(counts, list):
        encoded = coco_mask.frPyObjects({"counts": counts, "size": size}, *shape)
    elif isinstance(counts, str):
        encoded = {"counts": counts.encode("ascii"), "size": size}
    else:
        raise InputError("RLE counts are neither a list nor text", source=where)
    try:
        return coco_mask.decode(encoded).astype(bool)
    except Exception as exc:  # pycocotools raises bare exceptions for corrupt counts
        raise InputError(f"RLE does not decode ({exc})", source=where) from None


def _napari_csv(path: Path, *, masks: Path, image: str | None) -> Found:
    import csv

    with path.open(newline="") as f:
        rows = list(csv.DictReader(f))
    needed = {"index", "shape-type", "vertex-index", "axis-0", "axis-1"}
    if not rows or not needed <= set(rows[0]):
        raise InputError(
            f"a napari shapes CSV has the columns {', '.join(sorted(needed))}", source=str(path)
        )
    shapes: dict[str, tuple[str, list]] = {}
    for row in rows:
        try:
            # Only the last two axes: a 3-D layer's frame axis comes first.
            point = (float(row["axis-1"]) + 0.5, float(row["axis-0"]) + 0.5)
            if "axis-2" in row and row["axis-2"] not in (None, ""):
                point = (float(row["axis-2"]) + 0.5, float(row["axis-1"]) + 0.5)
        except ValueError:
            raise InputError(
                f"shape {row['index']}: a coordinate is not a number", source=str(path)
            ) from None
        shapes.setdefault(row["index"], (row["shape-type"], []))[1].append(point)
    found: dict[str, list[tuple[Shape, str]]] = {}
    for index, (kind, pts) in shapes.items():
        where = f"{path}: shape {index} ({kind})"
        arr = np.asarray(pts)
        drawn: Shape
        if kind in ("polygon", "rectangle") and len(arr) >= 3:
            drawn = Polygon(tuple(map(tuple, arr)))
        elif kind == "ellipse" and len(arr) == 4:  # its bounding box's corners
            (x0, y0), (x1, y1) = arr.min(axis=0), arr.max(axis=0)
            drawn = Ellipse((x0 + x1) / 2, (y0 + y1) / 2, (x1 - x0) / 2, (y1 - y0) / 2)
        else:
            raise InputError(
                f"a {kind} has no area; use polygons, rectangles or ellipses", source=where
            )
        found[str(int(index) + 1)] = [(drawn, where)]
    return found, None
