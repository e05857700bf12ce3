"""The simulated station through a vendor SDK: pylon's camera emulator fed with rendered frames.

A station with ``camera.backend: pylon`` *and* a ``camera.scene`` runs on pylon's
camera emulator (``PYLON_CAMEMU=1``): whenever the simulated controller's lights
change, frames of the scene under the new lights are rendered with the EMVA 1288
model (:class:`~inspect_validate.simulation.camera.SimulatedGrabber`), written as 16-bit
PNG and served by the emulator in ``ImageFileMode``, pixel-exactly in Mono16.
Every frame the capture keeps has passed through pylon's grab engine, buffers
and timestamps — the same path as a real Basler camera.
"""

from __future__ import annotations

import tempfile
from pathlib import Path
from typing import TYPE_CHECKING, Any, Protocol

from inspect_validate.camera.frame import Frame
from inspect_validate.camera.grabbers.base import Features, Grabber
from inspect_validate.errors import DeviceError

if TYPE_CHECKING:
    import numpy as np

    from inspect_validate.camera.grabbers.pylon import PylonGrabber


class Renderer(Protocol):
    """What the feed asks of the simulated camera that renders its frames (the device
    layer imports nothing of the simulation)."""

    name: str
    width: int
    height: int

    def configure(self, *, exposure_us: float | None = None, gain_db: float | None = None) -> None:
        """Set the exposure (µs) and gain (dB) the frames are rendered with."""

    def arm(
        self,
        acquisition: str,
        *,
        trigger_line: str | None = None,
        strobe_line: str | None = None,
        chunks: bool = False,
        trigger_delay_us: float = 0.0,
    ) -> None:
        """Take the acquisition mode the camera is armed with."""

    def render(self, state: dict[int, float], *, exposure_us: float | None = None) -> np.ndarray:
        """One frame under ``state`` (channel → % of full output)."""

    def light_state(self, *, fired: str | None = None) -> dict[int, float]:
        """The channels' light during an exposure starting now."""


__all__ = ["EmulatorFeed"]


class EmulatorFeed(Grabber):
    """Serve ``renderer``'s frames through the pylon emulator ``camera``.

    Parameters
    ----------
    camera : PylonGrabber
        Opened on the emulator.
    renderer : SimulatedGrabber
        Renders the scene under the controller's current lights.
    frames_per_light : int
        Noise realisations rendered per light setting; the emulator cycles
        through them, so a step should keep fewer frames than this.
    """

    def __init__(
        self, camera: PylonGrabber, renderer: Renderer, *, frames_per_light: int = 16
    ) -> None:
        self.grabber, self.renderer = camera, renderer
        self.frames_per_light = frames_per_light
        self.name = f"{camera.name} fed by the {renderer.name}"
        self.missing = camera.missing
        self._folder = tempfile.TemporaryDirectory(prefix="iv-emulator-")
        self._served: dict[int, float] | None = None
        self._sets = 0
        self._triggered = False

    def configure(
        self,
        *,
        exposure_us: float | None = None,
        gain_db: float | None = None,
        pixel_format: str | None = None,
        region: tuple[int, int, int, int] | None = None,
    ) -> None:
        if pixel_format not in (None, "Mono16"):
            raise DeviceError(
                f"{self.name}: the emulator serves 16-bit files pixel-exactly only in Mono16, not {pixel_format}"
            )
        if region is not None:
            raise DeviceError(f"{self.name}: the rendered frame size is set by camera.width/height")
        self.renderer.configure(exposure_us=exposure_us, gain_db=gain_db)
        self.grabber.configure(
            exposure_us=exposure_us,
            gain_db=gain_db,
            pixel_format="Mono16",
            region=(0, 0, self.renderer.width, self.renderer.height),
        )
        self._served = None

    def _serve(self, state: dict[int, float]) -> None:
        import cv2

        self._sets += 1
        folder = Path(self._folder.name) / f"setting_{self._sets:04d}"
        folder.mkdir()
        for i in range(self.frames_per_light):
            cv2.imwrite(str(folder / f"frame_{i:03d}.png"), self.renderer.render(state))
        self.grabber.serve_files(folder)
        self._served = state

    def restart_stream(self) -> bool:
        return self.grabber.restart_stream()

    def features(self) -> Features:
        return self.grabber.features()

    def arm(self, acquisition: str, **options: Any) -> None:
        self.grabber.arm(acquisition, **options)
        # The renderer lights a pulsed channel as the station's wiring would.
        self.renderer.arm(acquisition, **options)
        self._triggered = acquisition != "free-run"

    def drain(self) -> int:
        return self.grabber.drain()

    def _serve_current(self) -> None:
        state = self.renderer.light_state()
        if state != self._served:
            self._serve(state)  # stops the emulator's grab: before a trigger, not after

    def trigger(self) -> int:
        self._serve_current()
        return self.grabber.trigger()

    def grab(self, n: int, *, timeout_s: float = 2.0) -> list[Frame]:
        frames = []
        for _ in range(n):
            if not self._triggered:
                self._serve_current()
            frames += self.grabber.grab(1, timeout_s=timeout_s)
        return frames

    def close(self) -> None:
        try:
            self.grabber.close()
        finally:
            self._folder.cleanup()
