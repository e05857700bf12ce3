"""The Gardasoft driver against the simulated controller process on a pseudo-terminal."""

import json
import subprocess
import sys

import pytest

from camera.lights import GardasoftController
from inspect_validate.errors import DeviceError


@pytest.fixture
def simulator(tmp_path):
    procs = []

    def start(*faults):
        state = tmp_path / f"state{len(procs)}.json"
        proc = subprocess.Popen(
            [sys.executable, "-m", "camera.lights.simulator", "--state", str(state), *faults],
            stdout=subprocess.PIPE,
            text=True,
        )
        procs.append(proc)
        return proc.stdout.readline().strip(), state, proc

    yield start
    for p in procs:
        p.kill()
        p.wait()


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
