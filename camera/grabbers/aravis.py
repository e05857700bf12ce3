"""GenICam cameras through Aravis (GigE Vision and USB3 Vision), via PyGObject.

Aravis speaks GVCP/GVSP itself, so a GigE Vision camera needs no vendor GenTL
producer. It comes from the system: Debian's ``gir1.2-aravis-0.8`` (the library and
its introspection data), and PyGObject in the Python environment
(``pip install 'inspect-validate[aravis]'``; PyGObject below 3.51 builds against
Debian 12's GLib with ``libgirepository1.0-dev``, ``libcairo2-dev`` and ``pkg-config``).

* The camera is chosen by serial number, Aravis device id (``Aravis-Fake-TEST1``,
  ``Basler-21234567``) or index in Aravis' discovery list.
* Nodes by SFNC name first, then the legacy names GigE cameras of the GenICam 1.x
  era still carry: ``ExposureTimeAbs`` for ``ExposureTime``, ``GainAbs`` for
  ``Gain``. ``GainRaw`` is in the camera's own units, not dB: a camera with only
  ``GainRaw`` lists gain in ``missing`` (set ``camera.gain_raw`` to write it).
* Buffers are popped with a timeout, copied (packed formats unpacked) and pushed
  back; the pixel format is read from each buffer's PFNC code. A buffer that did
  not arrive whole (missing packets, a timeout inside the frame) is an error naming
  its status, never a frame.
* Triggers, strobe lines and chunks as :mod:`~inspect_validate.camera.grabbers.genicam`.
"""

from __future__ import annotations

import contextlib
from types import ModuleType
from typing import Annotated, Any, ClassVar, Literal

import numpy as np
from pydantic import Field

from inspect_validate.camera.grabbers.base import (
    Buffer,
    DeviceInfo,
    NodeMapGrabber,
    choose_device,
)
from inspect_validate.camera.pixelformats import PFNC_CODES
from inspect_validate.camera.registry import Backend, Opening, Search
from inspect_validate.camera.settings import CameraSettings
from inspect_validate.errors import DeviceError, IncompleteFrame

__all__ = ["BACKEND", "AravisGrabber", "AravisSettings", "discover_aravis", "import_aravis"]


def import_aravis() -> tuple[ModuleType, ModuleType]:
    """The ``Aravis`` and ``GLib`` modules, or a DeviceError saying what to install."""
    try:
        import gi

        gi.require_version("Aravis", "0.8")
        from gi.repository import Aravis, GLib
    except (ImportError, ValueError) as exc:
        raise DeviceError(
            f"Aravis is not available ({exc}): install Debian's gir1.2-aravis-0.8, and "
            "libgirepository1.0-dev libcairo2-dev pkg-config (PyGObject builds against "
            "them), then pip install 'inspect-validate[aravis]'"
        ) from None
    return Aravis, GLib


def _devices(Aravis) -> list[DeviceInfo]:
    """The cameras Aravis' last discovery found, keyed by their device id."""
    found = []
    for i in range(Aravis.get_n_devices()):
        address = Aravis.get_device_address(i) or ""
        found.append(
            DeviceInfo(
                Aravis.get_device_id(i),
                str(Aravis.get_device_serial_nbr(i) or ""),
                str(Aravis.get_device_vendor(i) or ""),
                str(Aravis.get_device_model(i) or ""),
                device_id=Aravis.get_device_id(i),
                interface=" ".join(filter(None, (Aravis.get_device_protocol(i), address))),
                source=str(Aravis.get_device_physical_id(i) or ""),
                backend="aravis",
            )
        )
    return found


def discover_aravis(search: Search) -> list[DeviceInfo]:
    """Every GigE Vision and USB3 Vision camera Aravis discovers now (its fake camera too,
    where one runs on an interface)."""
    Aravis, _ = import_aravis()
    Aravis.update_device_list()
    return _devices(Aravis)


class AravisGrabber(NodeMapGrabber):
    """A camera Aravis discovers, chosen by serial number, device id or index.

    Parameters
    ----------
    serial : str, optional
    device_id : str, optional
        Aravis' id for the device (``arv-tool-0.8`` lists them).
    index : int
        Position in Aravis' discovery list, when neither is given.
    num_buffers : int
        Buffers pushed to the stream.
    gain_raw : int, optional
        Written to ``GainRaw`` (the camera's own units) on :meth:`configure`.
    """

    def __init__(
        self,
        *,
        serial: str | None = None,
        device_id: str | None = None,
        index: int = 0,
        num_buffers: int = 8,
        gain_raw: int | None = None,
    ) -> None:
        self._aravis, self._glib = import_aravis()
        Aravis = self._aravis
        Aravis.update_device_list()
        found = _devices(Aravis)
        key: object
        if serial is None and device_id is not None:
            # An id Aravis did not discover may still open: a camera's address, a
            # camera on another subnet that answers to it directly.
            key = device_id
        else:
            key = choose_device(
                found,
                what="Aravis",
                serial=serial,
                index=index,
                hint="check power, cable, the network interface's address and the firewall "
                "(GVCP, UDP 3956)",
            ).key
        try:
            self._cam = Aravis.Camera.new(key)
        except self._glib.Error as exc:
            listing = ", ".join(d.describe() for d in found) or "none"
            raise DeviceError(
                f"cannot open Aravis camera {key} ({exc.message}); found: {listing}"
            ) from None
        self._dev = self._cam.get_device()
        opened = str(self._cam.get_device_serial_number())
        self.name = f"{self._cam.get_vendor_name()} {self._cam.get_model_name()} (serial {opened})"
        if serial is not None and opened != str(serial):
            # Two cameras answering at one address (two fake cameras on lo, a duplicate
            # IP): the one that answered is not the one asked for.
            self._cam = self._dev = None
            raise DeviceError(
                f"asked for the Aravis camera with serial {serial}, but {self.name} answered "
                f"at its address ({key}): two cameras share it (a duplicate IP address, "
                "another fake camera on lo); give each camera its own address"
            )
        self._num_buffers = num_buffers
        self._gain_raw = gain_raw
        self._stream: Any = None
        self._chunked = False
        self.missing = self._missing()

    # -- nodes ---------------------------------------------------------------------------

    def _has(self, name: str) -> bool:
        return self._dev.get_feature(name) is not None

    def _symbolics(self, name: str) -> tuple[str, ...]:
        if not self._has(name):
            return ()
        try:
            return tuple(self._dev.dup_available_enumeration_feature_values_as_strings(name))
        except self._glib.Error:
            return ()

    def _write(self, name: str, value, label: str) -> None:
        feature = self._dev.get_feature(name)
        if feature is None:
            self.missing.add(label)
            return
        node = type(feature).__name__
        try:
            if isinstance(value, bool) or node == "GcBoolean":
                self._dev.set_boolean_feature_value(name, bool(value))
            elif node in ("GcFloatNode", "GcConverter", "GcFloatRegNode"):
                self._dev.set_float_feature_value(name, float(value))
            elif node in ("GcIntegerNode", "GcIntReg", "GcMaskedIntReg", "GcIntConverter"):
                self._dev.set_integer_feature_value(name, int(value))
            else:
                self._dev.set_string_feature_value(name, str(value))
        except self._glib.Error as exc:
            raise DeviceError(
                f"{self.name}: cannot set {name} to {value!r} ({exc.message})"
            ) from None

    def _read(self, name: str) -> float | None:
        try:
            return self._dev.get_float_feature_value(name)
        except self._glib.Error:
            return None

    def _bounds(self, name: str) -> tuple[float, float] | None:
        feature = self._dev.get_feature(name)
        if feature is None:
            return None
        try:
            if "Int" in type(feature).__name__:
                low, high = self._dev.get_integer_feature_bounds(name)
            else:
                low, high = self._dev.get_float_feature_bounds(name)
        except self._glib.Error:
            return None
        return float(low), float(high)

    def _increment(self, name: str) -> float | None:
        try:
            return self._dev.get_float_feature_increment(name)
        except self._glib.Error:
            return None

    def _text(self, name: str) -> str | None:
        feature = self._dev.get_feature(name)
        if feature is None:
            return None
        try:
            return str(feature.get_value_as_string())
        except (self._glib.Error, AttributeError):  # not a value node, or not readable now
            return None

    def _execute(self, name: str) -> None:
        try:
            self._dev.execute_command(name)
        except self._glib.Error as exc:
            raise DeviceError(f"{self.name}: {name} failed ({exc.message})") from None

    def configure(
        self,
        *,
        exposure_us: float | None = None,
        gain_db: float | None = None,
        pixel_format: str | None = None,
        region: tuple[int, int, int, int] | None = None,
    ) -> None:
        super().configure(
            exposure_us=exposure_us, gain_db=gain_db, pixel_format=pixel_format, region=region
        )
        if self._gain_raw is not None:
            self._write("GainRaw", int(self._gain_raw), "gain_raw")

    # -- stream --------------------------------------------------------------------------

    def _start(self):
        if self._stream is not None:
            return
        try:
            stream = self._cam.create_stream(None, None)
            payload = self._cam.get_payload()
            for _ in range(self._num_buffers):
                stream.push_buffer(self._aravis.Buffer.new_allocate(payload))
            self._cam.start_acquisition()
        except self._glib.Error as exc:
            raise DeviceError(
                f"{self.name}: cannot start the acquisition ({exc.message})"
            ) from None
        self._stream = stream
        self._stream_started()

    def _stop(self) -> None:
        if self._stream is None:
            return
        self._stream_ended()  # a new stream counts from 0
        try:
            self._cam.stop_acquisition()
        except self._glib.Error:
            pass  # a camera that vanished: the stream is dropped all the same
        self._stream = None  # its queued buffers go with it

    # Aravis' stream statistics by the health names they feed; USB3 Vision streams have
    # the first three, GigE Vision streams all (arvgvstream.c, arvuvstream.c).
    _STREAM_INFOS: ClassVar[dict[str, str]] = {
        "n_completed_buffers": "frames_delivered",
        "n_failures": "frames_incomplete",
        "n_underruns": "frames_lost",
        "n_missing_frames": "frames_lost",
        "n_missing_packets": "packets_lost",
        "n_resend_requests": "resend_requests",
        "n_resent_packets": "packets_resent",
    }

    def _counters_offered(self) -> tuple[str, ...]:
        gige = self._cam is not None and self._cam.is_gv_device()
        return ("frames_delivered", "frames_incomplete", "frames_lost") + (
            ("packets_lost", "resend_requests", "packets_resent") if gige else ()
        )

    def _stream_counters(self) -> dict[str, float]:
        stream = self._stream
        if stream is None:
            return {}
        out: dict[str, float] = {}
        for i in range(stream.get_n_infos()):
            name = self._STREAM_INFOS.get(stream.get_info_name(i))
            if name is not None:
                out[name] = out.get(name, 0) + int(stream.get_info_uint64(i))
        return out

    def drain(self) -> int:
        drained = 0
        while self._stream is not None and (buf := self._stream.try_pop_buffer()) is not None:
            self._stream.push_buffer(buf)
            drained += 1
        return drained

    @contextlib.contextmanager
    def _fetch(self, timeout_s: float):
        buf = self._stream.timeout_pop_buffer(max(1, int(timeout_s * 1e6)))
        if buf is None:
            yield None
            return
        try:
            status = buf.get_status()
            if status != self._aravis.BufferStatus.SUCCESS:
                raise IncompleteFrame(
                    f"{self.name}: frame {buf.get_frame_id()} arrived incomplete "
                    f"({status.value_nick}); check the network (packet size, bandwidth, "
                    "a switch dropping packets)"
                )
            code = buf.get_image_pixel_format()
            chunk = {}
            if self._chunked:
                for name in self._CHUNKS:
                    try:
                        chunk[name] = float(buf.get_chunk_data_as_float(name))  # not every build
                    except (AttributeError, self._glib.Error, TypeError):
                        pass
            yield Buffer(
                pixels=np.frombuffer(buf.get_data(), np.uint8),  # PyGObject's bytes: read-only
                pixel_format=PFNC_CODES.get(code),
                width=buf.get_image_width(),
                height=buf.get_image_height(),
                frame_id=int(buf.get_frame_id()),
                timestamp_ns=int(buf.get_timestamp()),
                clock="device",
                reported=f"pixel format 0x{code:08x}",
                chunk=chunk,
            )
        finally:
            self._stream.push_buffer(buf)

    def close(self) -> None:
        self._stop()
        self._cam = self._dev = None


class AravisSettings(CameraSettings):
    """A GigE Vision or USB3 Vision camera through Aravis."""

    backend: Literal["aravis"]
    """GigE Vision and USB3 Vision cameras through Aravis (``gi``, ``Aravis-0.8``)."""
    simulate: bool = False
    """Stream the station's simulated scene from Aravis' fake GigE Vision camera on ``lo``."""
    simulate_interface: Annotated[str, Field(pattern=r"^[A-Za-z0-9_.:-]{1,64}$")] = "lo"
    """With ``simulate``: the interface (name or address) the fake camera listens on. Two
    fake cameras need an address each: add one to ``lo`` (``ip addr add 127.0.0.2/32 dev
    lo``) and give it to the second camera."""
    serial: str | None = None
    """The camera's serial number."""
    device_id: str | None = None
    """Aravis' id for the device, e.g. ``Aravis-Fake-TEST1`` (``arv-tool-0.8`` lists them)."""
    index: Annotated[int, Field(ge=0)] = 0
    """Position in Aravis' discovery list, when neither is given."""
    num_buffers: Annotated[int, Field(ge=1, le=1000)] = 8
    """Buffers pushed to the stream."""
    gain_raw: Annotated[int, Field(ge=0, le=1_000_000)] | None = None
    """Written to ``GainRaw`` (the camera's own units) on a camera without gain in dB."""


def open_aravis(settings: AravisSettings, opening: Opening) -> AravisGrabber:
    return AravisGrabber(
        serial=settings.serial,
        device_id=settings.device_id,
        index=settings.index,
        num_buffers=settings.num_buffers,
        gain_raw=settings.gain_raw,
    )


BACKEND = Backend(
    "aravis",
    AravisSettings,
    open_aravis,
    discover=discover_aravis,
    device_keys=lambda d: {"serial": d.serial} if d.serial else {"device_id": d.device_id},
)
