"""Other tools' annotations read as ROI sets (``inspect-validate rois import``): label
images, labelme JSON, COCO polygons and RLE, napari shapes CSV.

Coordinates follow each format's convention and are converted to this tool's (origin at
the top-left *corner*, pixel (x, y) covering [x, x+1) × [y, y+1)): labelme and COCO use
the same; napari puts pixel centres on whole numbers (its (row, column) is our
(column + ½, row + ½)). Pixel masks (label images, COCO RLE, labelme masks) stay exact.

Annotations are drawn by people for other purposes than measuring: touching objects
share a pixel or two, a click lands past the border, a line marks a direction. An import
makes an ROI file that every command accepts, and says what it changed
(:class:`Imported`): shapes are clipped to the frame, pixels two classes share are left
out of both (such classes are written as exact masks), shapes without an area and
labelme's ``__ignore__``/``_background_`` are skipped. Each format is read through a
schema, so a malformed file is refused naming the file and the field; nothing is written
until the whole ROI file has been made and read back in a folder of its own.
"""

from __future__ import annotations

import json
import math
import os
import shutil
import tempfile
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Annotated, Any

import numpy as np
from pydantic import (
    BaseModel,
    BeforeValidator,
    ConfigDict,
    Field,
    StrictFloat,
    StrictInt,
    ValidationError,
)

from inspect_validate.errors import InputError, listed
from inspect_validate.files import input_file
from inspect_validate.roi.roiset import ClassRoi, RoiSet
from inspect_validate.roi.shapes import (
    MAX_CLASSES,
    MAX_VERTICES,
    Ellipse,
    MaskImage,
    Polygon,
    Rect,
    Shape,
)

__all__ = ["FORMATS", "IGNORED_LABELS", "Imported", "import_annotations", "read_annotations"]

#: Labels that mark what is not an object (labelme's conventions): skipped unless named.
IGNORED_LABELS = ("__ignore__", "_background_")
#: The largest annotation file read (a JSON or CSV of outlines is kilobytes).
MAX_BYTES = 64 * 2**20
#: The largest image an annotation may describe, pixels a side and in all.
MAX_SIDE, MAX_PIXELS = 100_000, 2**28

Number = StrictInt | StrictFloat  # JSON numbers; no booleans, no text


def _finite(value: Any) -> Any:
    # Before the range: NaN fails every comparison, and was told "should be ≥ −10⁷".
    if isinstance(value, float) and not math.isfinite(value):
        raise ValueError(f"{value} is not a finite number")
    return value


Coordinate = Annotated[Number, BeforeValidator(_finite), Field(ge=-1e7, le=1e7)]
Point = tuple[Coordinate, Coordinate]
Side = Annotated[StrictInt, Field(gt=0, le=MAX_SIDE)]
Label = Annotated[str, Field(min_length=1, max_length=100)]


class _Foreign(BaseModel):
    """Another tool's file: its own keys besides ours are ignored."""

    model_config = ConfigDict(extra="ignore", frozen=True)


class LabelmeShape(_Foreign):
    label: Label
    points: Annotated[list[Point], Field(max_length=MAX_VERTICES)]
    shape_type: str | None = "polygon"
    mask: str | None = None  # a base64 PNG of the shape's box (shape_type mask)


class LabelmeFile(_Foreign):
    shapes: Annotated[list[LabelmeShape], Field(max_length=100_000)]
    imageWidth: Side | None = None
    imageHeight: Side | None = None


class Rle(_Foreign):
    counts: Annotated[list[Annotated[StrictInt, Field(ge=0)]], Field(max_length=MAX_PIXELS)] | str
    size: tuple[Side, Side]  # height, width


class CocoImage(_Foreign):
    id: StrictInt | str
    file_name: str | None = None
    width: Side
    height: Side


class CocoCategory(_Foreign):
    id: StrictInt
    name: Label


class CocoAnnotation(_Foreign):
    image_id: StrictInt | str
    category_id: StrictInt
    segmentation: (
        Annotated[
            list[Annotated[list[Coordinate], Field(max_length=2 * MAX_VERTICES)]],
            Field(max_length=10_000),
        ]
        | Rle
        | None
    ) = None


class CocoFile(_Foreign):
    images: list[CocoImage]
    categories: list[CocoCategory]
    annotations: list[CocoAnnotation]


Part = tuple[Shape | np.ndarray, str]  # a shape or a boolean mask, and where it was drawn


@dataclass(frozen=True)
class Imported:
    """What an annotation file holds: per class its shapes (masks as arrays), the frame
    size where the file records it, and what was left out and why."""

    classes: dict[str, list[Part]]
    frame: tuple[int, int] | None
    notes: tuple[str, ...]


def read_annotations(
    path: str | Path,
    *,
    names: Mapping[str, str] | None = None,
    image: str | None = None,
    drop: Sequence[str] = (),
) -> Imported:
    """The classes in ``path``, by its format (:data:`FORMATS`, told by its suffix and,
    for JSON, its keys). Writes nothing.

    Parameters
    ----------
    path : path
        The annotation file.
    names : mapping, optional
        A label, category or shape number → the class name to give it (default: the
        file's own names, or its numbers); a name given twice merges those labels.
    image : str, optional
        COCO: the image whose annotations to take (its ``file_name`` or id; default: the
        only one).
    drop : sequence of str
        Labels to leave out (besides :data:`IGNORED_LABELS`, which ``names`` can keep).

    Raises
    ------
    InputError
        Not a file of a known format, a malformed one (naming the field), or one with no
        region left.
    """
    path = input_file(
        path,
        "annotation file",
        todo="give a label image, or a labelme, COCO or napari shapes file",
        largest=MAX_BYTES,
    )
    names = dict(names or {})
    reader = _reader(path)
    by_class, frame, notes = reader(path, image=image)
    unknown = sorted(set(names) - set(by_class))
    if unknown:
        raise InputError(
            f"--names gives {', '.join(unknown)}, which the file does not have (it has "
            f"{', '.join(by_class) or 'nothing with an area'})",
            source=str(path),
        )
    renamed: dict[str, list[Part]] = {}
    for label, parts in by_class.items():
        if label in drop or (label in IGNORED_LABELS and label not in names):
            notes.append(f"label {label!r}: left out ({len(parts)} shapes)")
            continue
        renamed.setdefault(names.get(label, label), []).extend(parts)
    if not renamed:
        raise InputError("the file holds no annotation with an area", source=str(path))
    if len(renamed) > MAX_CLASSES:
        raise InputError(
            f"{len(renamed)} classes, more than an ROI file holds ({MAX_CLASSES}); merge "
            "labels with --names or leave some out with --drop",
            source=str(path),
        )
    return Imported(renamed, frame, tuple(notes))


def import_annotations(
    path: str | Path,
    out: Path,
    *,
    names: Mapping[str, str] | None = None,
    image: str | None = None,
    drop: Sequence[str] = (),
    frame: tuple[int, int] | None = None,
    force: bool = False,
    comment: str = "",
) -> tuple[RoiSet, tuple[str, ...]]:
    """Import ``path`` as the ROI file ``out`` (:func:`read_annotations`), made so that
    every command accepts it: shapes clipped to the frame, shared pixels left out of both
    classes, each change said in the notes returned with the ROI set written.

    The ROI file and its masks (``<out stem>.<class>.png`` beside it) are made and read
    back in a folder of their own, then moved into place: a refused import leaves every
    existing file as it was. A mask file of that name that ``out`` does not name already
    (another ROI file's) is never overwritten.

    Raises
    ------
    InputError
        :func:`read_annotations`'s refusals; ``out`` or a mask file in the way; a frame
        size that contradicts the file's.
    """
    from inspect_validate.roi.roiset import class_masks, read_rois, write_rois

    src = str(path)
    found = read_annotations(path, names=names, image=image, drop=drop)
    if frame is not None and found.frame is not None and found.frame != frame:
        raise InputError(
            f"the file says its image is {found.frame[0]}×{found.frame[1]}, --size says "
            f"{frame[0]}×{frame[1]}",
            source=src,
        )
    size = frame or found.frame
    notes = list(found.notes)
    classes = _fitted(found.classes, size, notes) if size is not None else found.classes
    if not classes and size is not None:
        raise InputError(
            f"no class keeps a pixel of the {size[0]}×{size[1]} frame ({listed(notes, 3)}): "
            "nothing to import; check the shapes' coordinates and the image size",
            source=src,
        )
    if size is None and any(isinstance(p, np.ndarray) for ps in classes.values() for p, _ in ps):
        raise InputError("a pixel mask needs the image size; give --size WxH", source=src)

    out = Path(out)
    if out.is_dir():
        raise InputError("is a folder; give a file name for the ROI file", source=str(out))
    if out.exists() and not force:
        raise InputError(f"{out} exists; give --force to overwrite it", source="rois import")
    out.parent.mkdir(parents=True, exist_ok=True)
    ours = _masks_named_by(out) if out.exists() else set()
    stage = Path(tempfile.mkdtemp(prefix=".rois-import-", dir=out.parent))
    try:
        staged_rois = stage / out.name
        shaped = []
        for name, parts in classes.items():
            shapes: list[tuple[Shape, str]] = []
            for part, where in parts:
                if isinstance(part, np.ndarray):
                    shapes.append((_write_mask(part, stage / out.stem, name), where))
                else:
                    shapes.append((part, where))
            shaped.append(ClassRoi(name, tuple(shapes)))
        made = write_rois(RoiSet(tuple(shaped), src, size), staged_rois, comment=comment)
        if size is not None:
            class_masks(made, (size[1], size[0]))  # what every command will do with it
        masks = sorted(p for p in stage.iterdir() if p.name != out.name)
        for m in masks:
            target = out.parent / m.name
            if target.exists() and target.resolve() not in ours:
                raise InputError(
                    f"{target.name} exists and {out.name} does not name it (another ROI "
                    "file's mask?); choose another --out or remove it",
                    source=str(target),
                )
        for m in masks:
            os.replace(m, out.parent / m.name)
        os.replace(staged_rois, out)
    except InputError as exc:
        if exc.source is None or str(stage) not in exc.source:
            raise
        # The staging folder is the tool's own: the input is what the user can mend.
        said = str(exc).removeprefix(f"{exc.source}: ").replace(str(stage), str(out.parent))
        raise InputError(f"{said} (importing into {out})", source=src) from None
    finally:
        shutil.rmtree(stage, ignore_errors=True)
    return read_rois(out), tuple(notes)


def _masks_named_by(rois: Path) -> set[Path]:
    """The mask files an existing ROI file names (overwritten with it on --force)."""
    from inspect_validate.roi.roiset import read_rois

    try:
        held = read_rois(rois)
    except InputError:
        return set()
    return {
        shape.path.resolve()
        for cls in held.classes
        for shape, _ in cls.shapes
        if isinstance(shape, MaskImage)
    }


def _fitted(
    classes: dict[str, list[Part]], frame: tuple[int, int], notes: list[str]
) -> dict[str, list[Part]]:
    """The classes within the frame and apart: polygons clipped to it, other shapes that
    reach past it drawn as masks; pixels of several classes left out of each, those
    classes then one exact mask each; a shape or class with no pixel left out."""
    width, height = frame
    fitted: dict[str, list[Part]] = {}
    unions: dict[str, np.ndarray] = {}
    count = np.zeros((height, width), dtype=np.uint16)
    for name, parts in classes.items():
        kept: list[Part] = []
        union = np.zeros((height, width), dtype=bool)
        for part, where in parts:
            mask, part = _within(part, where, width, height, notes)
            if not mask.any():
                notes.append(f"{where}: covers no pixel of the frame; left out")
                continue
            kept.append((part, where))
            union |= mask
        if not kept:
            notes.append(f"class {name!r}: no pixel in the frame; left out")
            continue
        fitted[name], unions[name] = kept, union
        count += union
    shared = count > 1
    if shared.any():
        touched = [n for n, u in unions.items() if (u & shared).any()]
        for name in touched:
            with_others = [o for o in touched if o != name and (unions[o] & unions[name]).any()]
            n = int(np.count_nonzero(unions[name] & shared))
            notes.append(
                f"class {name!r}: {n} pixels it shares with {', '.join(map(repr, with_others))} "
                "left out (a pixel belongs to one class); written as an exact mask"
            )
            region = unions[name] & ~shared
            if not region.any():
                notes.append(f"class {name!r}: no pixel of its own; left out")
                del fitted[name]
                continue
            fitted[name] = [(region, f"{name}: its shapes less the shared pixels")]
    return fitted


def _within(
    part: Shape | np.ndarray, where: str, width: int, height: int, notes: list[str]
) -> tuple[np.ndarray, Shape | np.ndarray]:
    """A shape's pixels in the frame, and the shape to write: a polygon that reaches past
    the border clipped to it, another shape that does as its mask inside the frame."""
    from inspect_validate.roi.shapes import rasterise

    none = np.zeros((height, width), dtype=bool)
    if isinstance(part, np.ndarray):
        return part, part
    if isinstance(part, MaskImage):
        return rasterise(part, (height, width), where=where), part
    x0, y0, x1, y1 = part.bounds()
    if not (x0 >= 0 and y0 >= 0 and x1 <= width and y1 <= height):
        notes.append(f"{where}: clipped to the {width}×{height} frame")
        if isinstance(part, Polygon):
            clipped = _clip(np.asarray(part.vertices, dtype=float), width, height)
            if len(clipped) < 3:
                return none, part
            part = Polygon(tuple(map(tuple, clipped)))
        else:
            ys, xs = np.ogrid[0:height, 0:width]
            cx, cy = (x0 + x1) / 2, (y0 + y1) / 2
            rx, ry = (x1 - x0) / 2, (y1 - y0) / 2
            mask = ((xs + 0.5 - cx) / rx) ** 2 + ((ys + 0.5 - cy) / ry) ** 2 <= 1.0
            if isinstance(part, Rect):
                mask = (xs >= x0) & (xs < x1) & (ys >= y0) & (ys < y1)
            return mask, mask
    try:
        return rasterise(part, (height, width), where=where), part
    except InputError:  # covers no pixel centre: a sliver or a line
        return none, part


def _clip(vertices: np.ndarray, width: float, height: float) -> np.ndarray:
    """A polygon clipped to the rectangle [0, width] × [0, height] (Sutherland–Hodgman:
    exact for the convex clip region, whatever the polygon)."""
    for axis, limit, keep_below in ((0, 0.0, False), (0, width, True), (1, 0.0, False),
                                    (1, height, True)):  # fmt: skip
        if len(vertices) == 0:
            break
        s = vertices[:, axis] - limit
        inside = s <= 0 if keep_below else s >= 0
        prev = np.roll(vertices, 1, axis=0)
        sp = np.roll(s, 1)
        crosses = inside != np.roll(inside, 1)
        t = np.divide(sp, sp - s, out=np.zeros_like(s), where=crosses)
        cut = prev + t[:, None] * (vertices - prev)
        out = []
        for k in range(len(vertices)):  # per vertex: its edge's crossing, then itself
            if crosses[k]:
                out.append(cut[k])
            if inside[k]:
                out.append(vertices[k])
        vertices = np.asarray(out, dtype=float).reshape(-1, 2)
    return vertices


Reader = Callable[..., tuple[dict[str, list[Part]], tuple[int, int] | None, list[str]]]


def _reader(path: Path) -> Reader:
    suffix = path.suffix.lower()
    if suffix in (".png", ".tif", ".tiff"):
        return _label_image
    if suffix == ".csv":
        return _napari_csv
    if suffix == ".json":
        doc = _json(path)
        if isinstance(doc, dict) and "shapes" in doc:
            return lambda p, image: _labelme(p, doc)
        if isinstance(doc, dict) and "annotations" in doc and "categories" in doc:
            return lambda p, image: _coco(p, doc, image)
        raise InputError(
            "a JSON file that is neither labelme (shapes) nor COCO (annotations, categories)",
            source=str(path),
        )
    raise InputError(
        f"unknown annotation format {suffix!r}; one of: "
        + "; ".join(f"{k} ({v})" for k, v in FORMATS.items()),
        source=str(path),
    )


def _json(path: Path) -> Any:
    try:
        return json.loads(path.read_text())
    except (UnicodeDecodeError, ValueError) as exc:  # ValueError: also a 5000-digit number
        raise InputError(f"not valid JSON ({exc})", source=str(path)) from None
    except RecursionError:
        raise InputError("not valid JSON here (nested too deeply)", source=str(path)) from None


def _validated(model: type[BaseModel], doc: Any, path: Path, what: str) -> Any:
    from inspect_validate.config import explain

    try:
        return model.model_validate(doc)
    except ValidationError as exc:
        raise InputError(f"not a {what} file: {explain(exc)}", source=str(path)) from None


#: What ``rois import`` reads, by file type.
FORMATS = {
    ".png, .tif": "an integer label image, 0 the background (napari, ilastik, QuPath, CVAT's "
    "instance masks)",
    ".json": "labelme (polygon, rectangle, circle, mask) or COCO (polygons and RLE)",
    ".csv": "napari's shapes layer (polygon, rectangle, ellipse)",
}


def _write_mask(mask: np.ndarray, stem: Path, name: str) -> MaskImage:
    import cv2

    safe = "".join(c if c.isalnum() or c in "-_." else "_" for c in name)
    target = stem.parent / f"{stem.name}.{safe}.png"
    if not cv2.imwrite(str(target), mask.astype(np.uint8) * 255):
        raise InputError("cannot write the class's mask image", source=str(target))
    return MaskImage(target.resolve())


def _label_image(path: Path, *, image: str | None):
    from inspect_validate.images import read_image

    labels = read_image(path)
    if labels.ndim != 2:
        raise InputError("a label image is one plane of integer labels", source=str(path))
    if labels.dtype.kind not in "ui":
        raise InputError(
            f"labels are {labels.dtype}, not integers; export the labels as an integer image",
            source=str(path),
        )
    values = np.unique(labels)
    values = values[values != 0]
    if values.size > MAX_CLASSES:
        raise InputError(
            f"{values.size} labels, more than an ROI file holds ({MAX_CLASSES} classes): "
            "is this an instance image? Export one label per class",
            source=str(path),
        )
    found = {
        str(int(v)): [(labels == v, f"{path}: label {int(v)}")] for v in values
    }  # fmt: skip
    return found, (labels.shape[1], labels.shape[0]), []


_NO_AREA = {"line", "linestrip", "line_strip", "point", "points"}


def _camera_sized(width: int, height: int, what: str, path: Path) -> None:
    """Refuse an annotated image no camera takes, before a mask of its size is made."""
    if width * height > MAX_PIXELS:
        raise InputError(
            f"{what} is {width}×{height}: larger than any camera's frame ({MAX_PIXELS} pixels)",
            source=str(path),
        )


def _labelme(path: Path, doc: Any):
    import base64

    import cv2

    lm = _validated(LabelmeFile, doc, path, "labelme")
    frame = (lm.imageWidth, lm.imageHeight) if lm.imageWidth and lm.imageHeight else None
    if frame is not None:
        _camera_sized(*frame, "its image (imageWidth × imageHeight)", path)
    found: dict[str, list[Part]] = {}
    notes: list[str] = []
    skipped: dict[str, int] = {}
    for i, shape in enumerate(lm.shapes):
        label = shape.label.strip()
        kind = shape.shape_type or "polygon"
        where = f"{path}: shapes[{i}] '{label}' ({kind})"
        if not label:
            raise InputError("a shape without a label", source=where)
        pts = np.asarray(shape.points, dtype=float).reshape(-1, 2)
        drawn: Shape | np.ndarray
        if kind in _NO_AREA:
            skipped[kind] = skipped.get(kind, 0) + 1
            continue
        if kind in ("polygon", "oriented_rectangle") and len(pts) >= 3:
            drawn = Polygon(tuple(map(tuple, pts)))
        elif kind == "rectangle" and len(pts) == 2:
            (x0, y0), (x1, y1) = pts.min(axis=0), pts.max(axis=0)
            drawn = Polygon(((x0, y0), (x1, y0), (x1, y1), (x0, y1)))
        elif kind == "circle" and len(pts) == 2:
            r = float(np.hypot(*(pts[1] - pts[0])))
            if not r > 0:
                skipped["circle of radius 0"] = skipped.get("circle of radius 0", 0) + 1
                continue
            drawn = Ellipse(float(pts[0][0]), float(pts[0][1]), r, r)
        elif kind == "mask" and shape.mask is not None and len(pts) >= 1:
            if frame is None:
                raise InputError("a mask needs the file's imageWidth and imageHeight", source=where)
            try:
                raw = base64.b64decode(shape.mask, validate=False)
                patch = cv2.imdecode(np.frombuffer(raw, np.uint8), cv2.IMREAD_UNCHANGED)
            except (ValueError, cv2.error):
                patch = None
            if patch is None or patch.ndim != 2 or patch.size > MAX_PIXELS:
                raise InputError("its mask is not a base64 PNG of one plane", source=where)
            x1, y1 = (int(np.rint(v)) for v in pts[0])
            full = np.zeros((frame[1], frame[0]), dtype=bool)
            ys, xs = max(y1, 0), max(x1, 0)
            ye, xe = min(y1 + patch.shape[0], frame[1]), min(x1 + patch.shape[1], frame[0])
            if ys < ye and xs < xe:
                full[ys:ye, xs:xe] = patch[ys - y1 : ye - y1, xs - x1 : xe - x1] != 0
            drawn = full
        elif kind in ("polygon", "rectangle", "circle", "mask", "oriented_rectangle"):
            raise InputError(
                f"a {kind} of {len(pts)} points{' and no mask' if kind == 'mask' else ''}: "
                "not a shape labelme writes",
                source=where,
            )
        else:
            raise InputError(
                f"unknown labelme shape type {kind!r}: polygon, rectangle, circle and mask "
                "have an area (lines and points are skipped)",
                source=where,
            )
        found.setdefault(label, []).append((drawn, where))
    for kind, n in skipped.items():
        notes.append(f"{n} {kind} shape{'s' if n > 1 else ''}: no area; left out")
    return found, frame, notes


def _coco(path: Path, doc: Any, image: str | None):
    coco = _validated(CocoFile, doc, path, "COCO")
    images = coco.images
    if image is not None:
        chosen = [i for i in images if image in (str(i.id), str(i.file_name))]
    else:
        chosen = images
    if len(chosen) != 1:
        listing = ", ".join(str(i.file_name or i.id) for i in images) or "none"
        raise InputError(
            ("no image " + repr(image) if image is not None else f"{len(images)} images")
            + f" in the file ({listing}); give --image with the one whose regions to take",
            source=str(path),
        )
    picked = chosen[0]
    width, height = picked.width, picked.height
    _camera_sized(width, height, f"image {picked.file_name or picked.id}", path)
    categories: dict[int, str] = {}
    for c in coco.categories:
        if c.id in categories:
            raise InputError(
                f"category id {c.id} is listed twice ({categories[c.id]!r}, {c.name!r})",
                source=str(path),
            )
        categories[c.id] = c.name
    found: dict[str, list[Part]] = {}
    pixels: dict[str, np.ndarray] = {}
    notes: list[str] = []
    for i, ann in enumerate(coco.annotations):
        if str(ann.image_id) != str(picked.id):
            continue
        name = categories.get(ann.category_id)
        where = f"{path}: annotations[{i}] ({name})"
        if name is None:
            raise InputError(f"category {ann.category_id} is not listed", source=where)
        segmentation = ann.segmentation
        if isinstance(segmentation, list):
            for polygon in segmentation:
                pts = np.asarray(polygon, dtype=float)
                if pts.size % 2 or pts.size < 6:
                    raise InputError("a polygon is x, y pairs of at least 3 points", source=where)
                found.setdefault(name, []).append(
                    (Polygon(tuple(map(tuple, pts.reshape(-1, 2)))), where)
                )
        elif isinstance(segmentation, Rle):
            mask = _decode_rle(segmentation, (height, width), where)
            pixels[name] = pixels[name] | mask if name in pixels else mask
        else:
            notes.append(f"{where}: no segmentation (a bounding box alone is no region); left out")
    for name, mask in pixels.items():
        found.setdefault(name, []).append((mask, f"{path}: {name} (RLE)"))
    if not found:
        raise InputError(
            f"image {picked.file_name or picked.id} has no annotation with a segmentation "
            f"(of {len(coco.annotations)} annotations in the file)",
            source=str(path),
        )
    return found, (width, height), notes


def _decode_rle(rle: Rle, shape: tuple[int, int], where: str) -> np.ndarray:
    """A COCO run-length encoding (counts as a list, or pycocotools' compressed text),
    checked before pycocotools sees it (it crashes the process on some)."""
    if list(rle.size) != [shape[0], shape[1]]:
        raise InputError(
            f"RLE size {list(rle.size)} is not the image's [{shape[0]}, {shape[1]}]", source=where
        )
    n = shape[0] * shape[1]
    if isinstance(rle.counts, list):
        total = sum(rle.counts)
        if total != n:
            raise InputError(
                f"RLE counts sum to {total}, not the image's {shape[0]}×{shape[1]} = {n} pixels",
                source=where,
            )
        # Column-major runs, starting with background: decoded here, no library needed.
        values = np.repeat(np.arange(len(rle.counts)) % 2 == 1, rle.counts)
        return values.reshape(shape[1], shape[0]).T.copy()
    if not rle.counts.isascii() or any(c < "0" or c > "o" for c in rle.counts):
        raise InputError("RLE counts text is not COCO's compressed RLE", source=where)
    try:
        from pycocotools import mask as coco_mask
    except ImportError:
        raise InputError(
            "compressed COCO RLE needs pycocotools: pip install 'inspect-validate[coco]'",
            source=where,
        ) from None
    encoded = {"counts": rle.counts.encode("ascii"), "size": list(rle.size)}
    try:
        if int(coco_mask.area(encoded)) > n:
            raise ValueError("more pixels than the image")
        return coco_mask.decode(encoded).astype(bool)
    except Exception as exc:  # pycocotools raises bare exceptions for corrupt counts
        raise InputError(f"RLE does not decode ({exc})", source=where) from None


def _napari_csv(path: Path, *, image: str | None):
    import csv

    try:
        with path.open(newline="") as f:
            rows = list(csv.DictReader(f))
    except (UnicodeDecodeError, csv.Error) as exc:
        raise InputError(f"not a text CSV file ({exc})", source=str(path)) from None
    needed = {"index", "shape-type", "vertex-index", "axis-0", "axis-1"}
    if not rows or not needed <= set(rows[0]):
        raise InputError(
            f"a napari shapes CSV has the columns {', '.join(sorted(needed))}", source=str(path)
        )
    three = "axis-2" in rows[0]
    shapes: dict[int, tuple[str, list]] = {}
    for n, row in enumerate(rows, start=2):
        where = f"{path}: line {n}"
        values = [row.get(k) for k in (*sorted(needed), *(["axis-2"] if three else []))]
        if any(v is None or not str(v).strip() for v in values) or None in row:
            raise InputError(
                "a row with missing or extra values (every row has every column)", source=where
            )
        number = str(row["index"]).strip()
        if not (number.isascii() and number.isdigit() and len(number) < 10) or (
            number != str(int(number))
        ):
            raise InputError(f"index {number!r} is not a shape number (0, 1, 2…)", source=where)
        try:
            # Only the last two axes: a 3-D layer's frame axis comes first.
            axes = ("axis-2", "axis-1") if three else ("axis-1", "axis-0")
            x, y = (float(row[a]) + 0.5 for a in axes)
        except ValueError:
            raise InputError("a coordinate is not a number", source=where) from None
        if not (np.isfinite(x) and np.isfinite(y) and abs(x) <= 1e7 and abs(y) <= 1e7):
            raise InputError("a coordinate is not a finite number within ±10⁷", source=where)
        points = shapes.setdefault(int(number), (str(row["shape-type"]).strip(), []))[1]
        if len(points) >= MAX_VERTICES:
            # Said at the row that passes the limit, not after every row is parsed and the
            # ROI file is written (a shape of 10⁶ vertices took minutes to be refused).
            raise InputError(
                f"shape {number} has more than {MAX_VERTICES} vertices, more than an ROI file "
                "holds: simplify its outline (or import it as a label image)",
                source=where,
            )
        points.append((x, y))
    found: dict[str, list[Part]] = {}
    notes: list[str] = []
    for index, (kind, pts) in shapes.items():
        where = f"{path}: shape {index} ({kind})"
        arr = np.asarray(pts)
        drawn: Shape
        if kind in ("polygon", "rectangle") and len(arr) >= 3:
            drawn = Polygon(tuple(map(tuple, arr)))
        elif kind == "ellipse" and len(arr) == 4:  # its bounding box's corners
            (x0, y0), (x1, y1) = arr.min(axis=0), arr.max(axis=0)
            if not (x1 > x0 and y1 > y0):
                notes.append(f"{where}: no area; left out")
                continue
            drawn = Ellipse((x0 + x1) / 2, (y0 + y1) / 2, (x1 - x0) / 2, (y1 - y0) / 2)
        elif kind in ("line", "path", "points"):
            notes.append(f"{where}: no area; left out")
            continue
        else:
            raise InputError(
                f"a {kind} of {len(arr)} points: napari's shapes with an area are polygon, "
                "rectangle and ellipse",
                source=where,
            )
        found[str(index + 1)] = [(drawn, where)]
    return found, None, notes
