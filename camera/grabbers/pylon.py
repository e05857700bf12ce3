"""Basler cameras through pypylon (optional extra ``inspect-validate[pylon]``).

Also drives pylon's camera emulator (``PYLON_CAMEMU=1``, device class
``BaslerCamEmu``), which serves image files pixel-exactly with ``ImageFileMode``
— used in the tests to run a capture through the vendor SDK.
"""

from __future__ import annotations

import contextlib
import time
from pathlib import Path
from typing import Annotated, Any, ClassVar, Literal

import numpy as np
from pydantic import Field

from inspect_validate.camera.grabbers.base import (
    Buffer,
    DeviceInfo,
    NodeMapGrabber,
    choose_device,
)
from inspect_validate.camera.pixelformats import PACKED, PFNC_CODES
from inspect_validate.camera.registry import Backend, Opening, Search
from inspect_validate.camera.settings import CameraSettings
from inspect_validate.errors import DeviceError, IncompleteFrame

__all__ = ["BACKEND", "PylonGrabber", "PylonSettings", "discover_pylon"]


def _import_pylon():
    """pypylon's ``pylon`` and ``genicam`` modules, or a DeviceError saying what to install."""
    try:
        from pypylon import genicam, pylon
    except ImportError:
        raise DeviceError(
            "pypylon is not installed: pip install 'inspect-validate[pylon]'"
        ) from None
    return pylon, genicam


def _devices(pylon) -> list[DeviceInfo]:
    """The cameras pylon's transport layers enumerate, keyed by their device info."""
    factory = pylon.TlFactory.GetInstance()
    return [
        DeviceInfo(
            d,
            str(d.GetSerialNumber()),
            str(d.GetVendorName() or "Basler"),
            str(d.GetModelName()),
            interface=str(d.GetDeviceClass()),
            user_id=str(d.GetUserDefinedName()),
            access="free" if factory.IsDeviceAccessible(d) else "in use",
            backend="pylon",
        )
        for d in factory.EnumerateDevices()
    ]


def discover_pylon(search: Search) -> list[DeviceInfo]:
    """Every camera pylon sees (its emulator's too, where ``PYLON_CAMEMU`` asks for them)."""
    pylon, _ = _import_pylon()
    return _devices(pylon)


class PylonGrabber(NodeMapGrabber):
    """A pylon camera chosen by serial number or index."""

    def __init__(self, *, serial: str | None = None, index: int = 0) -> None:
        pylon, genicam = _import_pylon()
        self._pylon, self._genicam = pylon, genicam
        factory = pylon.TlFactory.GetInstance()
        found = _devices(pylon)
        chosen = choose_device(found, what="pylon", serial=serial, index=index)
        self._cam = pylon.InstantCamera(factory.CreateDevice(chosen.key))
        self._cam.Open()
        self._chunked = False
        self.name = chosen.describe()
        self._device_class = chosen.interface
        self.missing = self._missing()

    @property
    def nodes(self) -> Any:
        """The camera's node map (for settings this interface does not cover)."""
        return self._cam

    # -- nodes ---------------------------------------------------------------------------

    def _has(self, node: str) -> bool:
        """The camera has ``node`` now (pypylon answers any name with a placeholder, so
        ``hasattr`` cannot tell)."""
        return bool(self._genicam.IsAvailable(self._cam.GetNodeMap().GetNode(node)))

    def _symbolics(self, node: str) -> tuple[str, ...]:
        try:
            return tuple(getattr(self._cam, node).Symbolics)
        except (AttributeError, self._genicam.GenericException):  # absent or unavailable now
            return ()

    def _write(self, name: str, value, label: str) -> None:
        if not self._has(name):
            self.missing.add(label)
            return
        try:
            getattr(self._cam, name).Value = value
        except self._genicam.GenericException as exc:
            raise DeviceError(f"{self.name}: cannot set {name} to {value!r} ({exc})") from None

    def _read(self, name: str) -> float | None:
        try:
            return float(getattr(self._cam, name).Value)
        except (AttributeError, self._genicam.GenericException):
            return None

    def _bounds(self, name: str) -> tuple[float, float] | None:
        if not self._has(name):
            return None
        try:
            feature = getattr(self._cam, name)
            return float(feature.Min), float(feature.Max)
        except (AttributeError, self._genicam.GenericException):
            return None

    def _increment(self, name: str) -> float | None:
        try:
            feature = getattr(self._cam, name)
            return float(feature.Inc) if feature.HasInc() else None
        except (AttributeError, self._genicam.GenericException):
            return None

    def _text(self, name: str) -> str | None:
        try:
            return str(getattr(self._cam, name).ToString())
        except (AttributeError, self._genicam.GenericException):
            return None

    def _execute(self, name: str) -> None:
        try:
            getattr(self._cam, name).Execute()
        except self._genicam.GenericException as exc:
            raise DeviceError(f"{self.name}: {name} failed ({exc})") from None

    def serve_files(self, folder: str | Path) -> None:
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

    # -- stream --------------------------------------------------------------------------

    def _stop(self) -> None:
        if self._cam.IsGrabbing():
            self._stream_ended()  # pylon counts again from the next StartGrabbing
            self._cam.StopGrabbing()

    def _start(self) -> None:
        if not self._cam.IsGrabbing():
            self._cam.StartGrabbing(self._pylon.GrabStrategy_OneByOne)
            self._stream_started()

    # The stream grabber's statistics by the health names they feed. The packet counts
    # are a GigE Vision transport's: offered by GigE cameras only (other device classes,
    # the emulator among them, list the nodes and count no packets).
    _STATISTICS: ClassVar[dict[str, str]] = {
        "Statistic_Failed_Buffer_Count": "frames_incomplete",
        "Statistic_Buffer_Underrun_Count": "frames_lost",
        "Statistic_Failed_Packet_Count": "packets_lost",
        "Statistic_Resend_Request_Count": "resend_requests",
        "Statistic_Resend_Packet_Count": "packets_resent",
    }
    _PACKETS = ("packets_lost", "resend_requests", "packets_resent")

    def _statistic(self, node: str) -> float | None:
        try:
            return float(self._cam.GetStreamGrabberNodeMap().GetNode(node).GetValue())
        except (AttributeError, self._genicam.GenericException):
            return None

    def _counters_offered(self) -> tuple[str, ...]:
        gige = "GigE" in self._device_class
        offered = (
            ["frames_delivered"]
            if self._statistic("Statistic_Total_Buffer_Count") is not None
            else []
        )
        for node, name in self._STATISTICS.items():
            if (gige or name not in self._PACKETS) and self._statistic(node) is not None:
                offered.append(name)
        return tuple(offered)

    def _stream_counters(self) -> dict[str, float]:
        if not self._cam.IsGrabbing():
            return {}
        offered = self._offered()
        values = {
            name: self._statistic(node)
            for node, name in self._STATISTICS.items()
            if name in offered
        }
        total = self._statistic("Statistic_Total_Buffer_Count")
        if total is not None and "frames_delivered" in offered:
            values["frames_delivered"] = total - (values.get("frames_incomplete") or 0)
        return {k: v for k, v in values.items() if v is not None}

    def _before_trigger(self) -> None:
        # A trigger the camera is not ready for is dropped without a word (the emulator
        # right after StartGrabbing, a camera still reading out): wait until it is.
        if not self._cam.WaitForFrameTriggerReady(5000, self._pylon.TimeoutHandling_Return):
            raise DeviceError(
                f"{self.name}: not ready for a frame trigger within 5 s; check TriggerMode "
                "and that no exposure is still under way"
            )

    def drain(self) -> int:
        drained = 0
        while self._cam.IsGrabbing():
            result = self._cam.RetrieveResult(0, self._pylon.TimeoutHandling_Return)
            if not result.IsValid():
                break
            result.Release()
            drained += 1
        return drained

    @contextlib.contextmanager
    def _fetch(self, timeout_s: float):
        try:
            result = self._cam.RetrieveResult(
                int(timeout_s * 1000), self._pylon.TimeoutHandling_ThrowException
            )
        except self._genicam.TimeoutException:
            yield None
            return
        try:
            if not result.GrabSucceeded():
                raise IncompleteFrame(
                    f"{self.name}: grab failed ({result.GetErrorDescription()}); check the "
                    "cable and the bandwidth"
                )
            w, h = int(result.Width), int(result.Height)
            # The format the buffer itself carries (its PFNC code), not the node's setting.
            reported = PFNC_CODES.get(int(result.PixelType))
            if reported in PACKED:  # pylon leaves packed pixels packed in the raw buffer
                pixels = np.frombuffer(result.GetBuffer(), np.uint8)
            else:
                pixels = result.Array
            chunk = {}
            for name in self._CHUNKS if self._chunked else ():
                try:
                    chunk[name] = float(getattr(result, f"Chunk{name}").Value)
                except (AttributeError, self._genicam.GenericException):
                    pass
            stamp = int(result.TimeStamp)
            yield Buffer(
                pixels=pixels,
                pixel_format=reported,
                width=w,
                height=h,
                frame_id=int(result.ID),
                timestamp_ns=stamp or time.monotonic_ns(),
                clock="device" if stamp else "arrival",
                reported=reported or f"pixel type 0x{int(result.PixelType):08x}",
                chunk=chunk,
            )
        finally:
            result.Release()

    def close(self) -> None:
        self._stop()
        self._cam.Close()


class PylonSettings(CameraSettings):
    """A Basler camera through pypylon (``pip install 'inspect-validate[pylon]'``)."""

    backend: Literal["pylon"]
    """Basler cameras through pylon (``pypylon``)."""
    serial: str | None = None
    """The camera's serial number (default: by ``index``)."""
    index: Annotated[int, Field(ge=0)] = 0
    """Position in pylon's device list, when no serial is given."""
    simulate: bool = False
    """Render the station's simulated scene into pylon's camera emulator (PYLON_CAMEMU=1)."""


def open_pylon(settings: PylonSettings, opening: Opening) -> PylonGrabber:
    return PylonGrabber(serial=settings.serial, index=settings.index)


BACKEND = Backend("pylon", PylonSettings, open_pylon, discover=discover_pylon)
