"""Scene files: the object classes, candidate components and exposure of a prediction.

YAML, paths relative to the scene file (the manual, "Scene files")::

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
      - {file: spd.csv, irradiance: 20}               # W/m² at the object, 380–780 nm
    optics:
      - {lens: visible}                               # visible | uv | swir
      - ideal
      - {material: BK7, thickness_mm: 5}
      - {file: transmission.csv, f_number: 2.8}
    cameras:
      - cmos-visible                                  # built-in sensors
      - {builtin: cmos-visible, gain: 0.2}            # ... with EMVA parameters changed
      - {file: qe.csv, gain: 0.4, dark_noise: 2.5, saturation: 10000, bit_depth: 12}
    exposure: {mode: auto, target: 0.7}               # or {mode: fixed, time: 0.002}
    rank: {by: error}                                 # error | snr_db | cnr_db; comparison: "A vs B,C"
    comparisons:                                      # optional
      groups: default                                 # default | pairs | rest | ["A vs B,C", ...]
      weights: equal                                  # equal | {A: 0.7, B: 0.2, C: 0.1} (priors)

Every component kind is its own validated model (a discriminated union on the
key that names the kind): an unknown or misplaced key, a number out of its
physical range or a wrong type is an error naming the file and the field.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any, Literal

import numpy as np
from pydantic import (
    BeforeValidator,
    Field,
    field_validator,
    model_validator,
)

from inspect_validate.comparisons import Comparisons, ComparisonsSpec, RankBy
from inspect_validate.components.sensors import BIT_DEPTHS
from inspect_validate.config import StrictModel, load_yaml, one_of
from inspect_validate.constants import LONGEST_EXPOSURE_S
from inspect_validate.errors import InputError, sourced

if TYPE_CHECKING:
    from inspect_validate.model import Prediction, Ranking

__all__ = ["IRRADIANCE_BAND", "MAX_GRID_POINTS", "Scene", "read_scene"]

IRRADIANCE_BAND = (380.0, 780.0)
"""nm: the band a light's ``irradiance`` (W/m²) is stated over unless ``irradiance_band`` says otherwise."""
MAX_GRID_POINTS = 200_001
"""Integration wavelengths at most (a 1 nm grid is accurate to 2e-5 in μ)."""

Finite = Annotated[float, Field(allow_inf_nan=False)]
Positive = Annotated[float, Field(gt=0, allow_inf_nan=False)]
NonNegative = Annotated[float, Field(ge=0, allow_inf_nan=False)]
Nanometre = Annotated[float, Field(gt=1, le=100_000, allow_inf_nan=False)]
Name = Annotated[str, Field(min_length=1, max_length=200)]
Irradiance = Annotated[float, Field(gt=0, le=1e6, allow_inf_nan=False)]
"""W/m² at the object, up to 1000 suns: far below where the variances' squares overflow
float64 (1e300 W/m² did)."""


# --- lights ----------------------------------------------------------------------


class _LightCommon(StrictModel):
    name: Name | None = None
    """Shown in tables and reports (default: the spectrum's own name)."""
    irradiance: Irradiance | None = None
    """W/m² at the object, integrated over ``irradiance_band`` (default: relative SPD)."""
    irradiance_band: tuple[Nanometre, Nanometre] | None = None
    """[shortest, longest] nm over which ``irradiance`` is integrated (default 380–780)."""

    @field_validator("irradiance_band")
    @classmethod
    def _ordered(cls, v):
        if v is not None and not v[0] < v[1]:
            raise ValueError("give [shortest, longest] wavelength in nm")
        return v


class _LedParams(StrictModel):
    """A modelled LED (Ohno's spectral model)."""

    peak: Nanometre
    """Peak wavelength, nm."""
    fwhm: Annotated[float, Field(gt=0, le=2000, allow_inf_nan=False)]
    """Full width at half maximum, nm."""


class _WhiteLedParams(StrictModel):
    """A modelled phosphor-converted white LED: a blue die and a broad phosphor peak."""

    blue_peak: Nanometre = 450.0
    """Peak wavelength of the blue die, nm."""
    blue_fwhm: Annotated[float, Field(gt=0, le=2000)] = 20.0
    """Full width at half maximum of the die's peak, nm."""
    phosphor_peak: Nanometre = 560.0
    """Peak wavelength of the phosphor's emission, nm."""
    phosphor_fwhm: Annotated[float, Field(gt=0, le=2000)] = 120.0
    """Full width at half maximum of the phosphor's peak, nm."""
    phosphor_ratio: NonNegative = 2.2
    """The phosphor peak's power over the die's (their integrals)."""


class _Led(_LightCommon):
    led: _LedParams
    """A modelled LED, by its peak and width."""


class _Blackbody(_LightCommon):
    blackbody: Annotated[float, Field(gt=0, le=100_000, allow_inf_nan=False)]
    """Colour temperature, K."""


class _Cie(_LightCommon):
    cie: Name
    """A tabulated CIE illuminant by name: ``A``, ``D50``, ``D65``, ``FL1`` … ``FL12``,
    ``HP1`` … ``HP5`` (high-pressure lamps), ``LED-B1`` … (white LEDs)."""


class _Daylight(_LightCommon):
    daylight: Annotated[float, Field(ge=4000, le=25000)]
    """Colour temperature, K."""


class _WhiteLed(_LightCommon):
    white_led: _WhiteLedParams | None = None
    """A modelled white LED; ``null`` or ``{}`` takes the typical one."""


class _LightFile(_LightCommon):
    file: Name
    """CSV of the light's spectral power: wavelength in nm, then power (any unit: scaled
    by ``irradiance`` where given)."""


_LIGHT_KINDS = ("led", "blackbody", "cie", "daylight", "white_led", "file")
if TYPE_CHECKING:  # a union composed at run time (one_of)
    LightSpec = Any
else:
    LightSpec = one_of(
        dict(
            zip(
                _LIGHT_KINDS,
                (_Led, _Blackbody, _Cie, _Daylight, _WhiteLed, _LightFile),
                strict=True,
            )
        ),
        what="a light",
    )

# --- optics ----------------------------------------------------------------------

FNumber = Annotated[float, Field(ge=0.5, le=1000, allow_inf_nan=False)]


class _OpticsCommon(StrictModel):
    name: Name | None = None
    """Shown in tables and reports."""
    f_number: FNumber | None = None
    """The working f-number N (irradiance at the sensor ∝ 1/(4N²); default 4)."""


class _Lens(_OpticsCommon):
    lens: Literal["visible", "uv", "swir"]
    """A modelled lens: ``visible`` (AR-coated, 400–700 nm), ``uv`` (250–650 nm) or
    ``swir`` (400–1650 nm)."""


def _no_options(v):
    """An option-less component written with an empty mapping (``ideal: {}``) has none."""
    return None if v == {} else v


class _Ideal(_OpticsCommon):
    ideal: Annotated[None, BeforeValidator(_no_options)] = None
    """A lens that transmits everything (``ideal`` alone, or ``ideal: {}``)."""


class _Material(_OpticsCommon):
    material: Literal["BK7", "fused_silica", "CaF2", "MgF2", "ZnSe"]
    """A window or filter substrate, its transmission from its absorption and reflection."""
    thickness_mm: Annotated[float, Field(gt=0, le=1000, allow_inf_nan=False)] = 10.0
    """The material's thickness along the light's path, mm."""


class _OpticsFile(_OpticsCommon):
    file: Name
    """CSV of the optics' transmission: wavelength in nm, then 0–1 (or percent)."""


def _optics_shorthand(v):
    if v == "ideal":
        return {"ideal": None}
    if isinstance(v, str):
        return {"lens": v}
    return v


_OPTICS_KINDS = ("lens", "ideal", "material", "file")
if TYPE_CHECKING:  # a union composed at run time (one_of)
    OpticsSpec = Any
else:
    OpticsSpec = one_of(
        dict(zip(_OPTICS_KINDS, (_Lens, _Ideal, _Material, _OpticsFile), strict=True)),
        what="optics",
        shorthand=_optics_shorthand,
    )

# --- cameras ---------------------------------------------------------------------


class _EmvaOverrides(StrictModel):
    name: Name | None = None
    """Shown in tables and reports (default: the built-in's or the QE file's name)."""
    gain: Annotated[float, Field(gt=0, le=1000, allow_inf_nan=False)] | None = None
    """Overall system gain K, DN/e⁻."""
    dark_noise: Annotated[float, Field(ge=0, le=1e6, allow_inf_nan=False)] | None = None
    """Temporal dark noise σ_d, e⁻."""
    saturation: Annotated[float, Field(gt=0, le=1e9, allow_inf_nan=False)] | None = None
    """Saturation capacity μ_e.sat, e⁻."""
    bit_depth: Annotated[int, Field(ge=BIT_DEPTHS[0], le=BIT_DEPTHS[1])] | None = None
    """Bits of a grey value: 8 (Mono8) to 32."""
    dark_offset: NonNegative | None = None
    """Dark offset μ_y.dark, DN."""
    pixel_pitch: Annotated[float, Field(gt=0, le=1000, allow_inf_nan=False)] | None = None
    """Pixel pitch, µm (the pixel area A in μ_e)."""
    dark_current: Annotated[float, Field(ge=0, le=1e9, allow_inf_nan=False)] | None = None
    """Dark current, e⁻/s."""
    dsnu: Annotated[float, Field(ge=0, le=1e6, allow_inf_nan=False)] | None = None
    """DSNU, e⁻ rms."""
    prnu: Annotated[float, Field(ge=0, le=1, allow_inf_nan=False)] | None = None
    """PRNU, relative rms."""
    measured: Name | None = None
    """A camera file from ``characterize``: its values replace these."""


class _Builtin(_EmvaOverrides):
    builtin: Name
    """A built-in camera: ``cmos-visible``, ``cmos-nir-enhanced`` or ``ingaas-swir``; the
    keys beside it replace its values."""


class _CameraFile(_EmvaOverrides):
    file: Name
    """CSV of the camera's quantum efficiency: wavelength in nm, then 0–1 (or percent);
    its EMVA 1288 values are given beside it."""

    @model_validator(mode="after")
    def _emva(self):
        missing = [f for f in ("gain", "dark_noise", "saturation") if getattr(self, f) is None]
        if missing and self.measured is None:
            raise ValueError(
                f"a camera from a QE file needs its EMVA 1288 parameters: {', '.join(missing)}"
            )
        return self


def _camera_shorthand(v):
    return {"builtin": v} if isinstance(v, str) else v


if TYPE_CHECKING:  # a union composed at run time (one_of)
    SensorSpec = Any
else:
    SensorSpec = one_of(
        {"builtin": _Builtin, "file": _CameraFile}, what="a camera", shorthand=_camera_shorthand
    )

# --- classes ---------------------------------------------------------------------


class _BlinnPhongParams(StrictModel):
    """Blinn–Phong gloss (17): k_s·(N·H)ⁿ added to the diffuse reflectance."""

    ks: NonNegative
    """Specular strength k_s (a reflectance factor, spectrally flat)."""
    n: Positive
    """Shininess exponent n: the higher, the narrower the highlight."""


class _CookTorranceParams(StrictModel):
    """Cook–Torrance microfacet gloss (Beckmann distribution, Schlick's Fresnel term)."""

    roughness: Annotated[float, Field(gt=0, le=1)]
    """Beckmann roughness m: the facets' rms slope."""
    f0: Annotated[float, Field(ge=0, le=1)] = 0.04
    """Fresnel reflectance at normal incidence (0.04 for most plastics and glass)."""


class _BlinnPhong(StrictModel):
    blinn_phong: _BlinnPhongParams
    """A Blinn–Phong highlight."""


class _CookTorrance(StrictModel):
    cook_torrance: _CookTorranceParams
    """A Cook–Torrance highlight."""


if TYPE_CHECKING:  # a union composed at run time (one_of)
    GlossSpec = Any
else:
    GlossSpec = one_of({"blinn_phong": _BlinnPhong, "cook_torrance": _CookTorrance}, what="gloss")


class _ClassCommon(StrictModel):
    gloss: GlossSpec | None = None
    """A specular highlight on top of the diffuse reflectance (needs ``geometry``)."""


class _Spectrometer(StrictModel):
    """Raw spectrometer readings normalised by black and white references, (33)–(34)."""

    readings: Name
    """CSV of the class's readings: wavelength, then one column per sample."""
    black: Name
    """CSV of the black reference reading."""
    white: Name
    """CSV of the white reference reading."""


class _ClassFile(_ClassCommon):
    file: Name
    """CSV of the class's reflectance samples: wavelength in nm, then one column per
    sample (0–1 or percent)."""


class _ClassSpectrometer(_ClassCommon):
    spectrometer: _Spectrometer
    """Raw spectrometer readings, normalised here by black and white references."""


if TYPE_CHECKING:  # a union composed at run time (one_of)
    ClassSpec = Any
else:
    ClassSpec = one_of({"file": _ClassFile, "spectrometer": _ClassSpectrometer}, what="a class")

# --- the file --------------------------------------------------------------------


class _Wavelength(StrictModel):
    """The integration grid (default: where a light, optics and a camera all respond)."""

    start: Nanometre | None = None
    """First wavelength, nm."""
    stop: Nanometre | None = None
    """Last wavelength, nm."""
    step: Annotated[float, Field(gt=0, allow_inf_nan=False)] = 1.0
    """Grid step, nm."""


ExposureTime = Annotated[float, Field(ge=1e-9, le=LONGEST_EXPOSURE_S, allow_inf_nan=False)]
"""1 ns to the longest exposure a camera is set to, s."""


class _Exposure(StrictModel):
    """How the exposure time of each combination is chosen."""

    mode: Literal["auto", "fixed"] = "auto"
    """``auto``: the brightest class at ``target`` × saturation; ``fixed``: ``time``."""
    time: ExposureTime | None = None
    """``fixed``: the exposure time, s (1 ns to 100 s)."""
    target: Annotated[float, Field(gt=0, le=1)] = 0.7
    """``auto``: the brightest class's mean as a fraction of saturation."""
    max_time: ExposureTime | None = None
    """``auto``: the longest exposure time allowed, s (default: 100 s, beyond which a
    combination is skipped as too dim)."""

    @model_validator(mode="after")
    def _fixed_time(self):
        if self.mode == "fixed" and self.time is None:
            raise ValueError("a fixed exposure needs 'time' in seconds")
        return self


class _Rank(StrictModel):
    """How ``predict`` ranks the combinations."""

    by: RankBy = "error"
    """ε Gauss (lowest first), SNR_dB or CNR_dB (highest first)."""
    comparison: Name | None = None
    """The comparison ranked by, ``"A vs B,C"`` (default: each combination's worst)."""


class _Geometry(StrictModel):
    """Directions at the object, each pointing away from the surface (normalised here):
    with them, Lambert's cosine and any gloss enter the reflectance."""

    light: tuple[Finite, Finite, Finite]
    """Towards the light, [x, y, z]."""
    view: tuple[Finite, Finite, Finite] = (0.0, 0.0, 1.0)
    """Towards the camera, [x, y, z]."""
    normal: tuple[Finite, Finite, Finite] = (0.0, 0.0, 1.0)
    """The surface normal, [x, y, z]."""


ClassName = Annotated[str, Field(min_length=1, max_length=100, pattern=r"^[^,]+$")]


class _Scene(StrictModel):
    """Candidate lights, optics and cameras, and the object classes to tell apart."""

    name: Name | None = None
    """Shown in reports."""
    geometry: _Geometry | None = None
    """Light and view directions, for glossy classes (default: diffuse only)."""
    wavelength: _Wavelength = _Wavelength()
    """The integration grid."""
    classes: dict[ClassName, ClassSpec] = Field(min_length=2)
    """Class name → its reflectance samples (a file, or spectrometer readings)."""
    lights: list[LightSpec] = Field(min_length=1)
    """Candidate lights; each has exactly one of the kind keys."""
    optics: list[OpticsSpec] = Field(min_length=1)
    """Candidate optics; a plain name is a built-in lens."""
    cameras: list[SensorSpec] = Field(min_length=1)
    """Candidate cameras; a plain name is a built-in camera."""
    exposure: _Exposure = _Exposure()
    """How each combination's exposure time is chosen."""
    rank: _Rank = _Rank()
    """How ``predict`` ranks the combinations."""
    comparisons: ComparisonsSpec = ComparisonsSpec()
    """Which groups of classes to compare, and how a group is weighted."""

    @field_validator("classes")
    @classmethod
    def _names(cls, v):
        for name in v:
            if " vs " in f" {name} ":
                raise ValueError(f"class name {name!r}: 'vs' separates groups in comparisons")
        return v


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
    model = load_yaml(path, _Scene, what="scene file")
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
        [c.name for c in classes], model.comparisons, source=f"{path}: comparisons"
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

    if isinstance(spec, _ClassFile):
        reflectance = read_spectrum_csv(base / spec.file, kind=SpectrumKind.REFLECTANCE, name=name)
    else:
        s = spec.spectrometer
        reflectance = read_spectrometer(
            base / s.readings, black=base / s.black, white=base / s.white, name=name
        )
    gloss = None
    if isinstance(spec.gloss, _BlinnPhong):
        gloss = BlinnPhong(**spec.gloss.blinn_phong.model_dump())
    elif isinstance(spec.gloss, _CookTorrance):
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

    if isinstance(spec, _Led):
        light = led(spec.led.peak, spec.led.fwhm)
    elif isinstance(spec, _Blackbody):
        light = blackbody(spec.blackbody)
    elif isinstance(spec, _Cie):
        light = cie_illuminant(spec.cie)
    elif isinstance(spec, _Daylight):
        light = cie_daylight(spec.daylight)
    elif isinstance(spec, _WhiteLed):
        light = phosphor_white_led(**(spec.white_led or _WhiteLedParams()).model_dump())
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
    if isinstance(spec, _Ideal):
        o = ideal_lens(f_number=f_number or 4.0)
    elif isinstance(spec, _Lens):
        o = lens(spec.lens, f_number=f_number)
    elif isinstance(spec, _Material):
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
        if isinstance(spec, _Builtin):
            cam = builtin_sensor(spec.builtin)
            changed = f"{cam.name}, {', '.join(f'{k} {v:g}' for k, v in values.items())}"
            return replace(cam, name=spec.name or (changed if values else cam.name), **values)
        qe = read_spectrum_csv(base / spec.file, kind=SpectrumKind.QE)
        return SensorModel(spec.name or qe.name, qe, **values)

    if spec.measured is None:
        return make()
    from inspect_validate.components.camera_file import build_measured

    return build_measured(make, base / spec.measured, what="the scene's camera")
