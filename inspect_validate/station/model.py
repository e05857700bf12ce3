"""A station's illuminations as lights of its scene, and the prediction for the station as built.

Each controller channel drives one light of the station's scene, at an
irradiance E_c (W/m² at the object at 100 %: the station's value, else the
scene light's own). An illumination sets channels to percentages p_c, and its
spectral irradiance at the object is the sum

    E(λ) = Σ_c (p_c / 100) · E_c · S_c(λ) / ∫_band S_c dλ,

S_c the channel light's SPD and the integral over the band its irradiance is
stated for. A channel whose light has no irradiance anywhere gets a nominal
1 W/m²: its predictions are then relative, which calibration by ``fit`` or
``reference`` absorbs and ``absolute`` refuses.

The prediction for the station uses the station's camera settings — the fixed
exposure time and the gain in dB on top of the scene camera's K — and only the
scene's optics and camera the station names, so it is the one combination per
illumination that the station is.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import TYPE_CHECKING

import numpy as np

from inspect_validate.components.lights import Light
from inspect_validate.components.sensors import gain_factor
from inspect_validate.errors import InputError
from inspect_validate.spectra import Spectrum, SpectrumKind

if TYPE_CHECKING:
    from inspect_validate.comparisons import Comparisons
    from inspect_validate.components.optics import Optics
    from inspect_validate.components.sensors import SensorModel
    from inspect_validate.scene import Scene
    from inspect_validate.station.file import Station
    from inspect_validate.station.prediction import StationPrediction

__all__ = ["StationModel", "illumination_light", "station_model"]

NOMINAL_IRRADIANCE = 1.0  # W/m², for a channel whose light's irradiance is unknown


@dataclass(frozen=True)
class StationModel:
    """The scene components a station is built from.

    Attributes
    ----------
    scene : Scene
    channels : dict of int to Light
        Each controller channel's light at 100 %, with its irradiance (W/m²).
    nominal : frozenset of int
        Channels whose irradiance is not known (set to 1 W/m²).
    optics : Optics
    sensor : SensorModel
        The station camera's sensor model: the scene's (or the one ``characterize``
        measured), with the station's gain applied.
    scene_sensor : SensorModel
        The sensor model as the scene gives it (what a simulated camera renders).
    exposure_time : float or None
        The station's exposure, s (None: the scene's exposure control).
    """

    scene: Scene
    channels: dict
    nominal: frozenset
    optics: Optics
    sensor: SensorModel  # as measured, where the station names a camera file
    scene_sensor: SensorModel  # as the scene declares it
    exposure_time: float | None

    def illumination_lights(self, station: Station) -> list[Light]:
        """One light per illumination of ``station``, at its stated irradiance."""
        return [
            illumination_light(i.name, i.channels, self.channels, grid=self.scene.grid)
            for i in station.illuminations
        ]

    def predict(
        self,
        station: Station,
        *,
        comparisons: Comparisons | None = None,
        field: np.ndarray | None = None,
        corrected: bool = False,
        texture_share: np.ndarray | None = None,
    ) -> StationPrediction:
        """:func:`~inspect_validate.model.predict` of every illumination of ``station``
        at its stated irradiances (:meth:`StationPrediction.calibrated
        <inspect_validate.station.prediction.StationPrediction.calibrated>` scales them);
        ``field``, (illumination, class, 2), each class region's mean share of the light
        and its relative spread (:func:`~inspect_validate.characterization.field.
        field_factors`; None: every class at the stated irradiance); ``corrected``: the
        frames' shading corrected by that field (the station's ``field.corrected``);
        ``texture_share``, (illumination,), the share of each class's texture the lens's
        blur leaves under each (:func:`~inspect_validate.model.mtf.texture_share`; None:
        a sharp lens)."""
        from inspect_validate.model import Exposure
        from inspect_validate.model.acquisition import predict_chain, prepare
        from inspect_validate.station.prediction import StationPrediction

        exposure = (
            Exposure("fixed", time=self.exposure_time)
            if self.exposure_time is not None
            else self.scene.exposure
        )
        chain = prepare(
            self.illumination_lights(station),
            [self.optics],
            [self.sensor],
            list(self.scene.classes),
            exposure=exposure,
            grid=self.scene.grid,
            comparisons=comparisons or self.scene.comparisons,
        )
        if field is not None:
            chain = replace(chain, field=np.asarray(field, float), field_corrected=corrected)
        if texture_share is not None:
            chain = replace(chain, texture_share=np.asarray(texture_share, float))
        return StationPrediction.of(predict_chain(chain), chain=chain)

    def focus_mtf(self, station: Station, frequencies: np.ndarray) -> dict[str, np.ndarray]:
        """Per illumination of ``station``, its lens's MTF in focus at its f-number times
        its pixels' at ``frequencies`` (cycles/px; :func:`~inspect_validate.model.mtf.
        focus_mtf`): the diffraction averaged over the electrons each wavelength brings
        from a white target (the light, the lens's transmission, the sensor's QE)."""
        from inspect_validate.model import Exposure
        from inspect_validate.model.acquisition import prepare
        from inspect_validate.model.mtf import focus_mtf

        chain = prepare(
            self.illumination_lights(station),
            [self.optics],
            [self.sensor],
            list(self.scene.classes),
            exposure=Exposure(),
            grid=self.scene.grid,
            comparisons=None,
        )
        return {
            i.name: focus_mtf(
                frequencies,
                wavelengths=chain.grid,
                weights=e * chain.t[0] * chain.q[0],
                f_number=self.optics.f_number,
                pixel_pitch=self.sensor.pixel_pitch,
            )
            for i, e in zip(station.illuminations, chain.e, strict=True)
        }

    def focus_mtf50(self, station: Station) -> dict[str, float]:
        """Per illumination of ``station``, the MTF50 (cycles/px) of :meth:`focus_mtf`."""
        from inspect_validate.model.mtf import falls_to

        f = np.linspace(0.0, 1.0, 4001)
        return {name: falls_to(f, mtf) for name, mtf in self.focus_mtf(station, f).items()}


def _pick(items, name, *, what, field, source):
    if name is None:
        if len(items) == 1:
            return items[0]
        raise InputError(
            f"the scene has {len(items)} {what}; say which this station has with "
            f"'{field}: <name>' ({', '.join(x.name for x in items)})",
            source=source,
        )
    for x in items:
        if x.name == name:
            return x
    raise InputError(
        f"{field}: the scene has no {what[:-1] if what.endswith('s') else what} {name!r} "
        f"(it has {', '.join(x.name for x in items)})",
        source=source,
    )


def station_model(station: Station, scene: Scene | None = None) -> StationModel:
    """The scene components of ``station`` (a :class:`~inspect_validate.station.file.Station`).

    Raises
    ------
    InputError
        No scene, a channel naming a light the scene does not have, an
        ambiguous optics or camera (each message names the station file and field).
    """
    from inspect_validate.scene import read_scene

    source = str(station.path)
    if scene is None:
        if not station.scene:
            raise InputError(
                "the station has no 'scene:' (the spectra of its objects, lights, lens and camera)",
                source=source,
            )
        scene = read_scene(station.resolve(station.scene))
    if not station.channels:
        raise InputError(
            "the station has no 'channels:' (controller channel → scene light)", source=source
        )
    by_name = {light.name: light for light in scene.lights}
    channels, nominal = {}, set()
    for ch, spec in station.channels.items():
        if spec.light not in by_name:
            raise InputError(
                f"channels.{ch}: the scene has no light {spec.light!r} "
                f"(it has {', '.join(by_name)})",
                source=source,
            )
        light = by_name[spec.light]
        irradiance = spec.irradiance if spec.irradiance is not None else light.irradiance
        if irradiance is None:
            irradiance = NOMINAL_IRRADIANCE
            nominal.add(ch)
        channels[ch] = replace(light, irradiance=float(irradiance))
    optics = _pick(scene.optics, station.optics, what="optics", field="optics", source=source)
    sensor = scene_sensor = _pick(
        scene.cameras, station.camera.model, what="cameras", field="camera.model", source=source
    )
    if station.camera.measured:
        # What characterize measured replaces the declared values in the model; the
        # scene's sensor stays what a simulated camera renders (the world's sensor).
        from inspect_validate.components.camera_file import measured_sensor

        sensor = measured_sensor(scene_sensor, station.resolve(station.camera.measured))
    if station.camera.gain_db:
        gain = sensor.gain * gain_factor(station.camera.gain_db)
        sensor = replace(sensor, gain=gain, name=f"{sensor.name} at {station.camera.gain_db:g} dB")
    t = station.camera.exposure_us
    return StationModel(
        scene,
        channels,
        frozenset(nominal),
        optics,
        sensor,
        scene_sensor,
        None if t is None else t * 1e-6,
    )


def illumination_light(
    name: str, setting: dict, channels: dict, *, grid: np.ndarray, scale: float = 1.0
) -> Light:
    """The light of an illumination: its channels' lights summed at their percentages.

    Parameters
    ----------
    name : str
    setting : dict of int to float
        Channel → percent (0–100).
    channels : dict of int to Light
        Each channel's light at 100 %, with its irradiance (W/m², over its band).
    grid : ndarray
        Wavelengths of the summed SPD, nm.
    scale : float
        Factor on the result (a calibrated irradiance scale).

    Returns
    -------
    Light
        Absolute SPD, W·m⁻²·nm⁻¹, with ``irradiance`` its integral over ``grid``.
    """
    grid = np.asarray(grid, dtype=np.float64)
    total = np.zeros(grid.size)
    for ch, percent in setting.items():
        if percent <= 0:
            continue
        light = channels[ch]
        values = np.nan_to_num(light.spd.resample(grid)[0])
        total += (percent / 100.0) * light.irradiance / light.band_power() * values
    total *= scale
    power = float(np.trapezoid(total, grid))
    if not power > 0:
        raise InputError(
            f"illumination {name!r}: no light within {grid[0]:g}–{grid[-1]:g} nm "
            "(every channel off, or outside the scene's wavelengths)"
        )
    spd = Spectrum(grid, total[None, :], SpectrumKind.SPD, name, f"illumination {name}")
    return Light(name, spd, irradiance=power, band=(float(grid[0]), float(grid[-1])))
