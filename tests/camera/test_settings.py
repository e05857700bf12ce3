"""The keys every camera and controller section shares (camera/settings.py): a controller's
address, read by one parser wherever it is given."""

import pytest
from conftest import ROOT


@pytest.mark.parametrize(
    ("address", "says"),
    [
        ("socket://127.0.0.1", "no port: write socket://192.168.1.20:30313"),
        ("socket://127.0.0.1:99999", "port 99999 is out of range: a TCP port is 1–65535"),
        ("socket://h:0", "port 0 is out of range"),
        ("socket://:::::", "cannot read host:port after socket://"),
        ("socket://:30313", "no host"),
        ("socket://h:30313/x", "nothing may follow host:port"),
        ("socket://h:30313?verbose=1", "the one option socket:// takes is ?logging=debug"),
        ("telnet://h:23", "unknown URL scheme 'telnet'"),
    ],
)
def test_a_bad_controller_address_says_what_is_wrong_everywhere(cli, tmp_path, address, says):
    """One parser for the station file's controller.port, devices --port and init --port:
    what is wrong with the address, never pyserial's or Python's internals."""
    import yaml
    from conftest import copy_station

    path = copy_station(tmp_path)
    doc = yaml.safe_load(path.read_text())
    doc["controller"] = {"backend": "gardasoft", "port": address, "channels": 2}
    path.write_text(yaml.safe_dump(doc))
    code, _, err = cli(["capture", path, "--out", tmp_path / "c"])
    assert code == 2 and "controller.port" in err and says in err, err
    code, _, err = cli(["devices", "--port", address, "--probe"])
    assert code == 2 and "--port" in err and says in err, err
    code, _, err = cli(
        [
            "init",
            tmp_path / "s.yaml",
            "--scene",
            ROOT / "sample_images/scenes/paperboard/scene.yaml",
            "--camera",
            "simulated",
            "--controller",
            "gardasoft",
            "--port",
            address,
            "--no-interactive",
        ]
    )
    assert code == 2 and "--port" in err and says in err, err
    for message in (err,):
        assert "NoneType" not in message and "debug|info" not in message


@pytest.mark.parametrize(
    "address",
    [
        "/dev/ttyUSB0",
        "COM3",
        "socket://192.168.1.20:30313",
        "socket://[fe80::1]:30313",
        "rfc2217://host:2217",
        "loop://",
        "socket://h:30313?logging=debug",
    ],
)
def test_a_valid_controller_address_is_taken_as_given(address):
    from inspect_validate.camera.settings import controller_address

    assert controller_address(address) == address
