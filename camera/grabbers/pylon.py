"""Basler cameras through pypylon (optional extra ``inspect-validate[pylon]``).

Also drives pylon's camera emulator (``PYLON_CAMEMU=1``, device class
``BaslerCamEmu``), which serves image files pixel-exactly with ``ImageFileMode``
— used in the tests to run a capture through the vendor SDK.
"""

from __future__ import annotations

import time

from inspect_validate.camera.frame import Frame
from inspect_validate.camera.grabbers.base import NodeMapGrabber
from inspect_validate.camera.pixelformats import BIT_DEPTH

from inspect_validate.errors import DeviceError

__all__ = ["PylonCamera"]


class PylonCamera(NodeMapGrabber):
    """A pylon camera chosen by serial number or index."""

    def __init__(self, *, serial: str | None = None, index: int = 0):
        try:
            from pypylon import genicam, pylon
        except ImportError:
            raise DeviceError(
                "pypylon is not installed: pip install 'inspect-validate[pylon]'"
            ) from None
        self._pylon, self._genicam = pylon, genicam
        factory = pylon.TlFactory.GetInstance()
        devices = factory.EnumerateDevices()
        if not devices:
            raise DeviceError(
                "no pylon camera found; check power, cable, network and that no other program holds it"
            )
        serials = [d.GetSerialNumber() for d in devices]
        if serial is not None:
            if str(serial) not in serials:
                raise DeviceError(
                    f"no pylon camera with serial {serial}; found: {', '.join(serials)}"
                )
            device = devices[serials.index(str(serial))]
        elif index < len(devices):
            device = devices[index]
        else:
            raise DeviceError(f"pylon camera index {index} does not exist; {len(devices)} found")
        self._cam = pylon.InstantCamera(factory.CreateDevice(device))
        self._cam.Open()
        self._chunked = False
        self.name = f"Basler {device.GetModelName()} (serial {device.GetSerialNumber()})"
        self._exposure = self._first(self._EXPOSURE_NODES)
        self._gain = self._first(self._GAIN_NODES)
        self.missing = {
            label
            for label, node in (("exposure", self._exposure), ("gain", self._gain))
            if node is None
        }

    @property
    def nodes(self):
        """The camera's node map (for settings this interface does not cover)."""
        return self._cam

    def _has(self, node: str) -> bool:
        """The camera has ``node`` now (pypylon answers any name with a placeholder, so
        ``hasattr`` cannot tell)."""
        return bool(self._genicam.IsAvailable(self._cam.GetNodeMap().GetNode(node)))

    def _set(self, node: str | None, value, label: str):
        if node is None or not self._has(node):
            self.missing.add(label)
            return
        try:
            getattr(self._cam, node).Value = value
        except self._genicam.GenericException as exc:
            raise DeviceError(f"{self.name}: cannot set {node} to {value!r} ({exc})") from None

    def serve_files(self, folder) -> None:
        """Make pylon's camera emulator serve the images in ``folder``, cycling through them.

        The emulator reads the files when acquisition starts, so a grab in
        progress is stopped; the next :meth:`grab` starts it again.
        """
        if not self._has("ImageFileMode"):
            raise DeviceError(
                f"{self.name}: only pylon's camera emulator serves image files (PYLON_CAMEMU=1)"
            )
        if self._cam.IsGrabbing():
            self._cam.StopGrabbing()
        if self._has("TestImageSelector"):
            self._cam.TestImageSelector.Value = "Off"  # a test image would take precedence
        self._cam.ImageFileMode.Value = "On"
        self._cam.ImageFilename.Value = str(folder)

    def _symbolics(self, node: str) -> tuple[str, ...]:
        try:
            return tuple(getattr(self._cam, node).Symbolics)
        except (AttributeError, self._genicam.GenericException):  # absent or unavailable now
            return ()

    def _write(self, name: str, value, label: str) -> None:
        self._set(name, value, label)

    def _stop(self):
        if self._cam.IsGrabbing():
            self._cam.StopGrabbing()

    def trigger(self) -> int:
        self._start()
        # A trigger the camera is not ready for is dropped without a word (the emulator
        # right after StartGrabbing, a camera still reading out): wait until it is.
        if not self._cam.WaitForFrameTriggerReady(5000, self._pylon.TimeoutHandling_Return):
            raise DeviceError(
                f"{self.name}: not ready for a frame trigger within 5 s; check TriggerMode "
                "and that no exposure is still under way"
            )
        sent = time.monotonic_ns()
        try:
            self._cam.TriggerSoftware.Execute()
        except self._genicam.GenericException as exc:
            raise DeviceError(f"{self.name}: TriggerSoftware failed ({exc})") from None
        return sent

    def drain(self) -> int:
        drained = 0
        while self._cam.IsGrabbing():
            result = self._cam.RetrieveResult(0, self._pylon.TimeoutHandling_Return)
            if not result.IsValid():
                break
            result.Release()
            drained += 1
        return drained

    def increments(self) -> dict[str, float]:
        steps = {}
        for label, node in (("exposure_us", self._exposure), ("gain_db", self._gain)):
            if node is None:
                continue
            try:
                feature = getattr(self._cam, node)
                if feature.HasInc():
                    steps[label] = float(feature.Inc)
            except (AttributeError, self._genicam.GenericException):
                pass
        return steps

    def _start(self):
        if not self._cam.IsGrabbing():
            self._cam.StartGrabbing(self._pylon.GrabStrategy_OneByOne)

    def grab(self, n: int, *, timeout_s: float = 2.0) -> list[Frame]:
        pylon = self._pylon
        self._start()
        fmt = self._cam.PixelFormat.Value
        exposure = float(getattr(self._cam, self._exposure).Value) if self._exposure else None
        gain = float(getattr(self._cam, self._gain).Value) if self._gain else None
        frames = []
        for k in range(n):
            try:
                result = self._cam.RetrieveResult(
                    int(timeout_s * 1000), pylon.TimeoutHandling_ThrowException
                )
            except self._genicam.TimeoutException:
                raise DeviceError(
                    f"{self.name}: no frame within {timeout_s:g} s (frame {k + 1} of {n}); check trigger mode and exposure"
                ) from None
            try:
                if not result.GrabSucceeded():
                    raise DeviceError(f"{self.name}: grab failed ({result.GetErrorDescription()})")
                data = result.Array.copy()  # copy before the buffer returns to pylon
                chunk = {}
                for name in self._CHUNKS if self._chunked else ():
                    try:
                        chunk[name] = float(getattr(result, f"Chunk{name}").Value)
                    except (AttributeError, self._genicam.GenericException):
                        pass
                frames.append(
                    Frame(
                        data,
                        int(result.ID),
                        int(result.TimeStamp) or time.monotonic_ns(),
                        exposure,
                        gain,
                        fmt,
                        BIT_DEPTH.get(fmt, 8),
                        self.name,
                        "device" if result.TimeStamp else "arrival",
                        {"chunk": chunk} if chunk else {},
                    )
                )
            finally:
                result.Release()
        return frames

    def close(self) -> None:
        if self._cam.IsGrabbing():
            self._cam.StopGrabbing()
        self._cam.Close()
