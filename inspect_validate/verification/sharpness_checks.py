"""Whether the lens is as sharp as its f-number allows: each illumination's measured MTF50
(the station's ``sharpness:`` file, of ``characterize --sharpness``) against the in-focus
MTF50 of its optics and pixels (:meth:`~inspect_validate.station.model.StationModel.
focus_mtf50`), at least ``acceptance.sharpness`` of it (fixed: a lens below is out of
focus, or soiled, or not as good as its f-number).
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

from inspect_validate.verification.checks import Check, at_least

if TYPE_CHECKING:
    from inspect_validate.characterization.sharpness_file import SharpnessFile
    from inspect_validate.station.file import Station
    from inspect_validate.station.model import StationModel

__all__ = ["SHARPER_THAN_FOCUS", "sharpness_checks"]

SHARPER_THAN_FOCUS = 1.1
"""A lens measured this much sharper than its in-focus limit has other optics than the
scene says (an f-number, a pixel pitch), or a target sharpened by the camera."""


def sharpness_checks(
    station: Station, model: StationModel, measured: SharpnessFile
) -> tuple[list[Check], list[str]]:
    """The checks of each illumination's measured MTF50 against the in-focus limit, and
    notes (an MTF50 above the limit, an illumination the file lacks)."""
    ratio = station.acceptance.sharpness
    if ratio is None:
        return [], []
    limits = model.focus_mtf50(station)
    optics = f"f/{model.optics.f_number:g} and {model.sensor.pixel_pitch:g} µm pixels"
    checks, notes = [], []
    for name, limit in limits.items():
        record = measured.illuminations.get(name)
        if record is None:
            notes.append(
                f"{name}: the sharpness file has no edge of this illumination; capture the "
                "edge target under it (capture --target edge) and characterize --sharpness"
            )
            continue
        value = record.mtf50 if record.mtf50 is not None else math.inf
        share = value / limit
        checks.append(
            at_least(
                f"{name}: lens MTF50",
                "sharpness",
                value,
                ratio * limit,
                "cycles/px",
                f"measured {value:.3f} cycles/px on the edge, in focus at {optics} "
                f"{limit:.3f}: {100 * share:.0f} % of it (acceptance.sharpness "
                f"{100 * ratio:g} %); below, the lens is out of focus or soiled",
                illumination=name,
                subject="lens",
                quantity="mtf50",
            )
        )
        if share > SHARPER_THAN_FOCUS:
            notes.append(
                f"{name}: the edge's MTF50 is {100 * share:.0f} % of the in-focus limit at "
                f"{optics}: check the scene's f-number and pixel pitch (a simulated camera "
                "renders no diffraction)"
            )
    return checks, notes
