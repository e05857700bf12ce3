"""The verdict on a station's running line (its ``production:`` block): a batch of parts
(:mod:`.parts`) against the golden parts trained the same way on good ones
(:mod:`.parts_golden`), with its likely cause (:mod:`.diagnosis`).

**The verdict.** A batch of m parts is compared by the mean of each quantity over its
parts: if nothing changed, the batch mean x̄ₘ differs from the golden mean x̄ₙ by

    |x̄ₘ − x̄ₙ| ≤ t_{n−1}(1 − α/2) · s · √(1/m + 1/n)

with probability 1 − α, s the golden parts' standard deviation (a part's own pixel
noise is inside it). α is the check's share of the station's false-alarm rate
(:mod:`.checks`). A folder where fewer than half the frames hold a part fails its own
check, naming the reasons (a wrong reference, a moved camera, no parts passing).
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, replace
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from inspect_validate.errors import listed
from inspect_validate.verification.diagnosis import diagnosis_of
from inspect_validate.verification.parts import Parts, measure_parts
from inspect_validate.verification.parts_golden import production_golden

if TYPE_CHECKING:
    from inspect_validate.station.file import Station
    from inspect_validate.verification.checks import Check
    from inspect_validate.verification.diagnosis import Diagnosis
    from inspect_validate.verification.golden import Golden, Spread

__all__ = [
    "MIN_FOUND",
    "ProductionVerification",
    "counted_reasons",
    "verify_parts",
    "verify_production",
]

MIN_FOUND = 0.5
"""The fraction of a folder's frames that must hold a measured part."""


@dataclass(frozen=True)
class ProductionVerification:
    """A verdict on a batch of production frames: the checks (decided at
    ``false_alarm``), the parts, and whether every check passed."""

    station: Station
    golden: Golden
    parts: Parts
    checks: tuple[Check, ...]
    false_alarm: float
    skipped: tuple[str, ...] = ()  # what was not checked, and why
    notes: tuple[str, ...] = ()  # what a reader of the verdict should know of its inputs

    @property
    def passed(self) -> bool:
        return all(c.passed for c in self.checks)

    @functools.cached_property
    def cause(self) -> str | None:
        """The likely cause of the failed checks (None where every check passed): how the
        frames arrived where only the camera's record failed, why frames held no part,
        else the best of :attr:`diagnosis` (read once: the text, the JSON and the page
        each print it)."""
        return _cause(self)

    @functools.cached_property
    def field(self) -> dict[str, dict[str, tuple[float, float, float, float]]]:
        """Per class, the light's field as the parts show it (:func:`~inspect_validate.
        verification.parts.parts_field`): ``batch`` and ``golden``, each (slope x, slope
        y, their standard errors), relative to the class's μ per 100 px."""
        from inspect_validate.verification.diagnosis import station_sensor
        from inspect_validate.verification.parts import golden_field, parts_field

        sensor = station_sensor(self.station)
        dark = sensor.dark_offset if sensor is not None else 0.0
        g = next(iter(self.golden.illuminations.values()))
        trained = golden_field(g, dark_offset=dark)
        out: dict[str, dict[str, tuple[float, float, float, float]]] = {}
        for name, (slope, se) in parts_field(self.parts.measured, dark_offset=dark).items():
            out[name] = {"batch": (*slope, *se)}
            if name in trained:
                out[name]["golden"] = (*trained[name][0], *trained[name][1])
        return out

    @functools.cached_property
    def diagnosis(self) -> Diagnosis:
        """What the batch's parts changed against the golden parts, and the causes that
        explain it best first (:mod:`~inspect_validate.verification.diagnosis`)."""
        return diagnosis_of(self.station, self.parts.measured, self.golden)


def verify_production(
    station: Station, frames: Path, golden: Golden, *, source: str = "the golden file"
) -> ProductionVerification:
    """Verify ``station`` on the parts in ``frames`` against ``golden`` (trained by
    :func:`train_production`; ``source``, its file, for messages).

    Raises
    ------
    InputError
        A golden file trained on the bench (or of another illumination), and as
        :func:`measure_parts`.
    """
    from inspect_validate.station.file import station_hash

    production_golden(golden, station, source=source)
    parts = measure_parts(station, frames)
    verified = verify_parts(station, parts, golden, manifest=parts.manifest)
    if station.path is not None and golden.station_sha256 != station_hash(station):
        note = (
            "the golden file was trained with another version of the station file (its "
            "station_sha256 differs): its parts are the reference as they are; train it "
            "again if the station changed"
        )
        verified = replace(verified, notes=(note,))
    return verified


def verify_parts(
    station: Station,
    parts: Parts,
    golden: Golden,
    *,
    drift: bool = True,
    manifest: dict | None = None,
) -> ProductionVerification:
    """:func:`verify_production` of parts already measured, against a ``golden`` file
    :func:`production_golden` accepted for ``station`` (once, before the first batch: a
    watch verifies one a cycle); ``drift=False`` leaves out the golden statistics'
    checks (``watch --production``, whose charts replace them); ``manifest``, the capture
    that took them: what the camera reported is held to ``acceptance.health``
    (:func:`~.health_checks.health_checks`)."""
    from inspect_validate.verification.checks import at_least, decide
    from inspect_validate.verification.health_checks import health_checks

    assert station.production is not None
    name = station.production.illumination
    found = at_least(
        "parts found",
        "production",
        100 * parts.found,
        100 * MIN_FOUND,
        "%",
        f"{len(parts.measured)} of {len(parts.measured) + len(parts.not_measured)} frames "
        "hold a part" + (f"; {counted_reasons(parts.not_measured)}" if parts.not_measured else ""),
        illumination=name,
        subject="parts",
        quantity="found",
    )
    confidence = station.acceptance.confidence
    checks = [
        found,
        *(_drift_checks(parts, golden.illuminations[name], confidence) if drift else []),
    ]
    unhealthy, skipped = health_checks(station.acceptance.health, manifest or {})
    checks += unhealthy
    rate = station.acceptance.false_alarm_rate
    return ProductionVerification(
        station, golden, parts, decide(checks, rate), rate, tuple(skipped)
    )


def _cause(v: ProductionVerification) -> str | None:
    camera = [
        c.name.removeprefix("camera: ") for c in v.checks if c.kind == "health" and not c.passed
    ]
    failed = [c.name for c in v.checks if not c.passed and c.kind != "health"]
    if not failed:
        # the parts' own statistics held; what failed is how the frames arrived
        return f"the camera or its link: {', '.join(camera)}" if camera else None
    if "parts found" in failed:
        missing = v.parts.not_measured
        unusable = v.parts.unusable
        if unusable and 2 * len(unusable) >= len(missing):
            total = len(missing) + len(v.parts.measured)
            return (
                f"{len(unusable)} of {total} frames cannot be used as this station's frames "
                f"({counted_reasons(unusable)}): the line's program writes frames unlike the "
                "reference (size, colour, pixel type) or cuts them short"
            )
        return (
            "most frames hold no part to measure: a wrong reference, a moved camera or "
            "fixture, or no parts passing"
        )
    return v.diagnosis.text or (f"{listed(failed, 3)} failed, and no one cause explains what moved")


def counted_reasons(missing: dict[str, str]) -> str:
    """Why frames held no measured part (frame → why), each kind of reason counted, the
    commonest first: "no part found (2); the same frame as another (1)"."""
    counts: dict[str, int] = {}
    for why in missing.values():
        key = why.split(" keeps")[0] if " keeps " in why else why.split(":")[0]
        if key.startswith("the same frame as"):
            key = "the same frame as another"
        counts[key] = counts.get(key, 0) + 1
    return "; ".join(f"{why} ({n})" for why, n in sorted(counts.items(), key=lambda x: -x[1]))


def _drift_checks(parts: Parts, golden, confidence: float | None) -> list[Check]:
    """Each class's μ, σ² and focus, each comparison's SNR_dB: the batch mean against the
    golden parts' (module description), with tolerance intervals at ``confidence``."""
    if not parts.measured:
        return []
    checks = []
    ms = [p.measurement for p in parts.measured]
    for k, c in enumerate(ms[0].classes):
        g = golden.classes[c.name]
        quantities = [("μ", g.mean, [m.classes[k].mean for m in ms], "DN"),
                      ("σ²", g.variance, [m.classes[k].variance for m in ms], "DN²")]  # fmt: skip
        if g.focus is not None:
            quantities.append(("focus", g.focus, [p.focus[c.name] for p in parts.measured], "DN²"))
        for what, ref, values, unit in quantities:
            who = (c.name, {"μ": "mean", "σ²": "variance"}.get(what, what))
            checks.append(
                _batch_check(f"{c.name} {what} drift", values, ref, unit, confidence, who)
            )
    for j, comp in enumerate(ms[0].comparisons):
        ref = golden.comparisons[comp.label].snr_db
        values = [m.comparisons[j].snr_db for m in ms]
        checks.append(
            _batch_check(
                f"{comp.label} SNR_dB drift", values, ref, "dB", confidence, (comp.label, "snr_db")
            )
        )
    if golden.pose is not None:
        poses = [p.position for p in parts.measured]
        for i, (what, ref, unit) in enumerate(
            (
                ("x", golden.pose.x, "px"),
                ("y", golden.pose.y, "px"),
                ("rotation", golden.pose.angle, "°"),
            )
        ):
            name = f"pose {what} drift"
            checks.append(
                _batch_check(name, [p[i] for p in poses], ref, unit, confidence, ("pose", what))
            )
    return checks


def _batch_check(
    name: str,
    values: list[float],
    ref: Spread,
    unit: str,
    confidence: float | None,
    identity: tuple[str, str],
) -> Check:
    """|batch mean − golden mean| against t_{n−1} · s · √(1/m + 1/n), or the tolerance
    interval of a mean of m around the mean of n (its spread s/√m, its centre n/m such
    means) at ``confidence`` where that is wider."""
    from inspect_validate.verification.checks import Coverage, at_most, not_run

    who = {"subject": identity[0], "quantity": identity[1]}
    v = np.asarray(values, dtype=float)
    v = v[np.isfinite(v)]
    m, n, s = v.size, ref.n, ref.std
    if m == 0 or n < 2 or not math.isfinite(s):
        why = "no spread of good parts to set its limit"
        return not_run(name, "drift", 0.0, unit, "<=", why, **who)
    mean = float(v.mean())
    sd = s * math.sqrt(1.0 / m + 1.0 / n)
    return at_most(
        name,
        "drift",
        abs(mean - ref.mean),
        0.0,
        unit,
        f"golden {ref.summary()} {unit} over {n} parts, now {mean:.4g} over {m}; "
        f"prediction interval of a batch mean, sd {sd:.2g} {unit}, t with {n - 1} df",
        basis="statistical",
        standard_error=sd,
        df=n - 1,
        sided=2,
        coverage=None
        if confidence is None or s <= 0
        else Coverage(s / math.sqrt(m), n / m, confidence),
    )
