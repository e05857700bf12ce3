"""A scene: the object classes, candidate components and exposure of a prediction, read
from a scene file (its schema: :mod:`inspect_validate.scene_file`) and built into the
components :func:`inspect_validate.model.predict` takes. Every error names the file and
the field.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from inspect_validate.comparisons import Comparisons, RankBy
from inspect_validate.config import load_yaml
from inspect_validate.errors import InputError, sourced
from inspect_validate.scene_file import (
    IRRADIANCE_BAND,
    MAX_GRID_POINTS,
    BlackbodyLight,
    BlinnPhongGloss,
    BuiltinCamera,
    CieLight,
    ClassFile,
    CookTorranceGloss,
    DaylightLight,
    IdealOptics,
    LedLight,
    LensOptics,
    MaterialOptics,
    SceneFile,
    WhiteLedLight,
    WhiteLedParams,
)

if TYPE_CHECKING:
    from inspect_validate.model import Prediction, Ranking

__all__ = ["Scene", "read_scene"]


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
    rank_by: RankBy
    rank_comparison: str | None
    comparisons: Comparisons
    skipped: tuple[str, ...] = ()
    """Work the scene's declarations leave out, and why."""

    def _model_inputs(self) -> tuple[list, dict]:
        """The components and options as :func:`~inspect_validate.model.predict` and
        :func:`~inspect_validate.model.sweep` take them."""
        parts = [list(self.lights), list(self.optics), list(self.cameras), list(self.classes)]
        return parts, {"exposure": self.exposure, "comparisons": self.comparisons}

    def predict(self, *, grid: np.ndarray | None = None) -> Prediction:
        """:func:`inspect_validate.model.predict` for every combination of this scene."""
        from inspect_validate.model import predict

        parts, options = self._model_inputs()
        with sourced(self.source):
            return predict(*parts, grid=self.grid if grid is None else grid, **options)

    def sweep(
        self,
        *,
        by: RankBy | None = None,
        comparison: str | None = None,
        top: int = 10,
        client: Any = None,
    ) -> Ranking:
        """:func:`inspect_validate.model.sweep` of every combination of this scene, ranked as
        ``inspect-validate predict`` ranks it: by the scene's ``rank:`` unless ``by``
        (``"error"``, ``"snr_db"``, ``"cnr_db"``) and ``comparison`` (``"A vs B,C"``) say
        otherwise; the best ``top`` rows. Its ``skipped_work`` begins with the scene's own
        (:attr:`skipped`); :func:`~inspect_validate.report.prediction.format_prediction`
        prints it as the command does."""
        from inspect_validate.model import sweep

        parts, options = self._model_inputs()
        with sourced(self.source):
            ranking = sweep(
                *parts,
                grid=self.grid,
                by=by or self.rank_by,
                comparison=comparison if comparison is not None else self.rank_comparison,
                top=top,
                client=client,
                **options,
            )
        return replace(ranking, skipped_work=(*self.skipped, *ranking.skipped_work))

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
    from inspect_validate.components.geometry import Geometry
    from inspect_validate.model import Exposure

    path = Path(path)
    model = load_yaml(path, SceneFile, what="scene file")
    base = path.parent
    geometry = Geometry(**model.geometry.model_dump()) if model.geometry else None

    def build(make, spec, where):
        with sourced(where):  # errors from a component's own file name it already
            return make(spec, base)

    classes = tuple(
        build(
            lambda s, b, n=name: _object_class(n, s, b, geometry), spec, f"{path}: classes.{name}"
        )
        for name, spec in model.classes.items()
    )
    lights = tuple(build(_light, s, f"{path}: lights[{i}]") for i, s in enumerate(model.lights))
    optics = tuple(build(_optics, s, f"{path}: optics[{i}]") for i, s in enumerate(model.optics))
    cameras = tuple(build(_camera, s, f"{path}: cameras[{i}]") for i, s in enumerate(model.cameras))
    for kind, items in (("lights", lights), ("optics", optics), ("cameras", cameras)):
        names = [x.name for x in items]
        dup = {n for n in names if names.count(n) > 1}
        if dup:
            raise InputError(
                f"{kind}: duplicate name(s) {sorted(dup)}; give each a 'name'", source=str(path)
            )
    exposure = Exposure(**model.exposure.model_dump())
    comparisons = Comparisons.of(
        [c.name for c in classes],
        model.comparisons.groups,
        model.comparisons.weights,
        source=f"{path}: comparisons",
    )
    try:  # 'pixels' is for measurements: refuse it here, naming the file
        comparisons.class_weights()
    except InputError as exc:
        raise InputError(str(exc), source=f"{path}: comparisons.weights") from None
    grid, skipped = _grid(model.wavelength, classes, lights, optics, cameras, path)
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
        comparisons,
        skipped,
    )


def _grid(wl, classes, lights, optics, cameras, path) -> tuple[np.ndarray, tuple[str, ...]]:
    """The integration grid, and what its default range leaves out.

    Undeclared, ``start``/``stop`` span where a light, a lens and a camera can all be
    non-zero (each kind's supports joined, the kinds intersected): outside it every
    combination's integrand has a zero factor, so leaving it out changes no integral.
    The classes do not narrow it: a reflectance that misses a light's band must be
    reported, not cut away. If no wavelength has all three, the spectra's joined
    ranges are kept, and the combinations are skipped with their reasons.
    """
    kinds = [[x.spd for x in lights], [x.transmission for x in optics], [x.qe for x in cameras]]
    spectra = [c.reflectance for c in classes] + [s for kind in kinds for s in kind]
    joined = min(s.range[0] for s in spectra), max(s.range[1] for s in spectra)
    response = (
        max(min(s.support[0] for s in kind) for kind in kinds),
        min(max(s.support[1] for s in kind) for kind in kinds),
    )
    default = joined
    if response[1] > response[0]:
        # On the joined range's lattice, one step beyond the response on each side: the
        # ends then hold zeros, and every point inside keeps its trapezoid weight, so
        # each integral is the joined grid's, term for term.
        last = np.floor((joined[1] - joined[0]) / wl.step + 0.5)
        first_k = max(np.floor((response[0] - joined[0]) / wl.step) - 1, 0)
        last_k = min(np.ceil((response[1] - joined[0]) / wl.step) + 1, last)
        default = joined[0] + first_k * wl.step, joined[0] + last_k * wl.step

    def declared_or(bounds):
        return tuple(
            b if d is None else d for b, d in zip(bounds, (wl.start, wl.stop), strict=True)
        )

    start, stop = declared_or(default)
    if stop <= start:
        raise InputError(
            f"wavelength: stop {stop:g} nm is not above start {start:g} nm", source=str(path)
        )
    count = (stop - start) / wl.step + 1
    if count < 2:
        raise InputError(
            f"wavelength: {start:g}–{stop:g} nm is narrower than one {wl.step:g} nm step: one "
            "point cannot be integrated; widen the range or give a finer step",
            source=str(path),
        )
    if count > MAX_GRID_POINTS:
        raise InputError(
            f"wavelength: {start:g}–{stop:g} nm in {wl.step:g} nm steps is {count:.3g} points "
            f"(at most {MAX_GRID_POINTS - 1:,} + 1); use a coarser step (1 nm is accurate to 2e-5 in μ) "
            "or a narrower range",
            source=str(path),
        )
    skipped: tuple[str, ...] = ()
    lo, hi = declared_or(joined)
    if (lo, hi) != (start, stop):
        left_out = round((hi - lo) / wl.step) - round((stop - start) / wl.step)
        skipped = (
            f"wavelengths {lo:g}–{hi:g} nm (the spectra's ranges) narrowed to {start:g}–"
            f"{stop:g} nm, where a light, a lens and a camera all respond: {left_out} grid "
            "points with nothing to integrate",
        )
    return np.arange(start, stop + wl.step / 2, wl.step), skipped


def _object_class(name, spec, base, geometry):
    from inspect_validate.components.geometry import BlinnPhong, CookTorrance, reflectance_factor
    from inspect_validate.model import ObjectClass
    from inspect_validate.spectra import SpectrumKind, read_spectrometer, read_spectrum_csv

    if isinstance(spec, ClassFile):
        reflectance = read_spectrum_csv(base / spec.file, kind=SpectrumKind.REFLECTANCE, name=name)
    else:
        s = spec.spectrometer
        reflectance = read_spectrometer(
            base / s.readings, black=base / s.black, white=base / s.white, name=name
        )
    gloss = None
    if isinstance(spec.gloss, BlinnPhongGloss):
        gloss = BlinnPhong(**spec.gloss.blinn_phong.model_dump())
    elif isinstance(spec.gloss, CookTorranceGloss):
        gloss = CookTorrance(**spec.gloss.cook_torrance.model_dump())
    if geometry is None and gloss is None:
        return ObjectClass(name, reflectance)  # the chapter's diffuse model: nothing to apply
    diffuse, specular = reflectance_factor(geometry, gloss)
    note = f"geometry: diffuse × {diffuse:.4g}, specular + {specular:.4g}"
    return ObjectClass(
        name, reflectance.with_values(reflectance.values * diffuse + specular, notes=[note])
    )


def _light(spec, base):
    from inspect_validate.components import (
        blackbody,
        cie_daylight,
        cie_illuminant,
        led,
        phosphor_white_led,
    )
    from inspect_validate.components.lights import Light
    from inspect_validate.spectra import SpectrumKind, read_spectrum_csv

    if isinstance(spec, LedLight):
        light = led(spec.led.peak, spec.led.fwhm)
    elif isinstance(spec, BlackbodyLight):
        light = blackbody(spec.blackbody)
    elif isinstance(spec, CieLight):
        light = cie_illuminant(spec.cie)
    elif isinstance(spec, DaylightLight):
        light = cie_daylight(spec.daylight)
    elif isinstance(spec, WhiteLedLight):
        light = phosphor_white_led(**(spec.white_led or WhiteLedParams()).model_dump())
    else:
        spd = read_spectrum_csv(base / spec.file, kind=SpectrumKind.SPD)
        light = Light(spd.name, spd)
    return replace(
        light,
        name=spec.name or light.name,
        irradiance=spec.irradiance,
        band=spec.irradiance_band or IRRADIANCE_BAND,
    )


def _optics(spec, base):
    from inspect_validate.components import ideal_lens, lens, material_transmission
    from inspect_validate.components.optics import Optics
    from inspect_validate.spectra import SpectrumKind, read_spectrum_csv

    f_number = spec.f_number
    if isinstance(spec, IdealOptics):
        o = ideal_lens(f_number=f_number or 4.0)
    elif isinstance(spec, LensOptics):
        o = lens(spec.lens, f_number=f_number)
    elif isinstance(spec, MaterialOptics):
        t = material_transmission(spec.material, thickness_mm=spec.thickness_mm)
        o = Optics(t.name, t, f_number or 4.0)
    else:
        t = read_spectrum_csv(base / spec.file, kind=SpectrumKind.TRANSMISSION)
        o = Optics(t.name, t, f_number or 4.0)
    return Optics(spec.name or o.name, o.transmission, o.f_number)


def _camera(spec, base):
    from inspect_validate.components import SensorModel, builtin_sensor
    from inspect_validate.spectra import SpectrumKind, read_spectrum_csv

    given = {
        k: v
        for k, v in spec.model_dump(exclude={"builtin", "file", "name", "measured"}).items()
        if v is not None
    }

    def make(**measured):
        values = {**given, **measured}  # what characterize measured, over what is stated
        if isinstance(spec, BuiltinCamera):
            cam = builtin_sensor(spec.builtin)
            changed = f"{cam.name}, {', '.join(f'{k} {v:g}' for k, v in values.items())}"
            return replace(cam, name=spec.name or (changed if values else cam.name), **values)
        qe = read_spectrum_csv(base / spec.file, kind=SpectrumKind.QE)
        return SensorModel(spec.name or qe.name, qe, **values)

    if spec.measured is None:
        return make()
    from inspect_validate.components.camera_file import build_measured

    return build_measured(make, base / spec.measured, what="the scene's camera")
