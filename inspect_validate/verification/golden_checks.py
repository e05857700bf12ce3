"""Checks against a golden file (:mod:`.golden`): how far a station has drifted from
its golden statistics, in DN for μ and in dB for SNR_dB, and whether a golden file's
repeats can set such checks at a verification's false-alarm rate.

**The prediction interval.** From n repeats x₁ … x_n with mean x̄ and sample standard
deviation s, a new measurement x of an unchanged station lies within

    |x − x̄| ≤ t_{n−1}(1 − α/2) · √(s'² (1 + 1/n) + max(0, SE² − SE₀²))

with probability 1 − α: Student's t because s has n − 1 degrees of freedom, 1/n for
the uncertainty of x̄, SE the new measurement's own standard error and SE₀ the
repeats' (:mod:`.uncertainty`; a measurement of fewer pixels or frames than the
training varies more), s'² = max(s², SE₀²) (repeats cannot vary less than their
noise).

**The tolerance interval.** That probability is an average over trainings: a golden
file whose s came out small fails an unchanged station more often than α, one whose s
came out large less. With ``drift.confidence`` γ (default 0.95) the limit is the wider
of the prediction interval and the two-sided tolerance interval

    |x − x̄| ≤ k(n, 1 − α, γ) · √(s'² + max(0, SE² − SE₀²))

(:mod:`inspect_validate.stats.tolerance_interval`): with probability γ over the
training, *this* golden file fails an unchanged station at most α of the time. At 5
repeats and α near 10⁻⁴ the prediction interval is the wider (it already gives γ ≈
0.99); from about 12 repeats the tolerance interval is.

α is the check's share of the verification's false-alarm rate (:mod:`.checks`). Few repeats make t large: 5 repeats and 20 checks at 0.27 % give
limits 4.1 × as wide as a perfectly known spread would; a golden file whose limits
would be more than :data:`MAX_WIDENING` × as wide is refused, naming the repeats it
needs.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

from inspect_validate.errors import InputError
from inspect_validate.verification.checks import Check, Coverage, at_most

if TYPE_CHECKING:
    from collections.abc import Sequence

    from inspect_validate.acceptance import Drift
    from inspect_validate.station.file import Station
    from inspect_validate.verification.golden import Golden, Spread

__all__ = [
    "GOOD_WIDENING",
    "MAX_WIDENING",
    "above_floor",
    "detectable_change",
    "drift_checks",
    "drift_coverage",
    "drift_limit",
    "prediction_sd",
    "repeats_needed",
    "settings_checks",
    "validate_camera",
    "validate_golden",
    "widening",
]

MAX_WIDENING = 10.0
"""A golden file whose drift limits would be more than this many times as wide as a
perfectly known spread would set (too few repeats for the false-alarm rate asked) is
refused: its checks would catch only gross changes, which a fixed tolerance states
more plainly."""


GOOD_WIDENING = 2.0
"""The widening :func:`repeats_needed` names as enough for limits that track the spread."""


def above_floor(spread: Spread, floor: float, *, k: float = 3.0) -> bool:
    """Whether a comparison the golden file holds is drift-checked: its SNR_dB above
    ``floor`` (``drift.snr_floor_db``) by more than ``k`` of its repeats' standard
    deviation (k the false-alarm rate's normal equivalent). Below, SNR_dB is the log of a
    near-zero contrast; within k spreads above, the parts or captures the repeats learned
    fall either side of it. Decided from the golden file alone, so that ``train``,
    ``verify`` and ``watch`` keep one set of checks."""
    s = spread.std if spread.n >= 2 and math.isfinite(spread.std) else 0.0
    return spread.mean - k * s >= floor


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


def detectable_change(
    spread: Spread, share: float, *, power: float = 0.95, confidence: float | None = None
) -> float:
    """The smallest change of a quantity that its drift check catches with probability
    ``power``, in its unit: the limit (module description; with ``confidence``, the wider
    of the prediction and tolerance intervals) plus z(power) × :func:`prediction_sd`, at
    the repeats' own standard error (a verification captured as the training was)."""
    from inspect_validate.verification.checks import quantile

    sd = prediction_sd(spread, spread.standard_error)
    if not math.isfinite(sd):
        return math.nan
    return drift_limit(spread, share, confidence=confidence) + quantile(1.0 - power, sided=1) * sd


def drift_limit(
    spread: Spread,
    share: float,
    *,
    standard_error: float | None = None,
    confidence: float | None = None,
) -> float:
    """The statistical limit on |x − x̄| a drift check against ``spread`` sets at its
    false-alarm ``share`` (module description), in its unit; ``standard_error`` is the
    new measurement's (default the repeats' own). NaN without a spread."""
    from inspect_validate.verification.checks import covered_margin, quantile

    own = spread.standard_error if standard_error is None else standard_error
    sd = prediction_sd(spread, own)
    if not math.isfinite(sd):
        return math.nan
    limit = quantile(share, df=spread.n - 1) * sd
    coverage = drift_coverage(spread, own, confidence)
    if coverage is None:
        return limit
    return covered_margin(coverage, limit, share, df=spread.n - 1)[0]


def drift_coverage(
    spread: Spread, standard_error: float, confidence: float | None
) -> Coverage | None:
    """What the tolerance interval of a drift check against ``spread`` needs
    (:class:`~.checks.Coverage`; module description); None without ``confidence`` or a
    spread."""
    n, s = spread.n, spread.std
    if confidence is None or n < 2 or not math.isfinite(s):
        return None
    own = standard_error if math.isfinite(standard_error) else 0.0
    ref = spread.standard_error if math.isfinite(spread.standard_error) else own
    sd = math.sqrt(max(s * s, ref * ref) + max(0.0, own * own - ref * ref))
    return Coverage(sd, float(n), confidence) if sd > 0 else None


def drift_checks(
    golden: Golden, measurements: dict, drift: Drift | None, errors: dict, *, k: float = 3.0
) -> list[Check]:
    """Drift of each class's μ (DN) and each comparison's SNR_dB (dB) from ``golden``, which
    :func:`validate_golden` has accepted for the station.

    ``drift`` is the station's ``acceptance.drift``: a fixed tolerance it gives is held as
    it is; otherwise each check is statistical, its limit the wider of the prediction
    interval and the tolerance interval (module description) that :func:`~.checks.decide`
    sets from :func:`prediction_sd` and :func:`drift_coverage`.
    ``errors`` is illumination → the measurement's
    :class:`~.uncertainty.StandardErrors`; ``k`` the false-alarm rate's normal
    equivalent (:func:`above_floor`).
    """
    if drift is None:  # no drift section: a golden file alone asks for nothing
        return []
    checks = []
    for ill, m in measurements.items():
        g, se = golden.illuminations[ill], errors[ill]
        for i, c in enumerate(m.classes):
            ref = g.classes[c.name].mean
            checks.append(
                _drift_check(
                    f"{ill}: {c.name} μ drift",
                    c.mean,
                    ref,
                    drift.mean_dn,
                    float(se.mean[i]),
                    drift.confidence,
                    "DN",
                    f"golden {ref.summary()} DN over {ref.n} repeats, now {c.mean:.4g} DN",
                    (ill, c.name, "mean"),
                )
            )
        for j, comp in enumerate(m.comparisons):
            ref = g.comparisons[comp.label].snr_db
            if not above_floor(ref, drift.snr_floor_db, k=k):
                continue  # unseparable when trained: left out of every verification
            checks.append(
                _drift_check(
                    f"{ill}: {comp.label} SNR_dB drift",
                    comp.snr_db,
                    ref,
                    drift.snr_db,
                    float(se.snr_db[j]),
                    drift.confidence,
                    "dB",
                    f"golden {ref.summary(3)} dB over {ref.n} repeats, now {comp.snr_db:.2f} dB",
                    (ill, comp.label, "snr_db"),
                )
            )
    return checks


def _drift_check(
    name, value, ref: Spread, tolerance, standard_error, confidence, unit, detail, identity
) -> Check:
    ill, subject, quantity = identity
    who = {"illumination": ill, "subject": subject, "quantity": quantity}
    deviation = abs(value - ref.mean)
    if tolerance is not None:
        return at_most(
            name, "drift", deviation, tolerance, unit, f"{detail}; fixed tolerance", **who
        )
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
        coverage=drift_coverage(ref, standard_error, confidence),
        **who,
    )


def settings_checks(golden: Golden, manifest: dict) -> tuple[list[Check], list[str]]:
    """The camera's settings now (the capture's snapshot) against those ``golden`` was
    trained at: a fixed check that fails naming every node changed (``"Gamma 1 → 0.7"``),
    or, where either has no snapshot, a note saying so (nothing to compare is not a
    failure: a golden file from before snapshots, a camera without a node map)."""
    from inspect_validate.camera.storage import changed_settings

    now = (manifest.get("settings") or {}).get("values")
    if golden.settings is None:
        return [], [
            "no settings snapshot to compare: the golden file was trained from captures "
            "without one (retrain to have the camera's settings checked)"
        ]
    if now is None:
        return [], ["no settings snapshot to compare: the capture holds none"]
    if not now:  # V4L2, a replay: no node map to read
        return [], ["no settings snapshot to compare: the camera reports no settings nodes"]
    changed = changed_settings(golden.settings, now)
    detail = "; ".join(changed) if changed else f"{len(now)} nodes as trained"
    return [
        at_most(
            "camera settings unchanged since training",
            "settings",
            len(changed),
            0,
            "",
            f"{detail} (the camera's own values: another program, or the camera, changed them)"
            if changed
            else detail,
            subject="camera",
            quantity="settings",
        )
    ], []


def validate_golden(
    golden: Golden,
    station: Station,
    drift: Drift,
    *,
    classes: Sequence[str],
    comparisons: Sequence[str],
    source: str,
    share: float | None = None,
    k: float = 3.0,
) -> None:
    """Refuse, before any capture, a golden file that cannot check ``station``'s drift.

    ``share`` is a drift check's share of the false-alarm rate (:func:`~.checks.decide`):
    a golden file whose limits it would widen more than :data:`MAX_WIDENING` times is
    refused. ``k``: the rate's normal equivalent (:func:`above_floor`).

    Raises
    ------
    InputError
        Trained at other camera settings or illuminations, without one of the
        ``classes`` or ``comparisons`` (labels), or without a spread where
        ``drift`` gives no explicit tolerance, or too few repeats for the rate (names
        ``source``: retrain, or give the tolerance).
    """
    if golden.mode != "bench":
        raise InputError(
            "this golden file was trained on parts of the running line (train --production); "
            "verify it with verify --production, or train one from captures for the bench",
            source=source,
        )
    camera = station.camera
    validate_camera(golden, station, source=source)
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
            if not above_floor(spread, drift.snr_floor_db, k=k):
                continue  # never checked against this golden file
            _needs_spread(drift.snr_db, spread, f"{ill.name}: {text} SNR_dB", source, share)


def validate_camera(golden: Golden, station: Station, *, source: str) -> None:
    """Refuse a golden file trained on another camera than ``station``'s (a view of one
    camera of several, or a station of one).

    Raises
    ------
    InputError
        Naming both cameras and the file, and what to give.
    """
    if golden.camera != station.camera.name:
        raise InputError(
            f"the golden file was trained on {_camera(golden.camera)}, this is "
            f"{_camera(station.camera.name)}: give that camera's golden file "
            "(cameras[].golden, or watch --golden NAME=PATH), or train one with --camera",
            source=source,
        )


def _camera(name: str | None) -> str:
    return f"camera {name!r}" if name is not None else "a station of one camera"


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
