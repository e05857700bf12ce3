"""The measured camera: what ``characterize`` found, as a file a station reads.

A YAML file with the EMVA 1288 values the model uses (``camera:``, the scene's camera
keys) and where they came from (``measured:``: the station, its SHA-256, the capture
folder, the exposure gain in dB, the date, the tool, each value's standard error)::

    camera:
      gain: 0.02856            # DN/e⁻ at the gain it was measured at
      dark_noise: 12.1         # e⁻
      saturation: 9960         # e⁻
      ...
    measured: {station: ..., gain_db: 0, standard_errors: {gain: 6.1e-05, ...}}

A station names it with ``camera.measured``; :func:`measured_sensor` then replaces the
scene camera's values. The QE curve keeps its shape (the series is lit by one light); where
the light's irradiance was stated, its level is the measured one (``qe_scale``).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING, Any, Protocol

from inspect_validate.errors import InputError

if TYPE_CHECKING:
    from inspect_validate.components.sensors import SensorModel

__all__ = [
    "build_measured",
    "measured_sensor",
    "measured_values",
    "read_camera_file",
    "write_camera_file",
]


class Measured(Protocol):
    """What :func:`write_camera_file` reads of a measurement (a characterization's
    result has it, each value with its standard error as ``<name>_se``): EMVA 1288
    values, NaN where not measured."""

    gain: float
    dark_noise: float
    saturation: float
    bit_depth: int
    dark_offset: float
    dark_current: float
    dsnu: float
    prnu: float
    qe_scale: float
    saturation_reached: bool


def write_camera_file(
    path: str | Path,
    result: Measured,
    *,
    name: str,
    gain_db: float,
    provenance: dict,
) -> Path:
    """Write :class:`~.analysis.Characterization` ``result`` as a camera file at ``path``.

    Values that could not be measured (NaN: no dark current without an exposure
    series, no DSNU/PRNU without stacks) are left out, so the scene's stay.
    """
    import yaml

    from inspect_validate.files import atomic_write

    values = {
        "gain": result.gain,
        "dark_noise": result.dark_noise,
        "saturation": result.saturation,
        "bit_depth": result.bit_depth,
        "dark_offset": max(result.dark_offset, 0.0),
        "dark_current": max(result.dark_current, 0.0),
        "dsnu": result.dsnu,
        "prnu": result.prnu,
        "qe_scale": result.qe_scale,
    }
    camera: dict[str, str | int | float] = {"name": name}
    for key, value in values.items():
        if isinstance(value, int) or math.isfinite(value):
            camera[key] = value if isinstance(value, int) else float(f"{value:.6g}")
    errors = {
        key: float(f"{getattr(result, key + '_se'):.3g}")
        for key in ("gain", "dark_noise", "saturation", "dark_current", "dsnu", "prnu", "qe_scale")
        if math.isfinite(getattr(result, key + "_se"))
    }
    doc = {
        "camera": camera,
        "measured": {
            **provenance,
            "gain_db": float(gain_db),
            "date": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
            "standard_errors": errors,
            "saturation_reached": result.saturation_reached,
            "qe": (
                "the scene camera's curve × qe_scale (measured through the lens: their product)"
                if math.isfinite(result.qe_scale)
                else "the scene camera's curve (not measured: the illumination's irradiance is "
                "not stated)"
            ),
        },
    }
    head = "# The camera as `inspect-validate characterize` measured it (EMVA 1288).\n"
    text = head + yaml.safe_dump(doc, sort_keys=False, allow_unicode=True)
    return atomic_write(path, text.encode())


def _file_model() -> Any:
    """The camera file's validation model (built on first use: pydantic is not needed to
    write one)."""
    from typing import Annotated

    from pydantic import BaseModel, ConfigDict, Field

    from inspect_validate.components.sensors import BIT_DEPTHS
    from inspect_validate.config import StrictModel

    Positive = Annotated[float, Field(gt=0, le=1e9, allow_inf_nan=False)]
    NonNegative = Annotated[float, Field(ge=0, le=1e9, allow_inf_nan=False)]

    # Meanings as descriptions: a model built in a function has no source for
    # config.field_docs to read its docstrings from.
    def described(text: str, default=None):
        return Field(default, description=text)

    class MeasuredValues(StrictModel):
        """The measured EMVA 1288 values; each left out keeps the scene camera's."""

        name: str | None = described("Shown in tables and reports.")
        gain: Positive | None = described(
            "Overall system gain K, DN/e⁻, at the gain ``measured.gain_db`` it was measured at."
        )
        dark_noise: NonNegative | None = described("Temporal dark noise σ_d, e⁻.")
        saturation: Positive | None = described(
            "Saturation capacity μ_e.sat, e⁻ (where the variance peaks, EMVA 1288)."
        )
        bit_depth: Annotated[int, Field(ge=BIT_DEPTHS[0], le=BIT_DEPTHS[1])] | None = described(
            "Bits of a grey value (8 to 32)."
        )
        dark_offset: NonNegative | None = described(
            "Dark offset μ_y.dark, DN: below the bit depth's largest value."
        )
        dark_current: NonNegative | None = described("Dark current, e⁻/s.")
        dsnu: NonNegative | None = described("Dark signal non-uniformity, e⁻ rms.")
        prnu: Annotated[float, Field(ge=0, le=1, allow_inf_nan=False)] | None = described(
            "Photo-response non-uniformity, relative rms (0.01 = 1 %)."
        )
        qe_scale: Annotated[float, Field(gt=0, le=100, allow_inf_nan=False)] | None = described(
            "The measured level of the scene camera's QE curve (its shape kept), through the "
            "lens: measured where the light's irradiance was stated."
        )

    class Provenance(BaseModel):
        """Where the values came from: the station and its SHA-256, the capture folder, the
        date, each value's standard error (``standard_errors``)."""

        model_config = ConfigDict(extra="allow")  # station, date, standard errors, …
        gain_db: Annotated[float, Field(ge=-60, le=100, allow_inf_nan=False)] = described(
            "The camera's gain during the measurement, dB: K is brought back to 0 dB from it.",
            0.0,
        )

    class CameraFile(StrictModel):
        """A camera as ``characterize`` measured it."""

        camera: MeasuredValues = described("The model's values.", ...)
        measured: Provenance = described("How they were measured.", Provenance())

    return CameraFile


def read_camera_file(path: str | Path) -> dict:
    """The ``camera:`` values of a camera file and its ``measured:`` provenance, checked
    (errors name the file and the field)."""
    from inspect_validate.config import load_yaml

    doc = load_yaml(path, _file_model(), what="camera file")
    values = doc.camera.model_dump(exclude={"name"}, exclude_none=True)
    return {"values": values, "name": doc.camera.name, "measured": doc.measured.model_dump()}


def measured_values(path: str | Path) -> dict:
    """The camera file's model values, K brought back to 0 dB (the station or scene
    applies its own gain)."""
    doc = read_camera_file(path)
    values = dict(doc["values"])
    if "gain" in values:
        from inspect_validate.components.sensors import gain_factor

        values["gain"] /= gain_factor(doc["measured"]["gain_db"])
    return values


def measured_sensor(scene_camera: SensorModel, path: str | Path) -> SensorModel:
    """``scene_camera`` with the values of the camera file at ``path``
    (:func:`measured_values`)."""
    name = f"{scene_camera.name} (measured: {Path(path).name})"
    return build_measured(
        lambda **values: replace(scene_camera, name=name, **values),
        path,
        what=f"the scene's camera {scene_camera.name!r}",
    )


def build_measured(make: Callable[..., SensorModel], path: str | Path, *, what: str) -> SensorModel:
    """The sensor ``make(**values)`` builds from the camera file's values at ``path``, its
    QE curve scaled by the file's ``qe_scale`` (the declared curve's shape at the measured
    level).

    Parameters
    ----------
    make : callable
        ``make(**values) -> SensorModel``, the file's model values as keywords.
    path : str or Path
        The camera file.
    what : str
        What the other values come from, for the error.

    Raises
    ------
    InputError
        Naming the file, when its values cannot make a camera with the others.
    """
    values = measured_values(path)
    scale = values.pop("qe_scale", None)
    try:
        sensor = make(**values)
    except InputError as exc:  # the file's values with the others: name the file
        raise InputError(
            f"{exc}; the values come from this camera file and {what}", source=str(path)
        ) from None
    if scale is not None:
        qe = sensor.qe
        sensor = replace(
            sensor, qe=qe.with_values(qe.values * scale, name=f"{qe.name} × {scale:.3g}")
        )
    return sensor
