"""GenICam cameras through harvesters (GenTL consumer).

* The producer (``.cti``) comes from the station file, else from
  ``GENICAM_GENTL64_PATH`` (every ``.cti`` in its folders).
* Every fetch has a timeout; a frame's pixels are copied (packed formats
  unpacked by :mod:`inspect_validate.camera.pixelformats`) before the buffer is re-queued.
* Width, Height, PixelFormat and the region are locked while acquiring:
  acquisition is stopped to change them.
* Nodes a device lacks (e.g. no ExposureTime) are listed in ``missing`` and the
  frame records None for them; the capture goes on.
* A free-running producer keeps every announced buffer filled, so after a light
  switch up to ``num_buffers`` frames from before it wait in the queue — more than
  any fixed flush. :meth:`GenICamCamera.restart_stream` stops and restarts the
  acquisition, which discards them all; ``pipeline_frames`` still reports the
  buffer count for callers that do not restart.
* The pixel format is read from each buffer, not assumed from the setting: a
  buffer in another format than the one asked for is an error naming the device.
* Triggered acquisition (:meth:`GenICamCamera.arm`) by SFNC names:
  ``TriggerSelector=FrameStart``, ``TriggerMode``, ``TriggerSource``
  (``Software`` or ``LineN``), ``TriggerSoftware``, ``TriggerDelay``; a strobe
  output by ``LineSelector``/``LineMode``/``LineSource=ExposureActive``; the data
  stream's ``StreamBufferHandlingMode=OldestFirst`` where offered. Chunks
  (``ChunkModeActive``, ``ChunkSelector``/``ChunkEnable``) are read from the node
  map, where harvesters attaches each fetched buffer's chunk data.
"""

from __future__ import annotations

import os
import time
from pathlib import Path

from inspect_validate.camera.frame import Frame
from inspect_validate.camera.grabbers.base import NodeMapGrabber
from inspect_validate.camera.pixelformats import BIT_DEPTH, packed_size, unpack

from inspect_validate.errors import DeviceError

__all__ = ["GenICamCamera", "find_producers"]


def _entries(node) -> tuple[str, ...]:
    """An enumeration's entries, or () where the node is absent or not readable now."""
    try:
        return tuple(node.symbolics) if node is not None else ()
    except Exception:  # GenICam raises several types for unavailable nodes
        return ()


def find_producers(cti: str | None = None) -> list[Path]:
    """The GenTL producer files to load."""
    if cti:
        path = Path(cti)
        if not path.is_file():
            raise DeviceError(
                f"GenTL producer {path} not found; check camera.cti in the station file"
            )
        return [path]
    found = []
    for folder in filter(None, os.environ.get("GENICAM_GENTL64_PATH", "").split(os.pathsep)):
        found += sorted(Path(folder).glob("*.cti"))
    if not found:
        raise DeviceError(
            "no GenTL producer: give camera.cti in the station file or set GENICAM_GENTL64_PATH to the folder of your camera vendor's .cti"
        )
    return found


def _node(node_map, names):
    for name in names:
        if hasattr(node_map, name):
            return name, getattr(node_map, name)
    return None, None


class GenICamCamera(NodeMapGrabber):
    """A GenICam camera chosen by serial number or index."""

    def __init__(
        self,
        cti: str | None = None,
        *,
        serial: str | None = None,
        index: int = 0,
        num_buffers: int | None = None,
    ):
        from harvesters.core import Harvester

        self._harvester = Harvester()
        for producer in find_producers(cti):
            self._harvester.add_file(str(producer))
        self._harvester.update()
        devices = self._harvester.device_info_list
        if not devices:
            self._harvester.reset()
            raise DeviceError(
                "no GenICam camera found; check power, cable or network, and access rights"
            )
        serials = [d.serial_number for d in devices]
        if serial is not None:
            if str(serial) not in serials:
                self._harvester.reset()
                raise DeviceError(f"no camera with serial {serial}; found: {', '.join(serials)}")
            self._ia = self._harvester.create({"serial_number": str(serial)})
            info = devices[serials.index(str(serial))]
        else:
            if index >= len(devices):
                self._harvester.reset()
                raise DeviceError(
                    f"camera index {index} does not exist; {len(devices)} found (serials {', '.join(serials)})"
                )
            self._ia = self._harvester.create(index)
            info = devices[index]
        self.name = f"{info.vendor} {info.model} (serial {info.serial_number})"
        if num_buffers is not None:
            try:
                self._ia.num_buffers = int(num_buffers)
            except Exception as exc:  # harvesters refuses fewer than the producer's minimum
                self.close()
                raise DeviceError(
                    f"{self.name}: cannot announce {num_buffers} buffers ({exc})"
                ) from None
        # Every announced buffer may hold a frame from before a change, plus one in flight.
        self.pipeline_frames = int(self._ia.num_buffers) + 1
        self._acquiring = False
        self._chunked = False
        self._nodes = self._ia.remote_device.node_map
        self.missing = {
            label
            for label, names in (
                ("exposure", self._EXPOSURE_NODES),
                ("gain", self._GAIN_NODES),
                ("pixel_format", ("PixelFormat",)),
            )
            if _node(self._nodes, names)[0] is None
        }

    def _set(self, names, value, label):
        name, node = _node(self._nodes, names)
        if node is None:
            self.missing.add(label)
            return None
        try:
            node.value = value
            return node.value
        except Exception as exc:  # GenICam raises several types for out-of-range and access errors
            raise DeviceError(f"{self.name}: cannot set {name} to {value!r} ({exc})") from None

    def _stop(self):
        if self._acquiring:
            self._ia.stop()
            self._acquiring = False

    def _start(self):
        if not self._acquiring:
            try:
                self._ia.start()
            except Exception as exc:  # GenTL raises several types when it cannot arm
                raise DeviceError(f"{self.name}: cannot start the acquisition ({exc})") from None
            self._acquiring = True

    def _has(self, name: str) -> bool:
        return hasattr(self._nodes, name)

    def _symbolics(self, name: str) -> tuple[str, ...]:
        return _entries(getattr(self._nodes, name, None))

    def _write(self, name: str, value, label: str) -> None:
        self._set((name,), value, label)

    def _arm_stream(self) -> None:
        # Triggered frames are fetched in the order they were triggered.
        stream = self._ia.data_streams[0].node_map
        handling = getattr(stream, "StreamBufferHandlingMode", None)
        if "OldestFirst" in _entries(handling):
            try:
                handling.value = "OldestFirst"
            except Exception as exc:  # GenTL raises several types for access errors
                raise DeviceError(
                    f"{self.name}: cannot set StreamBufferHandlingMode to OldestFirst ({exc})"
                ) from None

    def trigger(self) -> int:
        self._start()
        sent = time.monotonic_ns()
        try:
            self._nodes.TriggerSoftware.execute()
        except Exception as exc:  # GenICam raises several types for access errors
            raise DeviceError(f"{self.name}: TriggerSoftware failed ({exc})") from None
        return sent

    def drain(self) -> int:
        if not self._acquiring:
            return 0
        drained = 0
        while (buf := self._ia.try_fetch(timeout=1e-6)) is not None:
            buf.queue()
            drained += 1
        return drained

    def increments(self) -> dict[str, float]:
        steps = {}
        for label, names in (("exposure_us", self._EXPOSURE_NODES), ("gain_db", self._GAIN_NODES)):
            _, node = _node(self._nodes, names)
            try:
                steps[label] = float(node.inc)
            except Exception:  # no node, or a float without an increment
                pass
        return steps

    def _chunk_values(self) -> dict[str, float]:
        """The fetched buffer's chunk values (harvesters attached them to the node map)."""
        values = {}
        for name in self._CHUNKS:
            node = getattr(self._nodes, f"Chunk{name}", None)
            try:
                values[name] = float(node.value)
            except Exception:  # not enabled, not in this buffer
                continue
        return values

    def _read(self, names):
        _, node = _node(self._nodes, names)
        try:
            return float(node.value) if node is not None else None
        except Exception:
            return None

    def grab(self, n: int, *, timeout_s: float = 2.0) -> list[Frame]:
        from genicam.gentl import TimeoutException

        self._start()
        exposure, gain = self._read(self._EXPOSURE_NODES), self._read(self._GAIN_NODES)
        frames = []
        for k in range(n):
            try:
                with self._ia.fetch(timeout=timeout_s) as buf:
                    arrived = time.monotonic_ns()
                    comp = buf.payload.components[0]
                    w, h = int(comp.width), int(comp.height)
                    fmt = self._buffer_format(comp)
                    if fmt in ("Mono8", "Mono10", "Mono12", "Mono14", "Mono16"):
                        data = comp.data.reshape(h, w).copy()  # copy before the buffer is re-queued
                    else:
                        raw = comp._buffer.raw_buffer
                        start = int(comp.data_offset)
                        data = unpack(raw[start : start + packed_size(fmt, w * h)], fmt, w, h)
                    try:
                        stamp, clock = int(buf.timestamp_ns), "device"
                    except Exception:  # producers without timestamps raise NotAvailableException
                        stamp, clock = arrived, "arrival"
                    chunk = self._chunk_values() if self._chunked else {}
                    frames.append(
                        Frame(
                            data,
                            int(buf.frame_id),
                            stamp,
                            exposure,
                            gain,
                            fmt,
                            BIT_DEPTH.get(fmt, 8),
                            self.name,
                            clock,
                            {"chunk": chunk} if chunk else {},
                        )
                    )
            except TimeoutException:
                raise DeviceError(
                    f"{self.name}: no frame within {timeout_s:g} s (frame {k + 1} of {n}); "
                    "check trigger mode, frame rate, exposure time and the cable"
                ) from None
        return frames

    def _buffer_format(self, comp) -> str:
        """The pixel format the buffer itself reports, checked against the request."""
        try:
            fmt = str(comp.data_format)
        except Exception:  # a producer that reports no format: the node's value
            fmt = str(self._nodes.PixelFormat.value)
        return self._checked_format(fmt, fmt)

    def close(self) -> None:
        try:
            self._stop()
            self._ia.destroy()
        finally:
            self._harvester.reset()
