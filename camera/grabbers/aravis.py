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

import time

import numpy as np
from inspect_validate.camera.frame import Frame
from inspect_validate.camera.grabbers.base import NodeMapGrabber
from inspect_validate.camera.pixelformats import BIT_DEPTH, PFNC_CODES, packed_size, unpack

from inspect_validate.errors import DeviceError

__all__ = ["AravisCamera", "import_aravis"]


def import_aravis():
    """The ``Aravis`` and ``GLib`` modules, or a DeviceError saying what to install."""
    try:
        import gi

        gi.require_version("Aravis", "0.8")
        from gi.repository import Aravis, GLib
    except (ImportError, ValueError) as exc:
        raise DeviceError(
            f"Aravis is not available ({exc}): install Debian's gir1.2-aravis-0.8 and "
            "pip install 'inspect-validate[aravis]' (PyGObject)"
        ) from None
    return Aravis, GLib


class AravisCamera(NodeMapGrabber):
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
    ):
        self._aravis, self._glib = import_aravis()
        Aravis = self._aravis
        Aravis.update_device_list()
        found = [
            (Aravis.get_device_id(i), Aravis.get_device_serial_nbr(i))
            for i in range(Aravis.get_n_devices())
        ]
        listing = ", ".join(f"{d} (serial {s})" for d, s in found) or "none"
        if serial is not None:
            ids = [d for d, s in found if s == str(serial)]
            if not ids:
                raise DeviceError(f"no Aravis camera with serial {serial}; found: {listing}")
            device_id = ids[0]
        elif device_id is None:
            if index >= len(found):
                raise DeviceError(
                    f"Aravis camera index {index} does not exist; found: {listing} — check "
                    "power, cable, the network interface's address and the firewall (GVCP, UDP 3956)"
                )
            device_id = found[index][0]
        try:
            self._cam = Aravis.Camera.new(device_id)
        except self._glib.Error as exc:
            raise DeviceError(f"cannot open Aravis camera {device_id} ({exc.message})") from None
        self._dev = self._cam.get_device()
        self.name = (
            f"{self._cam.get_vendor_name()} {self._cam.get_model_name()} "
            f"(serial {self._cam.get_device_serial_number()})"
        )
        self._num_buffers = num_buffers
        self._gain_raw = gain_raw
        self._stream = None
        self._chunked = False
        self.missing = {
            label
            for label, names in (
                ("exposure", self._EXPOSURE_NODES),
                ("gain", self._GAIN_NODES),
                ("pixel_format", ("PixelFormat",)),
            )
            if self._feature(names) is None
        }

    # -- nodes ---------------------------------------------------------------------------

    def _feature(self, names) -> str | None:
        return next((n for n in names if self._dev.get_feature(n) is not None), None)

    def _symbolics(self, name: str) -> tuple[str, ...]:
        if self._dev.get_feature(name) is None:
            return ()
        try:
            return tuple(self._dev.dup_available_enumeration_feature_values_as_strings(name))
        except self._glib.Error:
            return ()

    def _set(self, names, value, label: str):
        name = self._feature(names)
        if name is None:
            self.missing.add(label)
            return None
        node = type(self._dev.get_feature(name)).__name__
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
        return value

    def _read(self, names) -> float | None:
        name = self._feature(names)
        try:
            return self._dev.get_float_feature_value(name) if name else None
        except self._glib.Error:
            return None

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

    def _stop(self):
        if self._stream is None:
            return
        try:
            self._cam.stop_acquisition()
        except self._glib.Error:
            pass  # a camera that vanished: the stream is dropped all the same
        self._stream = None  # its queued buffers go with it

    def configure(self, *, exposure_us=None, gain_db=None, pixel_format=None, region=None) -> None:
        super().configure(
            exposure_us=exposure_us, gain_db=gain_db, pixel_format=pixel_format, region=region
        )
        if self._gain_raw is not None:
            self._set(("GainRaw",), int(self._gain_raw), "gain_raw")

    def _has(self, name: str) -> bool:
        return self._dev.get_feature(name) is not None

    def _write(self, name: str, value, label: str) -> None:
        self._set((name,), value, label)

    def trigger(self) -> int:
        self._start()
        sent = time.monotonic_ns()
        try:
            self._dev.execute_command("TriggerSoftware")
        except self._glib.Error as exc:
            raise DeviceError(f"{self.name}: TriggerSoftware failed ({exc.message})") from None
        return sent

    def drain(self) -> int:
        drained = 0
        while self._stream is not None and (buf := self._stream.try_pop_buffer()) is not None:
            self._stream.push_buffer(buf)
            drained += 1
        return drained

    def increments(self) -> dict[str, float]:
        steps = {}
        for label, names in (("exposure_us", self._EXPOSURE_NODES), ("gain_db", self._GAIN_NODES)):
            name = self._feature(names)
            try:
                # Aravis reports the smallest double for a float without an increment.
                if name and (inc := self._dev.get_float_feature_increment(name)) > 1e-12:
                    steps[label] = inc
            except self._glib.Error:
                pass
        return steps

    # -- frames --------------------------------------------------------------------------

    def grab(self, n: int, *, timeout_s: float = 2.0) -> list[Frame]:
        self._start()
        exposure, gain = self._read(self._EXPOSURE_NODES), self._read(self._GAIN_NODES)
        success = self._aravis.BufferStatus.SUCCESS
        frames = []
        for k in range(n):
            buf = self._stream.timeout_pop_buffer(max(1, int(timeout_s * 1e6)))
            if buf is None:
                raise DeviceError(
                    f"{self.name}: no frame within {timeout_s:g} s (frame {k + 1} of {n}); check "
                    "trigger mode, frame rate, exposure time, the cable and that the camera is "
                    "still powered"
                )
            try:
                status = buf.get_status()
                if status != success:
                    raise DeviceError(
                        f"{self.name}: frame {buf.get_frame_id()} arrived incomplete "
                        f"({status.value_nick}); check the network (packet size, bandwidth, "
                        "a switch dropping packets)"
                    )
                frames.append(self._frame(buf, exposure, gain))
            finally:
                self._stream.push_buffer(buf)
        return frames

    def _frame(self, buf, exposure, gain) -> Frame:
        code = buf.get_image_pixel_format()
        fmt = self._checked_format(PFNC_CODES.get(code), f"pixel format 0x{code:08x}")
        w, h = buf.get_image_width(), buf.get_image_height()
        raw = np.frombuffer(buf.get_data(), np.uint8)  # PyGObject's bytes: read-only
        if fmt == "Mono8":
            data = raw[: w * h].reshape(h, w).copy()
        elif fmt in ("Mono10", "Mono12", "Mono14", "Mono16"):
            data = raw[: 2 * w * h].view("<u2").reshape(h, w).astype(np.uint16)
        else:
            data = unpack(raw[: packed_size(fmt, w * h)], fmt, w, h)
        chunk = {}
        if self._chunked:
            for name in self._CHUNKS:
                try:
                    chunk[name] = float(buf.get_chunk_data_as_float(name))  # not in every build
                except (AttributeError, self._glib.Error, TypeError):
                    pass
        return Frame(
            data,
            int(buf.get_frame_id()),
            int(buf.get_timestamp()),
            exposure,
            gain,
            fmt,
            BIT_DEPTH[fmt],
            self.name,
            "device",
            {"chunk": chunk} if chunk else {},
        )

    def close(self) -> None:
        self._stop()
        self._cam = self._dev = None
