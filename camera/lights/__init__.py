"""LED controllers: Gardasoft RT, generic ASCII, manual, and a simulated Gardasoft."""

from inspect_validate.camera.lights.base import LedController
from inspect_validate.camera.lights.gardasoft import GardasoftController, SerialAscii
from inspect_validate.camera.lights.generic import GenericAsciiController

__all__ = ["GardasoftController", "GenericAsciiController", "LedController", "SerialAscii"]
