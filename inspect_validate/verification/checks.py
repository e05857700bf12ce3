"""One acceptance check: what was measured, its limit and unit, how the limit was set, and
the verdict.

A verification is a family of tests of one station. Each check has a *basis*:

``statistical``
    The limit comes from the verification's family-wise false-alarm rate and from what
    was measured: a prediction interval around the golden statistics (drift), or a margin
    for what these frames can resolve (ranking). A station that has not changed fails
    such a check with at most the check's share of the rate.
``tolerance``
    A limit the acceptance section gives (a model tolerance, a separation requirement,
    the gain's), widened by the value's own standard error at the check's share of the
    rate: a station exactly at the limit fails at most that often; one inside it less.
``fixed``
    A limit taken as it is: counts in these frames (saturated pixels), or a tolerance the
    user gave where none of the value's uncertainty is known or wanted (drift
    ``mean_dn``). Not part of the false-alarm rate.

:func:`decide` shares the rate among the statistical and tolerance checks that ran
(Bonferroni: each gets rate / m, so that the family's rate is at most the rate whatever
the checks' correlation) and sets every limit.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING, Any, Literal

if TYPE_CHECKING:
    from collections.abc import Iterable


__all__ = [
    "DEFAULT_FALSE_ALARM",
    "KINDS",
    "Basis",
    "Check",
    "Coverage",
    "at_least",
    "at_most",
    "confidence_text",
    "count_tests",
    "covered_margin",
    "decide",
    "normal_equivalent",
    "not_run",
    "quantile",
    "rate_of_k",
]

Basis = Literal["statistical", "tolerance", "fixed"]
Relation = Literal["≥", "≤"]

DEFAULT_FALSE_ALARM = 0.0027
"""The family-wise false-alarm rate of a verification unless the acceptance sets one:
0.27 %, the two-sided 3σ convention of control charts."""


def rate_of_k(k: float) -> float:
    """The two-sided false-alarm rate of a normal-equivalent k σ limit: 2 (1 − Φ(k))
    (k = 3: 0.27 %)."""
    return math.erfc(k / math.sqrt(2.0))


def normal_equivalent(rate: float) -> float:
    """The k of :func:`rate_of_k`: the two-sided normal quantile of ``rate``."""
    return quantile(rate)


def quantile(rate: float, *, df: float = math.inf, sided: int = 2) -> float:
    """The multiplier of a standard error that a value exceeds with probability ``rate``
    when nothing changed: the normal quantile, or Student's t with ``df`` degrees of
    freedom (a spread estimated from df + 1 repeats); ``sided`` 2 for |deviation|."""
    from inspect_validate.stats.quantiles import student_quantile

    return student_quantile(rate / sided, df)


@dataclass(frozen=True)
class Coverage:
    """What a tolerance interval needs to hold for the one golden file a check is made
    against (:mod:`inspect_validate.stats.tolerance_interval`).

    Attributes
    ----------
    spread : float
        The standard deviation of one new value of an unchanged station about the
        true reference, in the check's unit, estimated with the check's ``df``.
    n : float
        How many such values the reference (the golden mean) is the mean of.
    confidence : float
        The probability γ, over the training, that this golden file's limit fails an
        unchanged station at most the check's share of the false-alarm rate.
    """

    spread: float
    n: float
    confidence: float


KINDS: dict[str, str] = {
    "light": "the light reaches the camera (lit above dark)",
    "separation": "a comparison separates as the station asks (SNR_dB, ε)",
    "saturation": "a class's pixels saturated or at zero",
    "agreement": "measured against predicted (μ, SNR_dB)",
    "ranking": "the illuminations rank as predicted",
    "gain": "the camera's measured gain against its model",
    "drift": "drift from the golden statistics (bench or line)",
    "settings": "the camera's settings since training",
    "health": "what the camera and its transport reported",
    "sharpness": "the lens's MTF50 against its f-number's, or since it was measured",
    "production": "the running line's own checks (parts measured, located)",
    "cameras": "several cameras' rounds (the trigger's skew)",
}
"""Every kind of check, and what it is about: the reports group by it, and a check of
another kind is refused where it is made."""


@dataclass(frozen=True)
class Check:
    """A check of the ``acceptance:`` section.

    Attributes
    ----------
    name : str
        What is checked, e.g. ``"amber: A vs B,C SNR_dB"``.
    kind : str
        One of :data:`~inspect_validate.verification.checks.KINDS` (``light``,
        ``separation``, ``saturation``, ``agreement``, ``ranking``, ``gain``, ``drift``,
        ``settings``, ``health``, ``sharpness``, ``production``, ``cameras``).
    value, limit : float
        The measured value and the limit it was held to (1.0/0.0 for yes/no checks), in
        ``unit``; for statistical and tolerance checks the limit includes the margin.
    unit : str
        ``dB``, ``%``, ``DN``, ``DN/e⁻`` or ``""``.
    relation : str
        ``"≥"`` or ``"≤"``: how ``value`` must stand to ``limit``.
    passed : bool
        False for a failure and for a check that could not run; True for a pass and for a
        check too close to call (:attr:`undecided`).
    detail : str
        Context for a reader (predicted value, spread, why a value is missing).
    basis : {"statistical", "tolerance", "fixed"}
        How the limit was set (module description).
    given : float or None
        The limit before any margin: the acceptance's (tolerance, fixed), 0 for a
        statistical check centred on its reference.
    standard_error : float or None
        The standard deviation the margin is a multiple of, in ``unit``: the value's own
        standard error (tolerance), or the prediction interval's (statistical).
    df : float
        Degrees of freedom of ``standard_error`` (inf: known; n − 1 from n repeats).
    sided : int
        2 where the value is an absolute deviation (either direction counts), else 1.
    false_alarm : float or None
        This check's share of the family-wise rate (statistical and tolerance checks).
    undecided : bool
        The question is too close to call from these frames (a ranking of two
        illuminations predicted nearly equal): neither a pass nor a failure, and it does
        not fail the verification.
    predicted_gap : float or None
        For a ranking: how far apart the prediction puts the two in question; below what
        the frames resolve (the margin), the check is too close to call.
    coverage : Coverage or None
        For a drift check against a golden file: what its tolerance interval needs. The
        limit is then the wider of the prediction interval (averaged over trainings, an
        unchanged station fails at most the share) and the tolerance interval (for
        this golden file, with probability ``coverage.confidence``).
    confidence : float or None
        Set by ``decide`` for a check with ``coverage``: the probability over the
        training that the limit set fails an unchanged station at most the check's share
        (at least ``coverage.confidence``; more where the prediction interval is wider).
    illumination, subject, quantity : str or None
        The check's identity, what its name says for a reader: the illumination (None
        for a check of the whole capture), what is checked under it (a class, a
        comparison's label, a camera, the lens) and the quantity (``mean``, ``variance``,
        ``snr_db``, ``mtf50``, a health quantity…). Code reads these, never the name.
    """

    name: str
    kind: str
    value: float
    limit: float
    unit: str
    relation: str
    passed: bool
    detail: str = ""
    basis: Basis = "fixed"
    given: float | None = None
    standard_error: float | None = None
    df: float = math.inf
    sided: int = 1
    false_alarm: float | None = None
    undecided: bool = False
    predicted_gap: float | None = None
    coverage: Coverage | None = None
    confidence: float | None = None
    illumination: str | None = None
    subject: str | None = None
    quantity: str | None = None

    def __post_init__(self) -> None:
        if self.kind not in KINDS:
            raise ValueError(f"check {self.name!r}: kind {self.kind!r} is none of KINDS")

    @property
    def ran(self) -> bool:
        """False for a check that could not be evaluated (no value): not a pass."""
        return math.isfinite(self.value)

    @property
    def margin(self) -> float:
        """How far the limit lies beyond the given one (0 for fixed checks)."""
        if self.given is None or not math.isfinite(self.limit):
            return 0.0
        return abs(self.limit - self.given)

    @property
    def verdict(self) -> str:
        if self.undecided:
            return "TOO CLOSE"
        return "pass" if self.passed else ("FAIL" if self.ran else "NOT RUN")


def _holds(value: float, limit: float, relation: str) -> bool:
    return math.isfinite(value) and (value >= limit if relation == "≥" else value <= limit)


def _check(
    name,
    kind,
    value,
    limit,
    unit,
    relation,
    detail,
    *,
    basis: Basis = "fixed",
    standard_error: float | None = None,
    df: float = math.inf,
    sided: int = 1,
    predicted_gap: float | None = None,
    coverage: Coverage | None = None,
    illumination: str | None = None,
    subject: str | None = None,
    quantity: str | None = None,
):
    value = math.nan if value is None else float(value)  # not computed: said so below
    if not math.isfinite(value) and not detail:
        detail = "no value: the quantity could not be computed from these frames"
    se = None if standard_error is None else float(standard_error)
    return Check(
        name,
        kind,
        value,
        float(limit),
        unit,
        relation,
        _holds(value, float(limit), relation),
        detail,
        basis=basis,
        given=float(limit),
        standard_error=se,
        df=float(df),
        sided=sided,
        predicted_gap=predicted_gap,
        coverage=coverage,
        illumination=illumination,
        subject=subject,
        quantity=quantity,
    )


def not_run(
    name: str,
    kind: str,
    limit: float,
    unit: str,
    relation: str,
    why: str,
    *,
    illumination: str | None = None,
    subject: str | None = None,
    quantity: str | None = None,
) -> Check:
    """A check the acceptance section asks for that these frames cannot evaluate: it
    fails, saying why (a check asked for is never passed by not being done); its identity
    as :class:`Check`'s."""
    return Check(
        name, kind, math.nan, float(limit), unit, relation, False, f"could not run: {why}",
        illumination=illumination, subject=subject, quantity=quantity,
    )  # fmt: skip


def at_least(
    name: str,
    kind: str,
    value: float | None,
    limit: float,
    unit: str = "",
    detail: str = "",
    **options: Any,
) -> Check:
    """Passes when ``value ≥ limit`` (less the margin :func:`decide` sets; a NaN value
    fails). ``options``: ``basis`` (default ``"fixed"``), ``standard_error``, ``df``,
    ``sided``, ``predicted_gap``, ``coverage`` and the identity ``illumination``,
    ``subject``, ``quantity`` (:class:`Check`)."""
    return _check(name, kind, value, limit, unit, "≥", detail, **options)


def at_most(
    name: str,
    kind: str,
    value: float | None,
    limit: float,
    unit: str = "",
    detail: str = "",
    **options: Any,
) -> Check:
    """Passes when ``value ≤ limit`` (plus the margin :func:`decide` sets; a NaN value
    fails). ``options`` as in :func:`at_least`."""
    return _check(name, kind, value, limit, unit, "≤", detail, **options)


def _tested(c: Check) -> bool:
    """A check that spends part of the false-alarm rate: statistical or tolerance, with a
    value and a standard error."""
    return (
        c.basis != "fixed"
        and c.ran
        and c.standard_error is not None
        and math.isfinite(c.standard_error)
    )


def count_tests(checks: Iterable[Check]) -> int:
    """How many of ``checks`` share the false-alarm rate (:func:`decide`)."""
    return sum(_tested(c) for c in checks)


def decide(checks: Iterable[Check], rate: float) -> tuple[Check, ...]:
    """Set every check's limit and verdict at the family-wise false-alarm ``rate``.

    The statistical and tolerance checks that ran share ``rate`` equally
    (Bonferroni); each moves its given limit outward by its quantile (Student's t with
    its ``df``, one- or two-sided) times its standard error. A statistical check without
    a standard error could not set its limit and does not run; a tolerance check
    without one is held to its given limit. A ranking whose predicted gap is within the
    margin is too close to call (:attr:`Check.undecided`).
    """
    checks = list(checks)
    m = count_tests(checks)
    share = rate / m if m else rate
    out = []
    for c in checks:
        if not _tested(c):
            if c.basis == "statistical" and c.ran:
                out.append(
                    replace(
                        c,
                        value=math.nan,
                        passed=False,
                        detail=f"could not run: no spread to set its limit from; {c.detail}",
                    )
                )
            else:
                out.append(c)
            continue
        se = c.standard_error or 0.0  # tested: it has one
        margin = quantile(share, df=c.df, sided=c.sided) * se
        detail = c.detail
        confidence = None
        if c.coverage is not None and c.coverage.spread > 0:
            margin, confidence, why = _covered(c, margin, share)
            detail = f"{detail}; {why}"
        given = c.limit if c.given is None else c.given  # a check made with its limit
        limit = given + margin if c.relation == "≤" else given - margin
        gap = c.predicted_gap
        undecided = gap is not None and abs(gap) < margin
        if gap is not None and undecided:
            detail = (
                f"too close to call: predicted {abs(gap):.2g} {c.unit} apart, "
                f"these frames resolve {margin:.2g} {c.unit}; {detail}"
            )
        out.append(
            replace(
                c,
                limit=limit,
                passed=undecided or _holds(c.value, limit, c.relation),
                detail=detail,
                false_alarm=share,
                undecided=undecided,
                confidence=confidence,
            )
        )
    return tuple(out)


def covered_margin(
    coverage: Coverage, margin: float, share: float, *, df: float
) -> tuple[float, float, float | None]:
    """The wider of a prediction interval's ``margin`` and the tolerance interval
    ``coverage`` sets at the false-alarm ``share`` (its spread estimated with ``df``
    degrees of freedom), and the confidence that limit holds the share with for this
    golden file: ``(margin, confidence, k)``, k the tolerance factor where the tolerance
    interval is the wider, else None."""
    from inspect_validate.stats.tolerance_interval import tolerance_confidence, tolerance_factor

    n, content = coverage.n, 1.0 - share
    k = tolerance_factor(n=n, content=content, confidence=coverage.confidence, df=df)
    if k * coverage.spread > margin:
        return k * coverage.spread, coverage.confidence, k
    return margin, tolerance_confidence(margin / coverage.spread, n=n, content=content, df=df), None


def _covered(c: Check, margin: float, share: float) -> tuple[float, float, str]:
    """The margin of a check with a coverage (:func:`decide`), the confidence it gives,
    and which interval set it."""
    cov = c.coverage
    assert cov is not None
    margin, confidence, k = covered_margin(cov, margin, share, df=c.df)
    if k is not None:
        return (
            margin,
            confidence,
            f"limit from the tolerance interval, k {k:.3g} × {cov.spread:.2g} {c.unit}: "
            f"holds for this golden file with confidence {cov.confidence:g}",
        )
    return (
        margin,
        confidence,
        f"holds for this golden file with confidence {confidence_text(confidence)}",
    )


def confidence_text(x: float) -> str:
    """A confidence near 1 with the digits that tell it from 1 (0.9992, not 1)."""
    if x >= 1.0:
        return "1"
    digits = max(2, -math.floor(math.log10(1.0 - x)))
    return f"{math.floor(x * 10**digits) / 10**digits:.{digits}f}"
