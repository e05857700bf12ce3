"""The scene file's schema: what a scene file may say. YAML, paths relative to the scene
file (the manual, "Scene files")::

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

:func:`inspect_validate.scene.read_scene` reads a file against it and builds the
:class:`~inspect_validate.scene.Scene`.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Annotated, Any, Literal

from pydantic import (
    BeforeValidator,
    Field,
    field_validator,
    model_validator,
)

from inspect_validate.comparisons import RankBy, Weighting
from inspect_validate.components.sensors import BIT_DEPTHS
from inspect_validate.config import StrictModel, one_of
from inspect_validate.constants import LONGEST_EXPOSURE_S

__all__ = [
    "IRRADIANCE_BAND",
    "MAX_GRID_POINTS",
    "BlackbodyLight",
    "BlinnPhongGloss",
    "BlinnPhongParams",
    "BuiltinCamera",
    "CameraFile",
    "CieLight",
    "ClassCommon",
    "ClassFile",
    "ClassName",
    "ClassSpectrometer",
    "ComparisonsSpec",
    "CookTorranceGloss",
    "CookTorranceParams",
    "DaylightLight",
    "EmvaOverrides",
    "ExposureSpec",
    "ExposureTime",
    "FNumber",
    "Finite",
    "GeometrySpec",
    "IdealOptics",
    "Irradiance",
    "LedLight",
    "LedParams",
    "LensOptics",
    "LightCommon",
    "LightFile",
    "MaterialOptics",
    "Name",
    "Nanometre",
    "NonNegative",
    "OpticsCommon",
    "OpticsFile",
    "Positive",
    "RankSpec",
    "SceneFile",
    "SpectrometerReadings",
    "WavelengthGrid",
    "WhiteLedLight",
    "WhiteLedParams",
]

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


class LightCommon(StrictModel):
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


class LedParams(StrictModel):
    """A modelled LED (Ohno's spectral model)."""

    peak: Nanometre
    """Peak wavelength, nm."""
    fwhm: Annotated[float, Field(gt=0, le=2000, allow_inf_nan=False)]
    """Full width at half maximum, nm."""


class WhiteLedParams(StrictModel):
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


class LedLight(LightCommon):
    led: LedParams
    """A modelled LED, by its peak and width."""


class BlackbodyLight(LightCommon):
    blackbody: Annotated[float, Field(gt=0, le=100_000, allow_inf_nan=False)]
    """Colour temperature, K."""


class CieLight(LightCommon):
    cie: Name
    """A tabulated CIE illuminant by name: ``A``, ``D50``, ``D65``, ``FL1`` … ``FL12``,
    ``HP1`` … ``HP5`` (high-pressure lamps), ``LED-B1`` … (white LEDs)."""


class DaylightLight(LightCommon):
    daylight: Annotated[float, Field(ge=4000, le=25000)]
    """Colour temperature, K."""


class WhiteLedLight(LightCommon):
    white_led: WhiteLedParams | None = None
    """A modelled white LED; ``null`` or ``{}`` takes the typical one."""


class LightFile(LightCommon):
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
                (LedLight, BlackbodyLight, CieLight, DaylightLight, WhiteLedLight, LightFile),
                strict=True,
            )
        ),
        what="a light",
    )

# --- optics ----------------------------------------------------------------------

FNumber = Annotated[float, Field(ge=0.5, le=1000, allow_inf_nan=False)]


class OpticsCommon(StrictModel):
    name: Name | None = None
    """Shown in tables and reports."""
    f_number: FNumber | None = None
    """The working f-number N (irradiance at the sensor ∝ 1/(4N²); default 4)."""


class LensOptics(OpticsCommon):
    lens: Literal["visible", "uv", "swir"]
    """A modelled lens: ``visible`` (AR-coated, 400–700 nm), ``uv`` (250–650 nm) or
    ``swir`` (400–1650 nm)."""


def _no_options(v):
    """An option-less component written with an empty mapping (``ideal: {}``) has none."""
    return None if v == {} else v


class IdealOptics(OpticsCommon):
    ideal: Annotated[None, BeforeValidator(_no_options)] = None
    """A lens that transmits everything (``ideal`` alone, or ``ideal: {}``)."""


class MaterialOptics(OpticsCommon):
    material: Literal["BK7", "fused_silica", "CaF2", "MgF2", "ZnSe"]
    """A window or filter substrate, its transmission from its absorption and reflection."""
    thickness_mm: Annotated[float, Field(gt=0, le=1000, allow_inf_nan=False)] = 10.0
    """The material's thickness along the light's path, mm."""


class OpticsFile(OpticsCommon):
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
        dict(
            zip(_OPTICS_KINDS, (LensOptics, IdealOptics, MaterialOptics, OpticsFile), strict=True)
        ),
        what="optics",
        shorthand=_optics_shorthand,
    )

# --- cameras ---------------------------------------------------------------------


class EmvaOverrides(StrictModel):
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


class BuiltinCamera(EmvaOverrides):
    builtin: Name
    """A built-in camera: ``cmos-visible``, ``cmos-nir-enhanced`` or ``ingaas-swir``; the
    keys beside it replace its values."""


class CameraFile(EmvaOverrides):
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
        {"builtin": BuiltinCamera, "file": CameraFile}, what="a camera", shorthand=_camera_shorthand
    )

# --- classes ---------------------------------------------------------------------


class BlinnPhongParams(StrictModel):
    """Blinn–Phong gloss (17): k_s·(N·H)ⁿ added to the diffuse reflectance."""

    ks: NonNegative
    """Specular strength k_s (a reflectance factor, spectrally flat)."""
    n: Positive
    """Shininess exponent n: the higher, the narrower the highlight."""


class CookTorranceParams(StrictModel):
    """Cook–Torrance microfacet gloss (Beckmann distribution, Schlick's Fresnel term)."""

    roughness: Annotated[float, Field(gt=0, le=1)]
    """Beckmann roughness m: the facets' rms slope."""
    f0: Annotated[float, Field(ge=0, le=1)] = 0.04
    """Fresnel reflectance at normal incidence (0.04 for most plastics and glass)."""


class BlinnPhongGloss(StrictModel):
    blinn_phong: BlinnPhongParams
    """A Blinn–Phong highlight."""


class CookTorranceGloss(StrictModel):
    cook_torrance: CookTorranceParams
    """A Cook–Torrance highlight."""


if TYPE_CHECKING:  # a union composed at run time (one_of)
    GlossSpec = Any
else:
    GlossSpec = one_of(
        {"blinn_phong": BlinnPhongGloss, "cook_torrance": CookTorranceGloss}, what="gloss"
    )


class ClassCommon(StrictModel):
    gloss: GlossSpec | None = None
    """A specular highlight on top of the diffuse reflectance (needs ``geometry``)."""


class SpectrometerReadings(StrictModel):
    """Raw spectrometer readings normalised by black and white references, (33)–(34)."""

    readings: Name
    """CSV of the class's readings: wavelength, then one column per sample."""
    black: Name
    """CSV of the black reference reading."""
    white: Name
    """CSV of the white reference reading."""


class ClassFile(ClassCommon):
    file: Name
    """CSV of the class's reflectance samples: wavelength in nm, then one column per
    sample (0–1 or percent)."""


class ClassSpectrometer(ClassCommon):
    spectrometer: SpectrometerReadings
    """Raw spectrometer readings, normalised here by black and white references."""


if TYPE_CHECKING:  # a union composed at run time (one_of)
    ClassSpec = Any
else:
    ClassSpec = one_of({"file": ClassFile, "spectrometer": ClassSpectrometer}, what="a class")

# --- the file --------------------------------------------------------------------


class WavelengthGrid(StrictModel):
    """The integration grid (default: where a light, optics and a camera all respond)."""

    start: Nanometre | None = None
    """First wavelength, nm."""
    stop: Nanometre | None = None
    """Last wavelength, nm."""
    step: Annotated[float, Field(gt=0, allow_inf_nan=False)] = 1.0
    """Grid step, nm."""


ExposureTime = Annotated[float, Field(ge=1e-9, le=LONGEST_EXPOSURE_S, allow_inf_nan=False)]
"""1 ns to the longest exposure a camera is set to, s."""


class ExposureSpec(StrictModel):
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


class ComparisonsSpec(StrictModel):
    """The ``comparisons:`` section of a scene or station file, read by
    :meth:`~inspect_validate.comparisons.Comparisons.of` (``Comparisons.of(classes,
    spec.groups, spec.weights)``)."""

    # An empty list would leave nothing to rank or check: name one, or take "default".
    groups: (
        Literal["default", "pairs", "rest"]
        | Annotated[list[Annotated[str, Field(min_length=1)]], Field(min_length=1)]
    ) = "default"
    """``default``: every pair and, with three or more classes, each against the rest;
    ``pairs`` or ``rest`` alone; or a list of comparisons written ``"A vs B,C"``."""
    weights: Weighting | dict[str, Annotated[float, Field(gt=0, allow_inf_nan=False)]] = "equal"
    """How the classes of a group of several are weighted: ``equal``, ``pixels`` (by each
    class's pixel count; measurements only), or each class's prior, ``{A: 0.7, B: 0.3}``
    (normalised within the group)."""


class RankSpec(StrictModel):
    """How ``predict`` ranks the combinations."""

    by: RankBy = "error"
    """ε Gauss (lowest first), SNR_dB or CNR_dB (highest first)."""
    comparison: Name | None = None
    """The comparison ranked by, ``"A vs B,C"`` (default: each combination's worst)."""


class GeometrySpec(StrictModel):
    """Directions at the object, each pointing away from the surface (normalised here):
    with them, Lambert's cosine and any gloss enter the reflectance."""

    light: tuple[Finite, Finite, Finite]
    """Towards the light, [x, y, z]."""
    view: tuple[Finite, Finite, Finite] = (0.0, 0.0, 1.0)
    """Towards the camera, [x, y, z]."""
    normal: tuple[Finite, Finite, Finite] = (0.0, 0.0, 1.0)
    """The surface normal, [x, y, z]."""


ClassName = Annotated[str, Field(min_length=1, max_length=100, pattern=r"^[^,]+$")]


class SceneFile(StrictModel):
    """Candidate lights, optics and cameras, and the object classes to tell apart."""

    name: Name | None = None
    """Shown in reports."""
    geometry: GeometrySpec | None = None
    """Light and view directions, for glossy classes (default: diffuse only)."""
    wavelength: WavelengthGrid = WavelengthGrid()
    """The integration grid."""
    classes: dict[ClassName, ClassSpec] = Field(min_length=2)
    """Class name → its reflectance samples (a file, or spectrometer readings)."""
    lights: list[LightSpec] = Field(min_length=1)
    """Candidate lights; each has exactly one of the kind keys."""
    optics: list[OpticsSpec] = Field(min_length=1)
    """Candidate optics; a plain name is a built-in lens."""
    cameras: list[SensorSpec] = Field(min_length=1)
    """Candidate cameras; a plain name is a built-in camera."""
    exposure: ExposureSpec = ExposureSpec()
    """How each combination's exposure time is chosen."""
    rank: RankSpec = RankSpec()
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
