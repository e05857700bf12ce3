"""Opening the camera and light controller a station file describes."""

from __future__ import annotations

import contextlib
import os
import subprocess
import sys
import tempfile
from pathlib import Path

from inspect_validate.camera.station import Station

from inspect_validate.errors import DeviceError, InputError

__all__ = ["open_devices"]


@contextlib.contextmanager
def _simulated_controller(station: Station):
    """Start the simulated Gardasoft process on a pseudo-terminal and talk to it over pyserial."""
    from inspect_validate.camera.lights import GardasoftController

    with tempfile.TemporaryDirectory(prefix="iv-sim-") as tmp:
        state = Path(tmp) / "state.json"
        proc = subprocess.Popen(
            [
                sys.executable,
                "-m",
                "inspect_validate.camera.lights.simulator",
                "--state",
                str(state),
                "--channels",
                str(station.controller.channels),
                *station.controller.simulator_args,
            ],
            stdout=subprocess.PIPE,
            text=True,
            # Its own session: a Ctrl-C or SIGTERM to the terminal's process group reaches
            # the tool, which ends the cycle and then the controller, not the controller
            # first (which would read as an unplugged device).
            start_new_session=True,
        )
        try:
            port = proc.stdout.readline().strip()
            if not port:
                raise DeviceError("the simulated controller did not start")
            if station.controller.protocol is not None:  # the generic driver, e.g. --dialect line
                ctl = _generic_controller(station, port)
            else:
                ctl = GardasoftController(
                    port, channels=station.controller.channels, timeout=station.controller.timeout_s
                )
            with ctl:
                yield ctl, state
        finally:
            proc.kill()
            proc.wait()
            proc.stdout.close()  # else a ResourceWarning reaches the terminal


@contextlib.contextmanager
def open_devices(station: Station, *, target: str = "scene"):
    """Yield (controller, camera) for the station, closing both afterwards. ``target``:
    what a camera that renders the scene shows (``"uniform"``: a white target filling
    the frame, as for ``characterize``; real cameras see what is there)."""
    spec = station.controller
    with contextlib.ExitStack() as stack:
        state_path = None
        if spec.backend == "simulated":
            controller, state_path = stack.enter_context(_simulated_controller(station))
        elif spec.backend == "gardasoft":
            if not spec.port:
                raise InputError(
                    "controller.port is required for a Gardasoft controller",
                    source=str(station.path),
                )
            from inspect_validate.camera.lights import GardasoftController

            controller = stack.enter_context(
                GardasoftController(
                    spec.port,
                    channels=spec.channels,
                    timeout=spec.timeout_s,
                    error_codes=spec.error_codes,
                )
            )
        elif spec.backend == "generic":
            controller = stack.enter_context(_generic_controller(station, spec.port))
        else:
            from inspect_validate.camera.lights.manual import ManualController

            controller = stack.enter_context(ManualController(channels=spec.channels))
        camera = stack.enter_context(_open_camera(station, state_path, controller, target))
        yield controller, camera


def _generic_controller(station: Station, port: str | None):
    spec = station.controller
    if not port or spec.protocol is None:
        raise InputError(
            "controller.port and controller.protocol are required for a generic controller "
            "(see the manual, 'Station files')",
            source=str(station.path),
        )
    from inspect_validate.camera.lights.generic import GenericAsciiController

    proto = spec.protocol
    return GenericAsciiController(
        port,
        commands=proto.commands,
        channels=spec.channels,
        max_value=proto.max_value,
        baudrate=proto.baudrate,
        terminator=proto.terminator.encode(),
        reply_end=proto.reply_end.encode(),
        ok=proto.ok.encode() if proto.ok is not None else None,
        error=proto.error.encode(),
        timeout=spec.timeout_s,
        error_codes=spec.error_codes,
    )


@contextlib.contextmanager
def _fake_gige(station: Station, state_path: Path | None, target: str):
    """Aravis' fake GigE Vision camera in a process of its own on ``lo``, streaming the
    station's scene under the simulated controller's lights, opened through Aravis."""
    from inspect_validate.camera.grabbers.aravis import AravisCamera
    from inspect_validate.camera.grabbers.fake_gige import SENSOR as FAKE_SENSOR
    from inspect_validate.camera.grabbers.simulated import lit_by_simulator

    lit_by_simulator(station, state_path)  # the renderer itself is built in the camera's process
    spec = station.camera
    if spec.width > FAKE_SENSOR or spec.height > FAKE_SENSOR:
        raise InputError(
            f"camera.width/height {spec.width}×{spec.height} exceed the fake GigE camera's "
            f"{FAKE_SENSOR}×{FAKE_SENSOR} sensor",
            source=str(station.path),
        )
    if spec.acquisition == "hardware-trigger":
        raise InputError(
            "camera.acquisition: hardware-trigger cannot run on Aravis' fake camera: its Line0 "
            "has no wire from the simulated controller's trigger output; use software-trigger "
            "or free-run (or camera.backend: simulated, which models the wiring)",
            source=str(station.path),
        )
    # One per tool process at a time, and the same on each opening: a capture is resumed,
    # and characterize's series continued, only with the camera that began it.
    serial = f"IV{os.getpid()}"
    proc = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "inspect_validate.camera.grabbers.fake_gige",
            serial,
            "--station",
            str(station.path),
            "--state",
            str(state_path),
            "--target",
            target,
            # the world as it is now (watch schedules changes per cycle), not as filed
            "--world",
            station.camera.world.model_dump_json(),
        ],
        stdout=subprocess.PIPE,
        text=True,
        start_new_session=True,  # as the simulated controller: the tool takes Ctrl-C
    )
    try:
        if proc.stdout.readline().strip() != "ready":
            raise DeviceError(
                "Aravis' fake GigE Vision camera did not start (is libaravis-0.8 installed?)"
            )
        with AravisCamera(serial=serial, num_buffers=spec.num_buffers) as camera:
            yield camera
    finally:
        proc.kill()
        proc.wait()
        proc.stdout.close()


def _open_camera(station: Station, state_path: Path | None, controller, target="scene"):
    spec = station.camera
    if spec.backend == "simulated":
        from inspect_validate.camera.grabbers.simulated import scene_camera

        return scene_camera(station, state_path, target)
    if spec.backend == "genicam":
        from inspect_validate.camera.grabbers.genicam import GenICamCamera

        cti = str(station.resolve(spec.cti)) if spec.cti else None
        return GenICamCamera(
            cti, serial=spec.serial, index=spec.index, num_buffers=spec.num_buffers
        )
    if spec.backend == "pylon":
        from inspect_validate.camera.grabbers.pylon import PylonCamera

        if spec.simulate:  # the simulated station through pylon's camera emulator
            from inspect_validate.camera.grabbers.emulator_feed import EmulatorFeed
            from inspect_validate.camera.grabbers.simulated import scene_camera

            renderer = scene_camera(station, state_path, target)
            # Enough noise realisations that no step's frames repeat, even after discards.
            per_light = (
                max(station.frames, station.dark_frames) + station.discard_max + spec.flush_frames
            )
            return EmulatorFeed(
                PylonCamera(serial=spec.serial, index=spec.index),
                renderer,
                frames_per_light=per_light,
            )
        return PylonCamera(serial=spec.serial, index=spec.index)
    if spec.backend == "aravis":
        from inspect_validate.camera.grabbers.aravis import AravisCamera

        if spec.simulate:
            return _fake_gige(station, state_path, target)
        return AravisCamera(
            serial=spec.serial,
            device_id=spec.device_id,
            index=spec.index,
            num_buffers=spec.num_buffers,
            gain_raw=spec.gain_raw,
        )
    if spec.backend == "replay":
        if not spec.folder:
            raise InputError(
                "camera.folder is required for the replay camera", source=str(station.path)
            )
        from inspect_validate.camera.grabbers.replay import ReplayCamera

        return ReplayCamera(station.resolve(spec.folder), lights=lambda: controller.applied)
    from inspect_validate.camera.grabbers.v4l2 import V4l2Camera

    return V4l2Camera(spec.device if spec.device is not None else spec.index)
