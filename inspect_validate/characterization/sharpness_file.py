"""``sharpness.json``: each illumination's slanted-edge MTF, as ``characterize
--sharpness`` measured it, for the station file's ``sharpness:`` to name.

Per illumination: MTF50 and the MTF at half the Nyquist frequency (0.25 cycles/px), the
edge's angle and contrast, and the curve from 0 to 1 cycle/px.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Literal

from pydantic import BaseModel, ConfigDict
from pydantic import Field as Of

if TYPE_CHECKING:
    from collections.abc import Mapping

    from inspect_validate.characterization.targets import EdgeReading

__all__ = [
    "HALF_NYQUIST",
    "SHARPNESS_SCHEMA",
    "SharpnessFile",
    "read_sharpness",
    "sharpness_document",
]

SHARPNESS_SCHEMA = "inspect-validate/sharpness"
HALF_NYQUIST = 0.25
"""cycles/px: half the sensor's Nyquist frequency, where the MTF is quoted beside MTF50."""
_MAX_BYTES = 2**22
Fraction = Annotated[float, Of(ge=0, le=1, allow_inf_nan=False)]


class EdgeRecord(BaseModel):
    """One illumination's edge MTF as the file holds it."""

    model_config = ConfigDict(extra="ignore", frozen=True)
    mtf50: Annotated[float, Of(gt=0, le=1, allow_inf_nan=False)] | None
    """cycles/px where the MTF falls to ½ (None: above 1 cycle/px)."""
    mtf50_se: Annotated[float, Of(ge=0, le=1, allow_inf_nan=False)] | None = None
    """Its standard error from the frames' own spread (None: one frame)."""
    frames: Annotated[int, Of(ge=1, le=100_000)] | None = None
    mtf_half_nyquist: Annotated[float, Of(ge=-0.5, le=1.5, allow_inf_nan=False)]
    angle_deg: Annotated[float, Of(ge=-90, le=90, allow_inf_nan=False)]
    frequencies: list[Annotated[float, Of(ge=0, le=1, allow_inf_nan=False)]] = Of(
        default_factory=list
    )
    mtf: list[Annotated[float, Of(ge=-0.5, le=1.5, allow_inf_nan=False)]] = Of(default_factory=list)


class SharpnessFile(BaseModel):
    """A ``sharpness.json`` document."""

    model_config = ConfigDict(extra="ignore", frozen=True, populate_by_name=True)
    schema_: Literal["inspect-validate/sharpness"] = Of(
        "inspect-validate/sharpness", alias="schema"
    )
    schema_version: Literal[1] = 1
    illuminations: dict[str, EdgeRecord] = Of(min_length=1)


def sharpness_document(
    edges: Mapping[str, EdgeReading],
    *,
    region: tuple[int, int, int, int],
    inputs: dict | None = None,
) -> dict:
    """The ``sharpness.json`` document of ``edges`` (illumination → its reading), read in
    ``region`` (x, y, width, height), from ``inputs``."""
    from inspect_validate import __version__

    illuminations = {}
    for name, reading in edges.items():
        e = reading.edge
        keep = e.frequencies <= 1.0
        illuminations[name] = {
            "mtf50": e.mtf50 if math.isfinite(e.mtf50) else None,
            "mtf50_se": reading.mtf50_se if math.isfinite(reading.mtf50_se) else None,
            "frames": reading.frames,
            "mtf_half_nyquist": e.at(HALF_NYQUIST),
            "angle_deg": e.angle_deg,
            "vertical": e.vertical,
            "contrast_dn": e.contrast,
            "frequencies": [float(f) for f in e.frequencies[keep]],
            "mtf": [float(m) for m in e.mtf[keep]],
        }
    return {
        "schema": SHARPNESS_SCHEMA,
        "schema_version": 1,
        "tool_version": __version__,
        "inputs": inputs or {},
        "region": list(region),
        "unit": "cycles/px",
        "illuminations": illuminations,
    }


def read_sharpness(path: str | Path) -> SharpnessFile:
    """Read and validate a ``sharpness.json``.

    Raises
    ------
    InputError
        Missing, not JSON, not a sharpness file, or a value out of its range (naming the
        file and the field).
    """
    from inspect_validate.config import read_document

    return read_document(
        path,
        SharpnessFile,
        schema=SHARPNESS_SCHEMA,
        what="sharpness file",
        todo="give the sharpness.json that characterize STATION --sharpness EDGE --out DIR wrote",
        largest=_MAX_BYTES,
    )
