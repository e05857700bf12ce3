"""What ``design`` optimises, from a station file or a scene file: the channels' lights,
the optics and camera, the classes, the exposure and the comparisons."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

from inspect_validate.errors import InputError

if TYPE_CHECKING:
    import numpy as np

    from inspect_validate.comparisons import Comparisons
    from inspect_validate.components.optics import Optics
    from inspect_validate.components.sensors import SensorModel
    from inspect_validate.station.file import Station

__all__ = ["MAX_EXPOSURE_TIME", "DesignProblem", "design_problem"]

MAX_EXPOSURE_TIME = 100.0  # s: the longest a station file takes (camera.exposure_us ≤ 1e8)


@dataclass(frozen=True)
class DesignProblem:
    """One camera, one optics and a controller's channels, each a scene light.

    ``channels`` maps the controller channel (a scene's lights are numbered from
    1 in file order) to its light at 100 %, with its irradiance; ``objective``
    are the comparisons whose worst ε is minimised (the station's acceptance
    separation comparisons, else every comparison). With ``auto_exposure`` the
    exposure is designed too, up to ``max_exposure_time``; ``exposure_time`` is
    then only the reference the levels are computed at.
    """

    source: str
    kind: str  # "station" or "scene"
    channels: dict
    optics: Optics
    sensor: SensorModel
    classes: tuple
    grid: np.ndarray  # nm
    exposure_time: float  # s
    comparisons: Comparisons  # of the classes (all that are reported)
    objective: Comparisons  # the comparisons the objective is about
    max_saturated: float
    station: Station | None = None
    auto_exposure: bool = False
    max_exposure_time: float = MAX_EXPOSURE_TIME  # s
    rank_by: str = "error"  # what the scene ranks by (error, snr_db, cnr_db)
    skipped: tuple[str, ...] = ()  # work the scene's declarations leave out (Scene.skipped)


def design_problem(path: str | Path, *, auto_exposure: bool = False) -> DesignProblem:
    """Read a station file (it has ``controller:``) or a scene file as a design problem.

    Parameters
    ----------
    path : str or Path
    auto_exposure : bool, keyword-only
        Design the exposure time too. A scene whose exposure is ``auto`` is
        designed so anyway, up to its ``max_time``.

    Raises
    ------
    InputError
        A scene whose lights lack an irradiance, a scene with several optics or
        cameras, a station without ``scene:``, ``channels:`` or (unless
        ``auto_exposure``) ``camera.exposure_us``.
    """
    from inspect_validate.files import input_file
    from inspect_validate.strict_yaml import YAML_MAX_BYTES, parse_yaml

    path = Path(path)
    try:  # what input_file refuses (a pipe, a device, too large) read_scene says
        input_file(path, "scene file", todo="", largest=YAML_MAX_BYTES)
        doc = parse_yaml(path.read_text(), source=str(path))
    except (OSError, UnicodeDecodeError, InputError):
        doc = None  # read_scene says what is wrong with the file
    if isinstance(doc, dict) and "controller" in doc:
        return _from_station(path, auto_exposure)
    return _from_scene(path, auto_exposure)


def _from_station(path: Path, auto_exposure: bool) -> DesignProblem:
    from inspect_validate.comparisons import Comparisons
    from inspect_validate.station.file import read_station
    from inspect_validate.station.model import station_model

    st = read_station(path)
    if st.camera.exposure_us is None:
        if not auto_exposure:
            raise InputError(
                "camera.exposure_us is needed to design at the station's exposure (or design "
                "the exposure too: --auto-exposure)",
                source=str(path),
            )
        # any reference exposure will do: auto exposure rescales
        st = st.model_copy(update={"camera": st.camera.model_copy(update={"exposure_us": 1e3})})
    model = station_model(st)
    if model.nominal:
        ch = min(model.nominal)
        raise InputError(
            f"channel {ch} ({model.channels[ch].name}) has no irradiance: a mix needs every "
            f"channel's irradiance; give channels.{ch}.irradiance",
            source=str(path),
        )
    assert model.exposure_time is not None  # a reference exposure was set above
    classes = tuple(model.scene.classes)
    names = [c.name for c in classes]
    comparisons = Comparisons.of(
        names, st.comparisons.groups, st.comparisons.weights, source=f"{path}: comparisons"
    )
    objective = comparisons
    if st.acceptance.separation:
        objective = comparisons.subset([s.comparison for s in st.acceptance.separation])
    return DesignProblem(
        source=str(path),
        kind="station",
        channels=dict(model.channels),
        optics=model.optics,
        sensor=model.sensor,
        classes=classes,
        grid=model.scene.grid,
        skipped=model.scene.skipped,
        exposure_time=model.exposure_time,
        comparisons=comparisons,
        objective=objective,
        # None (no limit) designs to the default; 0 would put the ceiling at −∞.
        max_saturated=max(
            1e-3 if st.acceptance.max_saturated is None else st.acceptance.max_saturated, 1e-9
        ),
        station=st,
        auto_exposure=auto_exposure,
    )


def _from_scene(path: Path, auto_exposure: bool) -> DesignProblem:
    from inspect_validate.scene import read_scene

    sc = read_scene(path)
    auto = auto_exposure or sc.exposure.mode == "auto"
    longest = sc.exposure.max_time or MAX_EXPOSURE_TIME
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
        sensor=sc.cameras[0],
        classes=tuple(sc.classes),
        grid=sc.grid,
        # auto: any reference exposure will do (the levels rescale), below the longest
        exposure_time=float(sc.exposure.time or min(1e-3, longest)),
        comparisons=sc.comparisons,
        objective=objective,
        max_saturated=1e-3,
        auto_exposure=auto,
        max_exposure_time=max(longest, float(sc.exposure.time or 0.0)),
        rank_by=sc.rank_by,
        skipped=sc.skipped,
    )
