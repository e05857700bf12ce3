"""Gardasoft RT-series LED controllers over RS232 (pyserial).

Protocol (RT-series user manual, "Command configuration"): 115200 baud 8N1, no
handshake; a command line ends with CR; several commands may be joined by ``;``;
the controller's reply ends with ``>`` once the command line is done, and
contains ``Err n`` when a command failed. Commands used here:

=========  =======================================================
``RSc,s``  channel c continuous at s % (0 switches it off)
``RTc,p,d,s``  pulse mode: width p µs after delay d µs at s %
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

from camera.lights.base import LedController
from inspect_validate.errors import DeviceError

__all__ = ["GardasoftController", "SerialAscii"]

_ERR = re.compile(rb"Err\s*(\d+)")

try:  # a vanished pseudo-terminal or USB adapter raises termios.error, not OSError
    import termios

    _PORT_ERRORS: tuple[type[BaseException], ...] = (OSError, termios.error)
except ImportError:  # Windows
    _PORT_ERRORS = (OSError,)


class SerialAscii:
    """A line-oriented ASCII link: send a command, read until the prompt or an error.

    Parameters
    ----------
    port : str
        Serial device (``/dev/ttyUSB0``, ``COM3``, a pseudo-terminal path).
    terminator : bytes
        Appended to every command.
    prompt : bytes
        Ends a complete reply.
    timeout : float
        Seconds to wait for the prompt.
    """

    def __init__(
        self,
        port: str,
        *,
        baudrate: int = 115200,
        terminator: bytes = b"\r",
        prompt: bytes = b">",
        timeout: float = 1.0,
        error_codes: dict[int, str] | None = None,
    ):
        import serial

        self.port = port
        self.terminator, self.prompt, self.timeout = terminator, prompt, timeout
        self.error_codes = error_codes or {}
        try:
            self._serial = serial.Serial(
                port, baudrate=baudrate, timeout=0.05, write_timeout=timeout
            )
        except (serial.SerialException, *_PORT_ERRORS) as exc:
            raise DeviceError(
                f"{port}: cannot open the controller's serial port ({exc}); check the port name and that no other program holds it"
            ) from None
        self._serial.reset_input_buffer()

    def query(self, command: str) -> str:
        """Send ``command`` and return the reply text before the prompt."""
        import serial

        try:
            self._serial.reset_input_buffer()  # drop anything stale before a new command
            self._serial.write(command.encode("ascii") + self.terminator)
            reply = bytearray()
            deadline = time.monotonic() + self.timeout
            while time.monotonic() < deadline:
                reply += self._serial.read(256)
                if reply.rstrip().endswith(self.prompt):
                    break
            else:
                if reply:
                    raise DeviceError(
                        f"{self.port}: unexpected reply {bytes(reply[:60])!r} to {command!r} (no {self.prompt.decode()!r} within "
                        f"{self.timeout:g} s); check the baud rate and that this is the right device"
                    )
                raise DeviceError(
                    f"{self.port}: no answer to {command!r} within {self.timeout:g} s; check the cable, the port and that the controller is powered"
                )
        except (serial.SerialException, *_PORT_ERRORS) as exc:
            raise DeviceError(
                f"{self.port}: the connection failed while sending {command!r} ({exc}); the device may have been unplugged"
            ) from None
        text = bytes(reply).rstrip()[: -len(self.prompt)]
        m = _ERR.search(text)
        if m:
            code = int(m.group(1))
            meaning = f" ({self.error_codes[code]})" if code in self.error_codes else ""
            raise DeviceError(
                f"{self.port}: controller answered 'Err {code}'{meaning} to {command!r}; check the channel number and the value's range for this model"
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


class GardasoftController(LedController):
    """A Gardasoft RT-series controller on a serial port."""

    def __init__(
        self,
        port: str,
        *,
        channels: int = 4,
        timeout: float = 1.0,
        error_codes: dict[int, str] | None = None,
    ):
        self.name = f"Gardasoft RT on {port}"
        self.channels = channels
        self.link = SerialAscii(port, timeout=timeout, error_codes=error_codes)

    def _check(self, channel: int, percent: float | None = None):
        if not 1 <= channel <= self.channels:
            raise DeviceError(f"{self.name}: channel {channel} does not exist (1–{self.channels})")
        if percent is not None and not 0 <= percent <= 100:
            raise DeviceError(f"{self.name}: intensity {percent:g} % is outside 0–100 %")

    def set_intensity(self, channel: int, percent: float) -> None:
        self._check(channel, percent)
        self.link.query(f"RS{channel},{percent:g}")

    def pulse(self, channel: int, *, width_us: float, delay_us: float, percent: float) -> None:
        self._check(channel, percent)
        self.link.query(f"RT{channel},{width_us:g},{delay_us:g},{percent:g}")

    def trigger(self, channel: int) -> None:
        self._check(channel)
        self.link.query(f"TR{channel}")

    def status(self) -> str:
        return self.link.query("ST")

    def version(self) -> str:
        return self.link.query("VR")

    def close(self) -> None:
        self.link.close()
