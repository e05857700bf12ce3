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
  any fixed flush. :meth:`GenICamGrabber.restart_stream` stops and restarts the
  acquisition, which discards them all; ``pipeline_frames`` still reports the
  buffer count for callers that do not restart.
* The pixel format is read from each buffer, not assumed from the setting: a
  buffer in another format than the one asked for is an error naming the device.
* Triggered acquisition (:meth:`GenICamGrabber.arm`) by SFNC names:
  ``TriggerSelector=FrameStart``, ``TriggerMode``, ``TriggerSource``
  (``Software`` or ``LineN``), ``TriggerSoftware``, ``TriggerDelay``; a strobe
  output by ``LineSelector``/``LineMode``/``LineSource=ExposureActive``; the data
  stream's ``StreamBufferHandlingMode=OldestFirst`` where offered. Chunks
  (``ChunkModeActive``, ``ChunkSelector``/``ChunkEnable``) are read from the node
  map, where harvesters attaches each fetched buffer's chunk data.
"""

from __future__ import annotations

import contextlib
import os
import time
from pathlib import Path
from typing import Annotated, Literal

import numpy as np
from pydantic import Field

from inspect_validate.camera.grabbers.base import (
    Buffer,
    DeviceInfo,
    NodeMapGrabber,
    choose_device,
)
from inspect_validate.camera.pixelformats import BIT_DEPTH, PACKED, packed_size
from inspect_validate.camera.registry import Backend, Opening, Search
from inspect_validate.camera.settings import CameraSettings
from inspect_validate.errors import DeviceError, IncompleteFrame

__all__ = ["BACKEND", "GenICamGrabber", "GenicamSettings", "discover_genicam", "find_producers"]


def _entries(node) -> tuple[str, ...]:
    """An enumeration's entries, or () where the node is absent or not readable now."""
    try:
        return tuple(node.symbolics) if node is not None else ()
    except Exception:  # GenICam raises several types for unavailable nodes
        return ()


# One Harvester per set of producers in a process, shared by the cameras open on it: a
# second Harvester loading the same producer finds none of its devices (the producer is
# already initialised), so two cameras of one producer (TLSimu's several devices, two
# cameras behind one vendor's GenTL) need the one.
_HARVESTERS: dict[tuple[str, ...], list] = {}  # producers → [Harvester, cameras open on it]


def _harvester(producers: tuple[str, ...]):
    """The process's Harvester of ``producers`` (made and updated on first use)."""
    from harvesters.core import Harvester

    held = _HARVESTERS.get(producers)
    if held is None:
        harvester = Harvester()
        for producer in producers:
            harvester.add_file(producer)
        harvester.update()
        held = _HARVESTERS[producers] = [harvester, 0]
    held[1] += 1
    return held[0]


def _release(producers: tuple[str, ...]) -> None:
    """One camera less on ``producers``' Harvester; the last one resets it."""
    held = _HARVESTERS.get(producers)
    if held is None:
        return
    held[1] -= 1
    if held[1] <= 0:
        del _HARVESTERS[producers]
        held[0].reset()


def _complete(buf) -> bool:
    """The buffer holds its whole frame (GenTL's ``BUFFER_INFO_IS_INCOMPLETE``); a producer
    that does not say is taken at its word that it delivers only whole frames."""
    try:
        return bool(buf.module.is_complete())
    except Exception:  # not implemented by the producer, or not a harvesters buffer
        return True


def find_producers(
    cti: str | None = None, *, given_as: str = "camera.cti in the station file"
) -> list[Path]:
    """The GenTL producer files to load: ``cti``, else every one in
    ``GENICAM_GENTL64_PATH``'s folders (``given_as``: where a user gives ``cti``)."""
    if cti:
        path = Path(cti)
        if not path.exists():
            raise DeviceError(f"GenTL producer {path} not found; check {given_as}")
        if not path.is_file():  # a folder, a FIFO, /dev/null: nothing to load
            what = "a folder" if path.is_dir() else "not a regular file (a device or pipe)"
            raise DeviceError(
                f"GenTL producer {path} is {what}; give the vendor's .cti file in {given_as}"
            )
        with path.open("rb") as f:
            if path.suffix.lower() != ".cti" or f.read(4) not in (b"\x7fELF", b"MZ\x90\x00"):
                raise DeviceError(
                    f"{path} is no GenTL producer (a .cti is a shared library); give the "
                    f"vendor's .cti file in {given_as}"
                )
        return [path]
    found = []
    for folder in filter(None, os.environ.get("GENICAM_GENTL64_PATH", "").split(os.pathsep)):
        found += sorted(Path(folder).glob("*.cti"))
    if not found:
        raise DeviceError(
            f"no GenTL producer: give {given_as} or set GENICAM_GENTL64_PATH to the folder of "
            "your camera vendor's .cti"
        )
    return found


# GenTL's DEVICE_ACCESS_STATUS, as a person would say it.
_ACCESS = {1: "free", 2: "read-only", 3: "in use", 4: "in use", 5: "open here", 6: "open here"}


def _devices(harvester, source: str = "") -> list[DeviceInfo]:
    """The cameras a harvester's producers list, keyed by their index in it."""

    def text(device, name: str) -> str:
        try:
            return str(getattr(device, name))
        except Exception:  # producers leave optional fields "not available"
            return ""

    found = []
    for k, d in enumerate(harvester.device_info_list):
        try:
            access = _ACCESS.get(int(d.access_status), "")
        except Exception:  # not available from this producer
            access = ""
        found.append(
            DeviceInfo(
                k,
                text(d, "serial_number"),
                text(d, "vendor"),
                text(d, "model"),
                device_id=text(d, "id_"),
                interface=", ".join(filter(None, (text(d, "tl_type"), Path(source).name))),
                user_id=text(d, "user_defined_name"),
                access=access,
                source=source,
                backend="genicam",
            )
        )
    return found


def discover_genicam(search: Search) -> list[DeviceInfo]:
    """Every camera each GenTL producer lists (``search.cti``, else every ``.cti`` in
    ``GENICAM_GENTL64_PATH``), each producer loaded on its own so that a camera names the
    producer it came from."""
    from harvesters.core import Harvester

    found = []
    for producer in find_producers(search.cti, given_as="--cti"):
        harvester = Harvester()
        try:
            harvester.add_file(str(producer))
            harvester.update()
            found += _devices(harvester, str(producer))
        finally:
            harvester.reset()
    return found


class GenICamGrabber(NodeMapGrabber):
    """A GenICam camera chosen by serial number or index."""

    def __init__(
        self,
        cti: str | None = None,
        *,
        serial: str | None = None,
        index: int = 0,
        num_buffers: int | None = None,
    ) -> None:
        self._producers = tuple(str(p) for p in find_producers(cti))
        self._harvester = _harvester(self._producers)
        found = _devices(self._harvester)
        try:
            chosen = choose_device(found, what="GenICam", serial=serial, index=index)
            self._ia = self._harvester.create(chosen.key)
        except BaseException:
            _release(self._producers)
            raise
        self.name = chosen.describe()
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
        self._incomplete = 0
        self._chunked = False
        self._nodes = self._ia.remote_device.node_map
        self.missing = self._missing()

    # -- nodes ---------------------------------------------------------------------------

    def _has(self, name: str) -> bool:
        return hasattr(self._nodes, name)

    def _symbolics(self, name: str) -> tuple[str, ...]:
        return _entries(getattr(self._nodes, name, None))

    def _write(self, name: str, value, label: str) -> None:
        node = getattr(self._nodes, name, None)
        if node is None:
            self.missing.add(label)
            return
        try:
            node.value = value
        except Exception as exc:  # GenICam raises several types for out-of-range and access errors
            raise DeviceError(f"{self.name}: cannot set {name} to {value!r} ({exc})") from None

    def _read(self, name: str) -> float | None:
        try:
            return float(getattr(self._nodes, name).value)
        except Exception:  # absent or not readable now
            return None

    def _bounds(self, name: str) -> tuple[float, float] | None:
        try:
            node = getattr(self._nodes, name)
            return float(node.min), float(node.max)
        except Exception:  # absent, or not a numeric node
            return None

    def _increment(self, name: str) -> float | None:
        try:
            return float(getattr(self._nodes, name).inc)
        except Exception:  # a float without an increment
            return None

    def _text(self, name: str) -> str | None:
        try:
            return str(getattr(self._nodes, name).to_string())
        except Exception:  # absent, or not readable now
            return None

    def _execute(self, name: str) -> None:
        try:
            getattr(self._nodes, name).execute()
        except Exception as exc:  # GenICam raises several types for access errors
            raise DeviceError(f"{self.name}: {name} failed ({exc})") from None

    # -- stream --------------------------------------------------------------------------

    def _stop(self) -> None:
        if self._acquiring:
            self._stream_ended()  # GenTL counts from the acquisition start
            self._ia.stop()
            self._acquiring = False

    def _start(self):
        if not self._acquiring:
            try:
                self._ia.start()
            except Exception as exc:  # GenTL raises several types when it cannot arm
                raise DeviceError(f"{self.name}: cannot start the acquisition ({exc})") from None
            self._acquiring = True
            self._incomplete = 0
            self._stream_started()

    def _stream_info(self, name: str) -> int | None:
        """A ``STREAM_INFO_*`` of the data stream (``num_delivered``, ``num_underrun``),
        None where the producer does not implement it."""
        try:
            return int(getattr(self._ia.data_streams[0].module, name))
        except Exception:  # GenTL raises several types for info a producer lacks
            return None

    def _counters_offered(self) -> tuple[str, ...]:
        # Incomplete buffers are told by each buffer's own flag (BUFFER_INFO_IS_INCOMPLETE).
        offered = ["frames_incomplete"]
        if self._stream_info("num_delivered") is not None:
            offered.append("frames_delivered")
        if self._stream_info("num_underrun") is not None:
            offered.append("frames_lost")
        return tuple(offered)

    def _stream_counters(self) -> dict[str, float]:
        if not self._acquiring:
            return {}
        out: dict[str, float] = {"frames_incomplete": self._incomplete}
        delivered, underrun = self._stream_info("num_delivered"), self._stream_info("num_underrun")
        if delivered is not None:
            out["frames_delivered"] = max(delivered - self._incomplete, 0)
        if underrun is not None:
            out["frames_lost"] = underrun
        return out

    def _arm_stream(self) -> None:
        # Triggered frames are fetched in the order they were triggered.
        stream = self._ia.data_streams[0].node_map
        handling = getattr(stream, "StreamBufferHandlingMode", None)
        if handling is not None and "OldestFirst" in _entries(handling):
            try:
                handling.value = "OldestFirst"
            except Exception as exc:  # GenTL raises several types for access errors
                raise DeviceError(
                    f"{self.name}: cannot set StreamBufferHandlingMode to OldestFirst ({exc})"
                ) from None

    def drain(self) -> int:
        if not self._acquiring:
            return 0
        drained = 0
        while (buf := self._ia.try_fetch(timeout=1e-6)) is not None:
            buf.queue()
            drained += 1
        return drained

    @contextlib.contextmanager
    def _fetch(self, timeout_s: float):
        from genicam.gentl import TimeoutException

        try:
            buf = self._ia.fetch(timeout=timeout_s)
        except TimeoutException:
            yield None
            return
        try:
            arrived = time.monotonic_ns()
            if not _complete(buf):
                self._incomplete += 1
                raise IncompleteFrame(
                    f"{self.name}: frame {buf.frame_id} arrived incomplete (the producer "
                    "flags it); check the link (packet size, bandwidth, the cable)"
                )
            comp = buf.payload.components[0]
            w, h = int(comp.width), int(comp.height)
            try:
                reported = str(comp.data_format)
            except Exception:  # a producer that reports no format: the node's value
                reported = str(self._nodes.PixelFormat.value)
            if reported in PACKED:
                start = int(comp.data_offset)
                raw = comp._buffer.raw_buffer
                pixels = np.frombuffer(raw, np.uint8)[start : start + packed_size(reported, w * h)]
            elif reported in BIT_DEPTH:
                pixels = comp.data.reshape(h, w)
            else:  # not monochrome: refused by its format before its pixels are read
                pixels = comp.data
            try:
                stamp, clock = int(buf.timestamp_ns), "device"
            except Exception:  # producers without timestamps raise NotAvailableException
                stamp, clock = arrived, "arrival"
            yield Buffer(
                pixels=pixels,
                pixel_format=reported if reported in BIT_DEPTH else None,
                width=w,
                height=h,
                frame_id=int(buf.frame_id),
                timestamp_ns=stamp,
                clock=clock,
                reported=reported,
                chunk=self._chunk_values() if self._chunked else {},
            )
        finally:
            buf.queue()

    def _chunk_values(self) -> dict[str, float]:
        """The fetched buffer's chunk values (harvesters attached them to the node map)."""
        values = {}
        for name in self._CHUNKS:
            node = getattr(self._nodes, f"Chunk{name}", None)
            if node is None:
                continue
            try:
                values[name] = float(node.value)
            except Exception:  # not enabled, not in this buffer
                continue
        return values

    def close(self) -> None:
        try:
            self._stop()
            self._ia.destroy()
        finally:
            _release(self._producers)


class GenicamSettings(CameraSettings):
    """A GenICam camera through harvesters and its vendor's GenTL producer."""

    backend: Literal["genicam"]
    """GenICam cameras through a vendor's GenTL producer and ``harvesters``."""
    cti: str | None = None
    """The GenTL producer (.cti; a relative path is from the station file's folder;
    default: every one in ``GENICAM_GENTL64_PATH``)."""
    serial: str | None = None
    """The camera's serial number (default: by ``index``)."""
    index: Annotated[int, Field(ge=0)] = 0
    """Position in the producers' device list, when no serial is given."""
    num_buffers: Annotated[int, Field(ge=1, le=1000)] | None = None
    """Buffers announced to the stream (default: harvesters')."""


def open_genicam(settings: GenicamSettings, opening: Opening) -> GenICamGrabber:
    cti = str(opening.resolve(settings.cti)) if settings.cti else None
    return GenICamGrabber(
        cti, serial=settings.serial, index=settings.index, num_buffers=settings.num_buffers
    )


BACKEND = Backend(
    "genicam",
    GenicamSettings,
    open_genicam,
    discover=discover_genicam,
    device_keys=lambda d: {
        "cti": d.source,
        **({"serial": d.serial} if d.serial else {"index": d.key}),
    },
)
