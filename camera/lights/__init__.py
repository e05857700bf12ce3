"""LED controllers: Gardasoft RT, generic ASCII, manual, and a simulated Gardasoft."""

from camera.lights.base import LedController
from camera.lights.gardasoft import GardasoftController, SerialAscii

__all__ = ["GardasoftController", "LedController", "SerialAscii"]
