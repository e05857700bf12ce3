"""The golden parts of a running line: ``train --production`` measures every part in a
folder of frames of good parts (:mod:`.parts`); each quantity's spread over the parts (n of
them) is the part-to-part variation a production verdict allows (:mod:`.production`). A
golden file of the bench, or of another production light, is refused where parts are
verified.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

from inspect_validate.errors import InputError, listed
from inspect_validate.verification.parts import Parts, measure_parts

if TYPE_CHECKING:
    from inspect_validate.station.file import Station
    from inspect_validate.verification.golden import Golden

__all__ = ["golden_parts", "production_golden", "train_production"]


def train_production(station: Station, frames: Path) -> Golden:
    """The golden statistics of good parts: every part in ``frames`` measured, each
    quantity's values over the parts (module description).

    Raises
    ------
    InputError
        As :func:`measure_parts`; fewer than two parts measured (no spread).
    """
    return golden_parts(station, measure_parts(station, frames), source=str(frames))


def golden_parts(station: Station, parts: Parts, *, source: str = "the frames") -> Golden:
    """The golden statistics of measured good ``parts`` (:func:`train_production`)."""
    from inspect_validate import __version__
    from inspect_validate.station.file import station_hash
    from inspect_validate.verification.golden import golden_of

    if len(parts.measured) < 2:
        reasons = "; ".join(sorted(set(parts.not_measured.values()))[:2])
        raise InputError(
            f"{len(parts.measured)} part measured: golden statistics need the spread of two "
            f"or more good parts{f' ({reasons})' if reasons else ''}",
            source=source,
        )
    assert station.production is not None  # measure_parts refused a station without
    name = station.production.illumination
    only = station.model_copy(
        update={"illuminations": [i for i in station.illuminations if i.name == name]}
    )
    return golden_of(
        only,
        [{name: p.measurement} for p in parts.measured],
        parts.comparisons,
        captures=[p.frame for p in parts.measured],
        tool_version=__version__,
        station_sha256=station_hash(station),
        focus=[p.focus for p in parts.measured],
        poses=[p.position for p in parts.measured],
    )


def production_golden(golden: Golden, station: Station, *, source: str) -> None:
    """Refuse a golden file trained on the bench, or on another production illumination
    than ``station``'s (before any frame is read; ``source``, the file, for messages).

    Raises
    ------
    InputError
        Naming the file and what to give instead.
    """
    if station.production is None:
        raise InputError(
            "no 'production:' block: give one to verify the running line", source=str(station.path)
        )
    from inspect_validate.verification.golden_checks import validate_camera

    validate_camera(golden, station, source=source)
    if golden.mode != "production":
        raise InputError(
            "this golden file was trained on the bench (captures, every illumination); "
            "train one from good parts: inspect-validate train STATION --production "
            "--frames DIR --out FILE",
            source=source,
        )
    name = station.production.illumination
    if name not in golden.illuminations:
        raise InputError(
            f"the golden file holds {', '.join(golden.illuminations)}, not the production "
            f"illumination {name!r}; train it again from this station's parts",
            source=source,
        )
    from inspect_validate.verification.measured import station_regions

    g = golden.illuminations[name]
    rois, comparisons = station_regions(station)
    lacks = [f"class {c.name!r}" for c in rois.classes if c.name not in g.classes]
    lacks += [f"class {n!r}'s focus" for n, c in g.classes.items() if c.focus is None]
    lacks += [f"comparison {label!r}" for label in comparisons.labels if label not in g.comparisons]
    if g.pose is None:
        lacks.append("the parts' pose (x, y, rotation)")
    if lacks:
        raise InputError(
            f"the golden file lacks {listed(lacks, 3)} that a verdict on this station's "
            "parts checks (edited, or trained on another ROI file): train it again from "
            "this station's parts",
            source=source,
        )
