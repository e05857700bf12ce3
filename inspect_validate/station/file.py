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
      backend: simulated            # simulated | genicam | pylon | aravis | v4l2 | replay | none | a plugin's
      exposure_us: 20000
      gain_db: 0
    controller:
      backend: simulated            # simulated | gardasoft | generic | manual | a plugin's
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
from typing import TYPE_CHECKING, Annotated, Any, Literal, overload

from pydantic import (
    BaseModel,
    BeforeValidator,
    Field,
    model_validator,
)

from inspect_validate.acceptance import Acceptance, Calibration
from inspect_validate.camera.settings import Channel
from inspect_validate.config import StrictModel, one_of
from inspect_validate.files import atomic_write
from inspect_validate.scene_file import ComparisonsSpec, Irradiance
from inspect_validate.station.world import Rendered

__all__ = [
    "CameraSection",
    "ChannelLight",
    "ControllerSection",
    "Illumination",
    "Precision",
    "Station",
    "StationCamera",
    "read_station",
    "simulated_at",
    "station_hash",
    "write_station",
]


class StationCamera(StrictModel):
    """The keys of a station's own in every ``camera:`` section, whatever the backend: which
    camera of the scene the prediction uses."""

    model: str | None = None
    """Which of the scene's cameras this is (default: its only one)."""
    measured: str | None = None
    """A camera file written by ``characterize``: its EMVA 1288 values replace the scene
    camera's in every prediction of this station (the QE curve keeps the scene's shape, at
    the measured level where the file has ``qe_scale``)."""
    name: Annotated[str, Field(pattern=r"^[A-Za-z0-9][A-Za-z0-9_.-]{0,63}$")] | None = None
    """Its name among a station's ``cameras:`` (the folder of its frames in a capture, the
    prefix of its checks); required there."""
    rois: str | None = None
    """Its ROI file among a station's ``cameras:`` (default: the station's ``rois``)."""
    golden: str | None = None
    """Its golden file among a station's ``cameras:`` (``train --camera NAME`` writes it):
    what ``acceptance.drift`` holds this camera to (a relative path is from the station
    file's folder)."""


def _sections(kind: Literal["cameras", "controllers"], *, extra: tuple = ()) -> dict:
    """Backend name → the model of its section in a station file: the backend's own
    settings (:mod:`inspect_validate.camera.registry`, every installed one) and
    ``extra``; a camera whose backend has a simulator also renders (``simulate:``)."""
    from inspect_validate.camera import registry

    simulators = registry.backends("simulators") if kind == "cameras" else {}
    models = {name: _unloadable(name, why) for name, why in registry.broken(kind).items()}
    for name, backend in registry.backends(kind).items():
        bases = (backend.settings, *extra)
        if name in simulators and not issubclass(backend.settings, Rendered):
            bases += (Rendered,)
        models[name] = type(
            f"{backend.settings.__name__}Section",
            bases,
            {"__module__": __name__, "__doc__": backend.settings.__doc__},
        )
    return models


def _device_key(cam) -> tuple | None:
    """What chooses ``cam``'s device (backend and serial, device id or index; a simulated
    camera none: each renders its own): two cameras with one key are one device."""
    if getattr(cam, "simulate", False) and hasattr(cam, "simulate_interface"):
        # Aravis' fake cameras: two on one address answer for each other
        return (cam.backend, "simulate_interface", cam.simulate_interface)
    if cam.backend == "simulated" or getattr(cam, "simulate", False):
        return None
    for key in ("serial", "device_id", "device", "folder"):
        value = getattr(cam, key, None)
        if value is not None:
            return (cam.backend, key, str(value))
    index = getattr(cam, "index", None)
    return None if index is None else (cam.backend, "index", str(index))


def _unloadable(name: str, why: str) -> type:
    """A section model that refuses every section naming a backend whose package is
    installed but does not load, saying why."""

    class Unloadable(StrictModel):
        @model_validator(mode="before")
        @classmethod
        def _refuse(cls, value):
            raise ValueError(f"backend {name!r} is installed but cannot be used: {why}")

    return Unloadable


if TYPE_CHECKING:
    # The sections are composed at run time from whatever backends are installed: to a
    # type checker, any of them (their common keys are CameraSettings' and
    # ControllerSettings', a backend's own are its own).
    CameraSection = Any
    ControllerSection = Any
else:
    CameraSection = one_of(
        _sections("cameras", extra=(StationCamera,)), what="camera", field="backend"
    )
    ControllerSection = one_of(_sections("controllers"), what="controller", field="backend")


class ChannelLight(StrictModel):
    """What a controller channel drives: a light of the station's scene."""

    light: Annotated[str, Field(min_length=1)]
    """The scene light's name."""
    irradiance: Irradiance | None = None
    """W/m² at the object at 100 % (default: the scene light's own ``irradiance``)."""


def _channel_shorthand(v):
    return {"light": v} if isinstance(v, str) else v


class StationField(StrictModel):
    """The light's field over the frame, and whether the frames are corrected by it."""

    file: str = Field(min_length=1)
    """The ``field.json`` of ``characterize --field`` (a relative path is from the station
    file's folder)."""
    corrected: bool = False
    """The line's program corrects the shading (each frame's signal above dark divided by
    the field, as a camera's flat-field correction or HALCON's shading correction do):
    ``verify`` measures the frames so corrected, and predicts them, each class at the
    light's maximum with its noise divided alike. Without, each class is predicted at its
    region's share of the light and its spread over the region."""


def _field_shorthand(v):
    return {"file": v} if isinstance(v, str) else v


class Illumination(StrictModel):
    """One lighting state to capture: which channels are on, and at what drive level."""

    name: str = Field(pattern=r"^[A-Za-z0-9][A-Za-z0-9_.-]*$", max_length=100)
    """The step's name: its frames go to ``OUT/<name>/`` (so it starts with a letter or
    digit: ``..`` wrote them outside ``OUT``; ``dark`` and ``manifest.json`` are the
    capture's own)."""
    channels: dict[Channel, Annotated[float, Field(ge=0, le=100, allow_inf_nan=False)]]
    """Channel → drive level, % (channels not named are off)."""


class Precision(StrictModel):
    """Sequential stopping (:mod:`~inspect_validate.station.stopping`): ``frames`` becomes
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


class Production(StrictModel):
    """The station on its running line (the manual's "On the running line"): parts move
    under the one light that stays on, each located against a reference frame of a good
    part, the regions following it (:mod:`inspect_validate.roi.pose`)."""

    illumination: str = "production"
    """The station's illumination that stays on in production (nothing is switched);
    default its only one, or ``production`` in a station of the line's frames alone."""
    reference: str
    """A frame of a good part, in which the ROI file's regions are drawn (a relative path
    is from this file's folder)."""
    template: (
        tuple[
            Annotated[int, Field(ge=0)],
            Annotated[int, Field(ge=0)],
            Annotated[int, Field(ge=8)],
            Annotated[int, Field(ge=8)],
        ]
        | None
    ) = None
    """x, y, width, height of the reference window that holds the part, px (default: the
    regions' bounding box widened by ``margin``)."""
    margin: Annotated[int, Field(ge=0, le=10_000)] = 16
    """Pixels around the regions' bounding box that the default template takes in."""
    motion: Literal["translation", "euclidean", "affine"] = "euclidean"
    """How a part may lie: shifted; shifted and rotated; any affine map (a tilted part)."""
    max_rotation_deg: Annotated[float, Field(ge=0, le=180, allow_inf_nan=False)] = 30.0
    """The most a part may be turned, degrees: where the template is not found unturned
    (a texture without an outline, turned), the search sweeps its rotation over ± this."""
    min_score: Annotated[float, Field(gt=0, le=1, allow_inf_nan=False)] = 0.8
    """The lowest match score (ECC's correlation coefficient) that counts as a part; a
    frame below it is counted as "no part found" and never measured."""
    min_pixels: Annotated[int, Field(ge=1, le=10**9)] = 100
    """Pixels a class must keep on a part once its region is moved (a part cut by the
    frame's edge leaves fewer): below, the part is not measured."""
    parts: Annotated[int, Field(ge=2, le=100_000)] = 40
    """Frames ``capture --production`` takes, each of another part."""


class Station(StrictModel):
    """A station: its camera, its light controller, the illuminations to capture, and
    the scene, regions and checks that predict, measure and verify them."""

    name: str = Field(
        default="station", min_length=1, max_length=200, pattern=r"^[^\x00-\x1f\x7f]*$"
    )
    """Shown in reports, metrics and the history (one line, no control characters)."""
    camera: CameraSection
    """The camera and how frames start; ``backend`` chooses the kind. With ``cameras:``,
    the first of them (leave it out). A station with ``production:`` may leave it out: its
    frames then come from the line's own program (``backend: none``)."""
    cameras: list[CameraSection] = []
    """Several cameras on one trigger, each with its ``name`` (and its own ``rois``, its
    scene camera ``model``): every illumination triggers them together, and their frames
    are matched by trigger."""
    controller: ControllerSection
    """The light controller; ``backend`` chooses the kind. A station with ``production:``
    may leave it out (``backend: none``: nothing here switches its light)."""
    illuminations: list[Illumination] = Field(min_length=1)
    """The lighting states to capture, in order. A station with ``production:`` may leave
    them out: its one illumination is then the production one, of no channels."""
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
    """The scene file that predicts this station (a relative path is from this file's folder)."""
    rois: str | None = None
    """The ROI file of the classes in the camera's frames (a relative path is from this
    file's folder)."""
    field: Annotated[StationField, BeforeValidator(_field_shorthand)] | None = None
    """The light's field over the frame (the ``field.json`` of ``characterize --field``,
    or ``{file, corrected}``; a relative path is from this file's folder): each class is
    predicted at its region's share of each illumination's light, and its spread over
    the region, or, ``corrected: true``, measured and predicted on frames whose shading
    is corrected."""
    sharpness: str | None = None
    """The lens's measured MTF (the ``sharpness.json`` of ``characterize --sharpness``;
    relative to this file's folder): ``verify`` holds it to the optics' prediction."""
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
    production: Production | None = None
    """How the station is verified on its running line (moving parts, one light on)."""
    path: Path | None = Field(default=None, exclude=True)
    """The file the station was read from (set on reading, never written)."""
    sha256: str | None = Field(default=None, exclude=True)
    """The SHA-256 of that file's bytes as they were read (set on reading, never written)."""

    @model_validator(mode="before")
    @classmethod
    def _set_on_reading(cls, data):
        """``path`` and ``sha256`` are the reading's, never the file's: a file that gives
        them is refused rather than silently overridden."""
        if isinstance(data, dict):
            given = [k for k in ("path", "sha256") if k in data]
            if given:
                raise ValueError(
                    f"{given[0]!r} is not a key of a station file (it is set when the file is "
                    "read): remove it"
                )
        return data

    @model_validator(mode="before")
    @classmethod
    def _frames_alone(cls, data):
        """A station with ``production:`` needs no camera, controller or illumination: its
        frames may come from the line's own program (``--frames``). What is left out is
        ``backend: none`` (whatever would open it says what it needs) and one
        illumination of no channels, named as ``production.illumination`` says; one
        illumination given is the production one unless it names another."""
        if not (isinstance(data, dict) and isinstance(data.get("production"), dict)):
            return data
        data = dict(data)
        production = dict(data["production"])
        if "camera" not in data and not data.get("cameras"):
            data["camera"] = {"backend": "none"}
        if "controller" not in data:
            data["controller"] = {"backend": "none"}
        illuminations = data.get("illuminations")
        if "illuminations" not in data:
            name = production.get("illumination", "production")
            data["illuminations"] = [{"name": name, "channels": {}}]
        elif (
            "illumination" not in production
            and isinstance(illuminations, list)
            and len(illuminations) == 1
            and isinstance(illuminations[0], dict)
            and "name" in illuminations[0]
        ):
            production["illumination"] = illuminations[0]["name"]
        data["production"] = production
        return data

    @model_validator(mode="before")
    @classmethod
    def _first_camera(cls, data):
        """``cameras:`` given: ``camera`` is the first of them (what one-camera code reads)."""
        if isinstance(data, dict) and data.get("cameras"):  # cameras: [] is one camera
            if data.get("camera") is not None:
                raise ValueError(
                    "give camera: (one camera) or cameras: (several, each with a name), not both"
                )
            cameras = data["cameras"]
            if isinstance(cameras, list) and cameras and isinstance(cameras[0], dict):
                data = {**data, "camera": cameras[0]}
        return data

    @model_validator(mode="after")
    def _several_cameras(self):
        """Each of ``cameras:`` named once, a device once, triggered (frames are matched by
        trigger), and all on one kind of trigger."""
        drift = self.acceptance.drift
        if not self.cameras:
            for key, where in (("rois", "rois:"), ("golden", "acceptance.drift.golden:")):
                if getattr(self.camera, key) is not None:
                    raise ValueError(
                        f"camera.{key} is for one of several cameras: give {where} instead"
                    )
            if drift is not None and drift.golden is None:
                raise ValueError(
                    "acceptance.drift.golden: give the golden file 'train' wrote of this station"
                )
            return self
        if drift is not None and drift.golden is not None:
            raise ValueError(
                "acceptance.drift.golden: a golden file is of one camera; give each of "
                "cameras: its own golden (train STATION --camera NAME --out FILE)"
            )
        names = [c.name for c in self.cameras]
        for i, cam in enumerate(self.cameras):
            if cam.name is None:
                raise ValueError(f"cameras[{i}] ({cam.backend}): give it a name (name: top)")
        if len(set(names)) != len(names):
            twice = sorted({n for n in names if names.count(n) > 1})
            raise ValueError(f"cameras: {twice[0]!r} names two cameras; give each its own name")
        for name in names:
            # A camera's name is its folder beside the station's own report files and
            # capture: report.html as a camera's folder failed the report after the capture.
            if name in RESERVED_NAMES or name.lower().endswith((".html", ".json", ".xml")):
                raise ValueError(
                    f"cameras: {name!r} is a file or folder name the reports and captures "
                    "use beside each camera's folder; name the camera otherwise (top, side)"
                )
        seen: dict[tuple, str] = {}
        for cam in self.cameras:
            key = _device_key(cam)
            if key is not None and key in seen:
                raise ValueError(
                    f"cameras {seen[key]!r} and {cam.name!r} are the same device "
                    f"({key[0]} {key[1]} {key[2]}); give each camera its own"
                )
            if key is not None:
                seen[key] = cam.name
            if cam.acquisition == "free-run":
                raise ValueError(
                    f"cameras {cam.name!r}: several cameras are matched by their trigger; "
                    "camera.acquisition free-run cannot be (give software-trigger, "
                    "hardware-trigger or auto)"
                )
        kinds = {c.acquisition == "hardware-trigger" for c in self.cameras}
        if len(kinds) > 1:
            raise ValueError(
                "cameras: either every camera is hardware-triggered from the controller's one "
                "trigger output, or none is (software triggers are sent to each in turn)"
            )
        return self

    @property
    def camera_names(self) -> tuple[str, ...]:
        """The names of ``cameras:`` (empty for a station of one camera)."""
        return tuple(c.name for c in self.cameras)

    def one_camera(self, what: str) -> Station:
        """This station, where it has one camera; an InputError naming ``what`` (a command)
        for a station of several (``cameras:``), saying what to do."""
        if self.cameras:
            from inspect_validate.errors import InputError

            raise InputError(
                f"{what} takes a station of one camera, and this one has "
                f"{len(self.cameras)} ({', '.join(self.camera_names)}): give --camera NAME "
                "to take one of them alone",
                source=str(self.path),
            )
        return self

    def with_golden(self, path: str | Path) -> Station:
        """This station checking drift against the golden file at ``path`` (a path from
        the working directory: ``--golden``), in its acceptance's drift section or the
        default one.

        Raises
        ------
        InputError
            A station of several cameras (each camera's golden file is its own:
            ``cameras[].golden``, or one camera's view).
        """
        from inspect_validate.acceptance import Drift
        from inspect_validate.errors import InputError

        if self.cameras:
            raise InputError(
                "--golden is one camera's: give --camera NAME with it, or each camera's "
                "golden file in cameras[].golden",
                source=str(self.path),
            )
        acc = self.acceptance
        golden = str(Path(path).absolute())
        drift = (
            acc.drift.model_copy(update={"golden": golden}) if acc.drift else Drift(golden=golden)
        )
        return self.model_copy(update={"acceptance": acc.model_copy(update={"drift": drift})})

    def view(self, name: str) -> Station:
        """The station as its camera ``name`` alone sees it: that camera, its ROI file,
        every other key as it is (what a verification of one camera reads).

        Raises
        ------
        InputError
            No camera of that name.
        """
        for cam in self.cameras:
            if cam.name == name:
                acceptance = self.acceptance
                if acceptance.drift is not None and cam.golden is not None:
                    drift = acceptance.drift.model_copy(update={"golden": cam.golden})
                    acceptance = acceptance.model_copy(update={"drift": drift})
                return self.model_copy(
                    update={
                        "camera": cam.model_copy(update={"rois": None, "golden": None}),
                        "cameras": [],
                        "rois": cam.rois or self.rois,
                        "acceptance": acceptance,
                        "name": f"{self.name} · {name}",
                    }
                )
        from inspect_validate.errors import InputError

        raise InputError(
            f"no camera {name!r} (the station has {', '.join(self.camera_names) or 'one, unnamed'})",
            source=str(self.path),
        )

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
        names = [i.name for i in self.illuminations]
        for field, wanted in (
            ("characterize.illumination", self.characterize.illumination),
            ("production.illumination", self.production and self.production.illumination),
        ):
            if wanted is not None and wanted not in names:
                raise ValueError(
                    f"{field}: no illumination {wanted!r} (the station has {', '.join(names)})"
                )
        if self.production is not None and not self.rois:
            raise ValueError("production: the regions that follow the part need 'rois'")
        return self

    def _check_timing(self) -> None:
        """Triggered lights cover every camera's exposure; every part a mode needs is given.

        The prediction integrates the light over ``exposure_us``: a pulse that ends
        early or starts late would make every frame darker than predicted, so such a
        station is refused when read, before any device is opened.
        """
        for cam in self.cameras or [self.camera]:
            self._check_camera_timing(cam)

    def _check_camera_timing(self, cam) -> None:
        ctl = self.controller
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
        """A camera renders the scene (simulated, or pylon's emulator fed with renderings)."""
        return any(
            c.backend == "simulated" or getattr(c, "simulate", False)
            for c in self.cameras or [self.camera]
        )

    @property
    def file(self) -> Path:
        """The station file (a station made in code and never written has none)."""
        if self.path is None:
            from inspect_validate.errors import InputError

            raise InputError(
                f"station {self.name!r} has no file; write it with write_station first"
            )
        return self.path

    @property
    def folder(self) -> Path:
        """The folder the station file's paths are relative to (the working directory for
        a station made in code)."""
        return self.path.parent if self.path is not None else Path()

    @overload
    def resolve(self, relative: str | Path) -> Path: ...
    @overload
    def resolve(self, relative: None) -> None: ...
    def resolve(self, relative: str | Path | None) -> Path | None:
        """A path given in the station file, relative to the file."""
        return None if relative is None else (self.folder / relative)


def read_station(path: str | Path) -> Station:
    """Read and validate a station file; errors name the file and field."""
    from inspect_validate.config import validate
    from inspect_validate.strict_yaml import read_mapping_and_hash

    # The file read once: its mapping, and its hash (which version a capture was of).
    doc, sha256 = read_mapping_and_hash(path, what="station file")
    station = validate(doc, Station, what="station file", source=str(path))
    names = [i.name for i in station.illuminations]
    if len(set(names)) != len(names) or {"dark", "manifest.json"} & set(names):
        from inspect_validate.errors import InputError

        raise InputError(
            "illumination names must be unique and not 'dark' or 'manifest.json' (the "
            "capture's dark frames and its manifest)",
            source=str(path),
        )
    return station.model_copy(update={"path": Path(path), "sha256": sha256})


RESERVED_NAMES = frozenset({"frames", "dark", "report.html", "verification.json", "junit.xml"})
"""Names no camera of several takes: what a report or capture folder holds beside the
cameras' folders."""


def station_hash(station: Station | str | Path) -> str:
    """SHA-256 of the station file's bytes: which configuration a capture belongs to (a
    station read from its file: the bytes it was read from, not read again)."""
    if isinstance(station, Station):
        if station.sha256 is not None:
            return station.sha256
        station = station.file
    return hashlib.sha256(Path(station).read_bytes()).hexdigest()


def write_station(
    station: Station, path: str | Path, *, comment: str = "", explained: bool = False
) -> Station:
    """Write ``station`` as a station file at ``path`` and read it back from there.

    The paths it names (scene, ROIs, field, sharpness, GenTL producer, replay folder,
    golden file) are written absolute, so the file means the same wherever it lies;
    ``comment`` heads the file (one ``#`` line per line). ``explained``: every key
    comes with a comment saying what it means (its model's field docstring).
    """
    import yaml

    doc = station.model_dump(mode="json", exclude={"path"}, exclude_unset=True)
    for key in ("scene", "rois", "sharpness"):
        if doc.get(key):
            doc[key] = str(station.resolve(doc[key]).resolve())
    if doc.get("field"):
        doc["field"]["file"] = str(station.resolve(doc["field"]["file"]).resolve())
    for key in ("cti", "folder", "measured"):
        if doc["camera"].get(key):
            doc["camera"][key] = str(station.resolve(doc["camera"][key]).resolve())
    drift = doc.get("acceptance", {}).get("drift")
    if drift:
        drift["golden"] = str(station.resolve(drift["golden"]).resolve())
    head = "".join(f"# {line}\n" for line in comment.splitlines())
    if explained:
        body = "\n".join(_explained(station, doc)) + "\n"
    else:
        body = yaml.safe_dump(doc, sort_keys=False, allow_unicode=True)
    atomic_write(path, (head + body).encode())
    return read_station(path)


def _explained(model: BaseModel, doc: dict, indent: str = "") -> list[str]:
    """``doc`` (``model`` dumped) as block YAML, each key under a comment of what it
    means: the first sentence of its field's docstring. A nested model is a block of
    its own; lists and mappings of models are written one flow-style line per entry."""
    import yaml

    from inspect_validate.config import field_docs

    def flow(value) -> str:
        text = yaml.safe_dump(
            value, default_flow_style=True, allow_unicode=True, width=10**6, sort_keys=False
        )
        return text.strip().removesuffix("...").strip()

    def keys(value):  # channel numbers as numbers (JSON made them text)
        if isinstance(value, dict):
            return {int(k) if str(k).isdigit() else k: keys(v) for k, v in value.items()}
        return [keys(v) for v in value] if isinstance(value, list) else value

    meanings = {
        "backend": "Which backend drives it (`inspect-validate devices` lists what it finds)",
        **field_docs(type(model)),
    }
    lines = []
    # The backend first: it says which keys may follow.
    for key, value in sorted(keys(doc).items(), key=lambda kv: kv[0] != "backend"):
        meaning = " ".join(meanings.get(key, "").split())
        if meaning:
            first = meaning.split(". ")[0].rstrip(". ").replace("``", "`")
            lines.append(f"{indent}# {first}")
        inner = getattr(model, key, None)
        if isinstance(value, dict) and value and isinstance(inner, BaseModel):
            lines.append(f"{indent}{key}:")
            lines += _explained(inner, value, indent + "  ")
        elif isinstance(value, dict) and value:
            lines.append(f"{indent}{key}:")
            lines += [f"{indent}  {flow(k)}: {flow(v)}" for k, v in value.items()]
        elif isinstance(value, list) and value:
            lines.append(f"{indent}{key}:")
            lines += [f"{indent}  - {flow(v)}" for v in value]
        else:
            lines.append(f"{indent}{key}: {flow(value)}")
    return lines


def simulated_at(station: Station, cycle: int, *, hours: float = 0.0) -> Station:
    """``station`` as its simulated world is at ``watch``'s cycle ``cycle`` (``hours`` in):
    the world's scheduled changes applied and the controller's scheduled faults added.
    A station whose devices are real is returned as it is."""

    def at(camera):
        world = getattr(camera, "world", None)
        if world is None or not world.changes:
            return camera
        return camera.model_copy(update={"world": world.at(cycle, hours=hours)})

    # each camera's world changes on its own schedule (a camera of several alone, too)
    camera, cameras = at(station.camera), [at(c) for c in station.cameras]
    if camera is station.camera and all(
        a is b for a, b in zip(cameras, station.cameras, strict=True)
    ):
        return station
    update: dict = {"camera": camera, "cameras": cameras}
    world = getattr(station.camera, "world", None)
    faults = world.controller_faults(cycle) if world is not None else []
    if faults and station.controller.backend == "simulated":
        args = [*station.controller.simulator_args, *faults]
        update["controller"] = station.controller.model_copy(update={"simulator_args": args})
    return station.model_copy(update=update)
