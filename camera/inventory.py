"""What this machine can reach: the cameras each installed backend sees, what a camera
offers, the serial ports, and which of them answer as a light controller
(``inspect-validate devices``).

Nothing here changes a device's settings. Opening a camera to read its features takes
it for the moment it is read (a camera another program holds cannot be read); probing a
port sends it an identification query (Gardasoft ``VR``) or a protocol's ``init`` and
``status`` commands, so ports are probed only when asked.
"""

from __future__ import annotations

import contextlib
import warnings
from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path

from inspect_validate.camera.controllers.gardasoft import GardasoftController, shown_text
from inspect_validate.camera.controllers.generic import protocol_controller
from inspect_validate.camera.grabbers.base import DeviceInfo, Features, Grabber
from inspect_validate.camera.registry import Opening, Search, backend, backends, broken
from inspect_validate.camera.settings import AsciiProtocol, ControllerSettings
from inspect_validate.errors import DeviceError, InputError

__all__ = [
    "Inventory",
    "SerialPort",
    "find_ports",
    "port_problem",
    "probe_port",
    "read_features",
    "take_inventory",
]


@dataclass(frozen=True)
class SerialPort:
    """A serial port (or a controller's TCP address) and what answered on it.

    Attributes
    ----------
    device : str
        The port (``/dev/ttyUSB0``, ``COM3``) or a pyserial URL (``socket://host:port``).
    description, hardware_id, serial : str
        What the operating system says of it (a USB adapter's name, VID:PID, serial).
    answer : str
        What answered a probe (``Gardasoft RT: <firmware>``), device text with its
        control characters escaped; "" where nothing did or the port was not probed.
    probed : bool
    problem : str
        Why the port cannot be a controller's, where that is known without asking (no
        such device, a folder, a regular file); it is then not probed.
    """

    device: str
    description: str = ""
    hardware_id: str = ""
    serial: str = ""
    answer: str = ""
    probed: bool = False
    problem: str = ""


def port_problem(port: str) -> str:
    """Why ``port`` cannot be a serial port, as far as the file system tells; "" where it
    may be one (a character device, or a URL, whose connection tells)."""
    import os
    import stat

    if "://" in port:
        return ""
    try:
        mode = os.stat(port).st_mode
    except FileNotFoundError:
        return "no such device"
    except OSError as exc:
        return exc.strerror or str(exc)
    if stat.S_ISDIR(mode):
        return "a folder, not a serial port"
    if not stat.S_ISCHR(mode):
        return "not a device (a serial port is a character device)"
    return ""


@dataclass(frozen=True)
class Inventory:
    """The devices found, and why a backend could not look.

    Attributes
    ----------
    cameras : tuple of DeviceInfo
    unavailable : dict
        Camera backend → why it could not look (its library missing: what to install;
        a plugin that does not load).
    ports : tuple of SerialPort
    without_discovery : tuple of str
        Installed camera backends with nothing to discover (replay, simulated).
    """

    cameras: tuple[DeviceInfo, ...]
    unavailable: dict[str, str] = field(default_factory=dict)
    ports: tuple[SerialPort, ...] = ()
    without_discovery: tuple[str, ...] = ()


def take_inventory(
    search: Search | None = None,
    *,
    only: Iterable[str] | None = None,
    ports: Iterable[str] = (),
    probe: bool = False,
    protocol: AsciiProtocol | None = None,
    timeout_s: float = 0.5,
) -> Inventory:
    """Every camera each installed camera backend can see now, and the serial ports.

    Parameters
    ----------
    search : Search, optional
        Where to look (a GenTL producer; default: where each backend looks by itself).
    only : iterable of str, optional
        The camera backends to ask (default: every installed one).
    ports, probe, protocol, timeout_s
        As for :func:`find_ports`.
    """
    cameras, unavailable, without = _cameras(search or Search(), only)
    found = find_ports(ports, probe=probe, protocol=protocol, timeout_s=timeout_s)
    return Inventory(tuple(cameras), unavailable, tuple(found), tuple(without))


def _cameras(
    search: Search, only: Iterable[str] | None
) -> tuple[list[DeviceInfo], dict[str, str], list[str]]:
    installed = backends("cameras")
    names = list(installed) if only is None else list(only)
    cameras: list[DeviceInfo] = []
    unavailable: dict[str, str] = {}
    without: list[str] = []
    for name in names:
        if name in broken("cameras"):
            unavailable[name] = broken("cameras")[name]
            continue
        backend("cameras", name, source="--backend")  # a name not installed: listed
        discover = installed[name].discover
        if discover is None:
            without.append(name)
            continue
        try:
            with warnings.catch_warnings():  # SWIG bindings warn on import, to no user's use
                warnings.simplefilter("ignore", DeprecationWarning)
                cameras += discover(search)
        except DeviceError as exc:  # its library missing, no producer: say what to do
            unavailable[name] = str(exc)
        except Exception as exc:  # a vendor library failing must not hide the others
            unavailable[name] = f"discovery failed ({type(exc).__name__}: {exc})"
    return cameras, unavailable, without


def read_features(info: DeviceInfo) -> Features:
    """What the found camera ``info`` offers, read from it (it is opened, read and
    closed; nothing is set).

    Raises
    ------
    DeviceError
        It cannot be opened (another program holds it, it vanished).
    """
    chosen = backend("cameras", info.backend)
    settings = chosen.settings.model_validate({"backend": info.backend, **chosen.device_keys(info)})
    with chosen.open(settings, Opening(source="devices", base=Path.cwd())) as grabber:
        assert isinstance(grabber, Grabber)
        return grabber.features()


def find_ports(
    extra: Iterable[str] = (),
    *,
    probe: bool = False,
    protocol: AsciiProtocol | None = None,
    timeout_s: float = 0.5,
) -> list[SerialPort]:
    """The serial ports the operating system lists (pyserial), plus ``extra`` ones
    (a pseudo-terminal, ``socket://host:port``), each probed where ``probe`` asks."""
    from serial.tools import list_ports

    ports = [
        SerialPort(
            p.device,
            description="" if p.description in ("n/a", p.device) else p.description,
            hardware_id="" if p.hwid == "n/a" else p.hwid,
            serial=p.serial_number or "",
        )
        for p in sorted(list_ports.comports(), key=lambda p: p.device)
    ]
    listed = {p.device for p in ports}
    ports += [SerialPort(d, problem=port_problem(d)) for d in extra if d not in listed]
    if not probe:
        return ports
    return [
        SerialPort(
            p.device,
            p.description,
            p.hardware_id,
            p.serial,
            answer=""
            if p.problem
            else probe_port(p.device, protocol=protocol, timeout_s=timeout_s),
            probed=not p.problem,
            problem=p.problem,
        )
        for p in ports
    ]


def probe_port(port: str, *, protocol: AsciiProtocol | None = None, timeout_s: float = 0.5) -> str:
    """What answers on ``port``: a controller speaking ``protocol`` (its ``init`` and
    ``status`` commands), else a Gardasoft RT controller (asked its firmware version).
    The given protocol goes first: a line-based controller would read the Gardasoft query
    left in its buffer as the start of its next command. "" where neither answers; never
    raises for a port that does not answer."""
    refused = ""  # a controller that answered, with an error (Err 999), is no silence
    if protocol is not None:
        if "status" not in protocol.commands and not protocol.commands.get("init"):
            raise InputError(
                "the protocol has neither a 'status' nor an 'init' command: nothing to probe "
                "with; add the controller's status query",
                source="--protocol",
            )
        try:
            with protocol_controller(port, protocol, ControllerSettings(timeout_s=timeout_s)) as c:
                return f"ASCII protocol: {shown_text((c.status() or 'answers').encode())}"
        except DeviceError as exc:
            refused = _error_answer(exc, port)
    try:
        with GardasoftController(port, timeout=timeout_s) as gardasoft:
            if protocol is not None:
                # End the other protocol's command line left unanswered in its buffer.
                with contextlib.suppress(DeviceError):
                    gardasoft.link.query("")
            return f"Gardasoft RT: {shown_text((gardasoft.version() or 'answers').encode())}"
    except DeviceError as exc:
        return _error_answer(exc, port) or refused


def _error_answer(exc: DeviceError, port: str) -> str:
    """What a port said when it answered a probe with an error or another reply (the
    error's text, less the port it names); "" where nothing answered."""
    text = str(exc).removeprefix(f"{port}: ")
    if text.startswith("controller answered") or "reply" in text:
        return f"answers, with an error: {text}"
    return ""
