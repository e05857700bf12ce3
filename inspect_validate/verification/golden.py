"""The golden statistics of a known-good station (``train``) and ``verify``'s drift check.

``train`` measures a station N times and keeps, per illumination, each class's
μ and σ² and each comparison's SNR_dB and ε, every repeat's value, its standard error
from its pixels and frames, and their spread. ``golden.json`` (schema
``inspect-validate/golden``, version 2; version 1, without the standard errors, is
read too) holds them with the camera settings and illuminations they were taken at.
``verify`` then checks how far the station has drifted from it, in DN for μ and in dB
for SNR_dB::

    acceptance:
      drift: {golden: golden.json}                # prediction intervals
      drift: {golden: golden.json, mean_dn: 2, snr_db: 0.5}   # fixed tolerances

**The prediction interval.** From n repeats x₁ … x_n with mean x̄ and sample standard
deviation s, a new measurement x of an unchanged station lies within

    |x − x̄| ≤ t_{n−1}(1 − α/2) · √(s'² (1 + 1/n) + max(0, SE² − SE₀²))

with probability 1 − α: Student's t because s has n − 1 degrees of freedom, 1/n for
the uncertainty of x̄, SE the new measurement's own standard error and SE₀ the
repeats' (:mod:`.uncertainty`; a measurement of fewer pixels or frames than the
training varies more), s'² = max(s², SE₀²) (repeats cannot vary less than their
noise). α is the check's share of the verification's false-alarm rate
(:mod:`.checks`). Few repeats make t large: 5 repeats and 20 checks at 0.27 % give
limits 4.1 × as wide as a perfectly known spread would; a golden file whose limits
would be more than :data:`MAX_WIDENING` × as wide is refused, naming the repeats it
needs.

The spread is what varied between the repeats: repeats of one placement
measure the noise of the estimates only, so re-place the parts (and let the
lights cool down) between repeats for limits that hold in production.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, ValidationError, model_validator

from inspect_validate.config import StrictModel
from inspect_validate.errors import InputError
from inspect_validate.files import input_file
from inspect_validate.verification.checks import Check, at_most

if TYPE_CHECKING:
    from collections.abc import Sequence

    from inspect_validate.acceptance import Drift
    from inspect_validate.comparisons import Comparisons
    from inspect_validate.roi.roiset import RoiSet
    from inspect_validate.station.file import Station

__all__ = [
    "GOLDEN_SCHEMA_VERSION",
    "MAX_WIDENING",
    "Golden",
    "Spread",
    "detectable_change",
    "drift_checks",
    "prediction_sd",
    "read_golden",
    "repeats_needed",
    "train",
    "validate_golden",
    "widening",
]

GOLDEN_SCHEMA_VERSION = 2
MAX_WIDENING = 10.0
"""A golden file whose drift limits would be more than this many times as wide as a
perfectly known spread would set (too few repeats for the false-alarm rate asked) is
refused: its checks would catch only gross changes, which a fixed tolerance states
more plainly."""
GOOD_WIDENING = 2.0
"""The widening :func:`repeats_needed` names as enough for limits that track the spread."""


class _Frozen(StrictModel):
    model_config = ConfigDict(populate_by_name=True)  # golden files are read back by alias


class Spread(BaseModel):
    """One quantity over the repeats: every value, each value's own standard error, and
    (derived, for readers of the file) their mean, sample standard deviation, minimum and
    maximum. Undefined values are None."""

    # The derived numbers are written for people and recomputed on reading.
    model_config = ConfigDict(extra="ignore", frozen=True)
    values: Annotated[list[float | None], Field(min_length=1, max_length=100_000)]
    """Every repeat's value."""
    standard_errors: list[Annotated[float, Field(ge=0, allow_inf_nan=False)] | None] | None = None
    """Each repeat's standard error from its pixels and frames (None in version 1 files)."""

    @model_validator(mode="after")
    def _paired(self):
        if self.standard_errors is not None and len(self.standard_errors) != len(self.values):
            raise ValueError(
                f"{len(self.standard_errors)} standard_errors for {len(self.values)} values"
            )
        return self

    @property
    def n(self) -> int:
        """The repeats with a value."""
        return int(self._finite.size)

    @property
    def standard_error(self) -> float:
        """The repeats' own standard error (root mean square; NaN where not recorded)."""
        se = [x for x in self.standard_errors or () if x is not None]
        return math.sqrt(sum(x * x for x in se) / len(se)) if se else math.nan

    @property
    def _finite(self) -> np.ndarray:
        v = np.array([np.nan if x is None else x for x in self.values], dtype=float)
        return v[np.isfinite(v)]

    @property
    def mean(self) -> float:
        v = self._finite
        return float(v.mean()) if v.size else math.nan

    @property
    def std(self) -> float:
        """Sample standard deviation (ddof 1); NaN for fewer than two finite values."""
        v = self._finite
        return float(v.std(ddof=1)) if v.size >= 2 else math.nan

    def summary(self, digits: int = 4) -> str:
        """``mean ± std`` for a reader; the mean alone where there is no spread."""
        if not math.isfinite(self.mean):
            return "—"
        if not math.isfinite(self.std):
            return f"{self.mean:.{digits}g} (no spread)"
        return f"{self.mean:.{digits}g} ± {self.std:.2g}"

    def document(self) -> dict:
        v = self._finite
        doc = {
            "mean": self.mean,
            "std": self.std,
            "min": float(v.min()) if v.size else None,
            "max": float(v.max()) if v.size else None,
            "values": list(self.values),
        }
        if self.standard_errors is not None:
            doc["standard_errors"] = list(self.standard_errors)
        return doc


def _within(spread, lo: float, hi: float, what: str) -> None:
    """Refuse a golden value no measurement can give (a negative variance, ε above ½)."""
    if spread is None:
        return
    for x in spread.values:
        if x is not None and not (lo <= x <= hi):
            raise ValueError(f"{what} {x!r} is impossible (it lies in [{lo:g}, {hi:g}])")


class GoldenClass(_Frozen):
    """One class under one illumination over the repeats."""

    mean: Spread
    """μ, DN."""
    variance: Spread
    """σ² (39), DN²."""

    @model_validator(mode="after")
    def _physical(self):
        _within(self.mean, 0.0, 2.0**62, "a mean grey value of")
        _within(self.variance, 0.0, 2.0**124, "a variance of")
        return self


class GoldenComparison(_Frozen):
    """One comparison under one illumination over the repeats."""

    snr_db: Spread
    """SNR_dB (36), dB."""
    error_gaussian: Spread
    """ε Gauss (37), a fraction."""
    error_kde: Spread | None = None
    """ε KDE (37), a fraction."""

    @model_validator(mode="after")
    def _physical(self):
        _within(self.error_gaussian, 0.0, 0.5, "a classification error of")
        _within(self.error_kde, 0.0, 0.5, "a classification error of")
        return self


class GoldenIllumination(_Frozen):
    """One illumination's golden statistics."""

    channels: dict[int, float]
    """Controller channel → drive level, % (a verification at others is refused)."""
    classes: dict[str, GoldenClass]
    """Class name → its statistics."""
    comparisons: dict[str, GoldenComparison]
    """Comparison (``"A vs B,C"``) → its statistics."""


class Golden(_Frozen):
    """A station's golden statistics, as ``golden.json`` holds them."""

    schema_: Literal["inspect-validate/golden"] = Field("inspect-validate/golden", alias="schema")
    """What the file is: always ``inspect-validate/golden``."""
    schema_version: Literal[1, 2] = 2
    """2; files of version 1 (no standard errors) are read too."""
    tool_version: str
    """The inspect-validate version that trained it."""
    station: str
    """The station file trained."""
    station_sha256: str
    """SHA-256 of the station file's bytes at training."""
    exposure_us: float | None
    """The camera's exposure, µs (a verification at another is refused)."""
    gain_db: float | None
    """The camera's gain, dB (likewise; null: the station left the camera's own)."""
    weighting: str
    """How groups of classes were weighted (``equal``, ``pixels``, ``priors``)."""
    repeats: Annotated[int, Field(ge=1, le=100_000)]
    """The captures trained on."""
    captures: list[str]
    """Their folders."""
    illuminations: dict[str, GoldenIllumination]
    """Per illumination: its channels, its classes' μ and σ², its comparisons' SNR_dB and ε."""

    @model_validator(mode="after")
    def _repeats(self):
        for ill, g in self.illuminations.items():
            for spread in (
                *(x for c in g.classes.values() for x in (c.mean, c.variance)),
                *(c.snr_db for c in g.comparisons.values()),
            ):
                if len(spread.values) != self.repeats:
                    raise ValueError(
                        f"illuminations.{ill}: {len(spread.values)} values where 'repeats' "
                        f"says {self.repeats}"
                    )
        return self

    def document(self) -> dict:
        """The ``golden.json`` document, each spread with its mean, std, min and max."""
        doc = self.model_dump(by_alias=True, exclude={"illuminations"})
        doc["illuminations"] = {
            ill: {
                "channels": {str(k): v for k, v in g.channels.items()},
                "classes": {
                    name: {"mean": c.mean.document(), "variance": c.variance.document()}
                    for name, c in g.classes.items()
                },
                "comparisons": {
                    label: {
                        "snr_db": c.snr_db.document(),
                        "error_gaussian": c.error_gaussian.document(),
                        "error_kde": None if c.error_kde is None else c.error_kde.document(),
                    }
                    for label, c in g.comparisons.items()
                },
            }
            for ill, g in self.illuminations.items()
        }
        return doc


def train(
    station: Station,
    captures: list[Path],
    *,
    regions: tuple[RoiSet, Comparisons] | None = None,
) -> Golden:
    """Measure every capture folder of ``station`` and gather the golden statistics;
    ``regions`` is :func:`~inspect_validate.verification.measured.station_regions` of it,
    read here if not given.

    Raises
    ------
    InputError
        A capture folder that is not a complete capture of the station, a station
        without ROIs (exit code 2).
    """
    from inspect_validate import __version__
    from inspect_validate.station.file import station_hash
    from inspect_validate.verification.measured import measure_capture, station_regions

    folders = [Path(c).resolve() for c in captures]
    for i, folder in enumerate(folders):
        if folder in folders[:i]:
            raise InputError(
                "given twice: the same capture twice would train a spread of zero; train on "
                "independent captures (--repeats N captures them)",
                source=str(captures[i]),
            )
    rois, comparisons = regions or station_regions(station)
    limits = station.acceptance.limits()
    runs = [
        measure_capture(station, f, rois=rois, comparisons=comparisons, limits=limits, kde="always")
        for f in captures
    ]
    from inspect_validate.verification.calibration import NO_LIGHT_REMEDY, light_levels

    for folder, run in zip(captures, runs, strict=True):
        for level in light_levels(run.measurements, run.dark, offset=None).values():
            if not level.reaches:
                raise InputError(
                    f"step {level.illumination!r}: no light reaches the camera "
                    f"({level.text}): golden statistics of frames no brighter than the "
                    f"dark ones would hold a dead light as good; {NO_LIGHT_REMEDY}, then "
                    "capture again",
                    source=str(folder),
                )
    first_seen: dict[str, tuple] = {}
    for folder, run in zip(captures, runs, strict=True):
        for where, digest in run.sha256.items():
            other = first_seen.setdefault(digest, (folder, where))
            if other[0] != folder:
                raise InputError(
                    f"{where} here is the same frame as {other[1]} in {other[0]}: the same "
                    "capture given twice would train a spread of zero; train on independent "
                    "captures (--repeats N captures them)",
                    source=str(folder),
                )

    return golden_of(
        station,
        [r.measurements for r in runs],
        comparisons,
        captures=[str(c) for c in captures],
        tool_version=__version__,
        station_sha256=station_hash(station.file),
    )


def golden_of(
    station: Station,
    runs: list[dict],
    comparisons: Comparisons,
    *,
    captures: list[str],
    tool_version: str,
    station_sha256: str,
) -> Golden:
    """The :class:`Golden` of ``runs``, each a dict illumination → its
    :class:`~inspect_validate.measurement.Measurement` (measured with ``comparisons``)."""
    from inspect_validate.verification.uncertainty import measured_standard_errors

    illuminations = {}
    for ill in station.illuminations:
        ms = [r[ill.name] for r in runs]
        se = [measured_standard_errors(m, comparisons, mixtures=()) for m in ms]
        classes = {
            c.name: GoldenClass(
                mean=_spread((m.classes[k].mean for m in ms), (e.mean[k] for e in se)),
                variance=_spread((m.classes[k].variance for m in ms), (e.variance[k] for e in se)),
            )
            for k, c in enumerate(ms[0].classes)
        }
        comps = {
            comp.label: GoldenComparison(
                snr_db=_spread((m.comparisons[j].snr_db for m in ms), (e.snr_db[j] for e in se)),
                error_gaussian=_spread(m.comparisons[j].error_gaussian for m in ms),
                error_kde=_spread(m.comparisons[j].error_kde for m in ms),
            )
            for j, comp in enumerate(ms[0].comparisons)
        }
        illuminations[ill.name] = GoldenIllumination(
            channels=dict(ill.channels), classes=classes, comparisons=comps
        )
    return Golden(
        tool_version=tool_version,
        station=str(station.path),
        station_sha256=station_sha256,
        exposure_us=station.camera.exposure_us,
        gain_db=station.camera.gain_db,
        weighting=runs[0][station.illuminations[0].name].weighting,
        repeats=len(runs),
        captures=captures,
        illuminations=illuminations,
    )


def _finite_or_none(x) -> float | None:
    return None if x is None or not math.isfinite(x) else float(x)


def _spread(values, standard_errors=None) -> Spread:
    return Spread(
        values=[_finite_or_none(x) for x in values],
        standard_errors=None
        if standard_errors is None
        else [_finite_or_none(x) for x in standard_errors],
    )


GOLDEN_MAX_BYTES = 64 * 2**20  # a golden file of thousands of classes is a few MB


def read_golden(path: str | Path) -> Golden:
    """Read and validate ``golden.json``.

    Raises
    ------
    InputError
        Missing, not JSON, or not a golden file of this schema (the message names
        the field).
    """
    import json

    from inspect_validate.config import explain

    # A regular file of bounded size: /dev/zero or a FIFO would read forever or block.
    path = input_file(
        path,
        "golden file",
        todo="give the golden.json 'train' wrote (inspect-validate train STATION --out FILE)",
        largest=GOLDEN_MAX_BYTES,
    )
    from inspect_validate.config import file_kind

    try:
        doc = json.loads(path.read_text())
    except (OSError, UnicodeDecodeError, ValueError) as exc:
        what = _kind_of_yaml(path) or f"not a golden JSON file ({exc})"
        raise InputError(
            f"{what}, where a golden file is expected{_WRITTEN}", source=str(path)
        ) from None
    except RecursionError:
        raise InputError("not a golden JSON file (nested too deeply)", source=str(path)) from None
    if not isinstance(doc, dict) or doc.get("schema") != "inspect-validate/golden":
        known = file_kind(doc)
        what = f"this is a {known[0]} ({known[1]})" if known else "not a golden file"
        raise InputError(f"{what}, where a golden file is expected{_WRITTEN}", source=str(path))
    try:
        return Golden.model_validate(doc)
    except ValidationError as exc:
        raise InputError(explain(exc), source=str(path)) from None


_WRITTEN = " (the JSON file inspect-validate train STATION --out FILE writes)"


def _kind_of_yaml(path: Path) -> str:
    """``this is a station file …`` where a file that is not JSON is one of the tool's
    YAML files; else nothing."""
    import yaml

    from inspect_validate.config import file_kind

    try:
        known = file_kind(yaml.safe_load(path.read_text()))
    except (OSError, UnicodeDecodeError, RecursionError, yaml.YAMLError):
        return ""
    return f"this is a {known[0]} ({known[1]})" if known else ""


def prediction_sd(spread: Spread, standard_error: float) -> float:
    """The standard deviation of a new value's deviation from ``spread``'s mean when
    nothing changed (module description): the repeats' spread, floored at their own
    standard error, times √(1 + 1/n), and what the new measurement's own standard error
    ``standard_error`` adds beyond the repeats'. NaN without a spread (one repeat)."""
    n, s = spread.n, spread.std
    if n < 2 or not math.isfinite(s):
        return math.nan
    own = standard_error if math.isfinite(standard_error) else 0.0
    ref = spread.standard_error
    if not math.isfinite(ref):  # a version 1 file: the repeats were measured alike
        ref = own
    var = max(s * s, ref * ref) * (1.0 + 1.0 / n) + max(0.0, own * own - ref * ref)
    return math.sqrt(var)


def widening(repeats: int, share: float) -> float:
    """How many times as wide a drift limit from ``repeats`` repeats is as one from a
    perfectly known spread, at a check's false-alarm ``share``:
    t_{n−1}(1 − α/2) √(1 + 1/n) / z(1 − α/2); inf for one repeat."""
    from inspect_validate.verification.checks import quantile

    if repeats < 2:
        return math.inf
    return quantile(share, df=repeats - 1) * math.sqrt(1.0 + 1.0 / repeats) / quantile(share)


def repeats_needed(share: float, *, factor: float = GOOD_WIDENING) -> int:
    """The fewest repeats whose :func:`widening` at ``share`` is at most ``factor``."""
    n = 2
    while widening(n, share) > factor and n < 100_000:
        n = n + 1 if n < 64 else int(n * 1.25)
    return n


def detectable_change(spread: Spread, share: float, *, power: float = 0.95) -> float:
    """The smallest change of a quantity that its drift check catches with probability
    ``power``, in its unit: (t_{n−1}(1 − α/2) + z(power)) × :func:`prediction_sd` at the
    repeats' own standard error (a verification captured as the training was)."""
    from inspect_validate.verification.checks import quantile

    sd = prediction_sd(spread, spread.standard_error)
    if not math.isfinite(sd):
        return math.nan
    return (quantile(share, df=spread.n - 1) + quantile(1.0 - power, sided=1)) * sd


def drift_checks(
    golden: Golden, measurements: dict, drift: Drift | None, errors: dict
) -> list[Check]:
    """Drift of each class's μ (DN) and each comparison's SNR_dB (dB) from ``golden``, which
    :func:`validate_golden` has accepted for the station.

    ``drift`` is the station's ``acceptance.drift``: a fixed tolerance it gives is held as
    it is; otherwise each check is statistical, its limit the prediction interval (module
    description) that :func:`~.checks.decide` sets from :func:`prediction_sd`.
    ``errors`` is illumination → the measurement's
    :class:`~.uncertainty.StandardErrors`.
    """
    if drift is None:  # no drift section: a golden file alone asks for nothing
        return []
    checks = []
    for ill, m in measurements.items():
        g, se = golden.illuminations[ill], errors[ill]
        for k, c in enumerate(m.classes):
            ref = g.classes[c.name].mean
            checks.append(
                _drift_check(
                    f"{ill}: {c.name} μ drift",
                    c.mean,
                    ref,
                    drift.mean_dn,
                    float(se.mean[k]),
                    "DN",
                    f"golden {ref.summary()} DN over {ref.n} repeats, now {c.mean:.4g} DN",
                )
            )
        for j, comp in enumerate(m.comparisons):
            ref = g.comparisons[comp.label].snr_db
            if max(ref.mean, comp.snr_db) < drift.snr_floor_db:
                continue  # both unseparable: their dB carry no drift to check
            checks.append(
                _drift_check(
                    f"{ill}: {comp.label} SNR_dB drift",
                    comp.snr_db,
                    ref,
                    drift.snr_db,
                    float(se.snr_db[j]),
                    "dB",
                    f"golden {ref.summary(3)} dB over {ref.n} repeats, now {comp.snr_db:.2f} dB",
                )
            )
    return checks


def _drift_check(name, value, ref: Spread, tolerance, standard_error, unit, detail) -> Check:
    deviation = abs(value - ref.mean)
    if tolerance is not None:
        return at_most(name, "drift", deviation, tolerance, unit, f"{detail}; fixed tolerance")
    sd = prediction_sd(ref, standard_error)
    return at_most(
        name,
        "drift",
        deviation,
        0.0,
        unit,
        f"{detail}; prediction interval, sd {sd:.2g} {unit}, t with {ref.n - 1} df",
        basis="statistical",
        standard_error=sd,
        df=ref.n - 1,
        sided=2,
    )


def validate_golden(
    golden: Golden,
    station: Station,
    drift: Drift,
    *,
    classes: Sequence[str],
    comparisons: Sequence[str],
    source: str,
    share: float | None = None,
) -> None:
    """Refuse, before any capture, a golden file that cannot check ``station``'s drift.

    ``share`` is a drift check's share of the false-alarm rate (:func:`~.checks.decide`):
    a golden file whose limits it would widen more than :data:`MAX_WIDENING` times is
    refused.

    Raises
    ------
    InputError
        Trained at other camera settings or illuminations, without one of the
        ``classes`` or ``comparisons`` (labels), or without a spread where
        ``drift`` gives no explicit tolerance, or too few repeats for the rate (names
        ``source``: retrain, or give the tolerance).
    """
    camera = station.camera
    if golden.exposure_us != camera.exposure_us or golden.gain_db != camera.gain_db:
        raise InputError(
            f"the golden file was trained at exposure {golden.exposure_us} µs and gain "
            f"{golden.gain_db} dB, the station runs {camera.exposure_us} µs and "
            f"{camera.gain_db} dB: retrain with 'inspect-validate train'",
            source=source,
        )
    for ill in station.illuminations:
        g = golden.illuminations.get(ill.name)
        if g is None:
            raise InputError(
                f"the golden file has no illumination {ill.name!r} "
                f"(it has {', '.join(golden.illuminations)}): retrain",
                source=source,
            )
        if g.channels != dict(ill.channels):
            raise InputError(
                f"illumination {ill.name!r} was trained with channels {g.channels} and is now "
                f"{dict(ill.channels)}: retrain",
                source=source,
            )
        for name in classes:
            spread = _entry(g.classes, name, ill.name, "class", source).mean
            _needs_spread(drift.mean_dn, spread, f"{ill.name}: {name} μ", source, share)
        for text in comparisons:
            spread = _entry(g.comparisons, text, ill.name, "comparison", source).snr_db
            if not spread.mean >= drift.snr_floor_db:
                continue  # not checked while it stays below the floor
            _needs_spread(drift.snr_db, spread, f"{ill.name}: {text} SNR_dB", source, share)


def _entry(table: dict, name: str, ill: str, what: str, source: str):
    if name not in table:
        raise InputError(
            f"the golden file has no {what} {name!r} under {ill!r} "
            f"(it has {', '.join(table)}): retrain with the station's ROIs and comparisons",
            source=source,
        )
    return table[name]


def _needs_spread(explicit, spread: Spread, where: str, source: str, share) -> None:
    if explicit is not None:
        return
    if not math.isfinite(spread.std):
        raise InputError(
            f"{where}: the golden file has no spread (trained with "
            f"{len(spread.values)} repeat(s)); train with --repeats 2 or more, or give the "
            "tolerance in acceptance.drift (mean_dn, snr_db)",
            source=source,
        )
    if share is not None and widening(spread.n, share) > MAX_WIDENING:
        raise InputError(
            f"{where}: {spread.n} repeats are too few for the false-alarm rate asked "
            f"({share:.2g} a check): the drift limits would be "
            f"{widening(spread.n, share):.0f} × as wide as the spread itself sets. Train "
            f"with --repeats {repeats_needed(share, factor=MAX_WIDENING)} or more "
            f"({repeats_needed(share)} for limits within {GOOD_WIDENING:g} ×), raise "
            "acceptance.false_alarm, or give fixed tolerances (acceptance.drift mean_dn, "
            "snr_db)",
            source=source,
        )
