"""LED controllers of any vendor that speak short ASCII commands over serial.

The station file gives the protocol (``controller.protocol``): command templates,
the terminator appended to commands, what ends a reply, and regular expressions
for success and error replies. Templates are Python format strings with the
fields ``{channel}``, ``{percent}`` (0–100) and ``{value}`` (the intensity in the
controller's own units: ``percent / 100 * max_value``), plus ``{width_us}`` and
``{delay_us}`` for pulses; ``trigger`` fires a channel once (hardware-triggered
stations). Example, for a controller taking 8-bit levels::

    controller:
      backend: generic
      port: /dev/ttyUSB0
      channels: 4
      protocol:
        baudrate: 9600
        terminator: "\\n"
        reply_end: "\\r\\n"
        ok: "^OK"
        error: "ERROR (?P<code>\\\\d+)"
        max_value: 255
        commands:
          set: "SET {channel} {value:.0f}"
          off: "OFF {channel}"
          status: "STATUS?"
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any, Literal

from inspect_validate.camera.controllers.base import LedController
from inspect_validate.camera.controllers.gardasoft import SerialAscii
from inspect_validate.camera.registry import Backend, Opening
from inspect_validate.camera.settings import AsciiProtocol, ControllerSettings, Port
from inspect_validate.errors import DeviceError

__all__ = ["BACKEND", "GenericAsciiController", "GenericSettings", "protocol_controller"]


class GenericAsciiController(LedController):
    """A controller driven by command templates from the station file.

    Parameters
    ----------
    port : str
        Serial device.
    commands : mapping
        ``set`` (required), and optionally ``off`` (used for 0 %), ``pulse``,
        ``status`` and ``init`` (a list sent once after opening, e.g. to enter
        remote mode).
    channels : int
        Output channels, numbered from 1.
    max_value : float
        The controller's value for 100 %.
    baudrate, terminator, reply_end, ok, error, timeout, error_codes
        As for :class:`~camera.controllers.gardasoft.SerialAscii`.
    """

    def __init__(
        self,
        port: str,
        *,
        commands: Mapping[str, str | Sequence[str]] | Mapping[Any, str | list[str]],
        channels: int = 4,
        max_value: float = 100.0,
        baudrate: int = 115200,
        terminator: bytes = b"\r",
        reply_end: bytes = b"\r\n",
        ok: bytes | None = None,
        error: bytes = rb"(?i)err\w*\s*(\d+)",
        timeout: float = 1.0,
        error_codes: dict[int, str] | None = None,
    ) -> None:
        if "set" not in commands:
            raise DeviceError(f"controller on {port}: the protocol needs a 'set' command template")
        self.name = f"ASCII controller on {port}"
        self.channels = channels
        self.commands = dict(commands)
        self.max_value = float(max_value)
        self.link = SerialAscii(
            port,
            baudrate=baudrate,
            terminator=terminator,
            reply_end=reply_end,
            ok=ok,
            error=error,
            timeout=timeout,
            error_codes=error_codes,
        )
        try:
            init = self.commands.get("init", ())
            for line in [init] if isinstance(init, str) else init:
                self.link.query(line)
        except DeviceError:
            self.link.close()
            raise

    def _send(self, template: str, channel: int, percent: float, **extra) -> str:
        self.check(channel, percent)
        command = template.format(
            channel=channel, percent=percent, value=percent / 100 * self.max_value, **extra
        )
        return self.link.query(command)

    def _template(self, key: str) -> str:
        """One command's template (only ``init`` may be a list)."""
        template = self.commands[key]
        assert isinstance(template, str)
        return template

    def set_intensity(self, channel: int, percent: float) -> None:
        key = "off" if percent == 0 and "off" in self.commands else "set"
        self._send(self._template(key), channel, percent)

    def pulse(self, channel: int, *, width_us: float, delay_us: float, percent: float) -> None:
        if "pulse" not in self.commands:
            raise DeviceError(f"{self.name}: the station file gives no 'pulse' command template")
        self._send(self._template("pulse"), channel, percent, width_us=width_us, delay_us=delay_us)

    def trigger(self, channel: int) -> None:
        if "trigger" not in self.commands:
            raise DeviceError(f"{self.name}: the station file gives no 'trigger' command template")
        self._send(self._template("trigger"), channel, 0.0)

    def status(self) -> str:
        return self.link.query(self._template("status")) if "status" in self.commands else ""

    def close(self) -> None:
        self.link.close()


class GenericSettings(ControllerSettings):
    """Any controller that speaks lines of ASCII, described by ``protocol``."""

    backend: Literal["generic"]
    """Any controller that takes ASCII commands, described by ``protocol``."""
    port: Port
    """Serial port (``/dev/ttyUSB0``, ``COM3``) or a pyserial URL (``socket://host:port`` on
    Ethernet)."""
    protocol: AsciiProtocol
    """The command templates and reply patterns."""


def protocol_controller(
    port: str, protocol: AsciiProtocol, settings: ControllerSettings
) -> GenericAsciiController:
    """A :class:`GenericAsciiController` on ``port`` speaking ``protocol``, with the
    channels, timeout and error codes of ``settings``."""
    return GenericAsciiController(
        port,
        commands=protocol.commands,
        channels=settings.channels,
        max_value=protocol.max_value,
        baudrate=protocol.baudrate,
        terminator=protocol.terminator.encode(),
        reply_end=protocol.reply_end.encode(),
        ok=protocol.ok.encode() if protocol.ok is not None else None,
        error=protocol.error.encode(),
        timeout=settings.timeout_s,
        error_codes=settings.error_codes,
    )


def open_generic(settings: GenericSettings, opening: Opening) -> GenericAsciiController:
    return protocol_controller(settings.port, settings.protocol, settings)


BACKEND = Backend("generic", GenericSettings, open_generic)
