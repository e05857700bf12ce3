"""The likely cause of a batch of parts' change against the golden parts: one reading of
the measured changes, for ``verify --production`` and ``watch --production`` alike.

Every class's μ (of the signal above the dark level), σ² and focus measure, and the parts'
position, is a relative (or, for the position, absolute) change of the batch mean from
the golden mean with its standard error, s·√(1/m + 1/n). Each candidate cause predicts a
pattern of those changes from a few parameters of its own:

========================  ===========================================================
cause                     what it moves (others stay)
========================  ===========================================================
light level (a)           every μ by a − 1; σ² and focus as the EMVA model says a light
                          does (texture by a², photon noise by a)
gain (a)                  every μ by a − 1, σ² and focus by a² − 1
light or gain (a)         without a camera model: μ by a − 1, σ² and focus between
                          0 and a² − 1 (the noise that stays can be most of them)
spectrum (a per class)    each class's μ by its own factor, σ² and focus with it
focus (f per class)       the focus measure, σ² towards it; μ steady
parts (σ² per class)      σ², the focus measure towards it; μ steady
shade (a per class)       as spectrum, and the part-to-part spread of μ of the classes
                          whose μ follows where the part lies
fixture (where parts lie) the parts' position (x, y, rotation); their statistics steady
========================  ===========================================================

A cause's score is the χ² it explains (Σ z² of the changes against nothing having
changed, less Σ z² of what is left over) less :data:`PARAMETER_COST` a parameter, z a
change in its standard errors. Each standard error is widened by
:data:`MODEL_TOLERANCE` of its change: the patterns are models, and a quantity measured
to a hundredth of its change must not outvote the rest. The best cause is named with its
size, and the runner-up with it where its score is within :data:`CLOSE` of the best.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from inspect_validate.station.file import Station
    from inspect_validate.verification.golden import Golden, GoldenIllumination, Spread
    from inspect_validate.verification.parts import Part

__all__ = [
    "CLOSE",
    "MODEL_TOLERANCE",
    "PARAMETER_COST",
    "Cause",
    "Change",
    "Diagnosis",
    "Sensor",
    "batch_changes",
    "diagnose",
    "diagnosis_of",
    "shaded_classes",
    "station_sensor",
]

MODEL_TOLERANCE = 0.1
"""Each change's standard error is widened by this fraction of the change (the
patterns are approximations: a focus measure is not exactly a² under a light)."""
PARAMETER_COST = 9.0
"""χ² a cause's parameter must explain to count (three standard errors)."""
CLOSE = 9.0
"""A runner-up within this χ² of the best cause is named beside it."""
LAPLACIAN_GAIN = 20.0
"""Σ k² of the focus measure's Laplacian kernel (cv2.Laplacian, ksize 1): white noise
of variance N adds 20 N to the focus measure."""


@dataclass(frozen=True)
class Change:
    """One quantity of the batch against the golden parts: ``quantity`` is ``mean``
    (relative, of the signal above dark), ``variance``, ``focus`` (relative), or ``x``,
    ``y``, ``angle`` (px, °; ``name`` None)."""

    name: str | None
    quantity: str
    value: float
    standard_error: float
    # The golden values a light's EMVA pattern needs: signal S = μ − μ_dark, σ², focus.
    signal: float = math.nan
    variance: float = math.nan
    focus: float = math.nan

    @property
    def scale(self) -> float:
        return math.hypot(self.standard_error, MODEL_TOLERANCE * self.value)


@dataclass(frozen=True)
class Cause:
    """A scored cause: its kind, score (χ² explained less its parameters' cost) and the
    sentence that names it with its size."""

    kind: str
    score: float
    text: str


@dataclass(frozen=True)
class Diagnosis:
    """The causes that explain something, best first; the changes they were read from."""

    causes: tuple[Cause, ...]
    changes: tuple[Change, ...]

    @property
    def text(self) -> str | None:
        """The best cause, and the runner-up where close; None where nothing moved
        beyond its standard errors."""
        if not self.causes:
            return None
        best, *rest = self.causes
        close = [c for c in rest[:1] if c.score >= best.score - CLOSE]
        return best.text + "".join(f"; or, nearly as well, {c.text}" for c in close)


@dataclass(frozen=True)
class Sensor:
    """The camera's EMVA 1288 values a light's noise pattern needs: K (DN/e⁻), σ_d (e⁻),
    μ_dark (DN)."""

    gain: float
    dark_noise: float
    dark_offset: float


def batch_changes(
    parts: Sequence[Part], golden: GoldenIllumination, *, dark_offset: float = 0.0
) -> tuple[Change, ...]:
    """The batch's changes against ``golden`` (a
    :class:`~inspect_validate.verification.golden.GoldenIllumination`): per class μ
    (its signal above ``dark_offset``, DN), σ², focus; the parts' x, y and rotation."""
    m = len(parts)
    out = []
    for k, c in enumerate(parts[0].measurement.classes):
        g = golden.classes.get(c.name)
        if g is None:
            continue
        mu = np.array([p.measurement.classes[k].mean for p in parts])
        var = np.array([p.measurement.classes[k].variance for p in parts])
        focus = np.array([p.focus.get(c.name, math.nan) for p in parts])
        signal = g.mean.mean - dark_offset
        golden_focus = g.focus.mean if g.focus is not None else math.nan
        for quantity, values, spread, base in (
            ("mean", mu - dark_offset, g.mean, signal),
            ("variance", var, g.variance, g.variance.mean),
            ("focus", focus, g.focus, golden_focus),
        ):
            change = _relative(values, spread, base, m)
            if change is not None:
                out.append(Change(c.name, quantity, *change, signal, g.variance.mean, golden_focus))
        # How much more the parts' μ spreads than the golden parts' (s²/s₀² − 1, its
        # standard error from the two variances' χ² laws): a shade fixed in the frame
        # spreads it, as the parts pass under it; nothing else here does.
        n = g.mean.n
        if m > 2 and n > 2 and g.mean.std > 0:
            ratio = float(np.var(mu, ddof=1)) / g.mean.std**2
            se = ratio * math.sqrt(2.0 / (m - 1) + 2.0 / (n - 1))
            out.append(Change(c.name, "spread", ratio - 1.0, se))
    if golden.pose is not None:
        position = np.array([p.position for p in parts])
        for i, (quantity, spread) in enumerate(
            (("x", golden.pose.x), ("y", golden.pose.y), ("angle", golden.pose.angle))
        ):
            v = position[:, i][np.isfinite(position[:, i])]
            se = _standard_error(v, spread)
            if v.size and math.isfinite(se):
                out.append(Change(None, quantity, float(v.mean()) - spread.mean, se))
    return tuple(out)


def _standard_error(values: np.ndarray, spread: Spread) -> float:
    """s·√(1/m + 1/n) from the golden parts' s (the batch's own where larger)."""
    m, n = values.size, spread.n
    if m == 0 or n < 2 or not math.isfinite(spread.std):
        return math.nan
    s = max(spread.std, float(values.std(ddof=1)) if m > 1 else 0.0)
    return s * math.sqrt(1.0 / m + 1.0 / n)


def _relative(values, spread, base: float, m: int) -> tuple[float, float] | None:
    if spread is None or not base > 0:
        return None
    v = np.asarray(values, float)
    v = v[np.isfinite(v)]
    se = _standard_error(v, spread)
    if not (v.size and math.isfinite(se)):
        return None
    return float(v.mean()) / base - 1.0, se / base


def diagnose(
    parts: Sequence[Part],
    golden: GoldenIllumination,
    *,
    sensor: Sensor | None = None,
    shaded: Sequence[str] = (),
) -> Diagnosis:
    """The likely causes of a batch's change against the golden parts (module
    description), best first.

    Parameters
    ----------
    parts : sequence of Part
        The batch's measured parts.
    golden : GoldenIllumination
        The golden parts' statistics under the production illumination.
    sensor : Sensor, keyword-only, optional
        The station camera's EMVA values, to tell a light from a gain; without them, the
        two are one cause.
    shaded : sequence of str, keyword-only
        Classes whose μ follows where the part lies (:func:`shaded_classes`).
    """
    if not parts:
        return Diagnosis((), ())
    dark = sensor.dark_offset if sensor is not None else 0.0
    changes = batch_changes(parts, golden, dark_offset=dark)
    total = sum((c.value / c.scale) ** 2 for c in changes if c.scale > 0)
    classes = sorted({c.name for c in changes if c.name is not None})
    causes = []
    for kind, params, fit in _candidates(changes, classes, sensor, shaded):
        residual, text = fit()
        score = total - residual - PARAMETER_COST * params
        if score > 0:
            causes.append(Cause(kind, score, text))
    causes.sort(key=lambda c: -c.score)
    return Diagnosis(tuple(causes), changes)


def _chi(c: Change, predicted: float | tuple[float, float]) -> float:
    """(change − predicted)² in the change's widened standard errors; a pair of values
    predicts anywhere between them."""
    if isinstance(predicted, tuple):
        lo, hi = min(predicted), max(predicted)
        miss = c.value - lo if c.value < lo else (c.value - hi if c.value > hi else 0.0)
    else:
        miss = c.value - predicted
    return (miss / c.scale) ** 2 if c.scale > 0 else 0.0


def _noise_pattern(c: Change, a: float, pattern: str, sensor: Sensor | None):
    """What a signal scaled by ``a`` does to ``c`` (a class's σ² or focus measure):
    ``gain`` scales all of it by a²; ``light`` its texture by a² and the photon noise by a
    (EMVA 1288: N = K S + K² σ_d² + 1/12 DN², the focus measure's noise 20 N);
    ``either`` (no camera model) anywhere between 1 and a² times it: the sensor's noise
    that stays (dark noise, quantisation) can be most of it."""
    if pattern == "gain":
        return a * a - 1
    if pattern == "either" or sensor is None:
        return (0.0, a * a - 1)
    k, spread = sensor.gain, (sensor.gain * sensor.dark_noise) ** 2 + 1 / 12
    base = c.variance if c.quantity == "variance" else c.focus
    weight = 1.0 if c.quantity == "variance" else LAPLACIAN_GAIN
    if not (base > 0 and c.signal > 0):
        return (0.0, a * a - 1)
    photon = min(weight * k * c.signal, base)
    fixed = min(weight * spread, base - photon)
    texture = base - photon - fixed
    return (texture * a * a + photon * a + fixed) / base - 1


def _best_factor(residual: Callable[[float], float]) -> tuple[float, float]:
    """The factor a in [0.05, 20] that leaves the least χ², and that χ²."""
    from scipy.optimize import minimize_scalar

    r = minimize_scalar(residual, bounds=(0.05, 20.0), method="bounded", options={"xatol": 1e-9})
    return float(r.x), float(r.fun)


def _level(changes: Sequence[Change], pattern: str, sensor: Sensor | None):
    """χ² left by a signal scaled by a, as a function of a: μ by a − 1, σ² and focus by
    ``pattern``, the parts' position steady."""

    def residual(a: float) -> float:
        total = 0.0
        for c in changes:
            if c.name is None or c.quantity == "spread":
                total += _chi(c, 0.0)
            elif c.quantity == "mean":
                total += _chi(c, a - 1)
            else:
                total += _chi(c, _noise_pattern(c, a, pattern, sensor))
        return total

    return residual


def _level_text(pattern: str, a: float) -> str:
    size = f"{100 * abs(a - 1):.1f} %"
    if pattern == "gain":
        return (
            f"the camera's gain is {'down' if a < 1 else 'up'} by about {size} (every "
            "class's μ moved together, and σ² by the square of μ's factor, the sensor's "
            "noise with it, where more or less light would move the noise as the EMVA model "
            "says): the gain or another camera setting changed"
        )
    if pattern == "light":
        return (
            f"the light is {'dimmer' if a < 1 else 'brighter'} by about {size} (every "
            "class's μ moved together, σ² with the light's photons as the EMVA model says, "
            "not as a gain would): LED output, or the exposure time"
        )
    return (
        f"the light is {'dimmer' if a < 1 else 'brighter'} by about {size}, or the camera's "
        f"gain {'lower' if a < 1 else 'higher'} (every class's μ moved together): LED "
        "output, exposure or gain; light or gain: this station has no camera model to tell "
        "them apart"
    )


def _candidates(changes: tuple[Change, ...], classes: list[str], sensor, shaded):
    """(kind, parameters, fit) of each cause that applies; ``fit()`` → (χ² left, text)."""
    by = {(c.name, c.quantity): c for c in changes}
    pose = [c for c in changes if c.name is None]
    means = [c for c in changes if c.quantity == "mean"]

    def steady(keep: Callable[[Change], bool]) -> float:
        """χ² of the changes a cause leaves where they were."""
        return sum(_chi(c, 0.0) for c in changes if keep(c))

    def named_level(pattern: str):
        def fit():
            _, left = _best_factor(_level(changes, pattern, sensor))
            # Its size from the means alone: what a reader checks it against, and σ² and
            # the focus measure follow a level only as closely as their models do.
            a, _ = _best_factor(_level(means, pattern, sensor))
            return left, _level_text(pattern, a)

        return fit

    if means:
        for pattern in ("either",) if sensor is None else ("light", "gain"):
            yield ("light or gain" if pattern == "either" else pattern), 1, named_level(pattern)

    def factors(free_spread: Sequence[str] = ()) -> tuple[float, dict[str, float]]:
        """χ² left with each class's signal scaled by its own factor (its μ spread free in
        ``free_spread``), and the factors − 1."""
        left, moved = steady(lambda c: c.name is None), {}
        for name in classes:
            own = [c for c in changes if c.name == name]
            if name in free_spread:
                own = [c for c in own if c.quantity != "spread"]
            a, r = _best_factor(_level(own, "light" if sensor else "either", sensor))
            left += r
            moved[name] = a - 1
        return left, moved

    def spectrum():
        left, _ = factors()
        named = ", ".join(
            f"{c.name} {100 * c.value:+.1f} %" for c in sorted(means, key=lambda c: str(c.name))
        )
        return left, (
            f"the classes' μ moved by different factors ({named}): the light's spectrum "
            "changed, or the parts differ"
        )

    if len(means) >= 2:
        yield "spectrum", len(classes), spectrum

    def free(quantity: str, towards: str) -> tuple[float, list[float]]:
        """χ² left with ``quantity`` free in each class and ``towards`` anywhere between
        0 and its change, μ and the position steady; the changes of ``quantity``."""
        left = steady(lambda c: c.name is None or c.quantity in ("mean", "spread"))
        moved = []
        for name in classes:
            own, other = by.get((name, quantity)), by.get((name, towards))
            if own is not None:
                moved.append(own.value)
            if other is not None:
                left += _chi(other, (0.0, own.value if own is not None else 0.0))
        return left, moved

    def focus():
        left, moved = free("focus", "variance")
        f = float(np.median(moved)) if moved else 0.0
        if f < 0:
            return left, (
                f"the focus measure fell by {100 * abs(f):.0f} % at steady μ: the lens lost "
                "focus (or a haze or dust on it)"
            )
        return (
            left,
            f"the focus measure rose by {100 * f:.0f} % at steady μ: sharper parts or edges",
        )

    def spread():
        left, moved = free("variance", "focus")
        v = float(np.median(moved)) if moved else 0.0
        return left, (
            f"the classes' spread (σ²) {'rose' if v > 0 else 'fell'} by {100 * abs(v):.0f} % "
            "at steady μ and focus: the parts differ"
        )

    if any(c.quantity == "focus" for c in changes):
        yield "focus", len(classes), focus
    yield "parts", len(classes), spread

    if shaded:

        def shade():
            left, _ = factors(shaded)
            return left, (
                f"{', '.join(shaded)}: μ now depends on where the part lies, its spread over "
                "the parts many times the golden parts': something fixed in the frame dims "
                "part of the image (dust or a smudge on the lens, a shadow)"
            )

        yield "shade", len(classes) + len(shaded), shade

    if pose:

        def fixture():
            moved = ", ".join(
                f"{'rotation' if c.quantity == 'angle' else c.quantity} "
                f"{c.value:+.2f}{'°' if c.quantity == 'angle' else ' px'}"
                for c in pose
            )
            return steady(lambda c: c.name is not None), (
                f"the parts lie elsewhere in the frame than the golden parts did ({moved}), "
                "their statistics steady: the camera or the fixture moved"
            )

        # One parameter, where the parts lie: a knock moves them along one direction
        # as much as several, and a check of the position fails at about 3 standard
        # errors, which three parameters' cost would leave unexplained.
        yield "fixture", 1, fixture


def shaded_classes(parts: Sequence[Part], golden: GoldenIllumination) -> list[str]:
    """The classes whose μ over the batch's parts spreads over 3 × the golden parts' and
    follows the parts' position (R² ≥ 0.5 of a quadratic in x, y): what a shade fixed in
    the frame does to parts passing under it. Needs 12 parts (6 coefficients)."""
    if len(parts) < 12:
        return []
    xy = np.array([p.position[:2] for p in parts])
    xy = (xy - xy.mean(axis=0)) / np.maximum(xy.std(axis=0), 1e-9)
    x, y = xy.T
    design = np.column_stack([np.ones(len(parts)), x, y, x * x, x * y, y * y])
    out = []
    for k, c in enumerate(parts[0].measurement.classes):
        g = golden.classes.get(c.name)
        mu = np.array([p.measurement.classes[k].mean for p in parts])
        if g is None or not (np.isfinite(g.mean.std) and mu.std(ddof=1) > 3 * g.mean.std):
            continue
        fit, *_ = np.linalg.lstsq(design, mu, rcond=None)
        residual = mu - design @ fit
        if 1 - residual.var() / mu.var() >= 0.5:
            out.append(c.name)
    return out


def diagnosis_of(station: Station, parts: Sequence[Part], golden: Golden) -> Diagnosis:
    """The :func:`~inspect_validate.verification.diagnosis.diagnose` of ``parts`` against
    ``golden``'s production illumination, with :func:`station_sensor`."""
    g = next(iter(golden.illuminations.values()))
    return diagnose(parts, g, sensor=station_sensor(station), shaded=shaded_classes(parts, g))


def station_sensor(station: Station) -> Sensor | None:
    """The station camera's EMVA values (a
    :class:`~inspect_validate.verification.diagnosis.Sensor`) where the station has a
    scene to take them from; None for a station of frames alone (its dark level taken as
    0 DN, and a light and a gain one cause)."""
    if station.scene is None:
        return None
    from inspect_validate.station.model import station_model

    s = station_model(station).sensor
    return Sensor(s.gain, s.dark_noise, s.dark_offset)
