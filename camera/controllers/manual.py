"""Manual light switching: the operator is asked to set each illumination."""

from __future__ import annotations

import sys
from collections.abc import Callable
from typing import Annotated, Literal

from pydantic import Field

from inspect_validate.camera.controllers.base import LedController, describe_setting
from inspect_validate.camera.registry import Backend, Opening
from inspect_validate.config import StrictModel
from inspect_validate.errors import DeviceError

__all__ = ["BACKEND", "ManualController", "ManualSettings"]


class ManualController(LedController):
    """For stations without a controller: prompts on the terminal and waits for Enter."""

    def __init__(self, *, channels: int = 4, prompt: Callable[[str], str] | None = None) -> None:
        self.name = "manual switching"
        self.channels = channels
        self._prompt = prompt or (lambda text: input(text))

    def set_intensity(self, channel: int, percent: float) -> None:
        self.apply({channel: percent})

    def apply(self, setting: dict[int, float]) -> None:
        setting = {c: v for c, v in setting.items() if v}
        if setting == self.applied:
            return
        what = describe_setting(setting) if setting else "all lights OFF"  # loud for the operator
        print(f"\nSet the lights: {what}", file=sys.stderr)
        try:
            self._prompt("Press Enter when done… ")
        except EOFError:
            raise DeviceError(
                f"{self.name}: no operator to switch the lights (standard input is closed); "
                "run the capture in a terminal, or use a controller backend"
            ) from None
        self.applied = setting

    def all_off(self) -> None:
        self.apply({})


class ManualSettings(StrictModel):
    """No controller: the capture asks the operator to switch each illumination."""

    backend: Literal["manual"]
    """No controller: the operator switches the lights when asked."""
    channels: Annotated[int, Field(ge=1, le=64)] = 4
    """How many lights the operator switches."""


def open_manual(settings: ManualSettings, opening: Opening) -> ManualController:
    return ManualController(channels=settings.channels)


BACKEND = Backend("manual", ManualSettings, open_manual)
