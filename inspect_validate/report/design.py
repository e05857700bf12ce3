"""The design of a mix as a versioned JSON document (schema ``inspect-validate/design`` v1)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

from inspect_validate import __version__

if TYPE_CHECKING:
    from inspect_validate.mix_design.solve import Design
    from inspect_validate.verification.results import Verification

__all__ = [
    "DESIGN_SCHEMA_VERSION",
    "DesignCheck",
    "design_document",
    "design_verification",
    "format_design",
]

DESIGN_SCHEMA_VERSION = 1


def design_document(d: Design) -> dict:
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


def design_verification(
    verification: Verification, objective: str, *, kind: str = "error"
) -> DesignCheck:
    """Summarise a :class:`~inspect_validate.verification.results.Verification` of a
    :func:`~inspect_validate.mix_design.station.design_station` over the ``objective`` comparisons
    (labels): the worst ε (``kind="error"``) or CNR (``"cnr"``) of the mix against the single
    channel's, predicted and measured."""
    from inspect_validate.mix_design.station import DESIGN_ILLUMINATION

    by = {(r.illumination, r.comparison): r for r in verification.comparisons}
    ills = tuple(dict.fromkeys(r.illumination for r in verification.comparisons))
    field, quantity, fmt = (
        ("error_gaussian", "ε", "{:.3g}") if kind == "error" else ("cnr_db", "CNR_dB", "{:.2f}")
    )
    rows = [
        [label]
        + [
            fmt.format(getattr(getattr(by[ill, label], what), field))
            for ill in ills
            for what in ("predicted", "measured")
        ]
        for label in objective
    ]

    def worst(ill, what):
        values = [getattr(getattr(by[ill, label], what), field) for label in objective]
        return max(values) if kind == "error" else min(values)

    if DESIGN_ILLUMINATION not in ills:  # its light never reached the camera: a failed check
        return DesignCheck(
            ills, quantity, rows, "FAIL: the mix was not measured (see its light check)", False
        )
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


def format_design(result: Design, *, source: str) -> str:
    """What ``inspect-validate design`` prints of a :class:`~inspect_validate.mix_design.solve.Design`:
    the mix, the choice of channels, the best single channel, ε and SNR_dB (or CNR_dB) of
    each comparison for both, the drive tolerance and the station file's entry.
    ``source`` names the station or scene file in the first line."""
    from inspect_validate.mix_design.solve import decibel, drive_percent
    from inspect_validate.text import render_table

    problem, objective = result.problem, result.objective
    out: list[str] = []
    names = {c: light.name for c, light in problem.channels.items()}
    goal = "minimising the worst ε Gauss" if objective == "error" else "maximising the worst CNR"
    exposure = f"{1e3 * result.exposure_time:.4g} ms" + (
        " (designed)" if problem.auto_exposure else ""
    )
    out.append(
        f"{source}: {len(names)} channels, exposure {exposure}, {goal} of "
        f"{', '.join(problem.objective.labels)} ({result.starts} starts)"
    )
    out.append(
        "designed mix: "
        + ", ".join(f"channel {c} ({names[c]}) {p:g} %" for c, p in result.percent.items())
    )
    if result.choice is not None:
        c = result.choice
        bound = f"ε {c.bound:.3g}" if objective == "error" else f"CNR {decibel(c.bound):.2f} dB"
        how = (
            "every subset optimised"
            if c.exhaustive
            else f"local search; no choice can beat all {len(names)} mixed, worst {bound}"
        )
        out.append(
            f"chose {len(c.channels)} of {len(names)} channels ({c.evaluated} subsets, {how})"
        )
    ch, level = result.single
    out.append(f"best single channel: {ch} ({names[ch]}) at {drive_percent(level):g} %")
    mix, single = result.mix, result.single_prediction
    ratio = "snr_db" if objective == "error" else "cnr_db"  # the chapter's SNR, or the objective
    rows = [
        [
            text,
            f"{mix.error_gaussian[0, 0, 0, j]:.3g}",
            f"{single.error_gaussian[0, 0, 0, j]:.3g}",
            f"{getattr(mix, ratio)[0, 0, 0, j]:.2f}",
            f"{getattr(single, ratio)[0, 0, 0, j]:.2f}",
        ]
        for j, text in enumerate(problem.comparisons.labels)
    ]
    name = "SNR_dB" if objective == "error" else "CNR_dB"
    out.append(
        render_table(["comparison", "ε mix", "ε single", f"{name} mix", f"{name} single"], rows)
    )
    if objective == "error":
        worst = max(result.flatness, key=lambda f: f["worst_error"])
        value = f"the worst ε is at most {worst['worst_error']:.3g}"
    else:
        worst = min(result.flatness, key=lambda f: f["worst_cnr_db"])
        value = f"the worst CNR is at least {worst['worst_cnr_db']:.2f} dB"
    out.append(
        f"drive tolerance: with one level off by ±10 % {value} "
        f"(channel {worst['channel']} {100 * worst['change']:+.0f} %)"
        + ("; +10 % on a level saturates" if any(f["saturates"] for f in result.flatness) else "")
    )
    entry = ", ".join(f"{c}: {p:g}" for c, p in result.percent.items())
    out.append(f"station entry:\n  - {{name: design, channels: {{{entry}}}}}")
    if problem.auto_exposure:
        out.append(f"  with camera.exposure_us: {1e6 * result.exposure_time:.6g}")
        top = max(result.levels.values())
        if top < 1.0:  # the single channel set the exposure; the mix alone needs less
            alone = ", ".join(
                f"{c}: {drive_percent(w / top):g}"
                for c, w in result.levels.items()
                if c in result.percent
            )
            out.append(
                f"  (the mix alone, faster: channels {{{alone}}} at camera.exposure_us "
                f"{1e6 * result.exposure_time * top:.6g})"
            )
    return "\n".join(out)
