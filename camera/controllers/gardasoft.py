"""Gardasoft RT-series LED controllers over RS232 or Ethernet (pyserial).

Protocol (RT-series user manual, "Command configuration"): 115200 baud 8N1, no
handshake; Ethernet models take the same command lines on TCP port 30313, which
pyserial opens from a URL (``port: socket://192.168.1.20:30313``). A command line
ends with CR; several commands may be joined by ``;``;
the controller's reply ends with ``>`` once the command line is done, and
contains ``Err n`` when a command failed. Commands used here:

=========  =======================================================
``RSc,s``  channel c continuous at s % (0 switches it off)
``RTc,p,d,s``  pulse mode: width p after delay d at s % (times in ms unless
           suffixed: sent as ``…us``)
``TRc``    simulate a trigger on channel c
``ST``     status report
``VR``     firmware version
=========  =======================================================

The meanings of ``Err`` codes differ between firmware versions; the message
always shows the code, the command and the port, and names a meaning only where
the station file's ``error_codes`` gives one.
"""

from __future__ import annotations

import re
import time
from typing import Literal

from inspect_validate.camera.controllers.base import LedController
from inspect_validate.camera.registry import Backend, Opening
from inspect_validate.camera.settings import REPLY_MAX, ControllerSettings, Port
from inspect_validate.errors import DeviceError

__all__ = ["BACKEND", "GardasoftController", "GardasoftSettings", "SerialAscii"]

_ERR = re.compile(rb"Err\s*(\d+)")

try:  # a vanished pseudo-terminal or USB adapter raises termios.error, not OSError
    import termios

    _PORT_ERRORS: tuple[type[BaseException], ...] = (OSError, termios.error)
except ImportError:  # Windows
    _PORT_ERRORS = (OSError,)


class SerialAscii:
    """A line-oriented ASCII link: send a command, read until the reply is complete.

    Parameters
    ----------
    port : str
        Serial device (``/dev/ttyUSB0``, ``COM3``, a pseudo-terminal path) or a
        pyserial URL: ``socket://host:port`` for a controller on Ethernet (the
        baud rate is then ignored).
    baudrate : int
    terminator : bytes
        Appended to every command.
    reply_end : bytes
        Ends a complete reply: a prompt such as ``b">"`` (trailing whitespace
        ignored) or a line ending such as ``b"\\r\\n"``.
    ok : bytes, optional
        Regular expression a successful reply must match; without it any reply
        that does not match ``error`` is success.
    error : bytes
        Regular expression of an error reply; its group ``code`` (or first
        group) is the error number looked up in ``error_codes``.
    timeout : float
        Seconds to wait for a complete reply.
    error_codes : dict, optional
        Error number → meaning, shown in messages.
    """

    def __init__(
        self,
        port: str,
        *,
        baudrate: int = 115200,
        terminator: bytes = b"\r",
        reply_end: bytes = b">",
        ok: bytes | None = None,
        error: bytes = rb"Err\s*(\d+)",
        timeout: float = 1.0,
        error_codes: dict[int, str] | None = None,
    ) -> None:
        import serial

        self.port = port
        self.terminator, self.reply_end, self.timeout = terminator, reply_end, timeout
        self.ok = re.compile(ok) if ok is not None else None
        self.error = re.compile(error)
        self.error_codes = error_codes or {}
        try:
            # serial_for_url opens a device path as serial.Serial would, and a URL
            # (socket://host:port) as a TCP connection with the same read/write calls.
            self._serial = serial.serial_for_url(
                port, baudrate=baudrate, timeout=0.05, write_timeout=timeout
            )
        except (serial.SerialException, ValueError, *_PORT_ERRORS) as exc:
            what = (
                "cannot connect to the controller; check its IP address, that it is on the "
                "network and that port 30313 (Gardasoft) or the one given is the controller's"
                if "://" in port
                else "cannot open the controller's serial port; check the port name and that "
                "no other program holds it"
            )
            raise DeviceError(f"{port}: {what} ({exc})") from None
        self._serial.reset_input_buffer()

    def _complete(self, reply: bytes) -> bool:
        end = self.reply_end
        if end.strip():  # a prompt character
            return reply.rstrip().endswith(end.strip())
        return bool(reply.strip()) and reply.endswith(end)  # a line ending; skip blank lines

    def query(self, command: str) -> str:
        """Send ``command`` and return the reply text (without the prompt)."""
        import serial

        try:
            self._serial.reset_input_buffer()  # drop anything stale before a new command
            self._serial.write(command.encode("ascii") + self.terminator)
            reply = bytearray()
            deadline = time.monotonic() + self.timeout
            while time.monotonic() < deadline:
                # What has arrived, or wait for one byte: a fixed-size read would sit out
                # the port's whole 50 ms timeout on every short reply.
                reply += self._serial.read(self._serial.in_waiting or 1)
                # Bounded before it is complete: the same reply is refused however it
                # arrives (in one read or in many).
                if len(reply) > REPLY_MAX:
                    raise DeviceError(
                        f"{self.port}: the reply to {command!r} runs past {REPLY_MAX} bytes "
                        f"without {self.reply_end.decode()!r} ({bytes(reply[:60])!r}…); check the "
                        "baud rate, reply_end and that this is the right device"
                    )
                if self._complete(bytes(reply)):
                    break
            else:
                if reply:
                    raise DeviceError(
                        f"{self.port}: unexpected reply {bytes(reply[:60])!r} to {command!r} (no {self.reply_end.decode()!r} within "
                        f"{self.timeout:g} s); check the baud rate and that this is the right device"
                    )
                raise DeviceError(
                    f"{self.port}: no answer to {command!r} within {self.timeout:g} s; check the cable, the port and that the controller is powered"
                )
        except (serial.SerialException, *_PORT_ERRORS) as exc:
            lost = (
                "the network connection was lost"
                if "://" in self.port
                else "the device may have been unplugged"
            )
            raise DeviceError(
                f"{self.port}: the connection failed while sending {command!r} ({exc}); {lost}"
            ) from None
        text = bytes(reply).strip()
        if self.reply_end.strip():
            text = text[: -len(self.reply_end.strip())].rstrip()
        m = self.error.search(text)
        if m:
            code = m.groupdict().get("code") or (m.group(1) if self.error.groups else None)
            said = shown_text(m.group(0).strip())  # device text: its control characters escaped
            if code is not None and code.isdigit() and len(code) <= 9:
                meaning = (
                    f" ({self.error_codes[int(code)]})" if int(code) in self.error_codes else ""
                )
                what = f"'{said}'{meaning}"
            else:
                what = f"'{said}'"
            raise DeviceError(
                f"{self.port}: controller answered {what} to {command!r}; check the channel number and the value's range for this model"
            )
        if self.ok is not None and not self.ok.search(text):
            raise DeviceError(
                f"{self.port}: reply {bytes(text[:60])!r} to {command!r} is neither success ({self.ok.pattern.decode()!r}) nor an error; "
                "check the station file's controller.protocol patterns against the controller's manual"
            )
        try:
            return text.decode("ascii").strip()
        except UnicodeDecodeError:
            raise DeviceError(
                f"{self.port}: reply to {command!r} is not ASCII ({bytes(text[:40])!r}); check the baud rate"
            ) from None

    def close(self) -> None:
        try:
            self._serial.close()
        except _PORT_ERRORS:
            pass


def shown_text(text: bytes, most: int = 80) -> str:
    """Device text as it may be printed: printable ASCII as it is, anything else (a
    terminal's escape codes, a bell) escaped, at most ``most`` bytes."""
    cut = text[:most]
    shown = "".join(chr(b) if 32 <= b < 127 else f"\\x{b:02x}" for b in cut)
    return shown + ("…" if len(text) > most else "")


class GardasoftController(LedController):
    """A Gardasoft RT-series controller on a serial port."""

    def __init__(
        self,
        port: str,
        *,
        channels: int = 4,
        timeout: float = 1.0,
        error_codes: dict[int, str] | None = None,
    ) -> None:
        self.name = f"Gardasoft RT on {port}"
        self.channels = channels
        self.link = SerialAscii(port, timeout=timeout, error_codes=error_codes)

    def set_intensity(self, channel: int, percent: float) -> None:
        self.check(channel, percent)
        self.link.query(f"RS{channel},{percent:g}")

    def pulse(self, channel: int, *, width_us: float, delay_us: float, percent: float) -> None:
        self.check(channel, percent)
        # The RT series reads a bare time as milliseconds: the unit goes with the number.
        self.link.query(f"RT{channel},{width_us:g}us,{delay_us:g}us,{percent:g}")

    def trigger(self, channel: int) -> None:
        self.check(channel)
        self.link.query(f"TR{channel}")

    def status(self) -> str:
        return self.link.query("ST")

    def version(self) -> str:
        return self.link.query("VR")

    def close(self) -> None:
        self.link.close()


class GardasoftSettings(ControllerSettings):
    """A Gardasoft RT-series controller."""

    backend: Literal["gardasoft"]
    """A Gardasoft LED controller, by its serial or Ethernet command set."""
    port: Port
    """Serial port (``/dev/ttyUSB0``, ``COM3``) or a pyserial URL (``socket://host:port`` on
    Ethernet)."""


def open_gardasoft(settings: GardasoftSettings, opening: Opening) -> GardasoftController:
    return GardasoftController(
        settings.port,
        channels=settings.channels,
        timeout=settings.timeout_s,
        error_codes=settings.error_codes,
    )


BACKEND = Backend("gardasoft", GardasoftSettings, open_gardasoft)
