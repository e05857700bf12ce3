"""Reading monochrome frames: 8/16-bit PNG, TIFF (also multi-page stacks), PGM, BMP, NPY.

A frame is a 2-D array of grey values in DN. A colour file whose channels are all
equal is accepted as grey; any other colour image is refused, since a
monochrome inspection must not silently measure a colour conversion.
"""

from __future__ import annotations

import glob
import json
from collections.abc import Iterable, Mapping
from pathlib import Path

import numpy as np

from inspect_validate.errors import InputError
from inspect_validate.files import input_file

__all__ = ["expand_paths", "is_image_name", "read_frames", "read_image", "recorded_bit_depth"]

_TIFF = (".tif", ".tiff")
_OPENCV = (".png", ".pgm", ".pnm", ".bmp", ".jpg", ".jpeg")


FramePaths = str | Path | Iterable[str | Path]
"""Frames to read: a file (a frame or a stack), a folder of them, a quoted glob pattern,
or a sequence of these."""


def read_image(path: str | Path, *, finite: bool = True) -> np.ndarray:
    """One image file as (H, W) or, for a multi-page TIFF or 3-D NPY, (N, H, W).

    ``finite=False`` lets NaN and infinite pixels of float images through, for a caller
    that uses some pixels only (a measurement: only its regions' pixels must be numbers).

    Raises
    ------
    InputError
        Missing, unreadable, empty or colour files (the message names the file).
    """
    path = input_file(path, "image file", todo="give an image file (TIFF, PNG, NPY…)")
    suffix = path.suffix.lower()
    colour: bool | None = None  # known from the file where it says (samples per pixel)
    image: np.ndarray | None
    try:
        if suffix in _TIFF:
            image, colour = _read_tiff(path)
        elif suffix == ".npy":
            image = np.load(path, allow_pickle=False)
        elif suffix in _OPENCV:
            import cv2

            image = cv2.imread(str(path), cv2.IMREAD_UNCHANGED)
            if image is None:
                raise ValueError("OpenCV could not decode it")
            colour = image.ndim == 3
        else:
            raise InputError(
                f"unknown image type '{suffix}': use TIFF, PNG, PGM, BMP or NPY", source=str(path)
            )
    except InputError:
        raise
    except Exception as exc:  # decoders raise many types for corrupt files
        raise InputError(f"cannot read image: {exc}", source=str(path)) from None
    image = np.asarray(image)
    if image.size == 0:
        raise InputError(f"an empty image (shape {image.shape}): no pixel", source=str(path))
    if image.dtype.kind not in "uif":
        raise InputError(f"not a grey-value image (dtype {image.dtype})", source=str(path))
    if finite and image.dtype.kind == "f" and not np.all(np.isfinite(image)):
        bad = np.argwhere(~np.isfinite(image))[0]
        raise InputError(
            f"pixel {tuple(int(i) for i in bad[::-1])} (x, y[, frame]) is NaN or infinite; "
            "grey values must be numbers",
            source=str(path),
        )
    largest = 0.0
    if image.dtype.kind == "f":
        # Over the finite values: an inf let through (finite=False) must not hide a 1e300.
        finite_values = np.abs(image[np.isfinite(image)]) if not finite else np.abs(image)
        largest = float(finite_values.max(initial=0.0))
    if largest >= 2.0**53:
        raise InputError(
            f"grey values up to {largest:.3g}: beyond 2⁵³ they are not a camera's "
            "grey values (check the file's scaling)",
            source=str(path),
        )
    if image.dtype.itemsize == 8 and image.dtype.kind in "ui":
        lo, hi = int(image.min()), int(image.max())
        if max(hi, -lo) >= 2**53:  # the bound float frames have: 1.2e17 was measured
            raise InputError(
                f"grey values up to {max(hi, -lo)} DN: beyond ±2⁵³ they are not a camera's "
                "grey values (check the data type the file was written with)",
                source=str(path),
            )
        image = image.astype(np.int64)  # uint64 below 2⁵³ converts exactly
    return _monochrome(image, path, colour=colour)


def recorded_bit_depth(path: str | Path, *, sidecar_record: dict | None = None) -> int | None:
    """The bit depth a captured frame was recorded with (Mono12 → 12, stored in uint16),
    from its sidecar (``frame_0001.json``; ``sidecar_record``: as already read) or its
    TIFF description; None where the file says nothing (a frame from elsewhere)."""
    path = Path(path)
    sidecar = path.with_suffix(".json")
    try:
        if sidecar_record is not None:
            meta = sidecar_record
        elif sidecar.is_file():
            meta = json.loads(sidecar.read_text())
        elif path.suffix.lower() in _TIFF:
            import tifffile

            with tifffile.TiffFile(path) as tif:
                meta = json.loads(getattr(tif.pages[0], "description", "") or "{}")
        else:
            return None
        bits = meta.get("bit_depth") if isinstance(meta, dict) else None
    except (OSError, ValueError, IndexError):
        return None
    return int(bits) if isinstance(bits, int) and 1 <= bits <= 32 else None


def _read_tiff(path: Path) -> tuple[np.ndarray, bool]:
    """Every page of a TIFF: one frame, or a stack (N, H, W) of pages of one size and
    type; and whether its pixels are colour (more than one sample per pixel), which the
    shape cannot tell for a stack of frames 3 or 4 pixels wide.

    A stack written page by page is a series per page to tifffile, whose
    ``imread`` returns the first only; pages are therefore read one by one.
    """
    import tifffile

    with tifffile.TiffFile(path) as tif:
        pages = list(tif.pages)
        colour = getattr(pages[0], "samplesperpixel", 1) > 1
        if len(pages) == 1 or (len(tif.series) == 1 and tif.series[0].ndim <= 3):
            image = tif.asarray()
            if colour and getattr(pages[0], "planarconfig", 1) == tifffile.PLANARCONFIG.SEPARATE:
                shape = (tif.shaped_metadata or ({},))[0].get("shape")
                if shape is not None and tuple(shape) == image.shape and image.ndim == 3:
                    # tifffile.imwrite of a (3, H, W) stack tags it planar RGB; the shape
                    # it records says the array was a stack of frames, not colour planes.
                    return image, False
                image = np.moveaxis(image, 0, -1)  # colour planes: samples last
            return image, colour
        first = pages[0].asarray()
        stack = np.empty((len(pages), *first.shape), first.dtype)  # no list of pages to copy
        stack[0] = first
        for i, page in enumerate(pages[1:], start=1):
            data = page.asarray()
            if data.shape != first.shape or data.dtype != first.dtype:
                raise InputError(
                    f"page {i + 1} is {data.shape} {data.dtype}, page 1 is {first.shape} "
                    f"{first.dtype}: the pages of a stack must be frames of one camera setting",
                    source=str(path),
                )
            stack[i] = data
        return stack, colour


_SETTING = ("exposure_us", "gain_db", "pixel_format")


def _capture_record(path: Path, sidecars: Mapping[Path, dict] | None = None) -> dict | None:
    """A captured frame's JSON sidecar (step and camera settings), if it has one (from
    ``sidecars`` where it was read already)."""
    if sidecars is not None and path in sidecars:
        return sidecars[path]
    sidecar = path.with_suffix(".json")
    if path.suffix.lower() not in _TIFF or not sidecar.is_file():
        return None
    try:
        meta = json.loads(sidecar.read_text())
    except (OSError, ValueError, RecursionError):
        return None
    return meta if isinstance(meta, dict) else None


def _monochrome(image: np.ndarray, path: Path, *, colour: bool | None = None) -> np.ndarray:
    # Where the file does not say (NPY), a trailing axis of 3 or 4 is colour (RGB[A]).
    if colour is None:
        colour = image.ndim >= 3 and image.shape[-1] in (3, 4)
    if colour:
        rgb = image[..., :3]
        if np.all(rgb == rgb[..., :1]):
            return np.ascontiguousarray(rgb[..., 0])
        raise InputError(
            "colour image: inspect-validate measures monochrome frames; "
            "save the camera's raw monochrome output instead",
            source=str(path),
        )
    if image.ndim not in (2, 3):
        raise InputError(f"unexpected image shape {image.shape}", source=str(path))
    return image


_IMAGE_SUFFIXES = _TIFF + _OPENCV + (".npy",)


def is_image_name(path: Path) -> bool:
    """A file name read as a frame where a folder is given: an image suffix, and not a
    dot-file (a writer's temporary name, or the system's own file)."""
    return path.suffix.lower() in _IMAGE_SUFFIXES and not path.name.startswith(".")


def expand_paths(paths: Iterable[str | Path]) -> list[Path]:
    """Image paths from files, folders (their images, sorted) and quoted glob patterns.

    A folder is what ``inspect-validate capture`` writes per step, so
    ``measure out/amber --dark out/dark`` reads exactly one step's frames.
    """
    out = []
    for raw in paths:
        path = Path(raw)
        if path.is_dir():
            found = sorted(p for p in path.iterdir() if is_image_name(p))
            if not found:
                raise InputError(
                    "folder holds no images (TIFF, PNG, PGM, BMP, NPY)", source=str(path)
                )
            out += found
        elif not path.exists() and any(c in str(raw) for c in "*?["):
            found = sorted(Path(p) for p in glob.glob(str(raw)))
            if not found:
                raise InputError("pattern matches no file", source=str(raw))
            out += found
        else:
            out.append(path)
    return out


def read_frames(
    paths: Iterable[str | Path],
    *,
    finite: bool = True,
    sidecars: Mapping[Path, dict] | None = None,
) -> np.ndarray:
    """Read frames taken at one setting into one stack (N, H, W).

    Paths may be files (one frame or a stack each), folders or glob patterns
    (:func:`expand_paths`). All frames must have the same size and data type,
    and frames written by a capture must all come from the same step. ``finite`` as in
    :func:`read_image`; ``sidecars``: the frames' sidecars as a capture's audit read them.
    """
    # Frames are copied into one preallocated stack as they are read: peak memory is the
    # stack plus one file, not twice the stack.
    stack, n, first = None, 0, None
    recorded: tuple[Path, dict] | None = None  # the first frame with a capture sidecar
    paths = expand_paths(paths)
    for i, path in enumerate(paths):
        meta = _capture_record(path, sidecars)
        if meta is not None:
            recorded = recorded or (path, meta)
            (pa, a), b = recorded, meta
            if b.get("step") != a.get("step"):
                raise InputError(
                    f"frames of capture step {b.get('step')!r} mixed with step {a.get('step')!r} "
                    f"({pa}): one stack is one illumination; give dark frames with --dark",
                    source=str(path),
                )
            differ = [k for k in _SETTING if b.get(k) != a.get(k)]
            if differ:
                raise InputError(
                    "taken at "
                    + ", ".join(f"{k} {b.get(k)}" for k in differ)
                    + f", but {pa} at "
                    + ", ".join(f"{k} {a.get(k)}" for k in differ)
                    + ": a stack must be one camera setting",
                    source=str(path),
                )
        image = read_image(path, finite=finite)
        frames = image if image.ndim == 3 else image[np.newaxis]
        if first is None:
            first = (path, frames.shape[1:], frames.dtype)
        elif frames.shape[1:] != first[1] or frames.dtype != first[2]:
            raise InputError(
                f"frame is {frames.shape[2]}×{frames.shape[1]} {frames.dtype}, but {first[0]} is "
                f"{first[1][1]}×{first[1][0]} {first[2]}: a stack must be one camera setting",
                source=str(path),
            )
        if len(paths) == 1:
            return frames
        # Room for as many frames in each file still to come as in this one.
        room = n + frames.shape[0] * (len(paths) - i)
        if stack is None:
            stack = np.empty((room, *frames.shape[1:]), frames.dtype)
        elif n + frames.shape[0] > stack.shape[0]:  # more frames than the files before
            grown = np.empty((room, *stack.shape[1:]), stack.dtype)
            grown[:n] = stack[:n]
            stack = grown
        stack[n : n + frames.shape[0]] = frames
        n += frames.shape[0]
    if stack is None:
        raise InputError("no frames given")
    return stack[:n]
