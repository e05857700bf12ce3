"""The golden statistics of a known-good station: the golden file, made by ``train``.

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

The checks that hold a station to it are :mod:`.golden_checks`'.

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

if TYPE_CHECKING:
    from inspect_validate.comparisons import Comparisons
    from inspect_validate.roi.roiset import RoiSet
    from inspect_validate.station.file import Station

__all__ = [
    "GOLDEN_SCHEMA_VERSION",
    "Golden",
    "GoldenClass",
    "GoldenComparison",
    "GoldenIllumination",
    "Spread",
    "golden_of",
    "read_golden",
    "train",
]

GOLDEN_SCHEMA_VERSION = 2


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
    focus: Spread | None = None
    """Production: the focus measure in the class's region (the Laplacian's variance), DN²."""

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


class GoldenPose(_Frozen):
    """Production: where the parts lay, their template's centre in the frame."""

    x: Spread
    """Column of the template's centre, px."""
    y: Spread
    """Row of the template's centre, px."""
    angle: Spread
    """Rotation against the reference, degrees."""


class GoldenIllumination(_Frozen):
    """One illumination's golden statistics."""

    channels: dict[int, float]
    """Controller channel → drive level, % (a verification at others is refused)."""
    classes: dict[str, GoldenClass]
    """Class name → its statistics."""
    comparisons: dict[str, GoldenComparison]
    """Comparison (``"A vs B,C"``) → its statistics."""
    pose: GoldenPose | None = None
    """Production: where the parts lay (a moved camera or fixture moves them all)."""


class Golden(_Frozen):
    """A station's golden statistics, as ``golden.json`` holds them."""

    schema_: Literal["inspect-validate/golden"] = Field("inspect-validate/golden", alias="schema")
    """What the file is: always ``inspect-validate/golden``."""
    schema_version: Literal[1, 2] = 2
    """2; files of version 1 (no standard errors) are read too."""
    mode: Literal["bench", "production"] = "bench"
    """``bench``: captures of every illumination, one repeat a capture; ``production``: the
    parts in frames of the running line under its one light, one repeat a part."""
    tool_version: str
    """The inspect-validate version that trained it."""
    station: str
    """The station file trained."""
    camera: str | None = None
    """The camera it was trained on, of a station of several (``train --camera``); null
    for a station of one camera. A golden file is refused for another camera."""
    station_sha256: str
    """SHA-256 of the station file's bytes at training."""
    exposure_us: float | None
    """The camera's exposure, µs (a verification at another is refused)."""
    gain_db: float | None
    """The camera's gain, dB (likewise; null: the station left the camera's own)."""
    weighting: str
    """How groups of classes were weighted (``equal``, ``pixels``, ``priors``)."""
    repeats: Annotated[int, Field(ge=1, le=100_000)]
    """The captures (parts, in production) trained on."""
    captures: list[str]
    """Their folders (frame files, in production)."""
    illuminations: dict[str, GoldenIllumination]
    """Per illumination: its channels, its classes' μ and σ², its comparisons' SNR_dB and ε."""
    settings: (
        dict[
            Annotated[str, Field(max_length=64)],
            Annotated[str, Field(max_length=200)],
        ]
        | None
    ) = None
    """The camera's settings snapshot the training captures share (node → value, as the
    camera reported it: the grabber's ``settings()``),
    which ``verify`` compares with its capture's; null: trained from captures without one
    (before snapshots were kept)."""

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
                **(
                    {"pose": {q: getattr(g.pose, q).document() for q in ("x", "y", "angle")}}
                    if g.pose is not None
                    else {}
                ),
                "classes": {
                    name: {
                        "mean": c.mean.document(),
                        "variance": c.variance.document(),
                        **({"focus": c.focus.document()} if c.focus is not None else {}),
                    }
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
        station_sha256=station_hash(station),
        settings=_shared_settings(captures, [r.manifest for r in runs]),
    )


def _shared_settings(captures: list[Path], manifests: list[dict]) -> dict[str, str] | None:
    """The settings snapshot every training capture holds, None if one holds none.

    Raises
    ------
    InputError
        Two captures whose snapshots differ (naming the nodes): the golden statistics
        would mix two settings of the camera.
    """
    from inspect_validate.camera.storage import changed_settings

    found = [(m.get("settings") or {}).get("values") for m in manifests]
    snapshots: list[dict[str, str]] = [s for s in found if isinstance(s, dict)]
    if len(snapshots) < len(found):
        return None
    first = snapshots[0]
    for folder, snapshot in zip(captures[1:], snapshots[1:], strict=True):
        changed = changed_settings(first, snapshot)
        if changed:
            raise InputError(
                f"the camera's settings differ from the first capture's ({captures[0]}): "
                f"{'; '.join(changed)}; train on captures of one setting",
                source=str(folder),
            )
    return dict(first)


def golden_of(
    station: Station,
    runs: list[dict],
    comparisons: Comparisons,
    *,
    captures: list[str],
    tool_version: str,
    station_sha256: str,
    focus: list[dict[str, float]] | None = None,
    poses: list[tuple[float, float, float]] | None = None,
    settings: dict[str, str] | None = None,
) -> Golden:
    """The :class:`Golden` of ``runs``, each a dict illumination → its
    :class:`~inspect_validate.measurement.Measurement` (measured with ``comparisons``);
    ``focus``, each run's class → focus measure, makes it a production golden file (one
    run a part), ``poses`` each part's (x, y, angle); ``settings`` the camera's settings
    snapshot the runs share."""
    from inspect_validate.verification.uncertainty import measured_standard_errors

    illuminations = {}
    for ill in station.illuminations:
        ms = [r[ill.name] for r in runs]
        se = [measured_standard_errors(m, comparisons, mixtures=()) for m in ms]
        classes = {
            c.name: GoldenClass(
                mean=_spread((m.classes[k].mean for m in ms), (e.mean[k] for e in se)),
                variance=_spread((m.classes[k].variance for m in ms), (e.variance[k] for e in se)),
                focus=None if focus is None else _spread(f[c.name] for f in focus),
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
        pose = None
        if poses is not None:
            x, y, angle = (_spread(p[i] for p in poses) for i in range(3))
            pose = GoldenPose(x=x, y=y, angle=angle)
        illuminations[ill.name] = GoldenIllumination(
            channels=dict(ill.channels), classes=classes, comparisons=comps, pose=pose
        )
    return Golden(
        tool_version=tool_version,
        station=str(station.path),
        camera=station.camera.name,
        station_sha256=station_sha256,
        exposure_us=station.camera.exposure_us,
        gain_db=station.camera.gain_db,
        weighting=runs[0][station.illuminations[0].name].weighting,
        repeats=len(runs),
        captures=captures,
        illuminations=illuminations,
        mode="bench" if focus is None else "production",
        settings=settings,
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
