"""The design of a mix as a versioned JSON document (schema ``inspect-validate/design`` v1)."""

from __future__ import annotations

from dataclasses import dataclass

from inspect_validate import __version__

__all__ = ["DESIGN_SCHEMA_VERSION", "DesignCheck", "design_document", "design_verification"]

DESIGN_SCHEMA_VERSION = 1


def design_document(d) -> dict:
    """Levels, the best single channel, per comparison μ/σ²/SNR/ε of both, the flatness and
    the path from the single channel to the mix."""
    p = d.problem

    def predicted(pred):
        return {
            "classes": [
                {
                    "name": name,
                    "mean": float(pred.mean[0, 0, 0, k]),
                    "variance": float(pred.variance[0, 0, 0, k]),
                    "saturated_fraction": float(pred.saturated_fraction[0, 0, 0, k]),
                }
                for k, name in enumerate(pred.classes)
            ],
            "comparisons": [
                {
                    "comparison": text,
                    "snr_db": float(pred.snr_db[0, 0, 0, j]),
                    "cnr_db": float(pred.cnr_db[0, 0, 0, j]),
                    "error_gaussian": float(pred.error_gaussian[0, 0, 0, j]),
                }
                for j, text in enumerate(p.comparisons.labels)
            ],
        }

    channel, level = d.single
    return {
        "schema": "inspect-validate/design",
        "schema_version": DESIGN_SCHEMA_VERSION,
        "tool_version": __version__,
        "source": p.source,
        "exposure_time_s": d.exposure_time,
        "exposure": "auto" if p.auto_exposure else "fixed",
        "objective": {
            **(
                {"minimise": "worst error_gaussian"}
                if d.objective == "error"
                else {"maximise": "worst cnr_db"}
            ),
            "comparisons": list(p.objective.labels),
        },
        "channels": {str(c): light.name for c, light in p.channels.items()},
        "levels": {str(c): w for c, w in d.levels.items()},
        "illumination": {"name": "design", "channels": {str(c): v for c, v in d.percent.items()}},
        "mix": predicted(d.mix),
        "best_single": {"channel": str(channel), "level": level, **predicted(d.single_prediction)},
        "drive_tolerance": d.flatness,
        "path": {
            "from": f"best single channel {channel}",
            "fraction": d.path["fraction"].tolist(),
            "comparisons": list(p.objective.labels),
            "error_gaussian": d.path["errors"].tolist(),
            "cnr": d.path["cnr"].tolist(),
        },
        "starts": d.starts,
        "choice": None
        if d.choice is None
        else {
            "channels": [str(list(p.channels)[i]) for i in d.choice.channels],
            "candidates": len(p.channels),
            "subsets_optimised": d.choice.evaluated,
            "exhaustive": d.choice.exhaustive,
            "lower_bound_error": d.choice.bound,
        },
        "skipped_work": list(p.skipped),
    }


@dataclass(frozen=True)
class DesignCheck:
    """A verified design: per objective comparison ε (or CNR_dB) predicted and measured for
    the mix and the best single channel, and whether the mix measured better."""

    illuminations: tuple
    quantity: str  # "ε" or "CNR_dB"
    rows: list
    verdict: str
    holds: bool

    @property
    def header(self) -> list[str]:
        """Column titles of :attr:`rows`."""
        return ["comparison"] + [
            f"{self.quantity} {ill} {what}"
            for ill in self.illuminations
            for what in ("predicted", "measured")
        ]


def design_verification(verification, objective, *, kind: str = "error") -> DesignCheck:
    """Summarise a :class:`~inspect_validate.verification.verify.Verification` of a
    :func:`~inspect_validate.mix_design.station.design_station` over the ``objective`` comparisons
    (labels): the worst ε (``kind="error"``) or CNR (``"cnr"``) of the mix against the single
    channel's, predicted and measured."""
    from inspect_validate.mix_design.station import DESIGN_ILLUMINATION

    by = {(r["illumination"], r["comparison"]): r for r in verification.comparisons}
    ills = tuple(dict.fromkeys(r["illumination"] for r in verification.comparisons))
    field, quantity, fmt = (
        ("error_gaussian", "ε", "{:.3g}") if kind == "error" else ("cnr_db", "CNR_dB", "{:.2f}")
    )
    rows = [
        [label]
        + [
            fmt.format(by[ill, label][what][field])
            for ill in ills
            for what in ("predicted", "measured")
        ]
        for label in objective
    ]

    def worst(ill, what):
        values = [by[ill, label][what][field] for label in objective]
        return max(values) if kind == "error" else min(values)

    mix = worst(DESIGN_ILLUMINATION, "measured")
    if len(ills) == 1:
        return DesignCheck(
            ills, quantity, rows, f"measured worst {quantity} of the mix: {fmt.format(mix)}", True
        )
    single = ills[1]
    if kind == "error":
        holds = mix < worst(single, "measured")
        ratio = worst(single, "measured") / max(mix, 1e-300)
        predicted = worst(single, "predicted") / max(
            worst(DESIGN_ILLUMINATION, "predicted"), 1e-300
        )
        gain = f"{ratio:.3g}× lower; predicted {predicted:.3g}×"
    else:
        holds = mix > worst(single, "measured")
        predicted = worst(DESIGN_ILLUMINATION, "predicted") - worst(single, "predicted")
        gain = f"{mix - worst(single, 'measured'):+.2f} dB; predicted {predicted:+.2f} dB"
    verdict = (
        f"measured worst {quantity}: mix {fmt.format(mix)}, {single} "
        f"{fmt.format(worst(single, 'measured'))} ({gain})"
    )
    if not holds:
        verdict += f": FAIL, the mix does not measure better than {single}"
    return DesignCheck(ills, quantity, rows, verdict, holds)
