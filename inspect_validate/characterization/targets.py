"""The station's targets measured: a flat card's captures as each illumination's field,
a slanted edge's as its MTF (``characterize --field FLAT --sharpness EDGE``).

Each capture (``capture --target flat`` or ``--target edge``) holds every illumination's
frames and the darks; an illumination's image is the mean of its frames less the mean
dark frame, per pixel.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from inspect_validate.errors import InputError

if TYPE_CHECKING:
    from inspect_validate.characterization.field import Field
    from inspect_validate.characterization.sharpness import EdgeMTF
    from inspect_validate.station.file import Station

__all__ = [
    "EDGE_WINDOW",
    "EdgeReading",
    "edge_window",
    "measure_field",
    "measure_sharpness",
    "target_images",
    "target_stacks",
]

EDGE_WINDOW = 100
"""Pixels a side of the window about the frame's centre an edge is read in, by default
(the simulated target's edge runs 0.6 of the frame's smaller side through it)."""


def target_images(station: Station, folder: Path, target: str) -> dict[str, np.ndarray]:
    """Each illumination's mean frame less the mean dark frame (DN) of a capture of
    ``target`` (``"flat"`` or ``"edge"``) of ``station``.

    Raises
    ------
    InputError
        Not a complete capture of that target, one without dark frames, frames that
        cannot be read.
    """
    return {
        name: stack.mean(axis=0) for name, stack in target_stacks(station, folder, target).items()
    }


def target_stacks(station: Station, folder: Path, target: str) -> dict[str, np.ndarray]:
    """Each illumination's frames less the mean dark frame (DN), (frames, height, width),
    of a capture of ``target`` (as :func:`target_images`)."""
    from inspect_validate.camera.storage import read_capture
    from inspect_validate.images import read_frames

    files, dark, *_ = read_capture(folder, [i.name for i in station.illuminations], target=target)
    if not dark:
        raise InputError(
            f"the {target} target's capture has no dark frames, and its field is the light "
            "above them: capture it with dark_frames > 0 in the station",
            source=str(folder),
        )
    below = read_frames(dark).mean(axis=0)
    out = {}
    for name, paths in files.items():
        stack = read_frames(paths).astype(np.float64)
        if stack.shape[1:] != below.shape:
            raise InputError(
                f"illumination {name!r}'s frames are {stack.shape[2]}×{stack.shape[1]} px and "
                f"the darks {below.shape[1]}×{below.shape[0]}",
                source=str(folder),
            )
        out[name] = stack - below
    return out


def measure_field(station: Station, folder: Path) -> dict[str, Field]:
    """Each illumination's :class:`~inspect_validate.characterization.field.Field` from a
    flat target's capture (:func:`target_images`, :func:`~.field.fit_field`)."""
    from inspect_validate.characterization.field import fit_field

    out = {}
    for name, image in target_images(station, folder, "flat").items():
        try:
            out[name] = fit_field(image)
        except InputError as exc:
            raise InputError(f"illumination {name!r}: {exc!s}", source=str(folder)) from None
    return out


def edge_window(shape: tuple[int, int], size: int = EDGE_WINDOW) -> tuple[int, int, int, int]:
    """(x, y, width, height) of the ``size`` px window about the centre of a frame of
    ``shape`` (height, width), clipped to the frame."""
    h, w = shape
    sw, sh = min(size, w), min(size, h)
    return (w - sw) // 2, (h - sh) // 2, sw, sh


@dataclass(frozen=True)
class EdgeReading:
    """An illumination's edge: the MTF of its frames' mean, the standard error of its
    MTF50 from the frames' own spread (each frame's MTF50; NaN from one frame), and the
    region (x, y, width, height) it was read in."""

    edge: EdgeMTF
    mtf50_se: float
    frames: int
    region: tuple[int, int, int, int]


def measure_sharpness(
    station: Station, folder: Path, *, region: tuple[int, int, int, int] | None = None
) -> dict[str, EdgeReading]:
    """Each illumination's edge MTF from an edge target's capture, read in ``region``
    (x, y, width, height; default :func:`edge_window`), with its MTF50's standard error.

    Raises
    ------
    InputError
        As :func:`target_images`; a region outside the frames; no edge in it
        (:func:`~inspect_validate.characterization.sharpness.edge_mtf`).
    """
    from inspect_validate.characterization.sharpness import edge_mtf

    out = {}
    for name, stack in target_stacks(station, folder, "edge").items():
        image = stack.mean(axis=0)
        x, y, w, h = region or edge_window(image.shape)
        if x < 0 or y < 0 or x + w > image.shape[1] or y + h > image.shape[0]:
            raise InputError(
                f"the edge's region {x},{y},{w},{h} leaves the {image.shape[1]}×"
                f"{image.shape[0]} frame: give --edge X,Y,W,H inside it",
                source=str(folder),
            )
        try:
            edge = edge_mtf(image[y : y + h, x : x + w])
            each = np.array([edge_mtf(frame[y : y + h, x : x + w]).mtf50 for frame in stack])
        except InputError as exc:
            raise InputError(
                f"illumination {name!r}, region {x},{y},{w},{h}: {exc}", source=str(folder)
            ) from None
        se = float(each.std(ddof=1) / np.sqrt(each.size)) if each.size > 1 else math.nan
        se = se if np.isfinite(each).all() else math.nan
        out[name] = EdgeReading(edge, se, each.size, (x, y, w, h))
    return out
