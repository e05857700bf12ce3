"""Opening the camera and light controller a station file describes."""

from __future__ import annotations

import contextlib
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
            "(see README, 'Station files')",
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


def _scene_renderer(station: Station, state_path: Path | None, target: str = "scene"):
    """The simulated camera of the station's scene, lit by the simulated controller's state."""
    spec = station.camera
    if state_path is None:
        raise InputError(
            f"a camera that renders the scene ({spec.backend}) needs the simulated controller "
            "(controller.backend: simulated)",
            source=str(station.path),
        )
    from inspect_validate.camera.grabbers.simulated import SimulatedCamera

    from inspect_validate.model.illumination import station_model

    return SimulatedCamera(
        station_model(station),
        state_path,
        world=spec.world,
        width=spec.width,
        height=spec.height,
        latency=spec.latency,
        target=target,
    )


def _open_camera(station: Station, state_path: Path | None, controller, target="scene"):
    spec = station.camera
    if spec.backend == "simulated":
        return _scene_renderer(station, state_path, target)
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

            renderer = _scene_renderer(station, state_path, target)
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
