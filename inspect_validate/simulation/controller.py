"""A simulated Gardasoft RT controller: a separate process on a pseudo-terminal.

Code under test opens the printed device path with pyserial exactly as it would
open ``/dev/ttyUSB0``; this process answers in the RT protocol
(:mod:`inspect_validate.camera.controllers.gardasoft`) and writes the channel state to a JSON file
(atomically, on every change) that the simulated camera reads to know which
light is on.

Run: ``python -m inspect_validate.simulation.controller --state STATE.json [--channels 4]``;
the first line on stdout is the device path. Faults for tests:

* ``--error CMD:CODE``: answer ``Err CODE`` to commands starting with CMD
  (e.g. ``RS3:3``), repeatable;
* ``--slow SECONDS``: answer late;
* ``--mute-after N``: stop answering after N command lines;
* ``--garbage-after N``: answer with non-ASCII bytes and no prompt after N;
* ``--vanish-after N``: exit (the port disappears) after N command lines;
* ``--drop-after N``: with ``--tcp``, close the connection after N command lines
  and wait for the next (a network glitch; the controller itself stays up).

``--tcp [PORT]`` listens on 127.0.0.1 instead of a pseudo-terminal, as an
Ethernet controller does on its port (Gardasoft: 30313; default here: a free
one), and prints ``socket://127.0.0.1:PORT``, the URL pyserial opens. One
connection at a time; when it closes the controller waits for the next, keeping
its channel state.

Its own error codes: 1 unknown command, 2 malformed parameters, 3 value out of range.

``--dialect line`` speaks a second, line-based protocol instead (for the generic
ASCII controller, :mod:`inspect_validate.camera.controllers.generic`): ``SET c v`` with v in 0–255,
``OFF c``, ``STATUS?``; lines end with LF, replies are ``OK`` or
``ERROR n: text`` ended by CR LF.
"""

from __future__ import annotations

import argparse
import json
import os
import socket
import sys
import time
import tty
from collections.abc import Sequence
from pathlib import Path

UNKNOWN, MALFORMED, RANGE = 1, 2, 3
_TIME_UNITS_US = {"US": 1.0, "MS": 1e3, "S": 1e6, "": 1e3}  # RT series: a bare time is ms


def _time_us(arg: str) -> float:
    """A time parameter of the RT protocol (``200us``, ``0.1``, ``0.1s``) in µs."""
    number = arg.rstrip("USM")
    return float(number) * _TIME_UNITS_US[arg[len(number) :]]


class Controller:
    def __init__(self, channels: int, state_path: Path, errors: dict[str, int]) -> None:
        self.channels = channels
        self.state_path = state_path
        self.errors = errors
        self.level = dict.fromkeys(range(1, channels + 1), 0.0)
        self.mode = dict.fromkeys(range(1, channels + 1), "continuous")
        self.pulse: dict[int, list[float]] = {}  # channel → [width µs, delay µs]
        self.triggers = 0  # TR commands so far: a hardware-triggered camera exposes on each
        self.sequence = 0
        self.save()

    def save(self) -> None:
        self.sequence += 1
        doc = {
            "channels": {str(c): v for c, v in self.level.items()},
            "mode": {str(c): m for c, m in self.mode.items()},
            "pulse": {str(c): p for c, p in self.pulse.items()},
            "triggers": self.triggers,
            "sequence": self.sequence,
            "time_ns": time.time_ns(),
        }
        tmp = self.state_path.with_suffix(".tmp")
        tmp.write_text(json.dumps(doc))
        os.replace(tmp, self.state_path)

    def command(self, text: str) -> str:
        cmd = text.strip().upper()
        for prefix, code in self.errors.items():
            if cmd.startswith(prefix):
                return f"Err {code}"
        head, args = cmd[:2], cmd[2:]
        try:
            if head == "RT":  # width and delay are times with optional units
                raw = args.split(",")
                if len(raw) != 4:
                    return f"Err {MALFORMED}"
                values = [float(raw[0]), _time_us(raw[1]), _time_us(raw[2]), float(raw[3])]
            else:
                values = [float(a) for a in args.split(",")] if args else []
        except (ValueError, KeyError):
            return f"Err {MALFORMED}"
        if head in ("RS", "RW"):
            if len(values) != 2:
                return f"Err {MALFORMED}"
            ch, pct = int(values[0]), values[1]
            if ch not in self.level or not 0 <= pct <= 100:
                return f"Err {RANGE}"
            self.level[ch], self.mode[ch] = pct, "continuous"
            self.save()
            return ""
        if head == "RT":
            if len(values) != 4:
                return f"Err {MALFORMED}"
            ch = int(values[0])
            if ch not in self.level or not 0 <= values[3] <= 100 or values[1] <= 0:
                return f"Err {RANGE}"
            self.level[ch], self.mode[ch] = values[3], "pulse"
            self.pulse[ch] = [values[1], values[2]]
            self.save()
            return ""
        if head == "TR":
            if len(values) != 1 or int(values[0]) not in self.level:
                return f"Err {RANGE}"
            self.triggers += 1
            self.save()
            return ""
        if cmd == "ST" or head == "ST":
            return "\r\n".join(
                f"CH{c} {self.mode[c]} {self.level[c]:g}%"
                + (" {:g}us {:g}us".format(*self.pulse[c]) if self.mode[c] == "pulse" else "")
                for c in self.level
            )
        if cmd == "VR":
            return "RT-simulated (inspect-validate) 1.0"
        return f"Err {UNKNOWN}"

    def line_command(self, text: str) -> str:
        """The ``line`` dialect: 8-bit levels, explicit OK, errors with a text."""
        words = text.strip().upper().split()
        for prefix, code in self.errors.items():
            if text.strip().upper().startswith(prefix):
                return f"ERROR {code}: refused"
        try:
            if words[:1] == ["SET"] and len(words) == 3:
                ch, level = int(words[1]), int(words[2])
                if ch not in self.level or not 0 <= level <= 255:
                    return f"ERROR {RANGE}: out of range"
                self.level[ch] = round(level / 255 * 100, 6)
            elif words[:1] == ["OFF"] and len(words) == 2:
                ch = int(words[1])
                if ch not in self.level:
                    return f"ERROR {RANGE}: out of range"
                self.level[ch] = 0.0
            elif words == ["STATUS?"]:
                return "OK " + " ".join(f"{c}={v:g}" for c, v in self.level.items())
            else:
                return f"ERROR {UNKNOWN}: unknown command"
        except ValueError:
            return f"ERROR {MALFORMED}: malformed"
        self.save()
        return "OK"


def serve(master: int, controller: Controller, args: argparse.Namespace) -> None:
    """Answer command lines on the file descriptor ``master`` (a pseudo-terminal's
    master side or a connected socket) until it closes."""
    pending = b""
    lines = 0
    while True:
        try:
            data = os.read(master, 4096)
        except OSError:
            return
        if not data:
            return
        pending += data
        sep = b"\n" if args.dialect == "line" else b"\r"
        while sep in pending:
            raw, pending = pending.split(sep, 1)
            raw = raw.strip(b"\r\n")
            if not raw:
                continue
            lines += 1
            if args.vanish_after is not None and lines > args.vanish_after:
                os._exit(0)
            if args.drop_after is not None and lines > args.drop_after:
                return
            if args.mute_after is not None and lines > args.mute_after:
                continue
            if args.garbage_after is not None and lines > args.garbage_after:
                os.write(master, b"\xff\xfe\x00\x80garbage")
                continue
            if args.slow:
                time.sleep(args.slow)
            if args.dialect == "line":
                reply = controller.line_command(raw.decode("ascii", "replace"))
                os.write(master, reply.encode() + b"\r\n")
                continue
            replies = [controller.command(c) for c in raw.decode("ascii", "replace").split(";")]
            text = "\r\n".join(r for r in replies if r)
            os.write(master, (text + "\r\n" if text else "").encode() + b">")


def end_with_parent(state_folder: Path | None = None, *, parent: int | None = None) -> None:
    """Exit when the process that started this one dies, even by ``kill -9`` (Linux:
    ``PR_SET_PDEATHSIG``), removing ``state_folder`` — the parent's temporary folder,
    which it can no longer remove — so no orphan or litter outlives it. ``parent``: that
    process's id, as it gave it (``--parent``); else the one this process has now, which
    is already another if the parent died while this one started."""
    import signal

    parent = os.getppid() if parent is None else parent

    def leave(*_) -> None:
        if state_folder is not None and state_folder.name.startswith("iv-sim-"):
            import shutil

            shutil.rmtree(state_folder, ignore_errors=True)
        os._exit(0)

    signal.signal(signal.SIGTERM, leave)
    if sys.platform.startswith("linux"):
        import ctypes

        libc = ctypes.CDLL(None, use_errno=True)
        libc.prctl(1, signal.SIGTERM)  # PR_SET_PDEATHSIG
        # The parent died before the request was made: this process was handed to
        # another (init, or a service manager that reaps orphans: not always pid 1).
        if os.getppid() != parent:
            leave()


def main(argv: Sequence[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--state", type=Path, required=True)
    parser.add_argument("--channels", type=int, default=4)
    parser.add_argument("--error", action="append", default=[], metavar="CMD:CODE")
    parser.add_argument("--slow", type=float, default=0.0)
    parser.add_argument("--mute-after", type=int)
    parser.add_argument("--garbage-after", type=int)
    parser.add_argument("--vanish-after", type=int)
    parser.add_argument("--drop-after", type=int)
    parser.add_argument("--dialect", choices=("gardasoft", "line"), default="gardasoft")
    parser.add_argument("--tcp", type=int, nargs="?", const=0, metavar="PORT")
    parser.add_argument("--parent", type=int, metavar="PID", help="the starting process's id")
    args = parser.parse_args(argv)
    end_with_parent(args.state.parent, parent=args.parent)
    try:
        _run(args)
    except FileNotFoundError:
        if args.state.parent.exists():
            raise
        # The parent removed its temporary folder while this process started or served:
        # it is done with the controller (a stopped watch), which ends without a word.


def _run(args: argparse.Namespace) -> None:
    errors = {}
    for item in args.error:
        prefix, code = item.rsplit(":", 1)
        errors[prefix.upper()] = int(code)
    controller = Controller(args.channels, args.state, errors)
    if args.tcp is not None:
        with socket.create_server(("127.0.0.1", args.tcp)) as server:
            print(f"socket://127.0.0.1:{server.getsockname()[1]}", flush=True)
            while True:
                conn, _ = server.accept()
                with conn:
                    serve(conn.fileno(), controller, args)
    master, slave = os.openpty()
    tty.setraw(slave)  # no echo, no line editing: bytes pass as a serial line would
    print(os.ttyname(slave), flush=True)
    serve(master, controller, args)


if __name__ == "__main__":
    main()
