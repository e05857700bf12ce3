"""The grabber interface shared by every camera backend."""

from __future__ import annotations

from abc import ABC, abstractmethod
from dataclasses import dataclass

from inspect_validate.camera.frame import Frame
from inspect_validate.camera.pixelformats import BIT_DEPTH

from inspect_validate.errors import DeviceError

__all__ = ["ACQUISITIONS", "Features", "Grabber", "NodeMapGrabber"]

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
    """

    software_trigger: bool = False
    trigger_lines: tuple[str, ...] = ()
    strobe_lines: tuple[str, ...] = ()
    chunks: tuple[str, ...] = ()


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

    def close(self) -> None:  # noqa: B027 - optional for backends without a connection
        """Release the device."""

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


class NodeMapGrabber(Grabber):
    """A camera with a GenICam node map: its triggers, lines and chunks are found and set
    by their SFNC names the same way whatever reaches them (harvesters, pylon, Aravis).

    A backend gives three small accessors — :meth:`_has`, :meth:`_symbolics` and
    :meth:`_write` — and :meth:`_stop` and :meth:`_start` for its acquisition.
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

    def features(self) -> Features:
        sources = self._symbolics("TriggerSource")
        strobe = ()
        if "ExposureActive" in self._symbolics("LineSource"):
            strobe = self._symbolics("LineSelector")
        chunks = ()
        if self._has("ChunkModeActive"):
            offered = self._symbolics("ChunkSelector")
            chunks = tuple(c for c in self._CHUNKS if c in offered)
        software = self._has("TriggerMode") and self._has("TriggerSoftware")
        return Features(
            # A producer whose TriggerSource lists nothing (TLSimu) still triggers by software.
            software_trigger=software and (not sources or "Software" in sources),
            trigger_lines=tuple(s for s in sources if s.startswith("Line")),
            strobe_lines=strobe,
            chunks=chunks,
        )

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

    def restart_stream(self) -> bool:
        """Stop and restart the acquisition, which drops every buffer queued or in flight.
        Started here, the first frame exposes while the capture finishes the last step."""
        self._stop()
        self._start()
        return True

    def configure(self, *, exposure_us=None, gain_db=None, pixel_format=None, region=None) -> None:
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
            for node, value in (("OffsetX", 0), ("OffsetY", 0), ("Width", w), ("Height", h)):
                self._write(node, int(value), "region")
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
        acquisition,
        *,
        trigger_line=None,
        strobe_line=None,
        chunks=False,
        trigger_delay_us=0.0,
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
