"""The simulated devices, registered as backends like any other
(:mod:`inspect_validate.camera.registry`): a simulated Gardasoft controller process on a
pseudo-terminal, a camera that renders the station's scene under the lights that
controller has on, and the simulators that serve that rendering through a real camera
stack — pylon's camera emulator, Aravis' fake GigE Vision camera."""

from __future__ import annotations

import contextlib
import os
import subprocess
import sys
import tempfile
from collections.abc import Iterator
from pathlib import Path
from typing import TYPE_CHECKING, Any, Literal

from inspect_validate.camera.grabbers.aravis import AravisSettings
from inspect_validate.camera.grabbers.pylon import PylonSettings
from inspect_validate.camera.registry import Backend, Opening
from inspect_validate.camera.settings import AsciiProtocol, CameraSettings, ControllerSettings
from inspect_validate.errors import DeviceError, InputError
from inspect_validate.station.world import Rendered

if TYPE_CHECKING:
    # The sections a station file reads for a camera with a simulator: the backend's
    # settings and Rendered's (station.file composes them at run time).
    class RenderedPylon(PylonSettings, Rendered): ...

    class RenderedAravis(AravisSettings, Rendered): ...

    from inspect_validate.camera.controllers.base import LedController
    from inspect_validate.camera.grabbers.base import Grabber

__all__ = [
    "ARAVIS_FAKE",
    "PYLON_EMULATOR",
    "SIMULATED_CAMERA",
    "SIMULATED_CONTROLLER",
    "SimulatedCameraSettings",
    "SimulatedControllerSettings",
]


class SimulatedControllerSettings(ControllerSettings):
    """A simulated Gardasoft controller, started as its own process on a pseudo-terminal."""

    backend: Literal["simulated"]
    """A simulated Gardasoft controller on a pseudo-terminal (no hardware)."""
    protocol: AsciiProtocol | None = None
    """Drive the simulator with the generic ASCII driver in its line dialect instead."""
    simulator_args: list[str] = []
    """Faults for the simulator (tests), e.g. ``["--vanish-after", "5"]``."""


class SimulatedCameraSettings(CameraSettings, Rendered):
    """A camera that renders the station's scene, lit by the simulated controller."""

    backend: Literal["simulated"]
    """A camera rendering the station's scene and simulated world (no hardware)."""


@contextlib.contextmanager
def open_simulated_controller(
    settings: SimulatedControllerSettings, opening: Opening
) -> Iterator[LedController]:
    """Start the simulated Gardasoft process on a pseudo-terminal and talk to it over
    pyserial; the controller yielded carries ``state_path``, the simulator's state file
    (which lights are on) that a simulated camera renders under."""
    from inspect_validate.camera.controllers import GardasoftController
    from inspect_validate.camera.controllers.generic import protocol_controller

    with tempfile.TemporaryDirectory(prefix="iv-sim-") as tmp:
        state = Path(tmp) / "state.json"
        proc = subprocess.Popen(
            [
                sys.executable,
                "-m",
                "inspect_validate.simulation.controller",
                "--state",
                str(state),
                "--channels",
                str(settings.channels),
                "--parent",
                str(os.getpid()),
                *settings.simulator_args,
            ],
            stdout=subprocess.PIPE,
            text=True,
            # Its own session: a Ctrl-C or SIGTERM to the terminal's process group reaches
            # the tool, which ends the cycle and then the controller, not the controller
            # first (which would read as an unplugged device).
            start_new_session=True,
        )
        try:
            assert proc.stdout is not None  # stdout=PIPE
            port = proc.stdout.readline().strip()
            if not port:
                raise DeviceError("the simulated controller did not start")
            controller: Any
            if settings.protocol is not None:  # the generic driver, e.g. --dialect line
                controller = protocol_controller(port, settings.protocol, settings)
            else:
                controller = GardasoftController(
                    port, channels=settings.channels, timeout=settings.timeout_s
                )
            controller.state_path = state
            with controller:
                yield controller
        finally:
            proc.kill()
            proc.wait()
            if proc.stdout is not None:
                proc.stdout.close()  # else a ResourceWarning reaches the terminal


def open_simulated_camera(settings: SimulatedCameraSettings, opening: Opening) -> Grabber:
    from inspect_validate.simulation.camera import scene_grabber

    return scene_grabber(opening.station, opening.state, opening.target)


def open_pylon_emulator(settings: RenderedPylon, opening: Opening) -> Grabber:
    """The station's simulated scene through pylon's camera emulator (``simulate: true``)."""
    from inspect_validate.camera.grabbers.emulator_feed import EmulatorFeed
    from inspect_validate.camera.grabbers.pylon import PylonGrabber
    from inspect_validate.simulation.camera import scene_grabber

    station = opening.station
    renderer = scene_grabber(station, opening.state, opening.target)
    # Enough noise realisations that no step's frames repeat, even after discards.
    per_light = (
        max(station.frames, station.dark_frames) + station.discard_max + settings.flush_frames
    )
    return EmulatorFeed(
        PylonGrabber(serial=settings.serial, index=settings.index),
        renderer,
        frames_per_light=per_light,
    )


@contextlib.contextmanager
def open_aravis_fake(settings: RenderedAravis, opening: Opening) -> Iterator[Grabber]:
    """Aravis' fake GigE Vision camera in a process of its own on ``lo``, streaming the
    station's scene under the simulated controller's lights, opened through Aravis
    (``simulate: true``)."""
    from inspect_validate.camera.grabbers.aravis import AravisGrabber
    from inspect_validate.simulation.camera import lit_by_simulator
    from inspect_validate.simulation.fake_gige import SENSOR as FAKE_SENSOR

    station = opening.station
    lit_by_simulator(station, opening.state)  # the renderer is built in the camera's process
    if settings.width > FAKE_SENSOR or settings.height > FAKE_SENSOR:
        raise InputError(
            f"camera.width/height {settings.width}×{settings.height} exceed the fake GigE "
            f"camera's {FAKE_SENSOR}×{FAKE_SENSOR} sensor",
            source=opening.source,
        )
    if settings.acquisition == "hardware-trigger":
        raise InputError(
            "camera.acquisition: hardware-trigger cannot run on Aravis' fake camera: its "
            f"{settings.trigger_line or 'trigger'} input has no wire from the simulated "
            "controller's trigger output; use software-trigger or free-run (or "
            "camera.backend: simulated, which models the wiring)",
            source=opening.source,
        )
    if settings.strobe_line is not None:
        raise InputError(
            f"camera.strobe_line: Aravis' fake camera has no {settings.strobe_line} output "
            "wired to the simulated controller; leave out strobe_line and controller.pulse, "
            "keeping camera.acquisition: software-trigger (or camera.backend: simulated, "
            "which models the wiring)",
            source=opening.source,
        )
    # One per tool process at a time, and the same on each opening: a capture is resumed,
    # and characterize's series continued, only with the camera that began it.
    name = getattr(settings, "name", None)  # a camera among several: each its own serial
    serial = f"IV{os.getpid()}" + (f"-{name}"[:12] if name else "")
    proc = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "inspect_validate.simulation.fake_gige",
            serial,
            "--station",
            str(station.path),
            "--state",
            str(opening.state),
            "--target",
            opening.target,
            # the world as it is now (watch schedules changes per cycle), not as filed
            "--world",
            settings.world.model_dump_json(),
            "--interface",
            settings.simulate_interface,
            "--parent",
            str(os.getpid()),
        ],
        stdout=subprocess.PIPE,
        text=True,
        start_new_session=True,  # as the simulated controller: the tool takes Ctrl-C
    )
    try:
        assert proc.stdout is not None  # stdout=PIPE
        if proc.stdout.readline().strip() != "ready":
            raise DeviceError(
                f"Aravis' fake GigE Vision camera did not start on {settings.simulate_interface} "
                "(is libaravis-0.8 installed? is camera.simulate_interface an interface or "
                "one of its addresses?)"
            )
        with AravisGrabber(serial=serial, num_buffers=settings.num_buffers) as camera:
            yield camera
    finally:
        proc.kill()
        proc.wait()
        if proc.stdout is not None:
            proc.stdout.close()


SIMULATED_CONTROLLER = Backend("simulated", SimulatedControllerSettings, open_simulated_controller)
SIMULATED_CAMERA = Backend("simulated", SimulatedCameraSettings, open_simulated_camera)


PYLON_EMULATOR = Backend("pylon", PylonSettings, open_pylon_emulator)
ARAVIS_FAKE = Backend("aravis", AravisSettings, open_aravis_fake)
