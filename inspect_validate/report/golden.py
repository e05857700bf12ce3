"""A golden file as ``inspect-validate train`` prints it."""

from __future__ import annotations

from inspect_validate.report.tables import render_table

__all__ = ["format_golden"]


def format_golden(golden) -> str:
    """Per illumination the classes' μ (DN) and σ² (DN²), then the comparisons' SNR_dB and
    ε Gauss, each as its spread over the repeats
    (:class:`~inspect_validate.verification.golden.Golden`)."""
    out: list[str] = []
    rows = [
        [
            ill,
            name,
            c.mean.summary(),
            c.variance.summary(),
        ]
        for ill, g in golden.illuminations.items()
        for name, c in g.classes.items()
    ]
    out.append(render_table(["illumination", "class", "μ [DN]", "σ² [DN²]"], rows))
    rows = [
        [
            ill,
            label,
            c.snr_db.summary(3),
            c.error_gaussian.summary(3),
        ]
        for ill, g in golden.illuminations.items()
        for label, c in g.comparisons.items()
    ]
    out.append(render_table(["illumination", "comparison", "SNR_dB", "ε Gauss"], rows))
    return "\n".join(out)
