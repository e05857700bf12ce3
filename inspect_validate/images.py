"""Reading monochrome frames: 8/16-bit PNG, TIFF (also multi-page stacks), PGM, BMP, NPY.

A frame is a 2-D array of grey values in DN. A colour file whose channels are all
equal is accepted as grey; any other colour image is refused, since a
monochrome inspection must not silently measure a colour conversion.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from inspect_validate.errors import InputError

__all__ = ["read_frames", "read_image"]

_TIFF = (".tif", ".tiff")
_OPENCV = (".png", ".pgm", ".pnm", ".bmp", ".jpg", ".jpeg")


def read_image(path: str | Path) -> np.ndarray:
    """One image file as (H, W) or, for a multi-page TIFF or 3-D NPY, (N, H, W).

    Raises
    ------
    InputError
        Missing, unreadable, empty or colour files (the message names the file).
    """
    path = Path(path)
    if not path.is_file():
        raise InputError("image file not found", source=str(path))
    suffix = path.suffix.lower()
    try:
        if suffix in _TIFF:
            import tifffile

            image = tifffile.imread(path)
        elif suffix == ".npy":
            image = np.load(path, allow_pickle=False)
        elif suffix in _OPENCV:
            import cv2

            image = cv2.imread(str(path), cv2.IMREAD_UNCHANGED)
            if image is None:
                raise ValueError("OpenCV could not decode it")
        else:
            raise InputError(
                f"unknown image type '{suffix}': use TIFF, PNG, PGM, BMP or NPY", source=str(path)
            )
    except InputError:
        raise
    except Exception as exc:  # decoders raise many types for corrupt files
        raise InputError(f"cannot read image: {exc}", source=str(path)) from None
    image = np.asarray(image)
    if image.dtype.kind not in "uif" or image.size == 0:
        raise InputError(f"not a grey-value image (dtype {image.dtype})", source=str(path))
    return _monochrome(image, path)


def _monochrome(image: np.ndarray, path: Path) -> np.ndarray:
    # Trailing axis of 3 or 4 is colour (RGB[A]) in every reader used here.
    if image.ndim >= 3 and image.shape[-1] in (3, 4):
        colour = image[..., :3]
        if np.all(colour == colour[..., :1]):
            return np.ascontiguousarray(colour[..., 0])
        raise InputError(
            "colour image: inspect-validate measures monochrome frames; "
            "save the camera's raw monochrome output instead",
            source=str(path),
        )
    if image.ndim not in (2, 3):
        raise InputError(f"unexpected image shape {image.shape}", source=str(path))
    return image


def read_frames(paths) -> np.ndarray:
    """Read frames taken at one setting into one stack (N, H, W).

    Each path may hold one frame or a stack; all frames must have the same size
    and data type.
    """
    stack, first = [], None
    for path in paths:
        image = read_image(path)
        frames = image if image.ndim == 3 else image[np.newaxis]
        if first is None:
            first = (path, frames.shape[1:], frames.dtype)
        elif frames.shape[1:] != first[1] or frames.dtype != first[2]:
            raise InputError(
                f"frame is {frames.shape[2]}×{frames.shape[1]} {frames.dtype}, but {first[0]} is "
                f"{first[1][1]}×{first[1][0]} {first[2]}: a stack must be one camera setting",
                source=str(path),
            )
        stack.append(frames)
    if not stack:
        raise InputError("no frames given")
    return np.concatenate(stack, axis=0)
