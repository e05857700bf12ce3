"""A first station file, drafted from a camera, a controller and a scene (``inspect-validate
init``): every scene light on a channel of its own, one illumination each at full drive,
the camera's pixel format and an exposure chosen from what the camera offers and what
the scene predicts."""

from __future__ import annotations

import re
from collections.abc import Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

from inspect_validate.camera.grabbers.base import Features
from inspect_validate.camera.pixelformats import BIT_DEPTH, PACKED
from inspect_validate.errors import InputError
from inspect_validate.station.file import Station

if TYPE_CHECKING:
    from inspect_validate.scene import Scene

__all__ = ["draft_station", "fitting_exposure_us", "pixel_format_for"]

#: The brightest class's predicted mean, as a fraction of saturation, that
#: :func:`fitting_exposure_us` aims at: the brightest class's mean reaches saturation
#: only for a light nearly twice as bright as the scene says (less the class's spread),
#: and stays well above the dark noise.
EXPOSURE_TARGET = 0.5


def draft_station(
    scene: str | Path,
    *,
    camera: Mapping[str, Any],
    controller: Mapping[str, Any],
    channels: Mapping[int, str] | None = None,
    irradiance: Mapping[int, float] | None = None,
    rois: str | Path | None = None,
    name: str | None = None,
    path: Path | None = None,
    parsed: Scene | None = None,
) -> Station:
    """A station of ``scene`` with these ``camera`` and ``controller`` sections: each
    channel (default: the scene's lights, in order, on channels 1, 2, …) drives its light
    and is one illumination at 100 %; ``irradiance`` gives a channel's W/m² at the object
    at 100 % (default: the scene light's own). ``parsed``: the scene already read from
    ``scene`` (it is read otherwise).

    Raises
    ------
    InputError
        The scene cannot be read, a channel names a light it does not have, or the
        sections do not validate (the message names the key).
    """
    from pydantic import ValidationError

    from inspect_validate.config import explain
    from inspect_validate.scene import read_scene

    parsed = parsed if parsed is not None else read_scene(scene)
    lights = [light.name for light in parsed.lights]
    chosen = dict(channels) if channels else {i: n for i, n in enumerate(lights, start=1)}
    unlit = sorted(set(irradiance or {}) - set(chosen))
    if unlit:
        raise InputError(f"irradiance of channel {unlit[0]}, which drives no light", source="init")
    for channel, light in chosen.items():
        if light not in lights:
            raise InputError(
                f"channel {channel}: the scene has no light {light!r} (it has {', '.join(lights)})",
                source=str(scene),
            )
    controller = dict(controller)
    # The controller's channel count: at least every channel used.
    if controller.get("backend") in ("simulated", "manual"):
        controller.setdefault("channels", max(chosen))
    else:
        controller["channels"] = max(controller.get("channels", 4), max(chosen))
    given = dict(irradiance or {})
    steps = [
        {"name": _step_name(light), "channels": {ch: 100}} for ch, light in sorted(chosen.items())
    ]
    if len({s["name"] for s in steps}) != len(steps):  # names that differ only in punctuation
        steps = [{**s, "name": f"{s['name']}_{n}"} for n, s in enumerate(steps, start=1)]
    doc: dict[str, Any] = {
        "name": name or f"{parsed.name} station",
        "camera": dict(camera),
        "controller": controller,
        "illuminations": steps,
        "frames": 4,
        "dark_frames": 4,
        "scene": str(Path(scene).resolve()),
        "channels": {
            ch: {"light": light, **({"irradiance": given[ch]} if ch in given else {})}
            for ch, light in sorted(chosen.items())
        },
    }
    if rois is not None:
        doc["rois"] = str(Path(rois).resolve())
    try:
        station = Station.model_validate(doc)
    except ValidationError as exc:
        raise InputError(explain(exc), source="init") from None
    return station.model_copy(update={"path": path})


def _step_name(light: str) -> str:
    """An illumination name from a light's (``amber LED`` → ``amber_LED``)."""
    return re.sub(r"[^A-Za-z0-9_.-]+", "_", light).strip("_") or "light"


def pixel_format_for(features: Features) -> str | None:
    """The format a station should ask this camera for: its deepest monochrome one,
    unpacked where the same depth is also offered packed (packing saves bandwidth, not
    information). None where the camera lists no format."""
    offered = features.monochrome
    if not offered:
        return None
    return max(offered, key=lambda f: (BIT_DEPTH[f], f not in PACKED))


def fitting_exposure_us(
    station: Station,
    *,
    target: float = EXPOSURE_TARGET,
    limits: tuple[float, float] | None = None,
    scene: Scene | None = None,
) -> float | None:
    """The exposure [µs] at which the scene predicts the brightest class of the brightest
    illumination at ``target`` × saturation (the model's automatic exposure: the sensor
    signal (32) is linear in the time), within the camera's ``limits`` [µs], to 2
    significant digits. None where a channel's light has no irradiance (the scene then
    predicts relative grey values only, not a time). ``scene``: the station's scene
    already read (read from the station otherwise).
    """
    from inspect_validate.model import Exposure, predict
    from inspect_validate.station.model import station_model

    model = station_model(station, scene)
    if model.nominal:
        return None
    prediction = predict(
        model.illumination_lights(station),
        [model.optics],
        [model.sensor],
        list(model.scene.classes),
        exposure=Exposure("auto", target=target),
        grid=model.scene.grid,
    )
    seconds = float(prediction.exposure_time.min())
    us = float(f"{seconds * 1e6:.2g}")
    if limits is not None:
        us = min(max(us, limits[0]), limits[1])
    return us
