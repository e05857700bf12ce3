"""``field.json``: each illumination's light field over the frame, as ``characterize
--field`` measured it on a flat target, for the station file's ``field:`` to name.

The file holds each field's surface (:class:`~inspect_validate.characterization.field.
Field`: its coefficients and the frame's size) and, for a reader, what follows from it:
the corners' falloff, the uniformity over the frame and over each class's region. Only
the surface is read back; the rest is recomputed.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, model_validator
from pydantic import Field as Of

from inspect_validate.errors import InputError

if TYPE_CHECKING:
    from collections.abc import Mapping

    from inspect_validate.characterization.field import Field

__all__ = ["FIELD_SCHEMA", "FieldFile", "field_document", "read_field", "write_field"]

FIELD_SCHEMA = "inspect-validate/field"
FIELD_MAX_BYTES = 2**22  # a few illuminations' surfaces and regions: kilobytes
Finite = Annotated[float, Of(allow_inf_nan=False)]


class FieldSurface(BaseModel):
    """One illumination's field: the surface and what a reader checks it by."""

    model_config = ConfigDict(extra="ignore", frozen=True)  # derived numbers: recomputed
    coefficients: list[Finite] = Of(min_length=1, max_length=1000)
    """Of the monomials xⁱ yʲ by total degree (x, y ±1 at the frame's edge pixels),
    divided by the surface's maximum."""
    residual: Annotated[float, Of(ge=0, allow_inf_nan=False)] = 0.0
    """RMS of the block means about the surface, relative to its maximum."""
    signal_dn: Annotated[float, Of(gt=0, allow_inf_nan=False)]
    """The flat target's signal at the brightest point, DN above dark."""

    @model_validator(mode="after")
    def _a_surface(self):
        from inspect_validate.characterization.field import degree_of

        degree_of(len(self.coefficients))  # ValueError: no polynomial's count
        return self


class FieldFile(BaseModel):
    """A ``field.json`` document."""

    model_config = ConfigDict(extra="ignore", frozen=True, populate_by_name=True)
    schema_: Literal["inspect-validate/field"] = Of("inspect-validate/field", alias="schema")
    schema_version: Literal[1] = 1
    width: Annotated[int, Of(ge=16, le=100_000)]
    """The frames' width the field was measured on, px."""
    height: Annotated[int, Of(ge=16, le=100_000)]
    illuminations: dict[str, FieldSurface] = Of(min_length=1)

    def fields(self) -> dict[str, Field]:
        """Each illumination's :class:`~inspect_validate.characterization.field.Field`."""
        from inspect_validate.characterization.field import Field

        return {
            name: Field(self.width, self.height, tuple(s.coefficients), s.residual, s.signal_dn)
            for name, s in self.illuminations.items()
        }


def field_document(
    fields: Mapping[str, Field],
    *,
    masks: Mapping[str, np.ndarray] | None = None,
    inputs: dict | None = None,
) -> dict:
    """The ``field.json`` document of ``fields`` (illumination → field), with each class's
    region (``masks``: class → boolean image) read off each field, and the ``inputs``
    it was measured from."""
    from inspect_validate import __version__
    from inspect_validate.characterization.field import region_field

    first = next(iter(fields.values()))
    illuminations = {}
    for name, f in fields.items():
        regions = {}
        for cls, mask in (masks or {}).items():
            r = region_field(f, mask)
            regions[cls] = {
                "mean": r.mean,
                "spread": r.spread,
                "uniformity": r.low / r.high,
                "low": r.low,
                "high": r.high,
            }
        illuminations[name] = {
            "coefficients": list(f.coefficients),
            "residual": f.residual,
            "signal_dn": f.signal,
            "corner_falloff": f.corner_falloff,
            "corners": [float(c) for c in f.corners],
            "uniformity": f.uniformity,
            "regions": regions,
        }
    return {
        "schema": FIELD_SCHEMA,
        "schema_version": 1,
        "tool_version": __version__,
        "inputs": inputs or {},
        "width": first.width,
        "height": first.height,
        "illuminations": illuminations,
    }


def write_field(path: Path, document: dict) -> Path:
    """Write ``document`` (:func:`field_document`) to ``path`` atomically."""
    from inspect_validate.files import write_json

    return write_json(document, path)


def read_field(path: str | Path) -> FieldFile:
    """Read and validate a ``field.json``.

    Raises
    ------
    InputError
        Missing, not JSON, not a field file, or a field that is not a surface (the
        message names the file and the field).
    """
    from inspect_validate.config import read_document

    read = read_document(
        path,
        FieldFile,
        schema=FIELD_SCHEMA,
        what="field file",
        todo="give the field.json that characterize STATION --field FLAT --out DIR wrote",
        largest=FIELD_MAX_BYTES,
    )
    from inspect_validate.characterization.field import MIN_FIELD, lowest

    for name, f in read.fields().items():
        with np.errstate(all="ignore"):
            top, low = float(f.map().max()), lowest(f)
        if not math.isclose(top, 1.0, rel_tol=1e-3) or not low > MIN_FIELD:
            raise InputError(
                f"illumination {name!r}: the surface runs from {low:.4g} to {top:.4g}, not "
                f"from above {MIN_FIELD} to 1 as characterize writes it: the file was "
                "edited; measure the field again",
                source=str(path),
            )
    return read
