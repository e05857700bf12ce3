"""The grabber interface shared by every camera backend."""

from __future__ import annotations

import contextlib
import math
import time
from abc import ABC, abstractmethod
from contextlib import AbstractContextManager
from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np

from inspect_validate.camera.frame import Frame
from inspect_validate.camera.pixelformats import BIT_DEPTH, PACKED, packed_size, unpack
from inspect_validate.errors import DeviceError, FrameTimeout

__all__ = [
    "ACQUISITIONS",
    "SETTINGS_NODES",
    "Buffer",
    "DeviceInfo",
    "Features",
    "Grabber",
    "NodeMapGrabber",
    "choose_device",
]

#: How frames are started: by the camera's own clock, by ``TriggerSoftware`` from the
#: capture, or by a pulse on one of the camera's input lines.
ACQUISITIONS = ("free-run", "software-trigger", "hardware-trigger")


@dataclass(frozen=True)
class Features:
    """What a camera offers beyond free-running, read from its node map.

    Attributes
    ----------
    software_trigger : bool
        ``TriggerMode`` and ``TriggerSoftware`` (``TriggerSelector=FrameStart`` where
        the selector exists).
    trigger_lines : tuple of str
        Input lines ``TriggerSource`` can take (``Line1`` …).
    strobe_lines : tuple of str
        Lines that can output ``ExposureActive`` (``LineSelector``/``LineSource``).
    chunks : tuple of str
        Chunk values the camera can append to a frame (``ExposureTime``, ``Gain``,
        ``Timestamp``, ``FrameID``), empty without ``ChunkModeActive``.
    pixel_formats : tuple of str
        Every entry of ``PixelFormat`` (colour ones too; :attr:`monochrome` those read).
    exposure_us, gain_db : (float, float) or None
        The range ``ExposureTime`` (µs) and ``Gain`` (dB) take, None where the camera
        has no such node or does not say.
    max_size : (int, int) or None
        The largest ``Width`` and ``Height`` [px].
    trigger_selectors, trigger_sources, lines : tuple of str
        The entries of ``TriggerSelector``, ``TriggerSource`` and ``LineSelector``.
    health : tuple of str
        The health quantities the camera and its transport report
        (:mod:`~inspect_validate.camera.health`; the capture counts triggers itself).
    """

    software_trigger: bool = False
    trigger_lines: tuple[str, ...] = ()
    strobe_lines: tuple[str, ...] = ()
    chunks: tuple[str, ...] = ()
    pixel_formats: tuple[str, ...] = ()
    exposure_us: tuple[float, float] | None = None
    gain_db: tuple[float, float] | None = None
    max_size: tuple[int, int] | None = None
    trigger_selectors: tuple[str, ...] = ()
    trigger_sources: tuple[str, ...] = ()
    lines: tuple[str, ...] = ()
    health: tuple[str, ...] = ()

    @property
    def monochrome(self) -> tuple[str, ...]:
        """The offered pixel formats this tool reads (every one where none are listed)."""
        if not self.pixel_formats:
            return ()
        return tuple(f for f in self.pixel_formats if f in BIT_DEPTH)

    @property
    def bit_depth(self) -> int | None:
        """The deepest monochrome format's bits, None where no format is listed."""
        return max((BIT_DEPTH[f] for f in self.monochrome), default=None)


@dataclass(frozen=True)
class DeviceInfo:
    """A camera a backend found, before it is opened.

    Attributes
    ----------
    key : object
        The backend's handle to open it by (an index, a device info object, an id).
    serial : str
    vendor, model : str
    device_id : str
        The backend's own id for it, where it has one (Aravis: ``Aravis-Fake-TEST1``).
    interface : str
        How it is reached (``GEV 192.168.1.20``, ``U3V``, ``GigE``…).
    user_id : str
        The name a user gave it (``DeviceUserID``), where the backend reads one.
    access : {"free", "in use", "read-only", "open here", ""}
        Whether another program holds it; "" where the backend cannot tell.
    source : str
        Where the backend found it: a GenTL producer's file, a device node.
    backend : str
        The backend that found it.
    """

    key: object
    serial: str
    vendor: str = ""
    model: str = ""
    device_id: str = ""
    interface: str = ""
    user_id: str = ""
    access: str = ""
    source: str = ""
    backend: str = ""

    def describe(self) -> str:
        what = " ".join(x for x in (self.vendor, self.model) if x) or self.device_id or "camera"
        return f"{what} (serial {self.serial})"


def choose_device(
    found: list[DeviceInfo],
    *,
    what: str,
    serial: str | None = None,
    device_id: str | None = None,
    index: int = 0,
    hint: str = "check power, cable or network, and that no other program holds it",
) -> DeviceInfo:
    """The camera a station asks for among those a backend ``what`` found: by serial
    number, else by device id, else by index.

    Raises
    ------
    DeviceError
        None found (with ``hint``), or none that matches (listing those found).
    """
    listing = ", ".join(d.describe() for d in found) or "none"
    if not found:
        raise DeviceError(f"no {what} camera found; {hint}")
    if serial is not None:
        match = [d for d in found if d.serial == str(serial)]
        if not match:
            raise DeviceError(f"no {what} camera with serial {serial}; found: {listing}")
        return match[0]
    if device_id is not None:
        match = [d for d in found if d.device_id == device_id]
        if not match:
            raise DeviceError(f"no {what} camera {device_id}; found: {listing}")
        return match[0]
    if index >= len(found):
        raise DeviceError(
            f"{what} camera index {index} does not exist; {len(found)} found ({listing})"
        )
    return found[index]


@dataclass
class Buffer:
    """One frame as a backend fetched it, before it becomes a :class:`Frame`.

    Attributes
    ----------
    pixels : ndarray
        The payload: the image as an (H, W) array of the format's storage type, or its
        bytes (uint8, flat) for a packed format (:func:`~.pixelformats.unpack`).
    pixel_format : str or None
        The format the buffer itself reports, by its PFNC name (None: not one this tool
        knows; ``reported`` says how the buffer named it).
    width, height : int
    frame_id : int
    timestamp_ns : int
    clock : str
        What ``timestamp_ns`` is (:class:`Frame`).
    reported : str
        The format as the buffer named it, for messages.
    chunk : dict
        Chunk values that came with the frame (``ExposureTime``, ``Gain``…).
    """

    pixels: np.ndarray
    pixel_format: str | None
    width: int
    height: int
    frame_id: int
    timestamp_ns: int
    clock: str = "device"
    reported: str = ""
    chunk: dict = field(default_factory=dict)


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

    def features(self) -> Features:
        """What the camera offers beyond free-running (default: nothing)."""
        return Features()

    def arm(
        self,
        acquisition: str,
        *,
        trigger_line: str | None = None,
        strobe_line: str | None = None,
        chunks: bool = False,
        trigger_delay_us: float = 0.0,
    ) -> None:
        """Set the camera up for ``acquisition`` (one of :data:`ACQUISITIONS`).

        Triggered: ``TriggerSelector=FrameStart``, ``TriggerMode=On`` and
        ``TriggerSource`` ``Software`` or ``trigger_line``, the stream's buffers handed
        out oldest first, and the stream restarted so that no frame from before
        arrives. ``strobe_line`` outputs ``ExposureActive`` (the light controller's
        trigger input). ``chunks`` appends exposure, gain, timestamp and frame id to
        every frame (``Frame.extra["chunk"]``). The capture checks :meth:`features`
        first; a backend refuses what it lacks with a :class:`DeviceError`.
        """
        if acquisition != "free-run" or strobe_line or chunks:
            raise DeviceError(f"{self.name}: free-runs only (no trigger, lines or chunks)")

    def drain(self) -> int:
        """Drop frames already delivered and not yet fetched; returns how many (a
        triggered capture calls it before each trigger, so the frame it fetches next
        is the one it triggered)."""
        return 0

    def trigger(self) -> int:
        """Start one frame (``TriggerSoftware``); returns the host monotonic time (ns)
        just before the command, which the frame's exposure cannot precede."""
        raise DeviceError(f"{self.name}: has no software trigger")

    def increments(self) -> dict[str, float]:
        """The smallest step of ``exposure_us`` and ``gain_db`` the camera applies (a
        chunk value within it of the request is the request)."""
        return {}

    def settings(self) -> dict[str, str]:
        """The camera's own values of the nodes that shape its image
        (:data:`SETTINGS_NODES` it has and can read now), each as the camera's string form:
        what a capture records so that a change made by another program is seen. Empty
        for a camera without a node map."""
        return {}

    def health(self) -> dict[str, float]:
        """What the camera and its transport report of the acquisition
        (:mod:`~inspect_validate.camera.health`): its counters since it was opened, its
        gauges now. Only what the backend offers is present; default none."""
        return {}

    def close(self) -> None:  # noqa: B027 - optional for backends without a connection
        """Release the device."""

    def __enter__(self):
        return self

    def __exit__(self, *exc) -> None:
        self.close()


SETTINGS_NODES = (
    # format and region
    "PixelFormat", "Width", "Height", "OffsetX", "OffsetY",
    "BinningHorizontal", "BinningVertical", "BinningHorizontalMode", "BinningVerticalMode",
    "DecimationHorizontal", "DecimationVertical", "ReverseX", "ReverseY",
    # exposure, gain, black level
    "ExposureMode", "ExposureAuto", "ExposureTime", "ExposureTimeAbs", "ExposureTimeRaw",
    "GainAuto", "GainSelector", "Gain", "GainAbs", "GainRaw", "DigitalShift",
    "BlackLevelSelector", "BlackLevel", "BlackLevelAbs", "BlackLevelRaw",
    # tone curves and colour
    "Gamma", "GammaEnable", "GammaSelector", "LUTEnable", "LUTSelector",
    "BalanceWhiteAuto", "BalanceRatioSelector", "BalanceRatio",
    # trigger and acquisition
    "TriggerSelector", "TriggerMode", "TriggerSource", "TriggerActivation", "TriggerDelay",
    "AcquisitionMode", "AcquisitionFrameRateEnable", "AcquisitionFrameRate",
    "SensorShutterMode", "ADCBitDepth",
)  # fmt: skip
"""The SFNC nodes whose values shape a camera's image, read into a capture's settings
snapshot (:meth:`Grabber.settings`). Read-only and volatile nodes (temperature,
timestamps, counters) are not among them: they change without anyone changing the
camera."""


class NodeMapGrabber(Grabber):
    """A camera with a GenICam node map: the one grab path of every GenICam-style backend
    (harvesters, pylon, Aravis). Its exposure, gain, format, region, triggers, lines and
    chunks are found and set by their SFNC names; its frames are fetched with a timeout,
    checked against the format asked for, unpacked where packed, and made into
    :class:`Frame` the same way whatever reaches them.

    A backend gives what its library differs in: the node accessors :meth:`_has`,
    :meth:`_symbolics`, :meth:`_write`, :meth:`_read`, :meth:`_increment` and
    :meth:`_execute`; :meth:`_stop` and :meth:`_start` for its acquisition (which call
    :meth:`_stream_ended` and :meth:`_stream_started`); :meth:`_fetch`, one buffer with
    a timeout; and :meth:`_stream_counters`, its transport's own counts.
    """

    _CHUNKS = ("ExposureTime", "Gain", "Timestamp", "FrameID")
    # SFNC names first, then those of GenICam 1.x-era GigE cameras (ace classic, scout).
    _EXPOSURE_NODES = ("ExposureTime", "ExposureTimeAbs")
    _GAIN_NODES = ("Gain", "GainAbs")
    _requested_format: str | None = None  # the pixel format configure() asked for

    @abstractmethod
    def _has(self, name: str) -> bool:
        """The node ``name`` exists and is available now."""

    @abstractmethod
    def _symbolics(self, name: str) -> tuple[str, ...]:
        """An enumeration's entries, () where it is absent or not readable."""

    @abstractmethod
    def _write(self, name: str, value, label: str) -> None:
        """Set ``name``; record ``label`` in :attr:`missing` where the node is absent."""

    def _bounds(self, name: str) -> tuple[float, float] | None:
        """A numeric node's minimum and maximum, None where absent or not readable."""
        return None

    def features(self) -> Features:
        sources = self._symbolics("TriggerSource")
        strobe: tuple[str, ...] = ()
        if "ExposureActive" in self._symbolics("LineSource"):
            strobe = self._symbolics("LineSelector")
        chunks: tuple[str, ...] = ()
        if self._has("ChunkModeActive"):
            offered = self._symbolics("ChunkSelector")
            chunks = tuple(c for c in self._CHUNKS if c in offered)
        software = self._has("TriggerMode") and self._has("TriggerSoftware")
        w, h = self._bounds("Width"), self._bounds("Height")
        return Features(
            # A producer whose TriggerSource lists nothing (TLSimu) still triggers by software.
            software_trigger=software and (not sources or "Software" in sources),
            trigger_lines=tuple(s for s in sources if s.startswith("Line")),
            strobe_lines=strobe,
            chunks=chunks,
            pixel_formats=self._symbolics("PixelFormat"),
            exposure_us=self._range(self._EXPOSURE_NODES),
            gain_db=self._range(self._GAIN_NODES),
            max_size=(int(w[1]), int(h[1])) if w and h else None,
            trigger_selectors=self._symbolics("TriggerSelector"),
            trigger_sources=sources,
            lines=self._symbolics("LineSelector"),
            health=(
                *self._offered(),
                *(["temperature_c"] if self._has("DeviceTemperature") else []),
                *(["link_speed_mbps"] if self._first(self._LINK_SPEED) else []),
            ),
        )

    def _range(self, names) -> tuple[float, float] | None:
        name = self._first(names)
        return self._bounds(name) if name else None

    @abstractmethod
    def _stop(self) -> None:
        """Stop the acquisition (trigger and chunk settings are locked while it runs)."""

    @abstractmethod
    def _start(self) -> None:
        """Start the acquisition."""

    def _checked_format(self, fmt: str | None, reported: str) -> str:
        """The pixel format a buffer reports (None: not one this tool knows; ``reported``
        is how the buffer named it), checked against what :meth:`configure` asked for."""
        if fmt not in BIT_DEPTH:
            raise DeviceError(
                f"{self.name}: delivers {reported} frames, not a supported monochrome format; "
                f"set camera.pixel_format in the station file to one of {', '.join(BIT_DEPTH)}"
            )
        if self._requested_format is not None and fmt != self._requested_format:
            raise DeviceError(
                f"{self.name}: asked for {self._requested_format}, the buffer holds {fmt}; "
                "the device did not apply the pixel format (check it is not locked or overridden)"
            )
        return fmt

    def _first(self, names) -> str | None:
        """The first of ``names`` the camera has."""
        return next((n for n in names if self._has(n)), None)

    def _missing(self) -> set[str]:
        """The settings the camera has no node for (recorded, not failed)."""
        return {
            label
            for label, names in (
                ("exposure", self._EXPOSURE_NODES),
                ("gain", self._GAIN_NODES),
                ("pixel_format", ("PixelFormat",)),
            )
            if self._first(names) is None
        }

    @abstractmethod
    def _read(self, name: str) -> float | None:
        """A float node's value, None where it cannot be read."""

    @abstractmethod
    def _increment(self, name: str) -> float | None:
        """A float node's increment, None where it has none."""

    @abstractmethod
    def _text(self, name: str) -> str | None:
        """A node's value in the camera's string form, None where absent or not readable."""

    def settings(self) -> dict[str, str]:
        # Read twice: a node another program (or the camera) changes while it is read has
        # no one value to record; read a third time, one still changing is left out and
        # named (unstable_settings), never recorded half-changed.
        first, second = self._read_settings(), self._read_settings()
        moving = {n for n in first.keys() | second.keys() if first.get(n) != second.get(n)}
        third = self._read_settings(moving) if moving else {}
        self.unstable_settings = tuple(sorted(n for n in moving if third.get(n) != second.get(n)))
        return {n: v for n, v in {**second, **third}.items() if n not in self.unstable_settings}

    unstable_settings: tuple[str, ...] = ()
    """The nodes whose value changed while :meth:`settings` read them (left out of it)."""

    def _read_settings(self, names=SETTINGS_NODES) -> dict[str, str]:
        values = {}
        for name in names:
            if not self._has(name):
                continue
            text = self._text(name)
            if text is not None:
                # a camera that answers garbage (control characters, megabytes) is cut
                # to what a reader can compare
                values[name] = "".join(ch for ch in text if ch.isprintable())[:200]
        return values

    # -- health --------------------------------------------------------------------------
    # A stream's counters start again with every stream (Aravis makes a new one, pylon and
    # GenTL count from the acquisition start): each is folded into the totals since the
    # camera opened before its stream ends.
    _counted: dict[str, float] | None = None
    _stream_seen: dict[str, float] | None = None  # None: no stream running
    _offered_counters: tuple[str, ...] | None = None
    # the link speed's nodes, each with its factor to Mbit/s (it is in Mbit/s; in B/s)
    _LINK_SPEED: ClassVar[dict[str, float]] = {"GevLinkSpeed": 1.0, "DeviceLinkSpeed": 8e-6}

    def _offered(self) -> tuple[str, ...]:
        """:meth:`_counters_offered`, read once: what a camera's transport counts does not
        change while it is open (pylon's and GenTL's answer costs node reads)."""
        if self._offered_counters is None:
            self._offered_counters = self._counters_offered()
        return self._offered_counters

    def _stream_counters(self) -> dict[str, float]:
        """The running stream's own counters (:data:`~inspect_validate.camera.health.COUNTERS`
        names) since it started; {} while none runs."""
        return {}

    def _counters_offered(self) -> tuple[str, ...]:
        """The counters :meth:`_stream_counters` reports, known before a stream runs."""
        return ()

    def _stream_started(self) -> None:
        self._stream_seen = {}

    def _stream_ended(self) -> None:
        """Fold the stream's counters into the totals, before the stream stops or goes."""
        self._fold()
        self._stream_seen = None

    def _fold(self) -> None:
        if self._stream_seen is None:
            return
        counted = self._counted if self._counted is not None else {}
        try:
            now = self._stream_counters()
        except DeviceError:
            now = {}  # a camera that vanished reports nothing more; its totals stand
        for name, value in now.items():
            seen = self._stream_seen.get(name, 0)
            counted[name] = counted.get(name, 0) + max(value - seen, 0)
            self._stream_seen[name] = value
        self._counted = counted

    def health(self) -> dict[str, float]:
        self._fold()
        out: dict[str, float] = dict.fromkeys(self._offered(), 0)
        out.update(self._counted or {})
        out.update(self._gauges())
        return out

    def _gauges(self) -> dict[str, float]:
        """The temperature (the hottest place ``DeviceTemperatureSelector`` offers, the
        selector left as it was) and the link speed, where the camera has the nodes."""
        out: dict[str, float] = {}
        if self._has("DeviceTemperature"):
            places = self._symbolics("DeviceTemperatureSelector")
            readings = []
            if places:
                was = self._text("DeviceTemperatureSelector")
                for place in places:
                    try:
                        self._write("DeviceTemperatureSelector", place, "temperature")
                    except DeviceError:
                        continue
                    readings.append(self._read("DeviceTemperature"))
                if was in places:
                    with contextlib.suppress(DeviceError):
                        self._write("DeviceTemperatureSelector", was, "temperature")
            else:
                readings.append(self._read("DeviceTemperature"))
            finite = [r for r in readings if r is not None and math.isfinite(r)]
            if finite:
                out["temperature_c"] = max(finite)
        for node, scale in self._LINK_SPEED.items():
            speed = self._read(node) if self._has(node) else None
            if speed is not None and math.isfinite(speed) and speed > 0:
                out["link_speed_mbps"] = speed * scale
                break
        return out

    @abstractmethod
    def _execute(self, name: str) -> None:
        """Execute a command node (``TriggerSoftware``), a DeviceError if it fails."""

    @abstractmethod
    def _fetch(self, timeout_s: float) -> AbstractContextManager[Buffer | None]:
        """The next buffer, None after ``timeout_s``; the backend's buffer is handed back
        (re-queued) when the context ends, so its pixels are copied within it."""

    def _before_trigger(self) -> None:
        """Wait until the camera accepts a trigger, where the library can tell."""

    def trigger(self) -> int:
        self._start()
        self._before_trigger()
        sent = time.monotonic_ns()
        self._execute("TriggerSoftware")
        return sent

    def increments(self) -> dict[str, float]:
        steps = {}
        for label, names in (("exposure_us", self._EXPOSURE_NODES), ("gain_db", self._GAIN_NODES)):
            name = self._first(names)
            inc = self._increment(name) if name else None
            if inc is not None and inc > 1e-12:  # Aravis reports the smallest double for none
                steps[label] = float(inc)
        return steps

    def grab(self, n: int, *, timeout_s: float = 2.0) -> list[Frame]:
        self._start()
        exposure, gain = (
            self._read(name) if (name := self._first(names)) else None
            for names in (self._EXPOSURE_NODES, self._GAIN_NODES)
        )
        frames = []
        for k in range(n):
            with self._fetch(timeout_s) as buffer:
                if buffer is None:
                    raise FrameTimeout(
                        f"{self.name}: no frame within {timeout_s:g} s (frame {k + 1} of {n}); "
                        "check trigger mode, frame rate, exposure time, the cable and that the "
                        "camera is still powered"
                    )
                fmt = self._checked_format(buffer.pixel_format, buffer.reported)
                frames.append(
                    Frame(
                        data=self._decode(buffer, fmt),
                        frame_id=buffer.frame_id,
                        timestamp_ns=buffer.timestamp_ns,
                        exposure_us=exposure,
                        gain_db=gain,
                        pixel_format=fmt,
                        bit_depth=BIT_DEPTH[fmt],
                        device=self.name,
                        clock=buffer.clock,
                        extra={"chunk": buffer.chunk} if buffer.chunk else {},
                    )
                )
        return frames

    @staticmethod
    def _decode(buffer: Buffer, fmt: str) -> np.ndarray:
        """The buffer's pixels as an owned (H, W) array: copied, or unpacked from a packed
        format (before the backend re-queues the buffer)."""
        w, h, pixels = buffer.width, buffer.height, buffer.pixels
        if fmt in PACKED:
            return unpack(pixels.reshape(-1)[: packed_size(fmt, w * h)], fmt, w, h)
        if pixels.ndim == 2 and pixels.shape == (h, w):
            return pixels.copy()
        flat = pixels.reshape(-1)
        if flat.dtype == np.uint8 and fmt != "Mono8":  # 16-bit storage read as bytes
            return flat[: 2 * w * h].view("<u2").reshape(h, w).astype(np.uint16)
        return flat[: w * h].reshape(h, w).copy()

    def restart_stream(self) -> bool:
        """Stop and restart the acquisition, which drops every buffer queued or in flight.
        Started here, the first frame exposes while the capture finishes the last step."""
        self._stop()
        self._start()
        return True

    def configure(
        self,
        *,
        exposure_us: float | None = None,
        gain_db: float | None = None,
        pixel_format: str | None = None,
        region: tuple[int, int, int, int] | None = None,
    ) -> None:
        self._stop()  # Width/Height/PixelFormat are locked while acquiring
        if pixel_format is not None:
            offered = self._symbolics("PixelFormat")
            if pixel_format not in BIT_DEPTH or (offered and pixel_format not in offered):
                raise DeviceError(
                    f"{self.name}: pixel format {pixel_format} not offered as monochrome; "
                    f"it has {', '.join(offered) or 'none listed'}"
                )
            self._write("PixelFormat", pixel_format, "pixel_format")
            self._requested_format = pixel_format
        if region is not None:
            x, y, w, h = region  # offsets to 0 first: a larger size may not fit at them
            for node, size in (("OffsetX", 0), ("OffsetY", 0), ("Width", w), ("Height", h)):
                self._write(node, int(size), "region")
            self._write("OffsetX", int(x), "region")
            self._write("OffsetY", int(y), "region")
        for names, value, label in (
            (self._EXPOSURE_NODES, exposure_us, "exposure"),
            (self._GAIN_NODES, gain_db, "gain"),
        ):
            if value is not None:
                self._write(self._first(names) or names[0], float(value), label)

    def _arm_stream(self) -> None:
        """Settings of the data stream, where it has its own (buffer handling)."""

    def arm(
        self,
        acquisition: str,
        *,
        trigger_line: str | None = None,
        strobe_line: str | None = None,
        chunks: bool = False,
        trigger_delay_us: float = 0.0,
    ) -> None:
        self._stop()
        self._arm_nodes(
            acquisition,
            trigger_line=trigger_line,
            strobe_line=strobe_line,
            chunks=chunks,
            trigger_delay_us=trigger_delay_us,
        )
        self._arm_stream()
        self._chunked = bool(chunks)
        self._start()

    def _arm_nodes(
        self, acquisition, *, trigger_line, strobe_line, chunks, trigger_delay_us
    ) -> None:
        """The SFNC settings of :meth:`Grabber.arm`, in the order cameras accept them."""
        if "FrameStart" in self._symbolics("TriggerSelector"):
            self._write("TriggerSelector", "FrameStart", "trigger")
        triggered = acquisition != "free-run"
        if self._has("TriggerMode"):
            self._write("TriggerMode", "On" if triggered else "Off", "trigger")
        if triggered:
            self._write("TriggerSource", trigger_line or "Software", "trigger")
            if trigger_delay_us:
                delay = next((n for n in ("TriggerDelay", "TriggerDelayAbs") if self._has(n)), None)
                self._write(delay or "TriggerDelay", float(trigger_delay_us), "trigger")
        if strobe_line:
            self._write("LineSelector", strobe_line, "strobe")
            if self._has("LineMode"):
                self._write("LineMode", "Output", "strobe")
            self._write("LineSource", "ExposureActive", "strobe")
        if chunks:  # left as it is otherwise: some producers' chunk mode is fixed
            self._write("ChunkModeActive", True, "chunks")
            for name in self.features().chunks:
                self._write("ChunkSelector", name, "chunks")
                self._write("ChunkEnable", True, "chunks")
