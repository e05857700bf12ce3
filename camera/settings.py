"""The device settings a station file gives a camera and a light controller: the keys
every backend shares. A backend's own keys (which device, on which port) are in its
module, with its :class:`~inspect_validate.camera.registry.Backend`."""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import AfterValidator, Field, field_validator

from inspect_validate.config import StrictModel
from inspect_validate.constants import LONGEST_EXPOSURE_S

__all__ = [
    "AsciiProtocol",
    "CameraSettings",
    "Channel",
    "ControllerSettings",
    "Line",
    "Microseconds",
    "Pulse",
    "Seconds",
]

Seconds = Annotated[float, Field(gt=0, le=3600, allow_inf_nan=False)]
Channel = Annotated[int, Field(ge=1, le=64)]
Microseconds = Annotated[float, Field(ge=0, le=1e8, allow_inf_nan=False)]
Line = Annotated[str, Field(pattern=r"^Line[0-9]{1,2}$")]


# pyserial's URL schemes (serial.protocol_handler_packages) and which of them name a host.
_NETWORK_SCHEMES = {"socket", "rfc2217"}
_LOCAL_SCHEMES = {"loop", "spy", "alt", "hwgrep", "cp2110"}


def controller_address(text: str) -> str:
    """Check a controller's address: a serial port (``/dev/ttyUSB0``, ``COM3``) or a
    pyserial URL (``socket://host:port``, ``rfc2217://host:port``); returned as given.

    Raises
    ------
    ValueError
        What is wrong with it (no host, no port, a port outside 1–65535, an unknown
        URL scheme) and what to write instead.
    """
    from urllib.parse import urlsplit

    text = text.strip()
    if not text:
        raise ValueError("empty: give a serial port (/dev/ttyUSB0, COM3) or socket://host:port")
    if "://" not in text:
        return text
    scheme = text.split("://", 1)[0].lower()
    if scheme in _LOCAL_SCHEMES:
        return text
    if scheme not in _NETWORK_SCHEMES:
        raise ValueError(
            f"{text!r}: unknown URL scheme {scheme!r}: give a serial port (/dev/ttyUSB0, "
            "COM3) or socket://host:port (a controller on Ethernet)"
        )
    example = f"{scheme}://192.168.1.20:30313"
    parts = urlsplit(text)
    try:
        port = parts.port
    except ValueError:
        digits = parts.netloc.rsplit(":", 1)[-1]
        if digits.isdigit():
            raise ValueError(
                f"{text!r}: port {int(digits)} is out of range: a TCP port is 1–65535"
            ) from None
        raise ValueError(
            f"{text!r}: cannot read host:port after {scheme}:// (write {example}; an IPv6 "
            "host in brackets, [fe80::1]:30313)"
        ) from None
    if not parts.hostname:
        raise ValueError(f"{text!r}: no host: write {example}")
    if port is None:
        raise ValueError(f"{text!r}: no port: write {example} (Gardasoft listens on 30313)")
    if not 1 <= port <= 65535:
        raise ValueError(f"{text!r}: port {port} is out of range: a TCP port is 1–65535")
    if parts.path not in ("", "/"):
        raise ValueError(f"{text!r}: nothing may follow host:port but options (?…)")
    if scheme == "socket" and parts.query:
        name, _, level = parts.query.partition("=")
        if name != "logging" or level not in ("debug", "info", "warning", "error"):
            raise ValueError(
                f"{text!r}: the one option socket:// takes is ?logging=debug (or info, "
                "warning, error)"
            )
    return text


Port = Annotated[str, Field(min_length=1), AfterValidator(controller_address)]


class CameraSettings(StrictModel):
    """The keys every camera backend's section of a station file has: what it is set to
    and how its frames start (a backend adds the keys that choose its device)."""

    exposure_us: (
        Annotated[float, Field(gt=0, le=LONGEST_EXPOSURE_S * 1e6, allow_inf_nan=False)] | None
    ) = None
    """Exposure time set on the camera, µs (default: the camera's own)."""
    gain_db: Annotated[float, Field(ge=-60, le=100, allow_inf_nan=False)] | None = None
    """Analogue gain set on the camera, dB (default: the camera's own)."""
    pixel_format: str | None = None
    """A monochrome pixel format (``Mono8``, ``Mono12``, ``Mono16``…; default: the camera's)."""
    timeout_s: Seconds = 2.0
    """How long to wait for a frame before the camera counts as failed (exit 3)."""
    flush_frames: Annotated[int, Field(ge=0, le=1000)] = 4
    """Frames dropped after a switch by a camera that cannot restart its stream (V4L2,
    replay)."""
    acquisition: Literal["auto", "free-run", "software-trigger", "hardware-trigger"] = "auto"
    """How frames start (the user guide's "Real stations"); ``auto``: ``software-trigger`` where
    the camera has ``TriggerSoftware``, else ``free-run``."""
    settle_ms: Annotated[float, Field(ge=0, le=60_000, allow_inf_nan=False)] = 0.0
    """Triggered: wait this long after the controller confirms a switch, before the
    first trigger (a light that takes time to reach its level)."""
    trigger_line: Line | None = None
    """``hardware-trigger``: the input line the controller's trigger output drives."""
    trigger_delay_us: Microseconds = 0.0
    """``hardware-trigger``: the camera's ``TriggerDelay``, from the pulse to the exposure."""
    strobe_line: Line | None = None
    """The output line that carries ``ExposureActive`` to the controller's trigger
    input; the illuminations' channels then flash (``controller.pulse``)."""
    chunks: bool | None = None
    """Append exposure, gain, timestamp and frame id to every frame and check them;
    default: where the camera offers chunks. ``true`` refuses a camera without."""

    @field_validator("pixel_format")
    @classmethod
    def _mono(cls, v):
        from inspect_validate.camera.pixelformats import BIT_DEPTH

        if v is not None and v not in BIT_DEPTH:
            raise ValueError(f"{v!r} is not a monochrome format; use one of {', '.join(BIT_DEPTH)}")
        return v


_TEMPLATE_FIELDS = {
    "channel": 1,
    "percent": 50.0,
    "value": 50.0,
    "width_us": 100.0,
    "delay_us": 0.0,
}


class AsciiProtocol(StrictModel):
    """A generic ASCII controller's protocol (:mod:`inspect_validate.camera.controllers.generic`)."""

    commands: dict[Literal["set", "off", "pulse", "trigger", "status", "init"], str | list[str]]
    """Command templates with the fields ``{channel}``, ``{percent}``, ``{value}``,
    ``{width_us}``, ``{delay_us}``: ``set`` is required; ``init`` may be a list."""
    baudrate: int = Field(default=115200, gt=0)
    """Serial line speed (a TCP port ignores it)."""
    terminator: str = Field(default="\r", min_length=1)
    """Appended to every command sent."""
    reply_end: str = Field(default="\r\n", min_length=1)
    """What ends a reply."""
    ok: str | None = None
    """Regular expression a reply must match to be a success (default: any reply that is
    not an error)."""
    error: str = r"(?i)err\w*\s*(\d+)"
    """Regular expression of an error reply; its first group is the error code."""
    max_value: float = Field(default=100.0, gt=0)
    """The ``{value}`` sent for 100 % (``{value}`` = percent × max_value / 100)."""

    @field_validator("commands")
    @classmethod
    def _templates(cls, v):
        if "set" not in v:
            raise ValueError("a 'set' template is required, e.g. 'SET {channel} {value:.0f}'")
        for key, template in v.items():
            lines = [template] if isinstance(template, str) else template
            if key != "init" and not isinstance(template, str):
                raise ValueError(f"{key}: one command template, not a list")
            for line in lines:
                _check_template(key, line)
        return v

    @field_validator("terminator", "reply_end")
    @classmethod
    def _ascii(cls, v):
        if not v.isascii():
            raise ValueError(f"{v!r} is not ASCII (the controller's line is bytes of ASCII)")
        return v

    @field_validator("ok", "error")
    @classmethod
    def _regex(cls, v):
        if v is not None:
            _check_pattern(v)
        return v


#: The longest reply matched against a protocol's patterns, bytes.
REPLY_MAX = 4096


def _check_template(key: str, line: str) -> None:
    """A command template: ASCII, its fields the protocol's own, by name only, with a
    format spec of at most a few characters (``{percent:>1500000000}`` asked for 1.5 GB)."""
    import re
    import string

    fields = f"{{{'}, {'.join(_TEMPLATE_FIELDS)}}}"
    if not line.isascii():
        raise ValueError(f"{key}: template {line!r} is not ASCII (a controller reads ASCII)")
    try:
        parsed = list(string.Formatter().parse(line))
    except ValueError as exc:
        raise ValueError(
            f"{key}: template {line!r} does not parse ({exc}); fields are {fields}"
        ) from None
    for _, name, spec, conversion in parsed:
        if name is None:
            continue
        if name not in _TEMPLATE_FIELDS:
            raise ValueError(
                f"{key}: template {line!r} has the field {{{name}}}; fields are {fields}, "
                "by name (no index or attribute)"
            )
        widths = [int(n) for n in re.findall(r"\d+", spec or "")]
        if conversion or len(spec or "") > 12 or any(w > 64 for w in widths):
            raise ValueError(
                f"{key}: template {line!r}: the format of {{{name}}} is at most a width and "
                "a precision up to 64, e.g. {value:.0f} or {channel:02d}"
            )
    try:
        line.format(**_TEMPLATE_FIELDS)
    except (KeyError, IndexError, ValueError) as exc:
        raise ValueError(f"{key}: template {line!r} does not format ({exc})") from None


def _check_pattern(pattern: str) -> None:
    """A reply pattern: ASCII (replies are bytes), a valid expression, and no repeated
    group that repeats inside (``(a+)+``: backtracking that takes years on a reply of 40
    characters)."""
    import re

    if not pattern.isascii():
        raise ValueError(f"{pattern!r} is not ASCII (replies are matched as bytes)")
    try:
        re.compile(pattern.encode())
    except re.error as exc:
        raise ValueError(f"not a regular expression of bytes: {exc}") from None
    # A group that is one repeated atom, itself repeated: (a+)+, (\w*)*, ([a-z]{1,3})+.
    atom = r"(?:\\.|\[(?:\\.|[^\]])*\]|[^()\\|])"
    repeat = r"(?:[+*]|\{\d*,\d*\})"
    nested = re.search(rf"\((?:\?:)?{atom}{repeat}\){repeat}", pattern)
    if nested:
        raise ValueError(
            f"{nested.group(0)!r} repeats a group that repeats inside: on some replies the "
            "match backtracks for years; write it without the nested repetition "
            "(e.g. (a+)+ as a+)"
        )


class Pulse(StrictModel):
    """The controller's pulse (strobe) mode: Gardasoft ``RTc,width,delay,%``, the generic
    protocol's ``pulse`` template. Each trigger lights the channel ``width_us`` long,
    ``delay_us`` after the trigger."""

    width_us: Annotated[float, Field(gt=0, le=1e7, allow_inf_nan=False)]
    """How long each trigger lights the channel, µs."""
    delay_us: Microseconds = 0.0
    """From the trigger to the start of the light, µs."""
    max_duty: Annotated[float, Field(gt=0, le=1, allow_inf_nan=False)] = 1.0
    """The most the light may be on (width / trigger period; an overdriven LED's
    datasheet limit): the capture spaces triggers at least ``width_us / max_duty``."""
    trigger_channel: Channel = 1
    """``hardware-trigger``: the channel whose trigger (Gardasoft ``TRc``, the generic
    ``trigger`` template) fires the lights and, through the controller's trigger
    output, the camera's ``trigger_line``."""


class ControllerSettings(StrictModel):
    """The keys every light controller backend's section of a station file has (a backend
    adds the keys that reach its device)."""

    channels: Annotated[int, Field(ge=1, le=64)] = 4
    """How many output channels the controller has."""
    timeout_s: Seconds = 1.0
    """How long to wait for a reply before the controller counts as gone (exit 3)."""
    error_codes: dict[int, str] = {}
    """Meanings of the controller's error codes, shown in messages (``{21: over-current}``)."""
    pulse: Pulse | None = None
    """Strobe the lights instead of lighting them continuously."""
