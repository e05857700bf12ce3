"""LED controllers: Gardasoft RT, generic ASCII, manual, and a simulated Gardasoft."""

from camera.lights.base import LedController
from camera.lights.gardasoft import GardasoftController, SerialAscii
from camera.lights.generic import GenericAsciiController

__all__ = ["GardasoftController", "GenericAsciiController", "LedController", "SerialAscii"]
