"""The one grab path of the GenICam-style backends (harvesters, pylon, Aravis), which each
backend reaches through its library's few accessors: device choice, feature writes,
the fetch loop, formats checked and packed formats unpacked, frames made by keywords.

Packed formats (Mono10p, Mono12p, Mono1xPacked) cannot come from a camera here: neither
pylon's emulator (Mono8–Mono16), TLSimu nor Aravis' fake camera offers one. The path is
therefore driven by a node map in memory that serves packed buffers as a camera's
transport delivers them (bytes packed by the independent bit-stream packer of
test_pixelformats); the real backends run the same path in test_pylon, test_genicam and
test_aravis with the formats their emulators have.
"""

import contextlib

import numpy as np
import pytest
from test_pixelformats import pack_lsb_stream

from inspect_validate.camera.grabbers.base import (
    Buffer,
    DeviceInfo,
    NodeMapGrabber,
    choose_device,
)
from inspect_validate.camera.pixelformats import PFNC_CODES
from inspect_validate.errors import DeviceError

CODES = {name: code for code, name in PFNC_CODES.items()}


class MemoryCamera(NodeMapGrabber):
    """A node map and a stream in memory: what a library gives the grab path."""

    def __init__(self, frames, *, formats=("Mono8", "Mono12p", "Mono10p", "Mono16")):
        self.name = "memory camera (serial M1)"
        self.nodes = {
            "ExposureTime": 1000.0,
            "Gain": 0.0,
            "PixelFormat": "Mono8",
            "TriggerMode": "Off",
            "TriggerSoftware": None,
        }
        self.formats = formats
        self.queue = list(frames)  # (format the buffer reports, (H, W) values)
        self.requeued = 0
        self.missing = self._missing()

    def _has(self, name):
        return name in self.nodes

    def _symbolics(self, name):
        return self.formats if name == "PixelFormat" else ()

    def _write(self, name, value, label):
        if name not in self.nodes:
            self.missing.add(label)
            return
        self.nodes[name] = value

    def _read(self, name):
        return float(self.nodes[name])

    def _increment(self, name):
        return 1.0 if name == "ExposureTime" else None

    def _text(self, name):
        value = self.nodes[name]
        return None if value is None else str(value)

    def _execute(self, name):
        self.nodes[name] = "executed"

    def _start(self):
        pass

    def _stop(self):
        pass

    @contextlib.contextmanager
    def _fetch(self, timeout_s):
        if not self.queue:
            yield None
            return
        fmt, values = self.queue.pop(0)
        h, w = values.shape
        bits = {"Mono10p": 10, "Mono12p": 12}.get(fmt)
        if bits:  # the transport's bytes, as the camera packed them
            pixels = np.frombuffer(pack_lsb_stream(values.reshape(-1), bits), np.uint8)
        else:
            pixels = values.astype(np.uint8 if fmt == "Mono8" else np.uint16)
        try:
            yield Buffer(
                pixels=pixels,
                pixel_format=fmt if fmt in CODES else None,
                width=w,
                height=h,
                frame_id=len(self.queue),
                timestamp_ns=123,
                reported=fmt,
            )
        finally:
            self.requeued += 1


@pytest.mark.parametrize(("fmt", "top"), [("Mono12p", 4095), ("Mono10p", 1023)])
def test_packed_frames_are_unpacked_by_the_shared_path(fmt, top):
    rng = np.random.default_rng(1)
    values = rng.integers(0, top + 1, (6, 10))
    camera = MemoryCamera([(fmt, values)])
    camera.configure(exposure_us=2000, pixel_format=fmt)
    (frame,) = camera.grab(1)
    assert np.array_equal(frame.data, values) and frame.data.dtype == np.uint16
    assert frame.pixel_format == fmt and frame.bit_depth == {"Mono12p": 12, "Mono10p": 10}[fmt]
    assert frame.exposure_us == 2000 and frame.device == camera.name
    assert camera.requeued == 1  # handed back after the pixels were copied out


def test_a_buffer_in_another_format_than_asked_is_an_error_naming_the_device():
    camera = MemoryCamera([("Mono8", np.zeros((2, 2)))])
    camera.configure(pixel_format="Mono12p")
    with pytest.raises(DeviceError, match="asked for Mono12p, the buffer holds Mono8"):
        camera.grab(1)
    camera = MemoryCamera([("RGB8", np.zeros((2, 2)))])
    with pytest.raises(DeviceError, match="delivers RGB8 frames, not a supported monochrome"):
        camera.grab(1)


def test_a_missing_frame_times_out_with_what_to_check():
    with pytest.raises(DeviceError, match=r"no frame within 0.5 s \(frame 2 of 2\)"):
        MemoryCamera([("Mono8", np.zeros((2, 2)))]).grab(2, timeout_s=0.5)


def test_trigger_increments_and_missing_settings_through_the_accessors():
    camera = MemoryCamera([])
    assert camera.missing == set()
    camera.trigger()
    assert camera.nodes["TriggerSoftware"] == "executed"
    assert camera.increments() == {"exposure_us": 1.0}
    del camera.nodes["Gain"]
    assert camera._missing() == {"gain"}


def test_a_device_is_chosen_by_serial_id_or_index_and_refused_by_name():
    found = [
        DeviceInfo(0, "A1", "Basler", "acA1920"),
        DeviceInfo(1, "B2", "Acme", "x", device_id="Acme-B2"),
    ]
    assert choose_device(found, what="test", serial="B2").key == 1
    assert choose_device(found, what="test", device_id="Acme-B2").key == 1
    assert choose_device(found, what="test", index=0).describe() == "Basler acA1920 (serial A1)"
    with pytest.raises(DeviceError, match=r"no test camera with serial C3; found: Basler"):
        choose_device(found, what="test", serial="C3")
    with pytest.raises(DeviceError, match=r"test camera index 5 does not exist; 2 found"):
        choose_device(found, what="test", index=5)
    with pytest.raises(DeviceError, match="no test camera found; check"):
        choose_device([], what="test")
