"""V4L2 cameras (USB/UVC, MIPI) through OpenCV's V4L2 backend.

What OpenCV's ``VideoCapture`` does not do for a measurement, this class does:

* the V4L2 backend is forced (``cv2.CAP_V4L2``): no silent fall-back to
  GStreamer or FFmpeg, which would convert or compress;
* RGB conversion is off (``CAP_PROP_CONVERT_RGB = 0``), so ``GREY`` arrives as
  uint8 and ``Y10``/``Y16`` as uint16 — raw grey values, not a colour conversion;
* every ``set()`` is checked *and read back*: drivers accept values they then
  round or ignore, and OpenCV returns True for some of those;
* OpenCV keeps several driver buffers queued, so the frames after a change can
  be older than the change: :attr:`pipeline_frames` tells the capture how many
  to flush, and the queue is shortened where the driver allows.

V4L2 exposure (``exposure_time_absolute``) is in units of 100 µs. V4L2 gain has
device-specific units, not dB, so ``gain_db`` is reported as missing: set the
gain with ``v4l2-ctl -c gain=…`` and keep it fixed.
"""

from __future__ import annotations

import os
import time
from collections.abc import Callable
from pathlib import Path
from typing import Annotated, Any, Literal

import numpy as np
from pydantic import Field

from inspect_validate.camera.frame import Frame
from inspect_validate.camera.grabbers.base import DeviceInfo, Grabber
from inspect_validate.camera.registry import Backend, Opening, Search
from inspect_validate.camera.settings import CameraSettings
from inspect_validate.errors import DeviceError

__all__ = ["BACKEND", "V4l2Grabber", "V4l2Settings"]

# Pixel format name → V4L2 fourcc, bit depth, dtype OpenCV returns it as (raw mode).
FORMATS = {
    "Mono8": ("GREY", 8, np.uint8),
    "Mono10": ("Y10 ", 10, np.uint16),
    "Mono16": ("Y16 ", 16, np.uint16),
}
_MANUAL_EXPOSURE = 1  # V4L2_EXPOSURE_MANUAL in the exposure_auto menu


def _fourcc(code: str) -> int:
    return sum(ord(ch) << (8 * i) for i, ch in enumerate(code))


def _fourcc_text(value: float) -> str:
    v = int(value)
    return "".join(chr((v >> (8 * i)) & 0xFF) for i in range(4))


def _text(path: Path) -> str:
    """A sysfs attribute's value, "" where the driver does not give it."""
    try:
        return path.read_text().strip()
    except OSError:
        return ""


def discover_v4l2(
    search: Search, *, sysfs: Path = Path("/sys/class/video4linux")
) -> list[DeviceInfo]:
    """The video devices the kernel lists (``/sys/class/video4linux``), with the name its
    driver gives and, for a USB camera, the USB device's maker and serial number. A
    camera whose driver adds a metadata node lists both (``index 0`` is the video one);
    whether a node may be read is checked, not whether another program holds it."""
    found = []
    nodes = [n for n in sysfs.glob("video*") if n.name[5:].isdigit()]
    for node in sorted(nodes, key=lambda n: int(n.name[5:])):
        device = Path("/dev") / node.name
        usb = node / "device" / ".."  # the USB device above the interface, where there is one
        index = _text(node / "index")
        found.append(
            DeviceInfo(
                str(device),
                _text(usb / "serial"),
                _text(usb / "manufacturer"),
                _text(node / "name"),
                device_id=str(device),
                interface="USB" if (usb / "idVendor").exists() else "",
                access=(
                    "no device node"
                    if not device.exists()
                    else ""
                    if os.access(device, os.R_OK)
                    else "no permission (group video)"
                ),
                source=f"index {index}" if index else "",
                backend="v4l2",
            )
        )
    return found


class V4l2Grabber(Grabber):
    """A V4L2 device by path (``/dev/video2``) or index.

    Parameters
    ----------
    device : str or int
        Device node or its number.
    buffers : int
        Driver buffers to ask for (fewer buffers, fewer stale frames).
    opener : callable, optional
        ``opener(path, api) -> VideoCapture``; ``cv2.VideoCapture`` by default.
    """

    def __init__(
        self,
        device: str | int = 0,
        *,
        buffers: int = 1,
        opener: Callable[[str, int], Any] | None = None,
    ) -> None:
        import cv2

        self._cv2 = cv2
        self.device = f"/dev/video{device}" if isinstance(device, int) else str(device)
        self.name = f"V4L2 camera {self.device}"
        self.missing = {"gain"}
        # OpenCV logs its own failure ("[ WARN:0@0.04] global cap.cpp:212 …") to stderr,
        # ahead of and apart from the error below, which says what to do.
        level = cv2.utils.logging.getLogLevel()
        cv2.utils.logging.setLogLevel(cv2.utils.logging.LOG_LEVEL_ERROR)
        try:
            cap = (opener or cv2.VideoCapture)(self.device, cv2.CAP_V4L2)
        finally:
            cv2.utils.logging.setLogLevel(level)
        if not cap.isOpened():
            exists = os.path.exists(self.device)
            raise DeviceError(
                f"{self.name}: cannot open it with OpenCV's V4L2 backend; "
                + ("" if exists else "there is no such device node; ")
                + "check that it exists (v4l2-ctl --list-devices), that you may read it "
                "(group 'video') and that no other program holds it"
            )
        self._cap = cap
        self._timeout_ms: float | None = None
        self.frame_id = 0
        try:
            self._set(cv2.CAP_PROP_CONVERT_RGB, 0, "RGB conversion off")
            # A shorter queue where the driver allows; the read-back value is what counts.
            cap.set(cv2.CAP_PROP_BUFFERSIZE, buffers)
            queued = cap.get(cv2.CAP_PROP_BUFFERSIZE)
            self.pipeline_frames = (int(queued) if queued > 0 else 4) + 1
            self.pixel_format = self._current_format()
        except DeviceError:
            cap.release()
            raise

    def _set(self, prop: int, value: float, what: str) -> float:
        """Set ``prop``, then read it back; the value read back is returned."""
        if not self._cap.set(prop, value):
            raise DeviceError(
                f"{self.name}: the driver refused {what} ({value:g}); see v4l2-ctl --all for what it offers"
            )
        return self._cap.get(prop)

    def _current_format(self) -> str | None:
        code = _fourcc_text(self._cap.get(self._cv2.CAP_PROP_FOURCC))
        return next((name for name, (fc, _, _) in FORMATS.items() if fc == code), None)

    def configure(
        self,
        *,
        exposure_us: float | None = None,
        gain_db: float | None = None,
        pixel_format: str | None = None,
        region: tuple[int, int, int, int] | None = None,
    ) -> None:
        cv2 = self._cv2
        if pixel_format is not None or self.pixel_format is None:
            want = pixel_format or "Mono8"
            if want not in FORMATS:
                raise DeviceError(
                    f"{self.name}: pixel format {want} is not available through V4L2; use {', '.join(FORMATS)}"
                )
            code = FORMATS[want][0]
            got = _fourcc_text(self._set(cv2.CAP_PROP_FOURCC, _fourcc(code), f"format {code!r}"))
            if got != code:
                raise DeviceError(
                    f"{self.name}: asked for format {code.strip()!r}, the driver delivers {got.strip()!r}; "
                    "it has no such monochrome format (v4l2-ctl --list-formats-ext)"
                )
            self.pixel_format = want
        if region is not None:
            x, y, w, h = region
            if x or y:
                raise DeviceError(
                    f"{self.name}: V4L2 through OpenCV sets the frame size only, not an offset; use region (0, 0, w, h)"
                )
            self._cap.set(cv2.CAP_PROP_FRAME_WIDTH, w)
            self._cap.set(cv2.CAP_PROP_FRAME_HEIGHT, h)
            size = (
                int(self._cap.get(cv2.CAP_PROP_FRAME_WIDTH)),
                int(self._cap.get(cv2.CAP_PROP_FRAME_HEIGHT)),
            )
            if size != (w, h):
                raise DeviceError(
                    f"{self.name}: asked for {w}×{h}, the driver set {size[0]}×{size[1]}; "
                    "choose a size from v4l2-ctl --list-formats-ext"
                )
        if exposure_us is not None:
            if self._cap.get(cv2.CAP_PROP_EXPOSURE) == -1:  # OpenCV's answer for a missing control
                self.missing.add("exposure")
            else:
                mode = self._set(cv2.CAP_PROP_AUTO_EXPOSURE, _MANUAL_EXPOSURE, "manual exposure")
                if mode != _MANUAL_EXPOSURE:
                    raise DeviceError(
                        f"{self.name}: automatic exposure stays on (mode {mode:g}); a measurement needs a fixed exposure"
                    )
                applied = self._set(cv2.CAP_PROP_EXPOSURE, exposure_us / 100, "the exposure") * 100
                if abs(applied - exposure_us) > max(100.0, 0.01 * exposure_us):  # one 100 µs step
                    raise DeviceError(
                        f"{self.name}: asked for an exposure of {exposure_us:g} µs, the driver set {applied:g} µs; "
                        "choose one inside the range v4l2-ctl --all shows for exposure_time_absolute"
                    )

    def _exposure_us(self) -> float | None:
        if "exposure" in self.missing:
            return None
        value = self._cap.get(self._cv2.CAP_PROP_EXPOSURE)
        return None if value == -1 else float(value) * 100

    def grab(self, n: int, *, timeout_s: float = 2.0) -> list[Frame]:
        cv2 = self._cv2
        if self.pixel_format is None:
            self.configure()
        assert self.pixel_format is not None  # configure() reads the driver's format
        if self._timeout_ms != timeout_s * 1000:
            # Without it OpenCV waits 10 s for a frame; older builds lack the property.
            if self._cap.set(cv2.CAP_PROP_READ_TIMEOUT_MSEC, timeout_s * 1000):
                self._timeout_ms = timeout_s * 1000
        _, depth, dtype = FORMATS[self.pixel_format]
        width = int(self._cap.get(cv2.CAP_PROP_FRAME_WIDTH))
        height = int(self._cap.get(cv2.CAP_PROP_FRAME_HEIGHT))
        exposure = self._exposure_us()
        frames = []
        for k in range(n):
            ok, image = self._cap.read()
            arrived = time.monotonic_ns()
            if not ok or image is None:
                raise DeviceError(
                    f"{self.name}: no frame (frame {k + 1} of {n}, timeout {timeout_s:g} s); "
                    "check the cable, the trigger mode and that the exposure is shorter than the timeout"
                )
            if image.shape != (height, width) or image.dtype != dtype:
                raise DeviceError(
                    f"{self.name}: got a {image.shape} {image.dtype} buffer, expected {height}×{width} "
                    f"{np.dtype(dtype).name} ({self.pixel_format}); the driver delivers a colour or compressed format"
                )
            self.frame_id += 1  # V4L2's sequence number does not pass through OpenCV
            frames.append(
                Frame(
                    data=image if image.flags.owndata else image.copy(),
                    frame_id=self.frame_id,
                    timestamp_ns=arrived,
                    exposure_us=exposure,
                    gain_db=None,
                    pixel_format=self.pixel_format,
                    bit_depth=depth,
                    device=self.name,
                    clock="arrival",
                    extra={"driver_timestamp_ms": float(self._cap.get(cv2.CAP_PROP_POS_MSEC))},
                )
            )
        return frames

    def close(self) -> None:
        self._cap.release()


class V4l2Settings(CameraSettings):
    """A Video4Linux2 camera (USB, UVC) through OpenCV."""

    backend: Literal["v4l2"]
    """USB (UVC) and MIPI cameras through Linux's V4L2, by OpenCV."""
    device: str | int | None = None
    """The device path (``/dev/video0``) or number (default: ``index``)."""
    index: Annotated[int, Field(ge=0)] = 0
    """The device number, when no device is given."""


def open_v4l2(settings: V4l2Settings, opening: Opening) -> V4l2Grabber:
    return V4l2Grabber(settings.device if settings.device is not None else settings.index)


BACKEND = Backend(
    "v4l2",
    V4l2Settings,
    open_v4l2,
    discover=discover_v4l2,
    device_keys=lambda d: {"device": d.device_id},
)
