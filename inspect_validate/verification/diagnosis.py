"""The likely cause of a change against a golden file: one reading of the measured
changes, for ``verify`` and ``watch``, on the bench and on the line alike.

Every class's μ (of the signal above the dark level), σ² and focus measure under each
illumination, and the parts' position, is a relative (or, for the position, absolute)
change of the batch mean from the golden mean with its standard error, s·√(1/m + 1/n)
(m parts a batch; a bench capture is a batch of one). Each candidate cause predicts a
pattern of those changes from a few parameters of its own:

========================  ===========================================================
cause                     what it moves (others stay)
========================  ===========================================================
light level (a)           every μ by a − 1; σ² and focus as the EMVA model says a light
                          does (texture by a², photon noise by a); with several
                          illuminations, all of them: the exposure or the lens
gain (a)                  every μ by a − 1, σ² and focus by a² − 1
light or gain (a)         without a camera model: μ by a − 1, σ² and focus between
                          0 and a² − 1 (the noise that stays can be most of them)
one light (a)             one illumination's classes as a light level, the others steady
lights (a per light)      each illumination's classes by a level of its own
spectrum (a per class)    each class's μ by its own factor, σ² and focus with it (of one
                          illumination, or of all)
focus (f per class)       the focus measure, σ² towards it; μ steady
parts (σ² per class)      σ², the focus measure towards it; μ steady (on the bench,
                          where the samples stay: the optics, blur or haze)
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
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from inspect_validate.components.sensors import SensorModel
    from inspect_validate.measurement import Measurement
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
    "capture_changes",
    "capture_diagnosis",
    "diagnose",
    "diagnose_changes",
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
    (relative, of the signal above dark), ``variance``, ``focus`` (relative), ``spread``
    (of μ over the parts), or ``x``, ``y``, ``angle`` (px, °; ``name`` None), under
    ``illumination``."""

    name: str | None
    quantity: str
    value: float
    standard_error: float
    # The golden values a light's EMVA pattern needs: signal S = μ − μ_dark, σ², focus.
    signal: float = math.nan
    variance: float = math.nan
    focus: float = math.nan
    illumination: str = ""

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

    @classmethod
    def of(cls, sensor: SensorModel) -> Sensor:
        """The values of a station model's sensor (its ``gain``, ``dark_noise``,
        ``dark_offset``)."""
        return cls(sensor.gain, sensor.dark_noise, sensor.dark_offset)


def batch_changes(
    parts: Sequence[Part],
    golden: GoldenIllumination,
    *,
    dark_offset: float = 0.0,
    illumination: str = "",
) -> tuple[Change, ...]:
    """The batch's changes against ``golden`` (a
    :class:`~inspect_validate.verification.golden.GoldenIllumination`, of
    ``illumination``): per class μ (its signal above ``dark_offset``, DN), σ², focus; the
    parts' x, y and rotation."""
    m = len(parts)
    out = []
    for k, c in enumerate(parts[0].measurement.classes):
        g = golden.classes.get(c.name)
        if g is None:
            continue
        mu = np.array([p.measurement.classes[k].mean for p in parts])
        var = np.array([p.measurement.classes[k].variance for p in parts])
        focus = np.array([p.focus.get(c.name, math.nan) for p in parts])
        out += _class_changes(c.name, g, mu, var, focus, dark_offset, illumination)
        # How much more the parts' μ spreads than the golden parts' (s²/s₀² − 1, its
        # standard error from the two variances' χ² laws): a shade fixed in the frame
        # spreads it, as the parts pass under it; nothing else here does.
        n = g.mean.n
        if m > 2 and n > 2 and g.mean.std > 0:
            ratio = float(np.var(mu, ddof=1)) / g.mean.std**2
            se = ratio * math.sqrt(2.0 / (m - 1) + 2.0 / (n - 1))
            out.append(Change(c.name, "spread", ratio - 1.0, se, illumination=illumination))
    if golden.pose is not None:
        position = np.array([p.position for p in parts])
        for i, (quantity, spread) in enumerate(
            (("x", golden.pose.x), ("y", golden.pose.y), ("angle", golden.pose.angle))
        ):
            v = position[:, i][np.isfinite(position[:, i])]
            se = _standard_error(v, spread)
            if v.size and math.isfinite(se):
                out.append(
                    Change(None, quantity, float(v.mean()) - spread.mean, se,
                           illumination=illumination)
                )  # fmt: skip
    return tuple(out)


def capture_changes(
    measurements: Mapping[str, Measurement], golden: Golden, *, dark_offset: float = 0.0
) -> tuple[Change, ...]:
    """A bench capture's changes against ``golden``: per illumination and class μ (its
    signal above ``dark_offset``, DN) and σ², each a batch of one."""
    out: list[Change] = []
    for ill, m in measurements.items():
        g = golden.illuminations.get(ill)
        if g is None:
            continue
        for c in m.classes:
            if (gc := g.classes.get(c.name)) is not None:
                mu, var = np.array([c.mean]), np.array([c.variance])
                out += _class_changes(c.name, gc, mu, var, None, dark_offset, ill)
    return tuple(out)


def _class_changes(name, g, mu, var, focus, dark_offset, illumination) -> list[Change]:
    """A class's relative changes of μ (above ``dark_offset``), σ² and the focus measure
    (None: not measured) from the batch's values."""
    signal = g.mean.mean - dark_offset
    golden_focus = g.focus.mean if g.focus is not None else math.nan
    out = []
    for quantity, values, spread, base in (
        ("mean", mu - dark_offset, g.mean, signal),
        ("variance", var, g.variance, g.variance.mean),
        ("focus", focus, g.focus, golden_focus),
    ):
        change = None if values is None else _relative(values, spread, base, len(mu))
        if change is not None:
            out.append(
                Change(name, quantity, *change, signal, g.variance.mean, golden_focus,
                       illumination)
            )  # fmt: skip
    return out


def _standard_error(values: np.ndarray, spread: Spread) -> float:
    """s·√(1/m + 1/n) from the golden parts' s (the batch's own, or the golden values'
    own standard error, where larger)."""
    m, n = values.size, spread.n
    if m == 0 or n < 2 or not math.isfinite(spread.std):
        return math.nan
    # Repeats cannot vary less than their own noise (a few repeats can, by chance)
    floor = spread.standard_error if math.isfinite(spread.standard_error) else 0.0
    s = max(spread.std, floor, float(values.std(ddof=1)) if m > 1 else 0.0)
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
    return diagnose_changes(
        batch_changes(parts, golden, dark_offset=dark), sensor=sensor, shaded=shaded
    )


def diagnose_changes(
    changes: Sequence[Change],
    *,
    sensor: Sensor | None = None,
    shaded: Sequence[str] = (),
    bench: bool = False,
) -> Diagnosis:
    """The causes that explain ``changes`` (module description), best first.

    Parameters
    ----------
    changes : sequence of Change
        Of a batch (:func:`batch_changes`), a capture (:func:`capture_changes`), or a
        watch's smoothed charts.
    sensor : Sensor, keyword-only, optional
        As :func:`diagnose`.
    shaded : sequence of str, keyword-only
        As :func:`diagnose`.
    bench : bool, keyword-only
        The same samples every time: a class's σ² that moved at steady μ is the optics,
        not other parts.
    """
    changes = tuple(changes)
    total = sum((c.value / c.scale) ** 2 for c in changes if c.scale > 0)
    causes = []
    for kind, params, fit in _candidates(changes, sensor, shaded, bench):
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


def _level_text(pattern: str, a: float, *, every: bool = False) -> str:
    """The sentence of a level ``a`` of ``pattern``; ``every``: of several illuminations."""
    size = f"{100 * abs(a - 1):.1f} %"
    dimmer = "dimmer" if a < 1 else "brighter"
    if pattern == "gain":
        return (
            f"the camera's gain is {'down' if a < 1 else 'up'} by about {size} (every "
            "class's μ moved together, and σ² by the square of μ's factor, the sensor's "
            "noise with it, where more or less light would move the noise as the EMVA model "
            "says): the gain or another camera setting changed"
        )
    if pattern == "light" and every:
        return (
            f"every illumination {dimmer} by about {size} (every class's μ moved together, "
            "σ² with the light's photons as the EMVA model says, not as a gain would): the "
            "exposure time, or the lens's transmission (dust, the aperture)"
        )
    if pattern == "light":
        return (
            f"the light is {dimmer} by about {size} (every class's μ moved together, σ² "
            "with the light's photons as the EMVA model says, not as a gain would): LED "
            "output, or the exposure time"
        )
    if every:
        return (
            f"every illumination {dimmer} by about {size}, or the camera's gain "
            f"{'lower' if a < 1 else 'higher'} (every class's μ moved together): exposure, "
            "gain or the lens's transmission; this station has no camera model to tell "
            "a light from a gain"
        )
    return (
        f"the light is {dimmer} by about {size}, or the camera's "
        f"gain {'lower' if a < 1 else 'higher'} (every class's μ moved together): LED "
        "output, exposure or gain; light or gain: this station has no camera model to tell "
        "them apart"
    )


def _candidates(changes: tuple[Change, ...], sensor, shaded, bench: bool):
    """(kind, parameters, fit) of each cause that applies; ``fit()`` → (χ² left, text)."""
    by = {(c.illumination, c.name, c.quantity): c for c in changes}
    pose = [c for c in changes if c.name is None]
    means = [c for c in changes if c.quantity == "mean"]
    lights = sorted({c.illumination for c in means})
    # (illumination, class) of every class measured: σ² and spectra are each their own
    classes = sorted({(c.illumination, c.name) for c in changes if c.name is not None})
    light = "light" if sensor else "either"

    def steady(keep: Callable[[Change], bool]) -> float:
        """χ² of the changes a cause leaves where they were."""
        return sum(_chi(c, 0.0) for c in changes if keep(c))

    def level(pattern: str, among: Sequence[str]) -> tuple[float, float]:
        """χ² left by one level of ``pattern`` over the illuminations ``among`` (their
        changes only), and the level from their means alone: what a reader checks its
        size against (σ² and the focus measure follow a level only as closely as their
        models do)."""
        own = [c for c in changes if c.illumination in among]
        _, left = _best_factor(_level(own, pattern, sensor))
        a, _ = _best_factor(_level([c for c in own if c.quantity == "mean"], pattern, sensor))
        return left, a

    def others(among: Sequence[str]) -> float:
        """χ² of the illuminations a cause leaves steady."""
        return steady(lambda c: c.illumination not in among)

    def named_level(pattern: str):
        def fit():
            left, a = level(pattern, lights)
            return left + others(lights), _level_text(pattern, a, every=len(lights) > 1)

        return fit

    if means:
        for pattern in ("either",) if sensor is None else ("light", "gain"):
            kind = "light or gain" if pattern == "either" else pattern
            yield (kind if len(lights) == 1 else f"every {kind}"), 1, named_level(pattern)

    def one_light(ill: str):
        def fit():
            left, a = level(light, [ill])
            what = "LED ageing or a failing channel" if a < 1 else "LED driven harder"
            return left + others([ill]), (
                f"illumination {ill} {'dimmer' if a < 1 else 'brighter'} by about "
                f"{100 * abs(a - 1):.1f} %, the others steady: {what}"
            )

        return fit

    def each_light():
        left, moved = others(lights), []
        for ill in lights:
            own, a = level(light, [ill])
            left += own
            moved.append(f"{ill} {100 * (a - 1):+.1f} %")
        return left, (
            f"the illuminations changed by different factors ({', '.join(moved)}): their "
            "LEDs changed one by one (ageing, drive currents)"
        )

    if len(lights) > 1:
        for ill in lights:
            yield f"light {ill}", 1, one_light(ill)
        yield "lights", len(lights), each_light

    def factors(among, free_spread: Sequence[str] = ()) -> tuple[float, dict]:
        """χ² left with each class of ``among`` (illumination, class) scaled by its own
        factor (its μ spread free in ``free_spread``), the rest steady; the factors − 1."""
        chosen = set(among)
        left = steady(lambda c: (c.illumination, c.name) not in chosen)
        moved = {}
        for key in among:
            own = [c for c in changes if (c.illumination, c.name) == key]
            if key[1] in free_spread:
                own = [c for c in own if c.quantity != "spread"]
            a, r = _best_factor(_level(own, light, sensor))
            left += r
            moved[key] = a - 1
        return left, moved

    def spectrum(among: Sequence[str]):
        def fit():
            left, _ = factors([k for k in classes if k[0] in among])
            named = "; ".join(
                (f"{ill}: " if len(lights) > 1 else "")
                + ", ".join(
                    f"{c.name} {100 * c.value:+.1f} %"
                    for c in sorted(means, key=lambda c: str(c.name))
                    if c.illumination == ill
                )
                for ill in among
            )
            samples = "the samples" if bench else "the parts"
            return left, (
                f"the classes' μ moved by different factors ({named}): the light's spectrum "
                f"changed (an LED's peak: its temperature, another bin), or {samples} differ"
            )

        return fit

    for ill in lights:
        if sum(c.illumination == ill for c in means) >= 2:
            yield (
                f"spectrum {ill}" if len(lights) > 1 else "spectrum",
                sum(k[0] == ill for k in classes),
                spectrum([ill]),
            )
    if len(lights) > 1 and len(means) > len(lights):
        yield "spectra", len(classes), spectrum(lights)

    def free(quantity: str, towards: str, level: bool) -> tuple[float, list[float], float]:
        """χ² left with ``quantity`` free in each class and ``towards`` anywhere between
        0 and its change, the position steady, and μ steady or (``level``) moved by one
        factor a; the changes of ``quantity``, and a − 1."""
        left = steady(lambda c: c.name is None or c.quantity == "spread")
        a = 1.0
        if level:
            a, r = _best_factor(_level(means, light, sensor))
            left += r
        else:
            left += steady(lambda c: c.quantity == "mean")
        moved = []
        for ill, name in classes:
            own, other = by.get((ill, name, quantity)), by.get((ill, name, towards))
            if own is not None:
                moved.append(own.value)
            if other is not None:
                left += _chi(other, (0.0, own.value if own is not None else 0.0))
        return left, moved, a - 1.0

    def steady_mu(a: float) -> str:
        # A blur mixes a region's border with its neighbours': μ moves a little too
        if a == 0:
            return "at steady μ"
        if abs(a) < 5e-4:
            return "with μ nearly steady (every class within 0.05 %)"
        return f"with μ nearly steady (every class {100 * a:+.1f} %)"

    def focus(level: bool):
        def fit():
            left, moved, a = free("focus", "variance", level)
            f = float(np.median(moved)) if moved else 0.0
            if f < 0:
                return left, (
                    f"the focus measure fell by {100 * abs(f):.0f} % {steady_mu(a)}: the lens "
                    "lost focus (or a haze or dust on it)"
                )
            return left, (
                f"the focus measure rose by {100 * f:.0f} % {steady_mu(a)}: sharper parts or edges"
            )

        return fit

    def spread(level: bool):
        def fit():
            left, moved, a = free("variance", "focus", level)
            v = float(np.median(moved)) if moved else 0.0
            if bench:  # the same samples: their texture and edges, seen through the lens
                return left, (
                    f"class noise (σ²) {'up' if v > 0 else 'down'} by {100 * abs(v):.0f} % "
                    f"{steady_mu(a)}: defocus or a soiled lens (blur, haze), or other samples"
                )
            return left, (
                f"the classes' spread (σ²) {'rose' if v > 0 else 'fell'} by "
                f"{100 * abs(v):.0f} % {steady_mu(a)} and focus: the parts differ"
            )

        return fit

    for with_level in (False, True) if means else (False,):
        if any(c.quantity == "focus" for c in changes):
            yield "focus", len(classes) + with_level, focus(with_level)
        yield "parts", len(classes) + with_level, spread(with_level)

    if shaded:

        def shade():
            left, _ = factors(classes, shaded)
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


def capture_diagnosis(
    measurements: Mapping[str, Measurement], golden: Golden, *, sensor: Sensor | None
) -> Diagnosis:
    """The :func:`diagnose_changes` of a bench capture's ``measurements`` (illumination →
    measurement) against ``golden``, the same samples each time."""
    dark = sensor.dark_offset if sensor is not None else 0.0
    changes = capture_changes(measurements, golden, dark_offset=dark)
    return diagnose_changes(changes, sensor=sensor, bench=True)


def station_sensor(station: Station) -> Sensor | None:
    """The station camera's EMVA values (a
    :class:`~inspect_validate.verification.diagnosis.Sensor`) where the station has a
    scene to take them from; None for a station of frames alone (its dark level taken as
    0 DN, and a light and a gain one cause)."""
    if station.scene is None:
        return None
    from inspect_validate.station.model import station_model

    return Sensor.of(station_model(station).sensor)
