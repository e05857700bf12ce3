"""GenICam backend against the simulated GenTL producer shipped in the genicam wheel (viky.cti)."""

from pathlib import Path

import numpy as np
import pytest

from camera.grabbers.genicam import GenICamCamera, find_producers
from inspect_validate.errors import DeviceError

genicam = pytest.importorskip("genicam")
CTI = next(iter(Path(genicam.__file__).parent.glob("*.cti")), None)
pytestmark = pytest.mark.skipif(
    CTI is None, reason="this genicam wheel ships no simulated producer"
)


def test_enumerate_configure_grab():
    with GenICamCamera(str(CTI), serial="1") as cam:
        assert "Viky" in cam.name and "serial 1" in cam.name
        # viky has no ExposureTime or Gain node: reported, not fatal.
        assert {"exposure", "gain"} <= cam.missing
        cam.configure(pixel_format="Mono8", region=(0, 0, 160, 120), exposure_us=1000, gain_db=3)
        frames = cam.grab(3, timeout_s=3)
        assert [f.data.shape for f in frames] == [(120, 160)] * 3
        assert all(
            f.data.dtype == np.uint8 and f.pixel_format == "Mono8" and f.bit_depth == 8
            for f in frames
        )
        ids = [f.frame_id for f in frames]
        assert ids == sorted(ids) and len(set(ids)) == 3
        assert frames[0].exposure_us is None and frames[0].clock in ("arrival", "device")
        assert (
            frames[0].data.flags.owndata
            or frames[0].data.base is None
            or frames[0].data.base.flags.owndata
        )
        # Locked nodes: configuring again stops the acquisition first.
        cam.configure(region=(0, 0, 200, 100))
        assert cam.grab(1)[0].data.shape == (100, 200)


def test_fetch_timeout_is_a_clear_error():
    with GenICamCamera(str(CTI), index=0) as cam:
        cam.configure(pixel_format="Mono8")
        cam._nodes.AcquisitionFrameRate.value = 1.0
        cam.grab(1, timeout_s=3)
        with pytest.raises(
            DeviceError, match=r"no frame within 0.01 s \(frame 1 of 2\); check trigger mode"
        ):
            cam.grab(2, timeout_s=0.01)


def test_colour_format_is_refused():
    with GenICamCamera(str(CTI), index=2) as cam:
        cam.configure()
        cam._nodes.PixelFormat.value = "RGBa8"
        with pytest.raises(DeviceError, match=r"RGBa8.*not a supported monochrome format"):
            cam.grab(1, timeout_s=3)
        with pytest.raises(DeviceError, match="Mono16 not offered"):
            cam.configure(pixel_format="Mono16")


def test_selection_and_producer_errors(tmp_path, monkeypatch):
    with pytest.raises(DeviceError, match="no camera with serial 42; found: 0, 1, 2"):
        GenICamCamera(str(CTI), serial="42")
    with pytest.raises(DeviceError, match="camera index 7 does not exist"):
        GenICamCamera(str(CTI), index=7)
    with pytest.raises(DeviceError, match=r"producer .* not found"):
        find_producers(str(tmp_path / "none.cti"))
    monkeypatch.setenv("GENICAM_GENTL64_PATH", str(CTI.parent))
    assert CTI in find_producers()
    monkeypatch.setenv("GENICAM_GENTL64_PATH", str(tmp_path))
    with pytest.raises(DeviceError, match="set GENICAM_GENTL64_PATH"):
        find_producers()
