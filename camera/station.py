"""Station files: camera, light controller, illuminations and frame counts (YAML).

Example (README, "Station files")::

    name: paperboard station
    camera:
      backend: simulated            # simulated | genicam | pylon | v4l2 | replay
      scene: ../scenes/paperboard/scene.yaml
      channels: {1: amber LED, 2: red LED}
      exposure_us: 20000
      gain_db: 0
    controller:
      backend: simulated            # simulated | gardasoft | generic | manual
      channels: 2
    illuminations:
      - {name: amber, channels: {1: 100}}
      - {name: red, channels: {2: 100}}
    frames: 4
    dark_frames: 4
    rois: rois.yaml
"""

from __future__ import annotations

import hashlib
from pathlib import Path
from typing import Literal

from pydantic import BaseModel, ConfigDict, Field, field_validator

from inspect_validate.config import load_yaml

__all__ = ["Station", "read_station", "station_hash"]


class CameraSpec(BaseModel):
    model_config = ConfigDict(extra="forbid")
    backend: Literal["simulated", "genicam", "pylon", "v4l2", "replay"]
    exposure_us: float | None = Field(default=None, gt=0)
    gain_db: float | None = None
    pixel_format: str | None = None
    timeout_s: float = Field(default=2.0, gt=0)
    flush_frames: int = Field(
        default=4, ge=0
    )  # dropped after a switch when timestamps cannot prove the exposure time
    # genicam / pylon
    cti: str | None = None
    serial: str | None = None
    index: int = Field(default=0, ge=0)
    # v4l2
    device: str | int | None = None
    # replay
    folder: str | None = None
    # simulated
    scene: str | None = None
    channels: dict[int, str] = {}
    channel_irradiance: dict[int, float] = {}
    width: int = Field(default=320, ge=16)
    height: int = Field(default=240, ge=16)
    latency: int = Field(default=2, ge=0)


_TEMPLATE_FIELDS = {
    "channel": 1,
    "percent": 50.0,
    "value": 50.0,
    "width_us": 100.0,
    "delay_us": 0.0,
}


class AsciiProtocol(BaseModel):
    """A generic ASCII controller's protocol (:mod:`inspect_validate.camera.lights.generic`)."""

    model_config = ConfigDict(extra="forbid")
    commands: dict[Literal["set", "off", "pulse", "status", "init"], str | list[str]]
    baudrate: int = Field(default=115200, gt=0)
    terminator: str = Field(default="\r", min_length=1)
    reply_end: str = Field(default="\r\n", min_length=1)
    ok: str | None = None
    error: str = r"(?i)err\w*\s*(\d+)"
    max_value: float = Field(default=100.0, gt=0)

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


class ControllerSpec(BaseModel):
    model_config = ConfigDict(extra="forbid")
    backend: Literal["simulated", "gardasoft", "generic", "manual"]
    port: str | None = None
    channels: int = Field(default=4, ge=1, le=64)
    timeout_s: float = Field(default=1.0, gt=0)
    error_codes: dict[int, str] = {}
    protocol: AsciiProtocol | None = None  # generic backend
    simulator_args: list[
        str
    ] = []  # faults for the simulated controller (tests): e.g. ["--vanish-after", "5"]


class Illumination(BaseModel):
    model_config = ConfigDict(extra="forbid")
    name: str = Field(pattern=r"^[A-Za-z0-9_.-]+$")
    channels: dict[int, float]

    @field_validator("channels")
    @classmethod
    def _percent(cls, v):
        for ch, pct in v.items():
            if not 0 <= pct <= 100:
                raise ValueError(f"channel {ch}: {pct} % is outside 0–100")
        return v


class Station(BaseModel):
    model_config = ConfigDict(extra="forbid")
    name: str = "station"
    camera: CameraSpec
    controller: ControllerSpec
    illuminations: list[Illumination] = Field(min_length=1)
    frames: int = Field(default=4, ge=1)
    dark_frames: int = Field(default=4, ge=0)
    discard_max: int = Field(default=20, ge=0)
    brightness_tolerance: float = Field(default=0.02, gt=0)
    rois: str | None = None
    scene: str | None = None
    path: Path | None = None

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
