"""Station files: camera, light controller, illuminations and frame counts (YAML).

The one description of a station that ``capture``, ``verify`` and ``train``
read: what is in front of the camera (``scene``, ``rois``), what each controller
channel drives (``channels``), the camera settings the prediction uses, and
what the station must achieve (``acceptance``). Example (the manual, "Station files")::

    name: paperboard station
    scene: ../scenes/paperboard/scene.yaml
    rois: rois.yaml
    channels:                       # controller channel → scene light
      1: {light: amber LED, irradiance: 5.0}    # W/m² at the object at 100 %
      2: red LED
    camera:
      backend: simulated            # simulated | genicam | pylon | aravis | v4l2 | replay
      exposure_us: 20000
      gain_db: 0
    controller:
      backend: simulated            # simulated | gardasoft | generic | manual
      channels: 2
    illuminations:
      - {name: amber, channels: {1: 100}}
      - {name: red, channels: {2: 100}}
    frames: 4                       # per illumination (the most, with precision:)
    precision: {mean: 0.001, variance: 0.01}   # optional: stop once μ and σ² are known
    dark_frames: 4
"""

from __future__ import annotations

import hashlib
from pathlib import Path
from typing import Annotated, Literal

from pydantic import (
    BeforeValidator,
    Field,
    field_validator,
    model_validator,
)

from inspect_validate.acceptance import Acceptance, Calibration
from inspect_validate.comparisons import ComparisonsSpec
from inspect_validate.config import StrictModel, load_yaml, one_of
from inspect_validate.scene import Irradiance

__all__ = [
    "ChannelLight",
    "Precision",
    "Pulse",
    "Station",
    "World",
    "WorldChange",
    "read_station",
    "simulated_at",
    "station_hash",
    "write_station",
]


Seconds = Annotated[float, Field(gt=0, le=3600, allow_inf_nan=False)]
Channel = Annotated[int, Field(ge=1, le=64)]
Microseconds = Annotated[float, Field(ge=0, le=1e8, allow_inf_nan=False)]
Line = Annotated[str, Field(pattern=r"^Line[0-9]{1,2}$")]


class _CameraCommon(StrictModel):
    model: str | None = None
    """Which of the scene's cameras this is (default: its only one)."""
    exposure_us: Annotated[float, Field(gt=0, le=1e8, allow_inf_nan=False)] | None = None
    """Exposure time set on the camera, µs (default: the camera's own)."""
    gain_db: Annotated[float, Field(ge=-60, le=100, allow_inf_nan=False)] | None = None
    """Analogue gain set on the camera, dB (default: the camera's own)."""
    pixel_format: str | None = None
    """A monochrome pixel format (``Mono8``, ``Mono12``, ``Mono16``…; default: the camera's)."""
    timeout_s: Seconds = 2.0
    """How long to wait for a frame before the camera counts as failed (exit 3)."""
    flush_frames: Annotated[int, Field(ge=0, le=1000)] = 4
    """Frames dropped after a switch by a camera that cannot restart its stream (V4L2,
    replay)."""
    acquisition: Literal["auto", "free-run", "software-trigger", "hardware-trigger"] = "auto"
    """How frames start (the user guide's "Real stations"); ``auto``: ``software-trigger`` where
    the camera has ``TriggerSoftware``, else ``free-run``."""
    settle_ms: Annotated[float, Field(ge=0, le=60_000, allow_inf_nan=False)] = 0.0
    """Triggered: wait this long after the controller confirms a switch, before the
    first trigger (a light that takes time to reach its level)."""
    trigger_line: Line | None = None
    """``hardware-trigger``: the input line the controller's trigger output drives."""
    trigger_delay_us: Microseconds = 0.0
    """``hardware-trigger``: the camera's ``TriggerDelay``, from the pulse to the exposure."""
    strobe_line: Line | None = None
    """The output line that carries ``ExposureActive`` to the controller's trigger
    input; the illuminations' channels then flash (``controller.pulse``)."""
    chunks: bool | None = None
    """Append exposure, gain, timestamp and frame id to every frame and check them;
    default: where the camera offers chunks. ``true`` refuses a camera without."""
    measured: str | None = None
    """A camera file written by ``characterize``: its EMVA 1288 values replace the scene
    camera's in every prediction of this station (the QE stays the scene's)."""

    @field_validator("pixel_format")
    @classmethod
    def _mono(cls, v):
        from inspect_validate.camera.pixelformats import BIT_DEPTH

        if v is not None and v not in BIT_DEPTH:
            raise ValueError(f"{v!r} is not a monochrome format; use one of {', '.join(BIT_DEPTH)}")
        return v


Factor = Annotated[float, Field(gt=0, le=100, allow_inf_nan=False)]
Percent = Annotated[float, Field(gt=-100, lt=100, allow_inf_nan=False)]
ShiftNm = Annotated[float, Field(ge=-200, le=200, allow_inf_nan=False)]
Transmission = Annotated[float, Field(gt=0, le=2, allow_inf_nan=False)]
BlurPx = Annotated[float, Field(ge=0, le=50, allow_inf_nan=False)]


class WorldChange(StrictModel):
    """A change of the simulated world from cycle ``start`` of ``watch`` on (to ``stop``,
    exclusive, if given): a step (factors), a gradual drift (% per cycle or per hour,
    compounding from the start) or a device fault. A station that is ageing, soiled or
    faulty on a schedule, for ``watch`` to notice."""

    start: Annotated[int, Field(ge=0)] = 0
    stop: Annotated[int, Field(ge=1)] | None = None
    irradiance: dict[Channel, Factor] = {}
    """Step: factor on the channel's irradiance (an LED replaced by a weaker one)."""
    percent_per_cycle: dict[Channel, Percent] = {}
    """Drift: the channel's output changes by this % every cycle (LED ageing: negative)."""
    percent_per_hour: dict[Channel, Percent] = {}
    """Drift: the channel's output changes by this % every hour of the watch."""
    peak_shift_nm: dict[Channel, ShiftNm] = {}
    """Step: the channel's spectrum shifted by this many nm more."""
    exposure: Factor | None = None
    """Step: factor on the light every frame collects (someone changed exposure or gain)."""
    transmission: Transmission | None = None
    """Step: factor on the lens transmission (a soiled lens)."""
    blur_px: BlurPx | None = None
    """Step: Gaussian blur σ in pixels (defocus: the classes bleed into each other)."""
    camera_timeout: bool = False
    """Fault: the camera delivers no frame (its grab times out)."""
    frozen: bool = False
    """Fault: the camera repeats one frame (a stale image from a hung driver)."""
    controller_faults: list[str] = []
    """Fault: arguments for the simulated controller, e.g. ``["--garbage-after", "2"]``."""

    def active(self, cycle: int) -> bool:
        return cycle >= self.start and (self.stop is None or cycle < self.stop)


class World(StrictModel):
    """How the simulated world differs from the station's scene.

    A simulator rendered from the very scene it is checked against can only
    agree with it; these deviations make the simulated station a reality that
    the verification has to notice or calibrate away. Per-channel entries are
    keyed by controller channel.
    """

    irradiance: dict[Channel, Annotated[float, Field(gt=0, le=100, allow_inf_nan=False)]] = {}
    """Factor on the channel's irradiance at the object (a dimmer or farther light)."""
    peak_shift_nm: dict[Channel, ShiftNm] = {}
    """The channel's spectrum shifted by this many nm (an LED drifted from its datasheet)."""
    width_scale: dict[Channel, Annotated[float, Field(ge=0.2, le=5, allow_inf_nan=False)]] = {}
    """The channel's spectrum stretched about its peak (FWHM × this factor)."""
    reflectance_seed: Annotated[int, Field(ge=0)] | None = None
    """The objects are another draw (bootstrap) from each class's reflectance samples."""
    irradiance_jitter: Annotated[float, Field(ge=0, le=0.5, allow_inf_nan=False)] = 0.0
    """Relative standard deviation of each channel's irradiance from one capture to the
    next (a driver's current, an LED's temperature): the spread between captures that a
    golden file's repeats must learn."""
    transmission: Transmission = 1.0
    """Factor on the lens transmission."""
    vignetting: Annotated[float, Field(ge=0, lt=1, allow_inf_nan=False)] = 0.0
    """Relative irradiance lost at the frame's corners (quadratic in the radius)."""
    ambient: Annotated[float, Field(ge=0, le=1000, allow_inf_nan=False)] = 0.0
    """W/m² of equal-energy light over 380–780 nm at the object, always on (also in darks)."""
    gain_error: Annotated[float, Field(gt=-0.9, lt=10, allow_inf_nan=False)] = 0.0
    """Relative error of the system gain K against the camera's declared one."""
    black_level: Annotated[float, Field(ge=0, le=60_000, allow_inf_nan=False)] | None = None
    """The sensor's real black level (dark offset), DN; default the declared one."""
    dark_current: Annotated[float, Field(ge=0, le=1e7, allow_inf_nan=False)] | None = None
    """The sensor's real dark current, e⁻/s; default the declared one."""
    dsnu: Annotated[float, Field(ge=0, le=1e5, allow_inf_nan=False)] | None = None
    """The sensor's real dark signal non-uniformity, e⁻ rms; default the declared one."""
    prnu: Annotated[float, Field(ge=0, le=0.5, allow_inf_nan=False)] | None = None
    """The sensor's real photo-response non-uniformity, relative rms; default the declared."""
    exposure: Factor = 1.0
    """Factor on the light every frame collects (the exposure the camera really uses)."""
    blur_px: BlurPx = 0.0
    """Gaussian blur σ of the image, pixels (defocus)."""
    camera_timeout: bool = False
    """The camera delivers no frame."""
    frozen: bool = False
    """The camera repeats its first frame."""
    exposure_glitch_every: Annotated[int, Field(ge=0, le=1000)] = 0
    """Every n-th frame is exposed at half the set exposure (a setting applied late),
    its chunk saying so; 0: never."""
    chunk_lag: bool = False
    """Chunks carry the previous frame's values (a known firmware fault)."""
    changes: list[WorldChange] = []
    """Changes over the cycles of ``watch`` (:meth:`at`)."""

    def at(self, cycle: int, *, hours: float = 0.0) -> World:
        """This world at ``watch``'s cycle ``cycle``, ``hours`` after it started: every
        active change applied, none left to apply."""
        import math

        w = self.model_dump(exclude={"changes"})
        for c in self.changes:
            if not c.active(cycle):
                continue
            n = cycle - c.start
            for ch in {*c.irradiance, *c.percent_per_cycle, *c.percent_per_hour}:
                factor = c.irradiance.get(ch, 1.0)
                factor *= (1 + c.percent_per_cycle.get(ch, 0.0) / 100) ** n
                # hours since the change began, as far as the cycles tell (uniform cycles)
                since = hours * n / cycle if cycle else 0.0
                factor *= math.exp(math.log1p(c.percent_per_hour.get(ch, 0.0) / 100) * since)
                w["irradiance"][ch] = w["irradiance"].get(ch, 1.0) * factor
            for ch, nm in c.peak_shift_nm.items():
                w["peak_shift_nm"][ch] = w["peak_shift_nm"].get(ch, 0.0) + nm
            if c.exposure is not None:
                w["exposure"] *= c.exposure
            if c.transmission is not None:
                w["transmission"] = min(w["transmission"] * c.transmission, 2.0)
            if c.blur_px is not None:
                w["blur_px"] = max(w["blur_px"], c.blur_px)
            w["camera_timeout"] |= c.camera_timeout
            w["frozen"] |= c.frozen
        # a drift schedule may not push a factor out of its range
        w["irradiance"] = {ch: min(max(f, 1e-6), 100.0) for ch, f in w["irradiance"].items()}
        return World(**w)

    def controller_faults(self, cycle: int) -> list[str]:
        """The simulated controller's fault arguments at ``cycle``."""
        return [a for c in self.changes if c.active(cycle) for a in c.controller_faults]


class _Rendered(StrictModel):
    """A camera that renders the station's scene (simulated, fed into pylon's emulator, or
    streamed by Aravis' fake GigE Vision camera)."""

    width: Annotated[int, Field(ge=16, le=20000)] = 320
    height: Annotated[int, Field(ge=16, le=20000)] = 240
    latency: Annotated[int, Field(ge=0, le=100)] = 2
    world: World = World()


class SimulatedCameraSpec(_CameraCommon, _Rendered):
    backend: Literal["simulated"]


class GenicamCameraSpec(_CameraCommon):
    backend: Literal["genicam"]
    cti: str | None = None
    serial: str | None = None
    index: Annotated[int, Field(ge=0)] = 0
    num_buffers: Annotated[int, Field(ge=1, le=1000)] | None = None  # harvesters' default else


class PylonCameraSpec(_CameraCommon, _Rendered):
    backend: Literal["pylon"]
    serial: str | None = None
    index: Annotated[int, Field(ge=0)] = 0
    # render the station's scene into pylon's camera emulator (PYLON_CAMEMU=1)
    simulate: bool = False


class AravisCameraSpec(_CameraCommon, _Rendered):
    backend: Literal["aravis"]
    # stream the station's scene from Aravis' fake GigE Vision camera on lo
    simulate: bool = False
    serial: str | None = None
    device_id: str | None = None  # Aravis' id, e.g. Aravis-Fake-TEST1 (arv-tool-0.8 lists them)
    index: Annotated[int, Field(ge=0)] = 0
    num_buffers: Annotated[int, Field(ge=1, le=1000)] = 8
    gain_raw: Annotated[int, Field(ge=0, le=1_000_000)] | None = None  # GainRaw, camera units


class V4l2CameraSpec(_CameraCommon):
    backend: Literal["v4l2"]
    device: str | int | None = None
    index: Annotated[int, Field(ge=0)] = 0


class ReplayCameraSpec(_CameraCommon):
    backend: Literal["replay"]
    folder: str


CameraSpec = one_of(
    {
        "simulated": SimulatedCameraSpec,
        "genicam": GenicamCameraSpec,
        "pylon": PylonCameraSpec,
        "aravis": AravisCameraSpec,
        "v4l2": V4l2CameraSpec,
        "replay": ReplayCameraSpec,
    },
    what="camera",
    field="backend",
)


_TEMPLATE_FIELDS = {
    "channel": 1,
    "percent": 50.0,
    "value": 50.0,
    "width_us": 100.0,
    "delay_us": 0.0,
}


class AsciiProtocol(StrictModel):
    """A generic ASCII controller's protocol (:mod:`inspect_validate.camera.lights.generic`)."""

    commands: dict[Literal["set", "off", "pulse", "trigger", "status", "init"], str | list[str]]
    """Command templates with the fields ``{channel}``, ``{percent}``, ``{value}``,
    ``{width_us}``, ``{delay_us}``: ``set`` is required; ``init`` may be a list."""
    baudrate: int = Field(default=115200, gt=0)
    """Serial line speed (a TCP port ignores it)."""
    terminator: str = Field(default="\r", min_length=1)
    """Appended to every command sent."""
    reply_end: str = Field(default="\r\n", min_length=1)
    """What ends a reply."""
    ok: str | None = None
    """Regular expression a reply must match to be a success (default: any reply that is
    not an error)."""
    error: str = r"(?i)err\w*\s*(\d+)"
    """Regular expression of an error reply; its first group is the error code."""
    max_value: float = Field(default=100.0, gt=0)
    """The ``{value}`` sent for 100 % (``{value}`` = percent × max_value / 100)."""

    @field_validator("commands")
    @classmethod
    def _templates(cls, v):
        if "set" not in v:
            raise ValueError("a 'set' template is required, e.g. 'SET {channel} {value:.0f}'")
        for key, template in v.items():
            lines = [template] if isinstance(template, str) else template
            if key != "init" and not isinstance(template, str):
                raise ValueError(f"{key}: one command template, not a list")
            for line in lines:
                try:
                    line.format(**_TEMPLATE_FIELDS)
                except (KeyError, IndexError, ValueError) as exc:
                    raise ValueError(
                        f"{key}: template {line!r} does not format ({exc!r}); "
                        f"fields are {{{'}, {'.join(_TEMPLATE_FIELDS)}}}"
                    ) from None
        return v

    @field_validator("ok", "error")
    @classmethod
    def _regex(cls, v):
        import re

        if v is not None:
            try:
                re.compile(v)
            except re.error as exc:
                raise ValueError(f"not a regular expression: {exc}") from None
        return v


class Pulse(StrictModel):
    """The controller's pulse (strobe) mode: Gardasoft ``RTc,width,delay,%``, the generic
    protocol's ``pulse`` template. Each trigger lights the channel ``width_us`` long,
    ``delay_us`` after the trigger."""

    width_us: Annotated[float, Field(gt=0, le=1e7, allow_inf_nan=False)]
    delay_us: Microseconds = 0.0
    max_duty: Annotated[float, Field(gt=0, le=1, allow_inf_nan=False)] = 1.0
    """The most the light may be on (width / trigger period; an overdriven LED's
    datasheet limit): the capture spaces triggers at least ``width_us / max_duty``."""
    trigger_channel: Channel = 1
    """``hardware-trigger``: the channel whose trigger (Gardasoft ``TRc``, the generic
    ``trigger`` template) fires the lights and, through the controller's trigger
    output, the camera's ``trigger_line``."""


class _ControllerCommon(StrictModel):
    channels: Annotated[int, Field(ge=1, le=64)] = 4
    """How many output channels the controller has."""
    timeout_s: Seconds = 1.0
    """How long to wait for a reply before the controller counts as gone (exit 3)."""
    error_codes: dict[int, str] = {}
    """Meanings of the controller's error codes, shown in messages (``{21: over-current}``)."""
    pulse: Pulse | None = None
    """Strobe the lights instead of lighting them continuously."""


class SimulatedControllerSpec(_ControllerCommon):
    """A simulated Gardasoft controller, started as its own process on a pseudo-terminal."""

    backend: Literal["simulated"]
    protocol: AsciiProtocol | None = None
    """Drive the simulator with the generic ASCII driver in its line dialect instead."""
    simulator_args: list[str] = []
    """Faults for the simulator (tests), e.g. ``["--vanish-after", "5"]``."""


class GardasoftControllerSpec(_ControllerCommon):
    """A Gardasoft RT-series controller."""

    backend: Literal["gardasoft"]
    port: Annotated[str, Field(min_length=1)]
    """Serial port (``/dev/ttyUSB0``, ``COM3``) or a pyserial URL (``socket://host:port`` on Ethernet)."""


class GenericControllerSpec(_ControllerCommon):
    """Any controller that speaks lines of ASCII, described by ``protocol``."""

    backend: Literal["generic"]
    port: Annotated[str, Field(min_length=1)]
    """Serial port (``/dev/ttyUSB0``, ``COM3``) or a pyserial URL (``socket://host:port`` on Ethernet)."""
    protocol: AsciiProtocol
    """The command templates and reply patterns."""


class ManualControllerSpec(StrictModel):
    """No controller: the capture asks the operator to switch each illumination."""

    backend: Literal["manual"]
    channels: Annotated[int, Field(ge=1, le=64)] = 4
    """How many lights the operator switches."""


ControllerSpec = one_of(
    {
        "simulated": SimulatedControllerSpec,
        "gardasoft": GardasoftControllerSpec,
        "generic": GenericControllerSpec,
        "manual": ManualControllerSpec,
    },
    what="controller",
    field="backend",
)


class ChannelLight(StrictModel):
    """What a controller channel drives: a light of the station's scene."""

    light: Annotated[str, Field(min_length=1)]
    """The scene light's name."""
    irradiance: Irradiance | None = None
    """W/m² at the object at 100 % (default: the scene light's own ``irradiance``)."""


def _channel_shorthand(v):
    return {"light": v} if isinstance(v, str) else v


class Illumination(StrictModel):
    """One lighting state to capture: which channels are on, and at what drive level."""

    name: str = Field(pattern=r"^[A-Za-z0-9_.-]+$", max_length=100)
    """The step's name: its frames go to ``OUT/<name>/``."""
    channels: dict[Channel, Annotated[float, Field(ge=0, le=100, allow_inf_nan=False)]]
    """Channel → drive level, % (channels not named are off)."""


class Precision(StrictModel):
    """Sequential stopping (:mod:`~inspect_validate.camera.stopping`): ``frames`` becomes
    the most an illumination gets; it ends once every class's μ and σ² are known to
    these relative standard errors."""

    mean: Annotated[float, Field(gt=0, lt=1, allow_inf_nan=False)]
    """Relative standard error of every class's μ to reach."""
    variance: Annotated[float, Field(gt=0, lt=1, allow_inf_nan=False)]
    """Relative standard error of every class's σ² to reach."""
    min_frames: Annotated[int, Field(ge=3, le=100_000)] = 3
    """Frames each illumination gets at least."""


class Characterize(StrictModel):
    """How ``characterize`` measures the camera (EMVA 1288): the light of the exposure
    series, its points, the frames of the spatial stacks and the analysed region."""

    illumination: str | None = None
    """The station's illumination that lights the series (default: its first)."""
    points: Annotated[int, Field(ge=8, le=1000)] = 50
    """Exposure times of the photon transfer series, dark to saturation."""
    frames_spatial: Annotated[int, Field(ge=2, le=10_000)] = 16
    """Frames averaged for the spatial (DSNU, PRNU) stacks."""
    region: (
        tuple[
            Annotated[int, Field(ge=0)],
            Annotated[int, Field(ge=0)],
            Annotated[int, Field(ge=1)],
            Annotated[int, Field(ge=1)],
        ]
        | None
    ) = None
    """x, y, width, height of the uniformly lit area analysed (default: the frame)."""


class Station(StrictModel):
    """A station: its camera, its light controller, the illuminations to capture, and
    the scene, regions and checks that predict, measure and verify them."""

    name: str = "station"
    """Shown in reports, metrics and the history."""
    camera: CameraSpec
    """The camera and how frames start; ``backend`` chooses the kind."""
    controller: ControllerSpec
    """The light controller; ``backend`` chooses the kind."""
    illuminations: list[Illumination] = Field(min_length=1)
    """The lighting states to capture, in order."""
    frames: int = Field(default=4, ge=1, le=100_000)
    """Frames per illumination (the most, with ``precision``)."""
    precision: Precision | None = None
    """Stop each illumination once the classes are known this well."""
    dark_frames: int = Field(default=4, ge=0, le=100_000)
    """Frames with every light off, subtracted per pixel."""
    discard_max: int = Field(default=20, ge=0, le=100_000)
    """Frames an illumination may discard (stale, unsettled) before it fails."""
    brightness_tolerance: float = Field(default=0.02, gt=0, le=1)
    """Relative change of a frame's mean that counts as the light still settling."""
    scene: str | None = None
    """The scene file that predicts this station (relative to this file)."""
    rois: str | None = None
    """The ROI file of the classes in the camera's frames (relative to this file)."""
    channels: dict[Channel, Annotated[ChannelLight, BeforeValidator(_channel_shorthand)]] = {}
    """Controller channel → the scene light it drives (a name, or ``{light, irradiance}``)."""
    optics: str | None = None
    """Which of the scene's optics the station has (default: its only one)."""
    comparisons: ComparisonsSpec = ComparisonsSpec()
    """Which groups of classes to compare, and how a group is weighted."""
    calibration: Calibration = Calibration()
    """How the prediction's absolute scale is tied to the measurement."""
    acceptance: Acceptance = Acceptance()
    """The checks ``verify`` runs and their limits."""
    characterize: Characterize = Characterize()
    """How ``characterize`` measures the camera."""
    path: Path | None = Field(default=None, exclude=True)
    """The file the station was read from (set on reading, never written)."""

    @model_validator(mode="after")
    def _channels_exist(self):
        """Every channel an illumination (or the simulated camera) uses is on the controller."""
        n = self.controller.channels
        for i, ill in enumerate(self.illuminations):
            missing = sorted(c for c in ill.channels if c > n)
            if missing:
                raise ValueError(
                    f"illuminations[{i}] ({ill.name}): channel {missing[0]} is not on the "
                    f"controller (controller.channels: {n})"
                )
        mapped = sorted(c for c in self.channels if c > n)
        if mapped:
            raise ValueError(
                f"channels: channel {mapped[0]} is not on the controller (controller.channels: {n})"
            )
        if self.precision is not None:
            if not self.rois:
                raise ValueError("precision: stopping on the classes' precision needs 'rois'")
            if self.frames < self.precision.min_frames:
                raise ValueError(
                    f"frames ({self.frames}) is the most an illumination gets with 'precision'; "
                    f"it must be at least precision.min_frames ({self.precision.min_frames})"
                )
        if self.renders and not (self.scene and self.channels):
            raise ValueError(
                "a simulated camera renders the station's scene: give 'scene' and 'channels' "
                "(controller channel → scene light)"
            )
        self._check_timing()
        wanted = self.characterize.illumination
        if wanted is not None and wanted not in {i.name for i in self.illuminations}:
            raise ValueError(
                f"characterize.illumination: no illumination {wanted!r} "
                f"(the station has {', '.join(i.name for i in self.illuminations)})"
            )
        return self

    def _check_timing(self) -> None:
        """Triggered lights cover the exposure; every part a mode needs is given.

        The prediction integrates the light over ``exposure_us``: a pulse that ends
        early or starts late would make every frame darker than predicted, so such a
        station is refused when read, before any device is opened.
        """
        cam, ctl = self.camera, self.controller
        pulse = getattr(ctl, "pulse", None)
        hardware = cam.acquisition == "hardware-trigger"
        if hardware and cam.trigger_line is None:
            raise ValueError(
                "camera.acquisition: hardware-trigger needs camera.trigger_line, the input "
                "the controller's trigger output drives (e.g. Line1)"
            )
        if cam.strobe_line is not None and cam.acquisition in ("free-run", "hardware-trigger"):
            raise ValueError(
                f"camera.strobe_line: a strobed light needs camera.acquisition: "
                f"software-trigger, not {cam.acquisition} (free-running frames are not paced "
                "to the light's duty cycle; a hardware trigger already comes with its pulse)"
            )
        if not (hardware or cam.strobe_line):
            if pulse is not None:
                raise ValueError(
                    "controller.pulse is used with camera.acquisition: hardware-trigger or "
                    "camera.strobe_line; give one of them or leave out the pulse"
                )
            return
        what = "hardware-trigger" if hardware else "camera.strobe_line"
        if ctl.backend == "manual":
            raise ValueError(f"{what}: a manual controller cannot pulse its lights")
        if pulse is None:
            raise ValueError(
                f"{what} needs controller.pulse: {{width_us: …}}, the light's pulse per frame"
            )
        if cam.exposure_us is None:
            raise ValueError(f"{what} needs camera.exposure_us, which the pulse must cover")
        commands = ctl.protocol.commands if getattr(ctl, "protocol", None) else None
        needed = ("pulse", "trigger") if hardware else ("pulse",)
        for key in needed:
            if commands is not None and key not in commands:
                raise ValueError(f"{what}: controller.protocol.commands needs a '{key}' template")
        if hardware and pulse.trigger_channel > ctl.channels:
            raise ValueError(
                f"controller.pulse.trigger_channel {pulse.trigger_channel} is not on the "
                f"controller (controller.channels: {ctl.channels})"
            )
        period_s = pulse.width_us / pulse.max_duty / 1e6
        if period_s > 60:
            raise ValueError(
                f"controller.pulse: width_us / max_duty spaces frames {period_s:.3g} s apart; "
                "a capture would take hours — check the units (µs) and the duty limit (0–1)"
            )
        # Both intervals from the trigger: the exposure starts at the camera's own delay
        # (a strobe's trigger is the exposure start itself).
        start = cam.trigger_delay_us if hardware else 0.0
        end = start + cam.exposure_us
        if pulse.delay_us > start or pulse.delay_us + pulse.width_us < end:
            need = "camera.trigger_delay_us" if hardware else "0 (the exposure's start)"
            raise ValueError(
                f"controller.pulse lights {pulse.delay_us:g}–{pulse.delay_us + pulse.width_us:g} µs "
                f"after the trigger, the exposure runs {start:g}–{end:g} µs: the pulse must "
                f"cover it (delay_us ≤ {need}, delay_us + width_us ≥ that + "
                f"camera.exposure_us = {end:g} µs)"
            )

    @property
    def renders(self) -> bool:
        """The camera renders the scene (simulated, or pylon's emulator fed with renderings)."""
        return self.camera.backend == "simulated" or getattr(self.camera, "simulate", False)

    def resolve(self, relative: str | None) -> Path | None:
        """A path given in the station file, relative to the file."""
        return None if relative is None else (self.path.parent / relative)


def read_station(path: str | Path) -> Station:
    """Read and validate a station file; errors name the file and field."""
    station = load_yaml(path, Station, what="station file")
    names = [i.name for i in station.illuminations]
    if len(set(names)) != len(names) or "dark" in names:
        from inspect_validate.errors import InputError

        raise InputError(
            "illumination names must be unique and not 'dark' (reserved for the dark frames)",
            source=str(path),
        )
    return station.model_copy(update={"path": Path(path)})


def station_hash(path: str | Path) -> str:
    """SHA-256 of the station file's bytes: which configuration a capture belongs to."""
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


def write_station(station: Station, path: str | Path, *, comment: str = "") -> Station:
    """Write ``station`` as a station file at ``path`` and read it back from there.

    The paths it names (scene, ROIs, GenTL producer, replay folder, golden
    file) are written absolute, so the file means the same wherever it lies;
    ``comment`` heads the file (one ``#`` line per line).
    """
    import yaml

    doc = station.model_dump(mode="json", exclude={"path"}, exclude_unset=True)
    for key in ("scene", "rois"):
        if doc.get(key):
            doc[key] = str(station.resolve(doc[key]).resolve())
    for key in ("cti", "folder", "measured"):
        if doc["camera"].get(key):
            doc["camera"][key] = str(station.resolve(doc["camera"][key]).resolve())
    drift = doc.get("acceptance", {}).get("drift")
    if drift:
        drift["golden"] = str(station.resolve(drift["golden"]).resolve())
    head = "".join(f"# {line}\n" for line in comment.splitlines())
    Path(path).write_text(head + yaml.safe_dump(doc, sort_keys=False, allow_unicode=True))
    return read_station(path)


def simulated_at(station: Station, cycle: int, *, hours: float = 0.0) -> Station:
    """``station`` as its simulated world is at ``watch``'s cycle ``cycle`` (``hours`` in):
    the world's scheduled changes applied and the controller's scheduled faults added.
    A station whose devices are real is returned as it is."""
    world = getattr(station.camera, "world", None)
    if world is None or not world.changes:
        return station
    update = {"camera": station.camera.model_copy(update={"world": world.at(cycle, hours=hours)})}
    faults = world.controller_faults(cycle)
    if faults and station.controller.backend == "simulated":
        args = [*station.controller.simulator_args, *faults]
        update["controller"] = station.controller.model_copy(update={"simulator_args": args})
    return station.model_copy(update=update)
