"""A golden file as ``inspect-validate train`` prints it."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

from inspect_validate.text import render_table

if TYPE_CHECKING:
    from inspect_validate.acceptance import Drift
    from inspect_validate.verification.golden import Golden

__all__ = ["format_golden"]


def format_golden(
    golden: Golden,
    *,
    share: float | None = None,
    rate: float | None = None,
    drift: Drift | None = None,
) -> str:
    """Per illumination the classes' μ (DN) and σ² (DN²), then the comparisons' SNR_dB and
    ε Gauss, each as its spread over the repeats
    (:class:`~inspect_validate.verification.golden.Golden`); with ``share`` (a drift
    check's part of the false-alarm ``rate``), the smallest change of μ and SNR_dB each
    drift check catches with 95 % probability
    (:func:`~inspect_validate.verification.golden_checks.detectable_change`; "—" for comparisons
    below ``drift.snr_floor_db``, which are not checked), what the limits promise for
    this golden file (``drift.confidence``), and, where ``drift`` gives a fixed
    ``mean_dn`` or ``snr_db``, what that tolerance catches beside them."""
    from inspect_validate.acceptance import Drift
    from inspect_validate.verification.checks import normal_equivalent, quantile
    from inspect_validate.verification.golden_checks import (
        above_floor,
        detectable_change,
        prediction_sd,
    )

    drift = drift or Drift(golden="-")
    k = normal_equivalent(rate) if rate else 3.0
    z = quantile(0.05, sided=1)

    def cells(spread, fixed, digits, checked=True):
        if share is None:
            return []
        if not checked:
            return ["—"] * (1 + (fixed is not None))
        x = detectable_change(spread, share, confidence=drift.confidence)
        out = ["—" if x != x else f"{x:.{digits}g}"]
        if fixed is not None:
            sd = prediction_sd(spread, spread.standard_error)
            out.append("—" if sd != sd else f"{fixed + z * sd:.{digits}g}")
        return out

    def head(fixed):
        if share is None:
            return []
        if fixed is None:
            return ["catches (95 %)"]
        return ["statistical would catch", "fixed catches"]

    out: list[str] = []
    rows = [
        [ill, name, c.mean.summary(), *cells(c.mean, drift.mean_dn, 3), c.variance.summary()]
        for ill, g in golden.illuminations.items()
        for name, c in g.classes.items()
    ]
    out.append(
        render_table(["illumination", "class", "μ [DN]", *head(drift.mean_dn), "σ² [DN²]"], rows)
    )
    rows = [
        [
            ill,
            label,
            c.snr_db.summary(3),
            *cells(c.snr_db, drift.snr_db, 2, above_floor(c.snr_db, drift.snr_floor_db, k=k)),
            c.error_gaussian.summary(3),
        ]
        for ill, g in golden.illuminations.items()
        for label, c in g.comparisons.items()
    ]
    out.append(
        render_table(["illumination", "comparison", "SNR_dB", *head(drift.snr_db), "ε Gauss"], rows)
    )
    if share is not None:
        out.append(_limits_text(golden.repeats, share, rate, drift))
    return "\n".join(out)


def _limits_text(n: int, share: float, rate: float | None, drift: Drift) -> str:
    """What the catches are measured against, and what the limits promise."""
    from inspect_validate.stats.tolerance_interval import tolerance_confidence
    from inspect_validate.verification.checks import (
        Coverage,
        confidence_text,
        covered_margin,
        quantile,
    )
    from inspect_validate.verification.golden_checks import (
        GOOD_WIDENING,
        repeats_needed,
        widening,
    )

    text = (
        f"catches: the smallest change of μ (DN) and SNR_dB (dB) its drift check catches "
        f"with 95 % probability, at a false-alarm rate of {100 * (rate or share):.3g} % "
        + (f"shared by the {round(rate / share)} checks verify makes " if rate else "")
        + f"({share:.2g} a check)"
    )
    if n < 2:
        return text
    w = widening(n, share)
    text += (
        f"; {n} repeats make the limits {w:.2g} × as wide as a well-known spread "
        f"would (Student's t, {n - 1} degrees of freedom)"
    )
    if w > GOOD_WIDENING:
        text += f"; {repeats_needed(share)} repeats bring it to {GOOD_WIDENING:g} ×"
    # the limits in units of the repeats' spread, captured as the training was
    predicted = quantile(share, df=n - 1) * math.sqrt(1.0 + 1.0 / n)
    text += (
        f"\nlimits: the prediction interval fails an unchanged station at most {share:.2g} "
        "a check on average over trainings; "
    )
    gamma = drift.confidence
    if gamma is None:
        achieved = tolerance_confidence(predicted, n=n, content=1.0 - share)
        text += (
            f"for this golden file it holds with confidence {confidence_text(achieved)} "
            "(drift.confidence is null: no tolerance interval)"
        )
    else:
        limit, achieved, k = covered_margin(Coverage(1.0, n, gamma), predicted, share, df=n - 1)
        if k is not None:
            text += (
                f"the tolerance interval at drift.confidence {gamma:g} widens it "
                f"{limit / predicted:.2f} × so that, with probability {gamma:g} over the "
                f"training, this golden file fails an unchanged station at most {share:.2g} "
                "a check (the catches include it)"
            )
        else:
            text += (
                f"it is wider than the tolerance interval at drift.confidence {gamma:g} and "
                f"holds for this golden file with confidence {confidence_text(achieved)}: "
                "the guarantee costs nothing here"
            )
    if drift.mean_dn is not None or drift.snr_db is not None:
        text += (
            "\nfixed catches: what the fixed tolerance of acceptance.drift catches with 95 % "
            "probability (the tolerance plus the measurement's own spread), beside what the "
            "statistical limit would catch; a change between the two passes unseen, and the "
            "fixed checks are outside the false-alarm rate"
        )
    return text
