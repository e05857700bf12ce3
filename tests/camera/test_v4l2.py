"""V4L2 backend: a fake at the OpenCV boundary (no V4L2 device exists in a container),
plus a device test behind the ``v4l2_device`` marker for machines with a camera."""

import glob

import cv2
import numpy as np
import pytest

from inspect_validate.camera.grabbers.v4l2 import V4l2Grabber, _fourcc, _fourcc_text
from inspect_validate.errors import DeviceError


class FakeCapture:
    """``cv2.VideoCapture`` on a pretend device, with the V4L2 backend's habits.

    ``set()`` answers as OpenCV does: False when the driver refuses, True when
    it accepted *something* — which may be a rounded value or another format.
    """

    def __init__(
        self,
        formats=("GREY", "Y16 "),
        sizes=((640, 480), (320, 240)),
        exposure=(1, 5000),  # range in 100 µs units; None: no such control
        substitute=None,  # format the driver delivers for one it lacks
        fixed_buffers=False,
        auto_exposure_sticks=False,
        reads=None,  # frames to deliver before reads fail
        opens=True,
    ):
        self.formats, self.sizes, self.exposure_range = formats, sizes, exposure
        self.substitute, self.fixed_buffers = substitute, fixed_buffers
        self.auto_exposure_sticks, self.reads, self.opens = auto_exposure_sticks, reads, opens
        self.palette = formats[0]
        self.size = sizes[0]
        self.pending = [None, None]
        self.props = {
            cv2.CAP_PROP_CONVERT_RGB: 1,
            cv2.CAP_PROP_BUFFERSIZE: 4,
            cv2.CAP_PROP_AUTO_EXPOSURE: 3,
            cv2.CAP_PROP_EXPOSURE: 100,
        }
        self.opened_with = None

    def __call__(self, path, api):
        self.opened_with = (path, api)
        return self

    def isOpened(self):
        return self.opens

    def set(self, prop, value):
        if prop == cv2.CAP_PROP_FOURCC:
            code = _fourcc_text(value)
            if code in self.formats:
                self.palette = code
            elif self.substitute:
                self.palette = self.substitute
            else:
                return False
            return True
        if prop in (cv2.CAP_PROP_FRAME_WIDTH, cv2.CAP_PROP_FRAME_HEIGHT):
            self.pending[prop == cv2.CAP_PROP_FRAME_HEIGHT] = int(value)
            if None not in self.pending:  # the driver picks the nearest size it has
                w, h = self.pending
                self.size = min(self.sizes, key=lambda s: abs(s[0] - w) + abs(s[1] - h))
                self.pending = [None, None]
            return True
        if prop == cv2.CAP_PROP_BUFFERSIZE and self.fixed_buffers:
            return False
        if prop == cv2.CAP_PROP_EXPOSURE:
            if self.exposure_range is None:
                return False
            lo, hi = self.exposure_range
            self.props[prop] = min(max(round(value), lo), hi)
            return True
        if prop == cv2.CAP_PROP_AUTO_EXPOSURE and self.auto_exposure_sticks:
            return True
        if prop == cv2.CAP_PROP_READ_TIMEOUT_MSEC:
            return True
        self.props[prop] = value
        return True

    def get(self, prop):
        if prop == cv2.CAP_PROP_FOURCC:
            return float(_fourcc(self.palette))
        if prop == cv2.CAP_PROP_FRAME_WIDTH:
            return float(self.size[0])
        if prop == cv2.CAP_PROP_FRAME_HEIGHT:
            return float(self.size[1])
        if prop == cv2.CAP_PROP_EXPOSURE and self.exposure_range is None:
            return -1.0
        if prop == cv2.CAP_PROP_POS_MSEC:
            return 1234.5
        return float(self.props.get(prop, -1))

    def read(self):
        if self.reads is not None:
            if self.reads == 0:
                return False, None
            self.reads -= 1
        w, h = self.size
        level = self.props[cv2.CAP_PROP_EXPOSURE]
        if self.props[cv2.CAP_PROP_CONVERT_RGB]:
            return True, np.full((h, w, 3), min(level, 255), np.uint8)
        if self.palette == "GREY":
            return True, np.full((h, w), min(level, 255), np.uint8)
        if self.palette in ("Y16 ", "Y10 "):
            return True, np.full((h, w), level, np.uint16)
        return True, np.zeros((1, w * h * 2), np.uint8)  # raw bytes of a format OpenCV cannot shape

    def release(self):
        self.opens = False


def test_grab_y16_with_settings_read_back():
    fake = FakeCapture()
    with V4l2Grabber("/dev/video3", opener=fake) as cam:
        assert fake.opened_with == ("/dev/video3", cv2.CAP_V4L2)  # the backend is forced
        assert fake.props[cv2.CAP_PROP_CONVERT_RGB] == 0
        assert cam.pipeline_frames == 2  # one queued buffer + the one being filled
        cam.configure(pixel_format="Mono16", exposure_us=2000, region=(0, 0, 320, 240))
        assert fake.props[cv2.CAP_PROP_AUTO_EXPOSURE] == 1
        frames = cam.grab(2)
    assert [f.frame_id for f in frames] == [1, 2]
    f = frames[0]
    assert f.data.shape == (240, 320) and f.data.dtype == np.uint16 and f.data[0, 0] == 20
    assert (f.pixel_format, f.bit_depth, f.exposure_us, f.gain_db) == ("Mono16", 16, 2000, None)
    assert f.clock == "arrival" and f.extra["driver_timestamp_ms"] == 1234.5
    assert cam.missing == {"gain"}  # V4L2 gain has no dB unit
    assert not fake.opens  # released


def test_default_format_switches_a_colour_device_to_grey():
    fake = FakeCapture(formats=("YUYV", "GREY"))
    cam = V4l2Grabber(0, opener=fake)
    assert cam.pixel_format is None and fake.opened_with[0] == "/dev/video0"
    frames = cam.grab(1)
    assert fake.palette == "GREY" and frames[0].data.dtype == np.uint8


@pytest.mark.parametrize(
    "fake, settings, message",
    [
        (FakeCapture(formats=("GREY",)), {"pixel_format": "Mono16"}, r"refused format 'Y16 '"),
        (
            FakeCapture(formats=("GREY",), substitute="YUYV"),
            {"pixel_format": "Mono16"},
            r"asked for format 'Y16', the driver delivers 'YUYV'",
        ),
        (FakeCapture(), {"pixel_format": "Mono12p"}, r"Mono12p is not available through V4L2"),
        (FakeCapture(), {"region": (0, 0, 500, 400)}, r"asked for 500×400, the driver set 640×480"),
        (FakeCapture(), {"region": (8, 0, 320, 240)}, r"not an offset"),
        (
            FakeCapture(),
            {"exposure_us": 900_000},
            r"asked for an exposure of 900000 µs, the driver set 500000 µs",
        ),
        (
            FakeCapture(auto_exposure_sticks=True),
            {"exposure_us": 1000},
            r"automatic exposure stays on",
        ),
    ],
)
def test_settings_the_driver_does_not_take_fail_loudly(fake, settings, message):
    with V4l2Grabber(0, opener=fake) as cam, pytest.raises(DeviceError, match=message) as info:
        cam.configure(**settings)
    assert "/dev/video0" in str(info.value)


def test_missing_exposure_is_reported_not_fatal():
    with V4l2Grabber(0, opener=FakeCapture(exposure=None, fixed_buffers=True)) as cam:
        cam.configure(exposure_us=1000)
        assert cam.missing == {"gain", "exposure"} and cam.pipeline_frames == 5
        assert cam.grab(1)[0].exposure_us is None


def test_read_failures_and_foreign_buffers():
    with V4l2Grabber(0, opener=FakeCapture(reads=1)) as cam:
        cam.grab(1)
        with pytest.raises(DeviceError, match=r"no frame \(frame 1 of 2, timeout 0.5 s\)"):
            cam.grab(2, timeout_s=0.5)
    fake = FakeCapture(formats=("GREY", "MJPG"))
    with V4l2Grabber(0, opener=fake) as cam:
        cam.grab(1)
        fake.palette = "MJPG"  # changed behind our back (another program)
        with pytest.raises(DeviceError, match=r"got a \(1, 614400\) uint8 buffer"):
            cam.grab(1)
    with pytest.raises(DeviceError, match=r"cannot open it with OpenCV's V4L2 backend"):
        V4l2Grabber("/dev/video7", opener=FakeCapture(opens=False))


def test_real_opencv_without_a_device_gives_a_clear_error(capfd):
    with pytest.raises(DeviceError, match=r"/dev/video99: cannot open it.*no such device node"):
        V4l2Grabber("/dev/video99")
    # OpenCV's own log line ("[ WARN:0@0.04] global cap.cpp:212 …") must not leak out
    # beside the error, at the file-descriptor level where the C++ library writes it.
    assert "WARN" not in capfd.readouterr().err


@pytest.mark.v4l2_device
@pytest.mark.skipif(not glob.glob("/dev/video*"), reason="no V4L2 device on this machine")
def test_device_grabs_grey_frames():
    device = sorted(glob.glob("/dev/video*"))[0]
    with V4l2Grabber(device) as cam:
        try:
            cam.configure(pixel_format="Mono8")
        except DeviceError as exc:  # a colour-only webcam: the refusal must say so
            assert "format" in str(exc) and device in str(exc)
            return
        frames = cam.grab(3, timeout_s=5)
    assert all(f.data.ndim == 2 and f.data.dtype == np.uint8 for f in frames)
    assert len({f.frame_id for f in frames}) == 3
