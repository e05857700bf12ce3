"""The capture sequence of the device layer on its own parts, no station file and no CLI
(``tests/cli/test_capture.py`` drives the same through ``inspect-validate capture``):
``capture_steps`` switching a real-protocol controller (the simulated Gardasoft process
on a pseudo-terminal) while a replay camera serves a folder of 16-bit TIFF frames, into
a capture folder. What the commands build on: steps saved whole, a controller's ``Err``
stopping the sequence with every frame already taken kept, a resume that takes only the
steps still missing, and the lights off at the end."""

import json

import numpy as np
import pytest
import tifffile

from inspect_validate.camera.capture import (
    INCOMPLETE,
    Round,
    Step,
    capture_steps,
    verified_frames,
    verified_rounds,
)
from inspect_validate.camera.controllers.gardasoft import GardasoftController
from inspect_validate.camera.frame import Frame
from inspect_validate.camera.grabbers.replay import ReplayGrabber
from inspect_validate.camera.settings import CameraSettings
from inspect_validate.camera.storage import CaptureStore
from inspect_validate.errors import DeviceError, IncompleteFrame

STEPS = [
    Step("amber", {1: 100.0}, 3),
    Step("red", {2: 100.0}, 3),
    Step("dark", {}, 2),
]


@pytest.fixture
def frames(tmp_path):
    """A folder of 40 frames of one brightness (a replay serves them in name order)."""
    folder = tmp_path / "frames"
    folder.mkdir()
    rng = np.random.default_rng(0)
    for i in range(40):
        tifffile.imwrite(folder / f"f{i:03d}.tif", rng.normal(2000, 20, (32, 48)).astype(np.uint16))
    return folder


def run(port, frames, out, *, resume=False, steps=STEPS):
    store = CaptureStore(out, station_path=out.parent / "s.yaml", station_sha256="0" * 64,
                         resume=resume)  # fmt: skip
    try:
        with GardasoftController(port, channels=4) as controller:
            grabber = ReplayGrabber(frames)
            try:
                return capture_steps(controller, grabber, steps, store, CameraSettings())
            finally:
                grabber.close()
    finally:
        store.release()


def test_every_step_is_saved_whole_and_the_lights_end_off(simulator, frames, tmp_path):
    port, state, _ = simulator()
    out = tmp_path / "capture"
    result = run(port, frames, out)
    assert result.steps == {"amber": 3, "red": 3, "dark": 2} and result.skipped == ()
    manifest = json.loads((out / "manifest.json").read_text())
    for step in STEPS:
        record = manifest["steps"][step.name]
        assert record["complete"] and len(record["sha256"]) == step.frames
        assert sorted(p.name for p in (out / step.name).glob("*.tif")) == sorted(record["sha256"])
    assert set(json.loads(state.read_text())["channels"].values()) == {0.0}


def test_an_err_reply_stops_the_sequence_and_keeps_what_was_taken(simulator, frames, tmp_path):
    """The controller refuses to set channel 2 to 100 % (red's setting): amber is saved and
    marked complete, red has no frame, the error names the command; a resume with a
    healthy controller takes red and dark only, amber's frames untouched."""
    port, _, _ = simulator("--error", "RS2,100:7")
    out = tmp_path / "capture"
    with pytest.raises(DeviceError, match=r"answered 'Err 7' to 'RS2,100'"):
        run(port, frames, out)
    manifest = json.loads((out / "manifest.json").read_text())
    assert manifest["steps"]["amber"]["complete"]
    assert not manifest["steps"].get("red", {}).get("complete")
    assert len(list((out / "amber").glob("*.tif"))) == 3
    assert not list(out.glob("red/*.tif"))
    kept = {p.name: p.read_bytes() for p in (out / "amber").glob("*.tif")}

    port, _, _ = simulator()
    result = run(port, frames, out, resume=True)
    assert result.skipped == ("amber",) and result.steps == {"red": 3, "dark": 2}
    assert {p.name: p.read_bytes() for p in (out / "amber").glob("*.tif")} == kept


# Which frames a step keeps (verified_frames): the verification logic alone.


class FakeCamera:
    """Frames with given (timestamp, mean) — the verification logic only; real devices are tested above."""

    name = "fake"

    def __init__(self, frames, clock="exposure"):
        self.frames = list(frames)
        self.clock = clock

    def grab(self, n, *, timeout_s=1.0):
        if self.frames[0] is None:  # as Aravis and pylon report a frame with packets lost
            self.frames.pop(0)
            raise IncompleteFrame("fake: frame arrived incomplete")
        stamp, mean = self.frames.pop(0)
        return [
            Frame(
                data=np.full((4, 4), mean, np.uint16),
                frame_id=0,
                timestamp_ns=stamp,
                exposure_us=None,
                gain_db=None,
                pixel_format="Mono16",
                bit_depth=16,
                device="fake",
                clock=self.clock,
            )
        ]


def _verified(*args, **kwargs):
    got = list(verified_frames(*args, **kwargs))
    return [f for f, _ in got], got[-1][1]


def test_verification_discards_stale_and_settling_frames():
    cam = FakeCamera([(5, 10), (6, 10), (20, 50), (21, 100), (22, 100), (23, 100)])
    frames, discarded = _verified(
        cam, 3, switched_ns=10, discard_max=5, tolerance=0.02, timeout_s=1
    )
    assert [f.data.mean() for f in frames] == [100, 100, 100]
    assert discarded == {"exposed before the switch": 2, "settling (brightness changed)": 1}


def test_frames_are_handed_out_as_soon_as_verified():
    """A jump on the last frame must not take the verified frames before it with it."""
    jumpy = FakeCamera([(20, 100), (21, 100), (22, 100), (23, 160)])
    got = verified_frames(jumpy, 4, switched_ns=10, discard_max=3, tolerance=0.02, timeout_s=1)
    handed = []
    with pytest.raises(DeviceError, match="brightness jumps"):
        for frame, _ in got:
            handed.append(frame.mean)
    assert handed == [100, 100, 100]


def test_incomplete_frames_are_discarded_and_counted():
    cam = FakeCamera([(20, 100), None, (21, 100), None, (22, 100)])
    frames, discarded = _verified(
        cam, 3, switched_ns=10, discard_max=2, tolerance=0.02, timeout_s=1
    )
    assert [f.data.mean() for f in frames] == [100, 100, 100]
    assert discarded == {"arrived incomplete (data lost on the way)": 2}
    lossy = FakeCamera([(20, 100), None, None, None, (21, 100)])
    with pytest.raises(DeviceError, match=r"3 frames were discarded \(arrived incomplete.*network"):
        _verified(lossy, 2, switched_ns=10, discard_max=2, tolerance=0.02, timeout_s=1)


def test_verification_fails_loudly():
    stale = FakeCamera([(1, 10)] * 10)
    with pytest.raises(
        DeviceError, match=r"4 frames were discarded \(exposed before the switch: 4\)"
    ):
        _verified(stale, 2, switched_ns=10, discard_max=3, tolerance=0.02, timeout_s=1)
    jumpy = FakeCamera([(20, 100), (21, 100), (22, 160), (23, 100), (24, 100)])
    with pytest.raises(DeviceError, match="brightness jumps within a step"):
        _verified(jumpy, 5, switched_ns=10, discard_max=3, tolerance=0.02, timeout_s=1)


def test_frames_without_exposure_timestamps_are_flushed():
    # Four old frames but a flush of three: the settling rule drops the fourth.
    cam = FakeCamera([(0, 10)] * 4 + [(0, 100)] * 3, clock="arrival")
    frames, discarded = _verified(
        cam, 2, switched_ns=10, discard_max=5, tolerance=0.02, timeout_s=1, flush=3
    )
    assert [f.data.mean() for f in frames] == [100, 100]
    assert discarded == {"flushed after the switch": 3, "settling (brightness changed)": 1}


def test_triggered_frames_are_the_ones_triggered_across_an_id_wrap():
    """A triggered frame must carry an id not seen before in the step: a frame handed out
    twice is dropped, while a GigE Vision block id wrapping at 16 bits is not."""
    ids = iter([65534, 65535, 65535, 1, 2])

    def next_frame():
        frame = Frame(
            data=np.full((4, 4), 100, np.uint16),
            frame_id=next(ids),
            timestamp_ns=50,
            exposure_us=None,
            gain_db=None,
            pixel_format="Mono16",
            bit_depth=16,
            device="f",
            clock="device",
        )
        return frame, 20, 0

    frames, discarded = _verified(
        FakeCamera([]),
        4,
        switched_ns=10,
        discard_max=3,
        tolerance=0.02,
        timeout_s=1,
        next_frame=next_frame,
    )
    assert [f.frame_id for f in frames] == [65534, 65535, 1, 2]
    assert discarded == {"not the triggered frame (frame id seen before)": 1}


# The same rules over rounds of several cameras (verified_rounds, the one sequence).


def _frame(mean, *, stamp=50, frame_id=0, chunk=None, textured=False):
    data = np.full((4, 4), mean, np.uint16)
    if textured:
        data[0, 0] += 1  # structure: a repeat of it is a stale camera
    frame = Frame(
        data=data, frame_id=frame_id, timestamp_ns=stamp, exposure_us=None, gain_db=None,
        pixel_format="Mono16", bit_depth=16, device="f", clock="exposure",
    )  # fmt: skip
    if chunk is not None:
        frame.extra["chunk"] = chunk
    return frame


def _rounds(rounds, n, *, chunks=None, discard_max=5):
    """``verified_rounds`` of cameras a and b over ``rounds``: (a's, b's) means, or a
    Frame, None (arrived incomplete) or a str (missed)."""
    it = iter(rounds)
    ids = iter(range(1, 10_000))

    def next_round():
        frames, missed = {}, {}
        for name, x in zip("ab", next(it), strict=True):
            if isinstance(x, str):
                missed[name] = x
            else:
                frames[name] = (
                    x if x is None or isinstance(x, Frame) else _frame(x, frame_id=next(ids))
                )
        return Round(frames, dict.fromkeys(frames, 20), missed)

    got = list(
        verified_rounds(
            ("a", "b"),
            n,
            next_round=next_round,
            switched_ns=10,
            discard_max=discard_max,
            tolerance=0.02,
            chunks=chunks or {},
        )
    )
    return (
        [(r.frames["a"].mean, r.frames["b"].mean) for r, _, _ in got],
        [at for _, at, _ in got],
        got[-1][2],
    )


def test_a_round_with_one_cameras_frame_refused_is_retaken_for_both():
    """b's frame incomplete in round 2, a's exposed before its trigger in round 4: both
    rounds are retaken for both cameras, each counting why; the rounds kept are 1, 3, 5."""
    early = _frame(100, stamp=5, frame_id=900)
    means, at, discarded = _rounds([(100, 80), (100, None), (100, 80), (early, 80), (100, 80)], 3)
    assert means == [(100, 80)] * 3 and at == [1, 3, 5]
    assert discarded["b"][INCOMPLETE] == 1
    assert discarded["a"]["exposed before its trigger"] == 1
    assert discarded["a"]["round retaken (b arrived incomplete (data lost on the way))"] == 1
    assert discarded["b"]["round retaken (a exposed before its trigger)"] == 1


def test_rounds_settle_then_lock_and_a_jump_is_an_error_naming_the_camera():
    """The first round dropped while b's light settles; once two rounds agree, b jumping
    is an error naming b, never a round kept."""
    _, at, discarded = _rounds([(100, 50), (100, 80), (100, 80), (100, 80)], 3)
    assert at == [2, 3, 4] and discarded["b"] == {"settling (brightness changed)": 1}
    with pytest.raises(DeviceError, match=r"cameras 'b': brightness jumps within a step"):
        _rounds([(100, 80), (100, 80), (100, 120), (100, 80)], 4)


def test_with_chunks_a_frame_off_the_level_is_dropped_for_several_cameras_as_for_one():
    """A camera with chunks whose frame leaves the level with its chunk as requested: the
    round is retaken (as one camera's frame is dropped), not an error; b's next frame on
    the level but with the first one's chunk is the lag, named so."""
    chunk = {"b": {"ExposureTime": (1000.0, 1.0)}}
    on = {"ExposureTime": 1000.0}
    rounds = [
        (100, _frame(80, frame_id=1, chunk=on)),
        (100, _frame(80, frame_id=2, chunk=on)),
        (100, _frame(60, frame_id=3, chunk=on)),
        (100, _frame(80, frame_id=4, chunk={"ExposureTime": 750.0})),
        (100, _frame(80, frame_id=5, chunk=on)),
    ]
    _, at, discarded = _rounds(rounds, 3, chunks=chunk)
    assert at == [1, 2, 5]
    assert discarded["b"]["brightness off the step's level, chunk as requested"] == 1
    assert any("chunks lag a frame" in reason for reason in discarded["b"]), discarded["b"]


def test_a_stale_camera_and_too_many_rounds_retaken_end_the_step_naming_it():
    """b handing out its textured frame again is a stale camera, named; a trigger that
    brought b no frame in round after round ends the step after discard_max, naming b."""
    still = _frame(80, frame_id=7, textured=True)
    with pytest.raises(DeviceError, match=r"cameras 'b': frame 7 is identical to the one before"):
        _rounds([(100, still), (100, still)], 2)
    with pytest.raises(DeviceError, match=r"cameras 'b': 3 rounds were retaken \(missed"):
        _rounds([(100, "missed")] * 4, 2, discard_max=2)


def test_settings_changing_while_read_are_named_in_the_capture(simulator, frames, tmp_path):
    """The settings snapshot of a camera whose node keeps changing while it is read: the
    node is left out of the hashed snapshot, listed as unstable, and the capture warns,
    naming it; the frames are captured as usual."""

    class Sweeping(ReplayGrabber):
        def settings(self):
            self.unstable_settings = ("Gamma",)
            return {"PixelFormat": "Mono16"}

    port, _, _ = simulator()
    out = tmp_path / "capture"
    store = CaptureStore(
        out, station_path=tmp_path / "s.yaml", station_sha256="0" * 64, resume=False
    )
    try:
        with GardasoftController(port, channels=4) as controller:
            with Sweeping(frames) as grabber:
                result = capture_steps(controller, grabber, STEPS[:1], store, CameraSettings())
    finally:
        store.release()
    manifest = json.loads((out / "manifest.json").read_text())
    assert manifest["settings"]["unstable"] == ["Gamma"]
    assert manifest["settings"]["values"] == {"PixelFormat": "Mono16"}
    (warning,) = result.warnings
    assert "Gamma changed while the settings were read" in warning
    assert manifest["warnings"] == [warning] and result.steps == {"amber": 3}
