"""LED controllers: Gardasoft RT, generic ASCII, manual, and a simulated Gardasoft."""

from inspect_validate.camera.controllers.base import LedController
from inspect_validate.camera.controllers.gardasoft import GardasoftController, SerialAscii
from inspect_validate.camera.controllers.generic import GenericAsciiController

__all__ = ["GardasoftController", "GenericAsciiController", "LedController", "SerialAscii"]
