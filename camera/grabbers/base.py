"""The grabber interface shared by every camera backend."""

from __future__ import annotations

from abc import ABC, abstractmethod

from inspect_validate.camera.frame import Frame

__all__ = ["Grabber"]


class Grabber(ABC):
    """A monochrome camera: configure, grab N frames, close.

    Every call that the device does not perform raises
    :class:`~inspect_validate.errors.DeviceError` naming the device and the
    setting. Settings a device does not have are listed in :attr:`missing`
    rather than failing: the capture records that, e.g., exposure could not be
    set. Use as a context manager.
    """

    name: str = "camera"
    missing: set[str]
    pipeline_frames: int = 0  # frames that can predate a change (driver queue); flushed at least

    @abstractmethod
    def configure(
        self,
        *,
        exposure_us: float | None = None,
        gain_db: float | None = None,
        pixel_format: str | None = None,
        region: tuple[int, int, int, int] | None = None,
    ) -> None:
        """Apply settings (region = x, y, width, height); values read back are in the frames."""

    @abstractmethod
    def grab(self, n: int, *, timeout_s: float = 2.0) -> list[Frame]:
        """The next ``n`` frames, each copied out of the driver's buffers."""

    def restart_stream(self) -> bool:
        """Drop every frame queued or in flight, if the backend can.

        Called after a light switch. True means no frame exposed before this
        call will be delivered (the capture then needs no flush); False (the
        default) means the capture must flush ``pipeline_frames``.
        """
        return False

    def close(self) -> None:  # noqa: B027 - optional for backends without a connection
        """Release the device."""

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()
