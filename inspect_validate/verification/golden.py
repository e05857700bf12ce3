"""The golden statistics of a known-good station (``train``) and ``verify``'s drift check.

``train`` measures a station N times and keeps, per illumination, each class's
μ and σ² and each comparison's SNR_dB and ε, every repeat's value and their
spread. ``golden.json`` (schema ``inspect-validate/golden``, version 1) holds
them with the camera settings and illuminations they were taken at. ``verify``
then checks how far the station has drifted from it, in DN for μ and in dB for
SNR_dB, against explicit tolerances or k times the trained spread (the sample
standard deviation across repeats, as a control chart's k-sigma limits)::

    acceptance:
      drift: {golden: golden.json, k: 3}          # k × spread
      drift: {golden: golden.json, mean_dn: 2, snr_db: 0.5}

The spread is what varied between the repeats: repeats of one placement
measure the noise of the estimates only, so re-place the parts (and let the
lights cool down) between repeats for limits that hold in production.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Annotated, Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, ValidationError, model_validator

from inspect_validate.config import StrictModel
from inspect_validate.errors import InputError
from inspect_validate.verification.checks import Check, at_most

__all__ = [
    "GOLDEN_SCHEMA_VERSION",
    "Golden",
    "Spread",
    "check_golden",
    "drift_checks",
    "read_golden",
    "train",
]

GOLDEN_SCHEMA_VERSION = 1


class _Frozen(StrictModel):
    model_config = ConfigDict(populate_by_name=True)  # golden files are read back by alias


class Spread(BaseModel):
    """One quantity over the repeats: every value, and (derived, for readers of the file)
    their mean, sample standard deviation, minimum and maximum. Undefined values are None."""

    # The derived numbers are written for people and recomputed on reading.
    model_config = ConfigDict(extra="ignore", frozen=True)
    values: Annotated[list[float | None], Field(min_length=1)]

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
        return {
            "mean": self.mean,
            "std": self.std,
            "min": float(v.min()) if v.size else None,
            "max": float(v.max()) if v.size else None,
            "values": list(self.values),
        }


def _within(spread, lo: float, hi: float, what: str) -> None:
    """Refuse a golden value no measurement can give (a negative variance, ε above ½)."""
    if spread is None:
        return
    for x in spread.values:
        if x is not None and not (lo <= x <= hi):
            raise ValueError(f"{what} {x!r} is impossible (it lies in [{lo:g}, {hi:g}])")


class GoldenClass(_Frozen):
    mean: Spread  # DN
    variance: Spread  # DN²

    @model_validator(mode="after")
    def _physical(self):
        _within(self.mean, 0.0, 2.0**62, "a mean grey value of")
        _within(self.variance, 0.0, 2.0**124, "a variance of")
        return self


class GoldenComparison(_Frozen):
    snr_db: Spread
    error_gaussian: Spread
    error_kde: Spread | None = None

    @model_validator(mode="after")
    def _physical(self):
        _within(self.error_gaussian, 0.0, 0.5, "a classification error of")
        _within(self.error_kde, 0.0, 0.5, "a classification error of")
        return self


class GoldenIllumination(_Frozen):
    channels: dict[int, float]  # controller channel → percent
    classes: dict[str, GoldenClass]
    comparisons: dict[str, GoldenComparison]


class Golden(_Frozen):
    """A station's golden statistics, as ``golden.json`` holds them."""

    schema_: Literal["inspect-validate/golden"] = Field("inspect-validate/golden", alias="schema")
    schema_version: Literal[1] = GOLDEN_SCHEMA_VERSION
    tool_version: str
    station: str
    station_sha256: str
    exposure_us: float | None
    gain_db: float
    weighting: str
    repeats: Annotated[int, Field(ge=1)]
    captures: list[str]
    illuminations: dict[str, GoldenIllumination]

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


def train(station, captures: list[Path], *, regions=None) -> Golden:
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
    from inspect_validate.camera.station import station_hash
    from inspect_validate.verification.measured import measure_capture, station_regions

    rois, comparisons = regions or station_regions(station)
    limits = station.acceptance.limits()
    runs = [
        measure_capture(station, f, rois=rois, comparisons=comparisons, limits=limits, kde="always")
        for f in captures
    ]
    first_seen = {}
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

    illuminations = {}
    for ill in station.illuminations:
        ms = [r.measurements[ill.name] for r in runs]
        classes = {
            c.name: GoldenClass(
                mean=_spread(m.classes[k].mean for m in ms),
                variance=_spread(m.classes[k].variance for m in ms),
            )
            for k, c in enumerate(ms[0].classes)
        }
        comparisons = {
            comp.label: GoldenComparison(
                snr_db=_spread(m.comparisons[j].snr_db for m in ms),
                error_gaussian=_spread(m.comparisons[j].error_gaussian for m in ms),
                error_kde=_spread(m.comparisons[j].error_kde for m in ms),
            )
            for j, comp in enumerate(ms[0].comparisons)
        }
        illuminations[ill.name] = GoldenIllumination(
            channels=dict(ill.channels), classes=classes, comparisons=comparisons
        )
    return Golden(
        tool_version=__version__,
        station=str(station.path),
        station_sha256=station_hash(station.path),
        exposure_us=station.camera.exposure_us,
        gain_db=station.camera.gain_db,
        weighting=runs[0].measurements[station.illuminations[0].name].weighting,
        repeats=len(runs),
        captures=[str(c) for c in captures],
        illuminations=illuminations,
    )


def _spread(values) -> Spread:
    return Spread(values=[None if x is None or math.isnan(x) else float(x) for x in values])


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

    path = Path(path)
    if not path.exists():
        raise InputError(
            "golden file not found; make it with 'inspect-validate train STATION --out FILE'",
            source=str(path),
        )
    # A regular file of bounded size: /dev/zero or a FIFO would read forever or block.
    if not path.is_file():
        raise InputError("not a regular file; give the golden.json 'train' wrote", source=str(path))
    if path.stat().st_size > GOLDEN_MAX_BYTES:
        raise InputError(
            f"{path.stat().st_size / 2**20:.0f} MB is no golden file (they are kilobytes); "
            "give the golden.json 'train' wrote",
            source=str(path),
        )
    try:
        doc = json.loads(path.read_text())
    except (OSError, UnicodeDecodeError, ValueError) as exc:
        raise InputError(f"not a golden JSON file ({exc})", source=str(path)) from None
    except RecursionError:
        raise InputError("not a golden JSON file (nested too deeply)", source=str(path)) from None
    if not isinstance(doc, dict) or doc.get("schema") != "inspect-validate/golden":
        raise InputError(
            "not a golden file (schema is not 'inspect-validate/golden')", source=str(path)
        )
    try:
        return Golden.model_validate(doc)
    except ValidationError as exc:
        raise InputError(explain(exc), source=str(path)) from None


def drift_checks(golden: Golden, measurements: dict, drift) -> list[Check]:
    """Drift of each class's μ (DN) and each comparison's SNR_dB (dB) from ``golden``, which
    :func:`check_golden` has accepted for the station.

    ``drift`` is the station's ``acceptance.drift``; a tolerance it does not
    give explicitly is ``k`` × the trained spread.
    """
    checks = []
    for ill, m in measurements.items():
        g = golden.illuminations[ill]
        for c in m.classes:
            ref = g.classes[c.name].mean
            tol, how = _tolerance(drift.mean_dn, drift.k, ref)
            checks.append(
                at_most(
                    f"{ill}: {c.name} μ drift",
                    "drift",
                    abs(c.mean - ref.mean),
                    tol,
                    "DN",
                    f"golden {ref.summary()} DN over {len(ref.values)} repeats, "
                    f"now {c.mean:.4g} DN; limit {how}",
                )
            )
        for comp in m.comparisons:
            ref = g.comparisons[comp.label].snr_db
            if max(ref.mean, comp.snr_db) < drift.snr_floor_db:
                continue  # both unseparable: their dB carry no drift to check
            tol, how = _tolerance(drift.snr_db, drift.k, ref)
            checks.append(
                at_most(
                    f"{ill}: {comp.label} SNR_dB drift",
                    "drift",
                    abs(comp.snr_db - ref.mean),
                    tol,
                    "dB",
                    f"golden {ref.summary(3)} dB, now {comp.snr_db:.2f} dB; limit {how}",
                )
            )
    return checks


def check_golden(golden: Golden, station, drift, *, classes, comparisons, source: str) -> None:
    """Refuse, before any capture, a golden file that cannot check ``station``'s drift.

    Raises
    ------
    InputError
        Trained at other camera settings or illuminations, without one of the
        ``classes`` or ``comparisons`` (labels), or without a spread where
        ``drift`` gives no explicit tolerance (names ``source``: retrain, or give
        the tolerance).
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
            _needs_spread(drift.mean_dn, spread, f"{ill.name}: {name} μ", source)
        for text in comparisons:
            spread = _entry(g.comparisons, text, ill.name, "comparison", source).snr_db
            _needs_spread(drift.snr_db, spread, f"{ill.name}: {text} SNR_dB", source)


def _entry(table: dict, name: str, ill: str, what: str, source: str):
    if name not in table:
        raise InputError(
            f"the golden file has no {what} {name!r} under {ill!r} "
            f"(it has {', '.join(table)}): retrain with the station's ROIs and comparisons",
            source=source,
        )
    return table[name]


def _needs_spread(explicit, spread: Spread, where: str, source: str) -> None:
    if explicit is None and not math.isfinite(spread.std):
        raise InputError(
            f"{where}: the golden file has no spread (trained with "
            f"{len(spread.values)} repeat(s)); train with --repeats 2 or more, or give the "
            "tolerance in acceptance.drift (mean_dn, snr_db)",
            source=source,
        )


def _tolerance(explicit, k, spread: Spread) -> tuple[float, str]:
    if explicit is not None:
        return float(explicit), "given"
    return k * spread.std, f"{k:g} × spread"
