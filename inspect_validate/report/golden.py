"""A golden file as ``inspect-validate train`` prints it."""

from __future__ import annotations

from typing import TYPE_CHECKING

from inspect_validate.text import render_table

if TYPE_CHECKING:
    from inspect_validate.verification.golden import Golden

__all__ = ["format_golden"]


def format_golden(
    golden: Golden,
    *,
    share: float | None = None,
    rate: float | None = None,
    snr_floor_db: float = -20.0,
) -> str:
    """Per illumination the classes' μ (DN) and σ² (DN²), then the comparisons' SNR_dB and
    ε Gauss, each as its spread over the repeats
    (:class:`~inspect_validate.verification.golden.Golden`); with ``share`` (a drift
    check's part of the false-alarm ``rate``), the smallest change of μ and SNR_dB each
    drift check catches with 95 % probability
    (:func:`~inspect_validate.verification.golden_checks.detectable_change`; "—" for comparisons
    below ``snr_floor_db``, which are not checked)."""
    from inspect_validate.verification.golden_checks import (
        GOOD_WIDENING,
        detectable_change,
        repeats_needed,
        widening,
    )

    def caught(spread, digits):
        if share is None:
            return []
        if digits == 2 and spread is not None and not spread.mean >= snr_floor_db:
            return ["—"]
        x = detectable_change(spread, share)
        return ["—" if x != x else f"{x:.{digits}g}"]

    caught_head = ["catches (95 %)"] if share is not None else []
    out: list[str] = []
    rows = [
        [ill, name, c.mean.summary(), *caught(c.mean, 3), c.variance.summary()]
        for ill, g in golden.illuminations.items()
        for name, c in g.classes.items()
    ]
    out.append(render_table(["illumination", "class", "μ [DN]", *caught_head, "σ² [DN²]"], rows))
    rows = [
        [ill, label, c.snr_db.summary(3), *caught(c.snr_db, 2), c.error_gaussian.summary(3)]
        for ill, g in golden.illuminations.items()
        for label, c in g.comparisons.items()
    ]
    out.append(
        render_table(["illumination", "comparison", "SNR_dB", *caught_head, "ε Gauss"], rows)
    )
    if share is not None:
        n = golden.repeats
        w = widening(n, share)
        text = (
            f"catches: the smallest change of μ (DN) and SNR_dB (dB) its drift check catches "
            f"with 95 % probability, at a false-alarm rate of {100 * (rate or share):.3g} % "
            + (f"shared by the {round(rate / share)} checks verify makes " if rate else "")
            + f"({share:.2g} a check)"
        )
        if n >= 2:
            text += (
                f"; {n} repeats make the limits {w:.2g} × as wide as a well-known spread "
                f"would (Student's t, {n - 1} degrees of freedom)"
            )
            if w > GOOD_WIDENING:
                text += f"; {repeats_needed(share)} repeats bring it to {GOOD_WIDENING:g} ×"
        out.append(text)
    return "\n".join(out)
