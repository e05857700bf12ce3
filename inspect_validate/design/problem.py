"""What ``design`` optimises, from a station file or a scene file: the channels' lights,
the optics and camera, the classes, the exposure and the comparisons."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from inspect_validate.errors import InputError

__all__ = ["DesignProblem", "design_problem"]


@dataclass(frozen=True)
class DesignProblem:
    """One camera, one optics and a controller's channels, each a scene light.

    ``channels`` maps the controller channel (a scene's lights are numbered from
    1 in file order) to its light at 100 %, with its irradiance; ``objective``
    are the comparisons whose worst ε is minimised (the station's acceptance
    separation comparisons, else every comparison).
    """

    source: str
    kind: str  # "station" or "scene"
    channels: dict
    optics: object
    camera: object
    classes: tuple
    grid: object
    exposure_time: float  # s
    comparisons: object  # Comparisons of the classes (all that are reported)
    objective: object  # Comparisons the objective is about
    max_saturated: float
    station: object | None = None


def design_problem(path: str | Path) -> DesignProblem:
    """Read a station file (it has ``controller:``) or a scene file as a design problem.

    Raises
    ------
    InputError
        A scene whose exposure is not fixed or whose lights lack an irradiance,
        a scene with several optics or cameras, a station without ``scene:``,
        ``channels:`` or ``camera.exposure_us``.
    """
    from inspect_validate.config import parse_yaml

    path = Path(path)
    try:
        doc = parse_yaml(path.read_text(), source=str(path))
    except (OSError, UnicodeDecodeError, InputError):
        doc = None  # read_scene says what is wrong with the file
    if isinstance(doc, dict) and "controller" in doc:
        return _from_station(path)
    return _from_scene(path)


def _from_station(path: Path) -> DesignProblem:
    from inspect_validate.camera.station import read_station
    from inspect_validate.comparisons import Comparisons
    from inspect_validate.model.illumination import station_model

    st = read_station(path)
    if st.camera.exposure_us is None:
        raise InputError(
            "camera.exposure_us is needed to design at the station's exposure", source=str(path)
        )
    model = station_model(st)
    if model.nominal:
        ch = min(model.nominal)
        raise InputError(
            f"channel {ch} ({model.channels[ch].name}) has no irradiance: a mix needs every "
            f"channel's irradiance; give channels.{ch}.irradiance",
            source=str(path),
        )
    classes = tuple(model.scene.classes)
    names = [c.name for c in classes]
    comparisons = Comparisons.of(names, st.comparisons, source=f"{path}: comparisons")
    objective = comparisons
    if st.acceptance.separation:
        objective = comparisons.subset([s.comparison for s in st.acceptance.separation])
    return DesignProblem(
        source=str(path),
        kind="station",
        channels=dict(model.channels),
        optics=model.optics,
        camera=model.camera,
        classes=classes,
        grid=model.scene.grid,
        exposure_time=model.exposure_time,
        comparisons=comparisons,
        objective=objective,
        # None (no limit) designs to the default; 0 would put the ceiling at −∞.
        max_saturated=max(
            1e-3 if st.acceptance.max_saturated is None else st.acceptance.max_saturated, 1e-9
        ),
        station=st,
    )


def _from_scene(path: Path) -> DesignProblem:
    from inspect_validate.scene import read_scene

    sc = read_scene(path)
    if sc.exposure.mode != "fixed":
        raise InputError(
            "design mixes lights at one exposure: give 'exposure: {mode: fixed, time: …}' "
            "(or design on a station file, which has its exposure)",
            source=str(path),
        )
    for what, items in (("optics", sc.optics), ("cameras", sc.cameras)):
        if len(items) != 1:
            raise InputError(
                f"design needs one of the scene's {what}, and it has {len(items)}; keep the "
                "one the station uses",
                source=str(path),
            )
    missing = [light.name for light in sc.lights if light.irradiance is None]
    if missing:
        raise InputError(
            f"light {missing[0]!r} has no irradiance: a mix needs every light's (W/m²)",
            source=str(path),
        )
    channels = {i + 1: light for i, light in enumerate(sc.lights)}
    objective = sc.comparisons
    if sc.rank_comparison:
        objective = sc.comparisons.subset([sc.rank_comparison])
    return DesignProblem(
        source=str(path),
        kind="scene",
        channels=channels,
        optics=sc.optics[0],
        camera=sc.cameras[0],
        classes=tuple(sc.classes),
        grid=sc.grid,
        exposure_time=float(sc.exposure.time),
        comparisons=sc.comparisons,
        objective=objective,
        max_saturated=1e-3,
    )
