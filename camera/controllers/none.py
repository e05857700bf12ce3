"""No light controller: a station whose light nobody here switches (a line's own light,
or a station of the line's frames alone, :mod:`inspect_validate.camera.grabbers.none`)."""

from __future__ import annotations

from typing import Literal, NoReturn

from pydantic import model_validator

from inspect_validate.camera.registry import Backend, Opening
from inspect_validate.camera.settings import ControllerSettings
from inspect_validate.errors import InputError

__all__ = ["BACKEND", "NoControllerSettings"]


class NoControllerSettings(ControllerSettings):
    """No controller: the station's light is not switched from here. The other
    controllers' keys but ``channels`` are refused here: nothing would use them."""

    backend: Literal["none"]
    """No controller: nothing here switches the light."""

    @model_validator(mode="after")
    def _nothing_to_set(self):
        given = sorted(
            set(self.model_fields_set) & (set(ControllerSettings.model_fields) - {"channels"})
        )
        if given:
            raise ValueError(
                f"{given[0]}: backend none opens no controller, so nothing uses it "
                "(give a controller backend to switch the lights)"
            )
        return self


def open_none(settings: NoControllerSettings, opening: Opening) -> NoReturn:
    raise InputError(
        "this station has no light controller (controller: backend none, or no controller: "
        "section): nothing here switches its light; give --production --frames FOLDER of the line's "
        "frames, or describe the controller under controller: to capture",
        source=opening.source,
    )


BACKEND = Backend("none", NoControllerSettings, open_none)
