"""`init`: a station file from a camera, a controller and a scene, commented, checked
against the camera's ranges, on which `capture` and `verify` run at once."""

from __future__ import annotations

import json
import os
import subprocess
import sys

import pytest
import yaml
from click.testing import CliRunner
from conftest import ROOT

from inspect_validate.camera.grabbers.base import Features
from inspect_validate.cli import cli as click_group
from inspect_validate.config import field_docs
from inspect_validate.station.draft import pixel_format_for
from inspect_validate.station.file import Station, read_station

SCENE = ROOT / "sample_images" / "scenes" / "paperboard" / "scene.yaml"
ROIS = ROOT / "sample_images" / "station" / "rois.yaml"


def test_simulated_station_from_init_captures_and_verifies(cli, tmp_path):
    out = tmp_path / "station.yaml"
    code, _, err = cli(
        [
            "init",
            out,
            "--scene",
            SCENE,
            "--camera-backend",
            "simulated",
            "--irradiance",
            "1=5",
            "--irradiance",
            "2=5",
            "--rois",
            ROIS,
            "--no-interactive",
        ]
    )
    assert code == 0, err
    st = read_station(out)
    assert [i.name for i in st.illuminations] == ["amber_LED", "red_LED"]
    assert {c: s.light for c, s in st.channels.items()} == {1: "amber LED", 2: "red LED"}
    assert st.name == "paperboard station" and st.controller.channels == 2
    # The exposure the scene predicts puts the brightest class near half of saturation.
    assert 1000 < st.camera.exposure_us < 50_000 and "half of saturation" in err
    text = out.read_text()
    meaning = " ".join(field_docs(Station)["illuminations"].split())
    assert f"# {meaning.split('. ')[0].rstrip('.')}" in text  # each key under its meaning
    code, outp, err = cli(["verify", out, "--report", tmp_path / "report"])
    assert code == 0, outp + err
    assert "PASS" in outp


def test_the_camera_is_read_and_its_ranges_checked_on_pylons_emulator(tmp_path):
    env = {**os.environ, "PYLON_CAMEMU": "1"}

    def init(*args):
        return subprocess.run(
            [
                sys.executable,
                "-m",
                "inspect_validate",
                "init",
                str(tmp_path / "s.yaml"),
                "--force",
                "--scene",
                str(SCENE),
                "--camera-backend",
                "pylon",
                "--controller",
                "simulated",
                "--no-interactive",
                *args,
            ],
            capture_output=True,
            text=True,
            env=env,
            timeout=120,
        )

    run = init("--irradiance", "1=5", "--irradiance", "2=5")
    if "pypylon is not installed" in run.stderr:
        pytest.skip("pypylon is not installed")
    assert run.returncode == 0, run.stderr
    doc = yaml.safe_load((tmp_path / "s.yaml").read_text())
    assert doc["camera"]["serial"] == "0815-0000"  # the only emulated camera
    assert doc["camera"]["pixel_format"] == "Mono16"  # its deepest monochrome format
    run = init("--exposure-us", "0.5")
    assert run.returncode == 2 and "--exposure-us 0.5: the camera takes 1–1e+07 µs" in run.stderr
    run = init("--exposure-us", "5000", "--pixel-format", "Mono12p")
    assert run.returncode == 2 and "offers Mono8, Mono10, Mono12, Mono16" in run.stderr
    run = init("--exposure-us", "5000", "--serial", "NOPE")
    assert run.returncode == 3 and "no pylon camera with serial or id 'NOPE'" in run.stderr


def test_a_generic_controller_on_tcp_is_written_with_its_protocol_and_probed(
    cli, simulator, tmp_path
):
    port, _, _ = simulator("--tcp", "--dialect", "line")
    protocol = tmp_path / "protocol.yaml"
    protocol.write_text(
        'commands: {set: "SET {channel} {value:.0f}", off: "OFF {channel}", status: "STATUS?"}\n'
        'terminator: "\\n"\nmax_value: 255\n'
    )
    out = tmp_path / "s.yaml"
    code, _, err = cli(
        [
            "init",
            out,
            "--scene",
            SCENE,
            "--camera-backend",
            "simulated",
            "--controller",
            "generic",
            "--port",
            port,
            "--protocol",
            protocol,
            "--exposure-us",
            "8000",
            "--channel",
            "3=red LED",
            "--no-interactive",
        ]
    )
    assert code == 0, err
    assert "nothing answered" not in err
    st = read_station(out)
    assert st.controller.port == port and st.controller.protocol.max_value == 255
    assert st.controller.channels == 4 and list(st.channels) == [3]
    assert [i.channels for i in st.illuminations] == [{3: 100.0}]
    code, _, err = cli(
        [
            "init",
            tmp_path / "t.yaml",
            "--scene",
            SCENE,
            "--camera-backend",
            "simulated",
            "--controller",
            "gardasoft",
            "--port",
            port,
            "--exposure-us",
            "8000",
            "--no-interactive",
        ]
    )
    assert code == 0 and "nothing answered on" in err  # a line-protocol device is no Gardasoft


@pytest.mark.parametrize(
    "args, message",
    [
        (
            ["--camera-backend", "simulated"],  # no irradiance: not predictable
            "give --exposure-us (exposure time, µs): the scene's lights have no irradiance",
        ),
        (
            ["--camera-backend", "acme", "--exposure-us", "1"],
            "no camera backend 'acme' is installed",
        ),
        (
            ["--camera-backend", "simulated", "--channel", "1=blue LED", "--exposure-us", "1"],
            "no light 'blue LED'",
        ),
        (["--camera-backend", "simulated", "--channel", "one=red LED"], "write CHANNEL=VALUE"),
        (
            ["--camera-backend", "simulated", "--irradiance", "3=5", "--exposure-us", "1"],
            "channel 3, which drives no light",
        ),
        (
            ["--camera-backend", "simulated", "--size", "640", "--exposure-us", "1"],
            "write WIDTHxHEIGHT",
        ),
        (
            ["--camera-backend", "simulated", "--size", "0x480", "--exposure-us", "1"],
            "each at least 1",
        ),
        (["--camera-backend", "v4l2", "--simulate"], "no emulator to render into"),
        (
            [
                "--camera-backend",
                "simulated",
                "--controller",
                "generic",
                "--port",
                "x",
                "--exposure-us",
                "1",
            ],
            "needs --protocol",
        ),
        ([], "give --camera"),
        (["--camera-backend", "simulated", "--channel", "²=red LED"], "the channel a number 1–64"),
        (["--camera-backend", "simulated", "--channel", "1="], "nothing after '='"),
    ],
)
def test_what_init_cannot_write_is_named(cli, tmp_path, args, message):
    out = tmp_path / "s.yaml"
    code, _, err = cli(["init", out, "--scene", SCENE, "--no-interactive", *args])
    assert code == 2 and message in err
    assert not out.exists()


def test_an_existing_file_is_kept_without_force(cli, tmp_path):
    out = tmp_path / "s.yaml"
    out.write_text("mine\n")
    code, _, err = cli(["init", out, "--scene", SCENE, "--camera", "simulated", "--no-interactive"])
    assert code == 2 and "--force" in err and out.read_text() == "mine\n"


def test_on_a_terminal_what_is_missing_is_asked(tmp_path):
    out = tmp_path / "s.yaml"
    answers = f"{SCENE}\nsimulated\n7000\n"
    result = CliRunner().invoke(click_group, ["init", str(out), "--interactive"], input=answers)
    assert result.exit_code == 0, result.output
    st = read_station(out)
    assert st.camera.backend == "simulated" and st.camera.exposure_us == 7000


def test_pixel_format_choice_prefers_depth_then_unpacked():
    assert (
        pixel_format_for(Features(pixel_formats=("Mono8", "Mono12Packed", "Mono12", "RGB8")))
        == "Mono12"
    )
    assert pixel_format_for(Features(pixel_formats=("Mono8", "Mono10p"))) == "Mono10p"
    assert pixel_format_for(Features(pixel_formats=("RGB8",))) is None
    assert pixel_format_for(Features()) is None
    assert json.dumps(Features().monochrome) == "[]"


def test_init_without_a_terminal_or_a_writable_place_says_so(tmp_path):
    """Standard input closed ('NoneType' object has no attribute 'isatty'), the input
    ending mid-question (exit 130 'interrupted'), a folder that cannot be made (a
    PermissionError traceback) and a folder given as the file ('give --force')."""
    import subprocess
    import sys

    def run(*args, stdin=None, **kw):
        return subprocess.run(
            [sys.executable, "-m", "inspect_validate", "init", *map(str, args)],
            capture_output=True, text=True, stdin=stdin, **kw,
        )  # fmt: skip

    import os

    closed = run(tmp_path / "a.yaml", "--scene", SCENE, preexec_fn=lambda: os.close(0))
    assert closed.returncode == 2 and "give --camera" in closed.stderr, closed.stderr
    ended = run(tmp_path / "b.yaml", "--scene", SCENE, "--interactive", stdin=subprocess.DEVNULL)
    assert ended.returncode == 2 and "the input ended before --camera" in ended.stderr
    simulated = ["--scene", SCENE, "--camera", "simulated", "--exposure-us", 8000,
                 "--channel", "1=amber LED", "--no-interactive"]  # fmt: skip
    blocked = run("/proc/1/nowhere/s.yaml", *simulated)
    assert blocked.returncode == 2 and "cannot create this folder" in blocked.stderr
    folder = run(tmp_path, *simulated)
    assert folder.returncode == 2 and "is a folder" in folder.stderr
    assert "Traceback" not in closed.stderr + ended.stderr + blocked.stderr + folder.stderr


def test_a_station_on_pylons_emulator_from_init_captures_16_bit_frames(cli, tmp_path):
    """init --simulate wrote no pixel_format, so the emulator's frames were Mono8 uint8
    where the manual and capture --help promise 16-bit TIFFs of the deepest format."""
    pytest.importorskip("pypylon")
    import json

    out = tmp_path / "station.yaml"
    args = ["init", out, "--scene", SCENE, "--camera", "pylon", "--simulate", "--irradiance",
            "1=5", "--irradiance", "2=5", "--rois", ROIS, "--no-interactive"]  # fmt: skip
    code, _, err = cli(args)
    assert code == 0, err
    assert read_station(out).camera.pixel_format == "Mono16"
    import os
    import subprocess
    import sys

    done = subprocess.run(  # pylon reads PYLON_CAMEMU as its transport layers start
        [sys.executable, "-m", "inspect_validate", "capture", str(out), "--out", str(tmp_path / "c")],
        env={**os.environ, "PYLON_CAMEMU": "1"}, capture_output=True, text=True,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    meta = json.loads(next((tmp_path / "c").glob("*/frame_0001.json")).read_text())
    assert meta["pixel_format"] == "Mono16"


def test_init_of_a_station_of_frames_alone_says_none_is_needed(tmp_path, capsys):
    """``--camera-backend none`` is a station of the line's frames: nothing to draft (it
    asked for an exposure, then would write a station its own backend refuses)."""
    from conftest import run_cli

    code = run_cli(["init", tmp_path / "s.yaml", "--scene", SCENE, "--camera-backend", "none"])
    err = capsys.readouterr().err
    assert code == 2 and "write rois: and production:" in err, err
    assert not (tmp_path / "s.yaml").exists()
