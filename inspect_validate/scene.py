"""Scene files: the object classes, candidate components and exposure of a prediction.

YAML, paths relative to the scene file (README, "Scene files")::

    wavelength: {start: 380, stop: 780, step: 1}      # nm; optional
    classes:
      A: {file: paperboard_A.csv}                     # CSV, one column per sample
      B: {spectrometer: {readings: B.csv, black: black.csv, white: white.csv}}
    lights:
      - {led: {peak: 590, fwhm: 15}, name: amber}
      - {blackbody: 3200}
      - {cie: D65}                                    # also FL1…, HP1 (sodium), LED-B1…
      - {daylight: 5500}
      - {white_led: {}}
      - {file: spd.csv, irradiance: 20}               # W/m² at the object
    optics:
      - {lens: visible}                               # visible | uv | swir
      - ideal
      - {material: BK7, thickness_mm: 5}
      - {file: transmission.csv, f_number: 2.8}
    cameras:
      - cmos-visible                                  # built-in sensors
      - {file: qe.csv, gain: 0.4, dark_noise: 2.5, saturation: 10000, bit_depth: 12}
    exposure: {mode: auto, target: 0.7}               # or {mode: fixed, time: 0.002}
    rank: {by: error}                                 # error | snr_db | cnr_db; comparison: "A vs B,C"
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from pydantic import BaseModel, ConfigDict, Field

from inspect_validate.config import load_yaml
from inspect_validate.errors import InputError

__all__ = ["Scene", "read_scene"]


class _Wavelength(BaseModel):
    model_config = ConfigDict(extra="forbid")
    start: float | None = Field(default=None, gt=0)
    stop: float | None = Field(default=None, gt=0)
    step: float = Field(default=1.0, gt=0)


class _Exposure(BaseModel):
    model_config = ConfigDict(extra="forbid")
    mode: str = "auto"
    time: float | None = Field(default=None, gt=0)
    target: float = Field(default=0.7, gt=0, le=1)
    max_time: float | None = Field(default=None, gt=0)


class _Rank(BaseModel):
    model_config = ConfigDict(extra="forbid")
    by: str = "error"
    comparison: str | None = None


class _Geometry(BaseModel):
    model_config = ConfigDict(extra="forbid")
    light: tuple[float, float, float]
    view: tuple[float, float, float] = (0.0, 0.0, 1.0)
    normal: tuple[float, float, float] = (0.0, 0.0, 1.0)


class _Scene(BaseModel):
    model_config = ConfigDict(extra="forbid")
    name: str | None = None
    geometry: _Geometry | None = None
    wavelength: _Wavelength = _Wavelength()
    classes: dict[str, dict[str, Any]] = Field(min_length=2)
    lights: list[Any] = Field(min_length=1)
    optics: list[Any] = Field(min_length=1)
    cameras: list[Any] = Field(min_length=1)
    exposure: _Exposure = _Exposure()
    rank: _Rank = _Rank()


@dataclass(frozen=True)
class Scene:
    """A parsed scene: components ready for :func:`inspect_validate.model.predict`."""

    name: str
    source: str
    classes: tuple
    lights: tuple
    optics: tuple
    cameras: tuple
    exposure: Any
    grid: np.ndarray
    rank_by: str
    rank_comparison: str | None

    def predict(self, *, grid: np.ndarray | None = None):
        """:func:`inspect_validate.model.predict` for every combination of this scene."""
        from inspect_validate.model import predict

        return predict(
            list(self.lights),
            list(self.optics),
            list(self.cameras),
            list(self.classes),
            exposure=self.exposure,
            grid=self.grid if grid is None else grid,
        )

    def notes(self) -> list[str]:
        """What was noticed while reading the spectra: masked wavelengths, clipped noise."""
        spectra = [(c.name, c.reflectance) for c in self.classes]
        spectra += [(x.name, x.spd) for x in self.lights]
        spectra += [(x.name, x.transmission) for x in self.optics]
        spectra += [(x.name, x.qe) for x in self.cameras]
        return [
            f"{name} ({s.source}): {note}"
            for name, s in spectra
            for note in s.notes
            if not note.startswith("columns:")
        ]


def read_scene(path: str | Path) -> Scene:
    """Read and validate a scene file; every error names the file and field."""
    from inspect_validate.model import Exposure

    path = Path(path)
    model = load_yaml(path, _Scene, what="scene file")
    base = path.parent
    from inspect_validate.components.geometry import Geometry

    geometry = Geometry(**model.geometry.model_dump()) if model.geometry else None
    classes = tuple(
        _object_class(name, spec, base, f"{path}: classes.{name}", geometry)
        for name, spec in model.classes.items()
    )
    lights = tuple(_light(s, base, f"{path}: lights[{i}]") for i, s in enumerate(model.lights))
    optics = tuple(_optics(s, base, f"{path}: optics[{i}]") for i, s in enumerate(model.optics))
    cameras = tuple(_camera(s, base, f"{path}: cameras[{i}]") for i, s in enumerate(model.cameras))
    for kind, items in (("lights", lights), ("optics", optics), ("cameras", cameras)):
        names = [x.name for x in items]
        dup = {n for n in names if names.count(n) > 1}
        if dup:
            raise InputError(
                f"{kind}: duplicate name(s) {sorted(dup)}; give each a 'name'", source=str(path)
            )
    try:
        exposure = Exposure(**model.exposure.model_dump())
    except InputError as exc:
        raise InputError(f"exposure: {exc}", source=str(path)) from None
    if model.rank.by not in ("error", "snr_db", "cnr_db"):
        raise InputError(
            f"rank.by must be error, snr_db or cnr_db, not {model.rank.by!r}", source=str(path)
        )
    grid = _grid(model.wavelength, classes, lights, optics, cameras, path)
    return Scene(
        model.name or path.stem,
        str(path),
        classes,
        lights,
        optics,
        cameras,
        exposure,
        grid,
        model.rank.by,
        model.rank.comparison,
    )


def _grid(wl, classes, lights, optics, cameras, path) -> np.ndarray:
    spectra = (
        [c.reflectance for c in classes]
        + [x.spd for x in lights]
        + [x.transmission for x in optics]
        + [x.qe for x in cameras]
    )
    start = wl.start if wl.start is not None else min(s.range[0] for s in spectra)
    stop = wl.stop if wl.stop is not None else max(s.range[1] for s in spectra)
    if stop <= start:
        raise InputError(
            f"wavelength: stop {stop:g} nm is not above start {start:g} nm", source=str(path)
        )
    return np.arange(start, stop + wl.step / 2, wl.step)


def _one_key(spec, where, allowed):
    if isinstance(spec, str):
        return spec, {}
    if not isinstance(spec, dict):
        raise InputError(f"expected a mapping or a name, got {spec!r}", source=where)
    keys = [k for k in spec if k in allowed]
    if len(keys) != 1:
        raise InputError(
            f"give exactly one of {', '.join(allowed)} (got {', '.join(map(str, spec)) or 'nothing'})",
            source=where,
        )
    extra = (
        set(spec)
        - set(allowed)
        - {
            "name",
            "irradiance",
            "f_number",
            "gain",
            "dark_noise",
            "saturation",
            "bit_depth",
            "dark_offset",
            "pixel_pitch",
            "thickness_mm",
            "gloss",
        }
    )
    if extra:
        raise InputError(f"unknown field(s) {sorted(extra)}", source=where)
    return keys[0], spec


def _object_class(name, spec, base, where, geometry):
    from inspect_validate.components.geometry import reflectance_factor
    from inspect_validate.model import ObjectClass
    from inspect_validate.spectra import SpectrumKind, read_spectrometer, read_spectrum_csv

    kind, spec = _one_key(spec, where, ("file", "spectrometer"))
    if kind == "file":
        reflectance = read_spectrum_csv(
            base / spec["file"], kind=SpectrumKind.REFLECTANCE, name=name
        )
    else:
        s = spec["spectrometer"]
        if not isinstance(s, dict) or set(s) != {"readings", "black", "white"}:
            raise InputError(
                "spectrometer needs readings, black and white (CSV files)", source=where
            )
        reflectance = read_spectrometer(
            base / s["readings"], black=base / s["black"], white=base / s["white"], name=name
        )
    gloss = _gloss(spec.get("gloss"), where)
    if geometry is None and gloss is None:
        return ObjectClass(name, reflectance)  # the chapter's diffuse model: nothing to apply
    try:
        diffuse, specular = reflectance_factor(geometry, gloss)
    except InputError as exc:
        raise InputError(str(exc), source=where) from None
    note = f"geometry: diffuse × {diffuse:.4g}, specular + {specular:.4g}"
    return ObjectClass(
        name, reflectance.with_values(reflectance.values * diffuse + specular, notes=[note])
    )


def _gloss(spec, where):
    from inspect_validate.components.geometry import BlinnPhong, CookTorrance

    if spec is None:
        return None
    models = {"blinn_phong": BlinnPhong, "cook_torrance": CookTorrance}
    if not isinstance(spec, dict) or len(spec) != 1 or next(iter(spec)) not in models:
        raise InputError(
            "gloss is {blinn_phong: {ks, n}} or {cook_torrance: {roughness, f0}}", source=where
        )
    kind, params = next(iter(spec.items()))
    try:
        return models[kind](**params)
    except TypeError as exc:
        raise InputError(f"gloss {kind}: {exc}", source=where) from None


def _light(spec, base, where):
    from dataclasses import replace

    from inspect_validate.components import (
        blackbody,
        cie_daylight,
        cie_illuminant,
        led,
        phosphor_white_led,
    )
    from inspect_validate.components.lights import Light
    from inspect_validate.spectra import SpectrumKind, read_spectrum_csv

    kind, spec = _one_key(spec, where, ("led", "blackbody", "cie", "daylight", "white_led", "file"))
    irradiance = spec.get("irradiance")
    try:
        if kind == "led":
            light = led(float(spec["led"]["peak"]), float(spec["led"]["fwhm"]))
        elif kind == "blackbody":
            light = blackbody(float(spec["blackbody"]))
        elif kind == "cie":
            light = cie_illuminant(str(spec["cie"]))
        elif kind == "daylight":
            light = cie_daylight(float(spec["daylight"]))
        elif kind == "white_led":
            light = phosphor_white_led(**(spec["white_led"] or {}))
        else:
            spd = read_spectrum_csv(base / spec["file"], kind=SpectrumKind.SPD)
            light = Light(spd.name, spd)
    except (KeyError, TypeError, ValueError) as exc:
        if isinstance(exc, InputError):
            raise InputError(str(exc), source=where) from None
        raise InputError(f"{kind}: missing or invalid parameter ({exc})", source=where) from None
    return replace(light, name=spec.get("name", light.name), irradiance=irradiance)


def _optics(spec, base, where):
    from inspect_validate.components import ideal_lens, lens, material_transmission
    from inspect_validate.components.optics import Optics
    from inspect_validate.spectra import SpectrumKind, read_spectrum_csv

    kind, spec = _one_key(spec, where, ("lens", "ideal", "material", "file"))
    f_number = float(spec.get("f_number", 4.0))
    if kind == "ideal":
        o = ideal_lens(f_number=f_number)
    elif kind == "lens":
        o = lens(str(spec["lens"]), f_number=spec.get("f_number"))
    elif kind == "material":
        t = material_transmission(
            str(spec["material"]), thickness_mm=float(spec.get("thickness_mm", 10.0))
        )
        o = Optics(t.name, t, f_number)
    else:
        t = read_spectrum_csv(base / spec["file"], kind=SpectrumKind.TRANSMISSION)
        o = Optics(t.name, t, f_number)
    return Optics(spec.get("name", o.name), o.transmission, o.f_number)


def _camera(spec, base, where):
    from inspect_validate.components import Camera, builtin_camera
    from inspect_validate.spectra import SpectrumKind, read_spectrum_csv

    if isinstance(spec, str):
        return builtin_camera(spec)
    kind, spec = _one_key(spec, where, ("builtin", "file"))
    if kind == "builtin":
        cam = builtin_camera(str(spec["builtin"]))
        return Camera(
            spec.get("name", cam.name),
            cam.qe,
            cam.gain,
            cam.dark_noise,
            cam.saturation,
            cam.bit_depth,
            cam.dark_offset,
            cam.pixel_pitch,
        )
    qe = read_spectrum_csv(base / spec["file"], kind=SpectrumKind.QE)
    missing = [f for f in ("gain", "dark_noise", "saturation") if f not in spec]
    if missing:
        raise InputError(
            f"a camera from a QE file needs its EMVA 1288 parameters: {', '.join(missing)}",
            source=where,
        )
    return Camera(
        spec.get("name", qe.name),
        qe,
        float(spec["gain"]),
        float(spec["dark_noise"]),
        float(spec["saturation"]),
        int(spec.get("bit_depth", 12)),
        float(spec.get("dark_offset", 0.0)),
        float(spec.get("pixel_pitch", 3.45)),
    )
