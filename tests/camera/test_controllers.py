"""LED controller drivers against the simulated controller process on a pseudo-terminal."""

import json
import re

import pytest

from inspect_validate.camera.controllers import GardasoftController, GenericAsciiController
from inspect_validate.errors import DeviceError


def test_sequence_sets_state(simulator):
    port, state, _ = simulator()
    with GardasoftController(port, channels=4) as c:
        assert "simulated" in c.version()
        c.apply({1: 40, 3: 75.5})
        assert json.loads(state.read_text())["channels"] == {
            "1": 40.0,
            "2": 0.0,
            "3": 75.5,
            "4": 0.0,
        }
        c.pulse(2, width_us=500, delay_us=10, percent=100)
        assert "CH2 pulse 100%" in c.status()
        c.all_off()
        assert set(json.loads(state.read_text())["channels"].values()) == {0.0}


def test_err_reply_is_decoded(simulator):
    port, _, _ = simulator("--error", "RS2:7")
    with GardasoftController(port, error_codes={7: "output overload"}) as c:
        with pytest.raises(
            DeviceError, match=r"answered 'Err 7' \(output overload\) to 'RS2,50'"
        ) as info:
            c.set_intensity(2, 50)
        assert port in str(info.value)


def test_no_answer_times_out(simulator):
    port, _, _ = simulator("--mute-after", "1")
    with GardasoftController(port, timeout=0.3) as c:
        c.set_intensity(1, 10)
        with pytest.raises(
            DeviceError, match=r"no answer to 'RS1,20' within 0.3 s; check the cable"
        ):
            c.set_intensity(1, 20)


def test_slow_answer_within_timeout_is_fine(simulator):
    port, state, _ = simulator("--slow", "0.2")
    with GardasoftController(port, timeout=1.0) as c:
        c.set_intensity(3, 30)
    assert json.loads(state.read_text())["channels"]["3"] == 30.0


def test_garbage_reply(simulator):
    port, _, _ = simulator("--garbage-after", "0")
    with (
        GardasoftController(port, timeout=0.3) as c,
        pytest.raises(DeviceError, match=r"unexpected reply .*check the baud rate"),
    ):
        c.set_intensity(1, 10)


def test_port_vanishes(simulator):
    port, _, proc = simulator("--vanish-after", "1")
    with GardasoftController(port, timeout=0.5) as c:
        c.set_intensity(1, 10)
        with pytest.raises(DeviceError) as info:
            c.set_intensity(1, 20)
            c.set_intensity(1, 30)
    assert port in str(info.value)
    proc.wait(timeout=5)


def test_bad_arguments_and_missing_port(simulator, tmp_path):
    port, _, _ = simulator()
    with GardasoftController(port, channels=2) as c:
        with pytest.raises(DeviceError, match="channel 3 does not exist"):
            c.set_intensity(3, 10)
        with pytest.raises(DeviceError, match="outside 0–100"):
            c.set_intensity(1, 120)
    with pytest.raises(DeviceError, match="cannot open the controller's serial port"):
        GardasoftController(str(tmp_path / "ttyNONE"))


LINE_PROTOCOL = dict(
    terminator=b"\n", reply_end=b"\r\n", ok=rb"^OK", error=rb"ERROR (?P<code>\d+)", max_value=255
)
LINE_COMMANDS = {"set": "SET {channel} {value:.0f}", "off": "OFF {channel}", "status": "STATUS?"}


def test_generic_controller_speaks_a_line_protocol(simulator):
    port, state, _ = simulator("--dialect", "line")
    with GenericAsciiController(port, commands=LINE_COMMANDS, channels=4, **LINE_PROTOCOL) as c:
        c.apply({1: 100, 2: 50})
        # 50 % of 255 is sent as level 128 (rounded), read back as 128/255.
        levels = json.loads(state.read_text())["channels"]
        assert levels == {"1": 100.0, "2": round(128 / 255 * 100, 6), "3": 0.0, "4": 0.0}
        assert c.status().startswith("OK 1=100 2=50.1961")
        c.all_off()
        assert set(json.loads(state.read_text())["channels"].values()) == {0.0}
        with pytest.raises(DeviceError, match="channel 5 does not exist"):
            c.set_intensity(5, 10)
        with pytest.raises(DeviceError, match="no 'pulse' command template"):
            c.pulse(1, width_us=10, delay_us=0, percent=50)


def test_generic_controller_errors(simulator):
    port, _, _ = simulator("--dialect", "line", "--error", "SET 2:9")
    with GenericAsciiController(
        port, commands=LINE_COMMANDS, error_codes={9: "interlock open"}, **LINE_PROTOCOL
    ) as c:
        with pytest.raises(
            DeviceError, match=r"answered 'ERROR 9' \(interlock open\) to 'SET 2 255'"
        ):
            c.set_intensity(2, 100)
    # A reply that matches neither pattern: the protocol in the station file is wrong.
    port, _, _ = simulator("--dialect", "line")
    strict = {**LINE_PROTOCOL, "ok": rb"^ACK"}
    with GenericAsciiController(port, commands=LINE_COMMANDS, **strict) as c:
        with pytest.raises(DeviceError, match=r"reply b'OK' to 'SET 1 26' is neither success"):
            c.set_intensity(1, 10)
    # A Gardasoft-style prompt protocol against a line-protocol device: no prompt ever comes.
    port, _, _ = simulator("--dialect", "line")
    with GenericAsciiController(
        port, commands=LINE_COMMANDS, terminator=b"\n", reply_end=b">", timeout=0.3
    ) as c:
        with pytest.raises(DeviceError, match=r"unexpected reply b'OK\\r\\n' to 'SET 1 10'"):
            c.set_intensity(1, 10)


def test_generic_controller_with_gardasoft_templates(simulator):
    """The generic driver configured for the RT protocol drives the RT simulator."""
    port, state, _ = simulator()
    commands = {"set": "RS{channel},{percent:g}", "status": "ST", "init": ["VR"]}
    with GenericAsciiController(
        port, commands=commands, reply_end=b">", error=rb"Err\s*(\d+)"
    ) as c:
        c.apply({3: 12.5})
        assert json.loads(state.read_text())["channels"]["3"] == 12.5
        assert "CH3 continuous 12.5%" in c.status()
        # The RT simulator's range error (channel 5 of 4) comes back through the generic patterns.
        with pytest.raises(DeviceError, match=r"answered 'Err 3' to 'RS5,10'"):
            c.link.query("RS5,10")


def test_controller_over_tcp_speaks_the_same_protocol(simulator):
    """An Ethernet controller is a port setting: pyserial's socket:// URL."""
    port, state, _ = simulator("--tcp")
    assert port.startswith("socket://127.0.0.1:")
    with GardasoftController(port, channels=4) as c:
        assert "simulated" in c.version()
        c.apply({2: 60})
        assert "CH2 continuous 60%" in c.status()
    # The controller keeps its state across connections, as a networked one does.
    with GardasoftController(port, channels=4) as c:
        assert "CH2 continuous 60%" in c.status()
    assert json.loads(state.read_text())["channels"]["2"] == 60.0


def test_dropped_tcp_connection_names_the_network(simulator):
    port, _, _ = simulator("--tcp", "--drop-after", "2")
    with GardasoftController(port, timeout=0.5) as c:
        c.set_intensity(1, 10)
        c.set_intensity(1, 20)
        with pytest.raises(DeviceError) as info:
            c.set_intensity(1, 30)
    assert str(info.value).startswith(f"{port}: the connection failed while sending 'RS1,30'")
    assert "the network connection was lost" in str(info.value)


def test_unreachable_tcp_controller_names_the_address(simulator):
    port, _, proc = simulator("--tcp")
    proc.kill()
    proc.wait()
    with pytest.raises(DeviceError, match=r"cannot connect to the controller; check its IP"):
        GardasoftController(port)
    with pytest.raises(DeviceError, match=r"socket://nowhere: cannot connect"):
        GardasoftController("socket://nowhere")


def _replying(reply: bytes):
    """A pseudo-terminal whose other end answers every command with ``reply``: a real tty,
    as a USB serial adapter is."""
    import os
    import threading
    import tty

    master, slave = os.openpty()
    tty.setraw(slave)
    done = threading.Event()

    def answer():
        while not done.is_set():
            try:
                if os.read(master, 4096):
                    os.write(master, reply)
            except OSError:
                return

    threading.Thread(target=answer, daemon=True).start()
    return os.ttyname(slave), lambda: (done.set(), os.close(master), os.close(slave))


def test_hostile_replies_are_named_escaped_and_bounded():
    """An error code of 5000 digits (int() refuses past 4300: a ValueError, exit 70) or of
    4000, a
    reply with a terminal's escape codes (printed raw, it retitled the terminal), and a
    reply that never ends are each a DeviceError that says what came."""
    from inspect_validate.camera.controllers.gardasoft import SerialAscii
    from inspect_validate.camera.settings import REPLY_MAX

    for reply, says in (
        (b"Err " + b"9" * 4000 + b">", r"answered 'Err 9{70}"),  # a code no table has
        (b"Err " + b"9" * 5000 + b">", f"runs past {REPLY_MAX} bytes"),  # in one read or many
        (b"Err 7\x1b]0;x\x07>", r"answered 'Err 7' \(overload\)"),
        (b"x" * (REPLY_MAX + 10), f"runs past {REPLY_MAX} bytes"),
    ):
        port, close = _replying(reply)
        try:
            link = SerialAscii(port, timeout=2.0, error_codes={7: "overload"})
            with pytest.raises(DeviceError, match=says):
                link.query("ST1")
            link.close()
        finally:
            close()
    # What a device says is printed with its control characters escaped.
    from inspect_validate.camera.inventory import probe_port

    port, close = _replying(b"RT: PWNED\x07\x1b]0;title\x07\r\n>")
    try:
        answer = probe_port(port, timeout_s=1.0)
    finally:
        close()
    assert "\x1b" not in answer and "\x07" not in answer
    assert "PWNED\\x07\\x1b]0;title\\x07" in answer, answer


@pytest.mark.parametrize(
    ("protocol", "says"),
    [
        ({"commands": {"set": "SET {channel[0]}"}}, "by name (no index or attribute)"),
        ({"commands": {"set": "SET {channel.foo}"}}, "by name (no index or attribute)"),
        ({"commands": {"set": "SÉT {channel}"}}, "not ASCII"),
        ({"commands": {"set": "SET {percent:>1500000000}"}}, "at most a width"),
        ({"commands": {"set": "SET {channel!r}"}}, "at most a width"),
        ({"commands": {"set": "SET {"}}, "does not parse"),
        ({"commands": {"set": "SET {channel}"}, "ok": "(?u)^OK"}, "bytes"),
        ({"commands": {"set": "SET {channel}"}, "ok": "^(a+)+$"}, "repeats a group"),
        ({"commands": {"set": "SET {channel}"}, "error": "É(\\d+)"}, "not ASCII"),
        ({"commands": {"set": "SET {channel}"}, "terminator": "→"}, "not ASCII"),
    ],
)
def test_a_protocol_that_would_hang_or_crash_is_refused(protocol, says):
    """Each was a traceback, a 1.5 GB template or a match that backtracked until killed."""
    from pydantic import ValidationError

    from inspect_validate.camera.settings import AsciiProtocol

    with pytest.raises(ValidationError, match=re.escape(says)):
        AsciiProtocol.model_validate(protocol)


def test_a_valid_protocol_is_taken():
    from inspect_validate.camera.settings import AsciiProtocol

    AsciiProtocol.model_validate(
        {"commands": {"set": "SET {channel:02d} {value:.0f}", "init": ["ECHO OFF"]},
         "ok": "^OK", "error": "(?i)err\\w*\\s*(\\d+)|(\\d+,)*\\d+ FAIL"}
    )  # fmt: skip
