"""No camera: a station whose frames come from the line's own program.

A station of the line's frames alone (``rois:`` and ``production:``, the manual's "On the
running line") opens no camera: ``train``, ``verify`` and ``watch`` read the frames from
``--frames``. Its ``camera:`` is ``backend: none``, written or left out; whatever would
open it says what it needs instead.
"""

from __future__ import annotations

from typing import Literal, NoReturn

from pydantic import model_validator

from inspect_validate.camera.registry import Backend, Opening
from inspect_validate.camera.settings import CameraSettings
from inspect_validate.errors import InputError

__all__ = ["BACKEND", "NoCameraSettings"]


class NoCameraSettings(CameraSettings):
    """No camera: the line's own program takes the frames (``--frames`` gives them). The
    other cameras' keys are refused here: nothing would set them."""

    backend: Literal["none"]
    """No camera: the frames come from elsewhere."""

    @model_validator(mode="after")
    def _nothing_to_set(self):
        # A setting here would be silently unused: the line's program sets the camera.
        given = sorted(set(self.model_fields_set) & set(CameraSettings.model_fields))
        if given:
            raise ValueError(
                f"{given[0]}: backend none opens no camera, so nothing sets it; the line's "
                "program sets its camera (give a camera backend to capture)"
            )
        return self


def open_none(settings: NoCameraSettings, opening: Opening) -> NoReturn:
    raise InputError(
        "this station has no camera (camera: backend none, or no camera: section): its "
        "frames come from the line's own program; give --production --frames FOLDER, or describe the "
        "camera under camera: to capture",
        source=opening.source,
    )


BACKEND = Backend("none", NoCameraSettings, open_none)
