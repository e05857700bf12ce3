"""The checks a station's ``acceptance:`` section asks for, made from a verification's
rows, each with its basis and standard error (:func:`~.checks.decide` sets their limits
at the false-alarm rate)."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from inspect_validate.verification.checks import Check, at_least, at_most, not_run
from inspect_validate.verification.results import RankingAgreement
from inspect_validate.verification.uncertainty import combined_standard_errors

if TYPE_CHECKING:
    from collections.abc import Collection, Mapping, Sequence

    from inspect_validate.acceptance import Acceptance
    from inspect_validate.measurement import Measurement
    from inspect_validate.verification.calibration import Gain
    from inspect_validate.verification.results import (
        ClassAgreement,
        ComparisonAgreement,
        RankingAgreement,
    )
    from inspect_validate.verification.uncertainty import StandardErrors

__all__ = ["acceptance_checks"]


def _ranking_check(ranking: RankingAgreement, errors, j: int) -> Check:
    """Whether the predicted best illumination measures best, as a statistical check.

    Each illumination's "badness" is its measured log₁₀ ε (or −SNR_dB, −CNR_dB). The
    value is how far the predicted best measures behind the measured best (0 where it
    measures best); it may do so by up to what these frames resolve: the margin,
    a multiple of the standard error of the difference. When the prediction itself puts
    the two in question (the predicted best and the measured best, or the predicted
    runner-up where they agree) closer than the margin, the check is too close to call.
    """
    sign = 1.0 if ranking.by == "log_error_gaussian" else -1.0
    unit, quantity, field = _RANKED[ranking.by]
    names = list(ranking.measured)
    bad_m = {n: sign * ranking.measured[n] for n in names}
    bad_p = {n: sign * ranking.predicted[n] for n in names}
    se = {n: float(getattr(errors[n], field)[j]) for n in names}
    best_p, best_m = ranking.predicted_best, ranking.measured_best
    other = best_m
    if other == best_p:  # they agree: the question is the predicted runner-up
        other = min((n for n in names if n != best_p), key=lambda n: bad_p[n])
    behind = bad_m[best_p] - bad_m[best_m]
    return at_most(
        f"ranking by {ranking.comparison}: predicted best {best_p} measures best",
        "ranking",
        behind,
        0.0,
        unit,
        f"measured best {best_m}; {quantity} measured "
        + ", ".join(f"{n} {ranking.measured[n]:.3g}" for n in names)
        + ", predicted "
        + ", ".join(f"{n} {ranking.predicted[n]:.3g}" for n in names)
        + f"; predicted gap to {other} {bad_p[other] - bad_p[best_p]:.2g} {unit}; "
        + ranking.tau_text,
        basis="statistical",
        standard_error=float(np.hypot(se[best_p], se[other])),
        predicted_gap=bad_p[other] - bad_p[best_p],
        subject=ranking.comparison,
        quantity=ranking.by,
    )


_RANKED = {  # by → unit, what it is, the StandardErrors field
    "log_error_gaussian": ("decades", "log₁₀ ε", "log_error"),
    "snr_db": ("dB", "SNR_dB", "snr_db"),
    "cnr_db": ("dB", "CNR_dB", "cnr_db"),
}


def acceptance_checks(
    acc: Acceptance,
    measurements: dict[str, Measurement],
    class_rows: Sequence[ClassAgreement],
    comparison_rows: Sequence[ComparisonAgreement],
    ranking: RankingAgreement | None,
    gain: Gain | None,
    gain_missing: str | None = None,
    errors: dict[str, StandardErrors] | None = None,
    *,
    unlit: Mapping[str, str] | None = None,
    agreed: Collection[tuple[str, str]] | None = None,
    model_errors: Mapping[str, StandardErrors] | None = None,
) -> tuple[list[Check], list[str]]:
    """The checks ``acc`` asks for, and the work left out (a skip: only what nobody asked
    for). A check that cannot be evaluated is :func:`not_run`, a failure that says why —
    never a skip. ``errors`` is illumination → the measurement's
    :class:`~.uncertainty.StandardErrors`: the tolerance checks' margins
    (:func:`~.checks.decide` sets them). ``unlit`` is illumination → what was measured,
    for those whose light does not reach the camera: left out of ``measurements``, their
    separation checks do not run. ``agreed`` holds the (illumination, comparison) pairs
    whose SNR_dB agreement is checked, decided from the prediction before any frame
    (:meth:`~.plan.Plan.agreed`); default: those predicted at or above the floor.
    ``model_errors`` is illumination → the prediction's own :class:`~.uncertainty.
    StandardErrors` (its reflectance samples), added in quadrature to the measurement's
    in the agreement checks (``agreement.parts: other``)."""
    errors = {} if errors is None else errors
    unlit = unlit or {}
    checks, skipped = [], []
    targets = [acc.illumination] if acc.illumination else [*measurements, *unlit]
    for sep in acc.separation:
        for ill in targets:
            if ill in unlit:
                checks += [
                    not_run(
                        f"{ill}: {sep.comparison} {what}",
                        "separation",
                        limit,
                        unit,
                        rel,
                        f"no light reaches the camera ({unlit[ill]})",
                        illumination=ill,
                        subject=sep.comparison,
                        quantity=quantity,
                    )
                    for what, quantity, limit, unit, rel in (
                        ("SNR_dB", "snr_db", sep.min_snr_db, "dB", "≥"),
                        ("CNR_dB", "cnr_db", sep.min_cnr_db, "dB", "≥"),
                        ("ε Gauss", "error_gaussian", sep.max_error, "", "≤"),
                        ("ε KDE", "error_kde", sep.max_error_kde, "", "≤"),
                    )
                    if limit is not None
                ]
                continue
            m = measurements[ill]
            j = m.comparisons.index(m.comparison(sep.comparison))
            comp, se = m.comparisons[j], errors[ill]
            where = f"{ill}: {comp.label}"
            tolerance: dict = {"basis": "tolerance", "illumination": ill, "subject": comp.label}
            if sep.min_snr_db is not None:
                checks.append(
                    at_least(
                        f"{where} SNR_dB",
                        "separation",
                        comp.snr_db,
                        sep.min_snr_db,
                        "dB",
                        standard_error=se.snr_db[j],
                        quantity="snr_db",
                        **tolerance,
                    )
                )
            if sep.min_cnr_db is not None:
                checks.append(
                    at_least(
                        f"{where} CNR_dB",
                        "separation",
                        comp.cnr_db,
                        sep.min_cnr_db,
                        "dB",
                        standard_error=se.cnr_db[j],
                        quantity="cnr_db",
                        **tolerance,
                    )
                )
            if sep.max_error is not None:
                # SE(ε) = ε ln 10 SE(log₁₀ ε)
                checks.append(
                    at_most(
                        f"{where} ε Gauss",
                        "separation",
                        comp.error_gaussian,
                        sep.max_error,
                        standard_error=comp.error_gaussian * np.log(10.0) * se.log_error[j],
                        quantity="error_gaussian",
                        **tolerance,
                    )
                )
            if sep.max_error_kde is not None:
                checks.append(
                    at_most(
                        f"{where} ε KDE",
                        "separation",
                        comp.error_kde,
                        sep.max_error_kde,
                        detail="fixed limit: ε KDE has no standard error here",
                        illumination=ill,
                        subject=comp.label,
                        quantity="error_kde",
                    )
                )
    for ill, m in measurements.items():
        for c in m.classes:
            for what, frac, limit in (
                ("saturated", c.saturated_fraction, acc.max_saturated),
                ("zero", c.zero_fraction, acc.max_zero),
            ):
                if limit is not None:
                    checks.append(
                        at_most(
                            f"{ill}: {c.name} {what}",
                            "saturation",
                            100 * frac,
                            100 * limit,
                            "%",
                            illumination=ill,
                            subject=c.name,
                            quantity=f"{what}_fraction",
                        )
                    )
    agree = acc.agreement
    if agree is not None:
        model_errors = model_errors or {}
        agreeing = {  # the prediction's own uncertainty beside the measurement's
            ill: combined_standard_errors(e, model_errors[ill]) if ill in model_errors else e
            for ill, e in errors.items()
        }
        class_index = {
            (ill, c.name): k for ill, m in measurements.items() for k, c in enumerate(m.classes)
        }
        for class_row in class_rows:
            where = f"{class_row.illumination}: {class_row.class_name}"
            pred = class_row.predicted
            k = class_index[class_row.illumination, class_row.class_name]
            se = agreeing[class_row.illumination]
            if agree.mean_relative is not None:
                signal = pred.mean - class_row.measured.dark_mean
                checks.append(
                    at_most(
                        f"{where} μ deviation",
                        "agreement",
                        100 * abs(class_row.mean_relative),
                        100 * agree.mean_relative,
                        "%",
                        f"predicted {pred.mean:.4g} DN, measured {class_row.measured.mean:.4g} DN",
                        basis="tolerance",
                        standard_error=100 * se.mean[k] / signal if signal > 0 else np.nan,
                        illumination=class_row.illumination,
                        subject=class_row.class_name,
                        quantity="mean",
                    )
                )
            if agree.variance_relative is not None:
                checks.append(
                    at_most(
                        f"{where} σ² deviation",
                        "agreement",
                        100 * abs(class_row.variance_relative),
                        100 * agree.variance_relative,
                        "%",
                        f"predicted {pred.variance:.4g} DN², "
                        f"measured {class_row.measured.variance:.4g} DN²",
                        basis="tolerance",
                        standard_error=100 * se.variance[k] / pred.variance
                        if pred.variance > 0
                        else np.nan,
                        illumination=class_row.illumination,
                        subject=class_row.class_name,
                        quantity="variance",
                    )
                )
        if agree.snr_db is not None:
            if agreed is None:
                agreed = {
                    (r.illumination, r.comparison)
                    for r in comparison_rows
                    if r.predicted.snr_db >= agree.snr_floor_db
                }
            left = [r for r in comparison_rows if (r.illumination, r.comparison) not in agreed]
            below = [
                f"{r.illumination}: {r.comparison}"
                for r in left
                if not r.predicted.snr_db >= agree.snr_floor_db
            ]
            near = [
                f"{r.illumination}: {r.comparison} ({r.predicted.snr_db:.1f} dB)"
                for r in left
                if r.predicted.snr_db >= agree.snr_floor_db
            ]
            if below:
                skipped.append(
                    f"SNR_dB agreement of {', '.join(below)}: predicted below "
                    f"agreement.snr_floor_db ({agree.snr_floor_db:g} dB), in every "
                    "verification of this station"
                )
            if near:
                skipped.append(
                    f"SNR_dB agreement of {', '.join(near)}: predicted above "
                    f"agreement.snr_floor_db ({agree.snr_floor_db:g} dB) by less than the "
                    "false-alarm rate's k of the model's own standard errors (its reflectance "
                    "samples), so parts that are another draw of their classes fall either "
                    "side of the floor; in every verification of this station"
                )
            index = {
                (ill, c.label): j
                for ill, m in measurements.items()
                for j, c in enumerate(m.comparisons)
            }
            for row in comparison_rows:
                if (row.illumination, row.comparison) not in agreed:
                    continue  # predicted unseparable: the dB carry no agreement to check
                j = index[row.illumination, row.comparison]
                checks.append(
                    at_most(
                        f"{row.illumination}: {row.comparison} SNR_dB deviation",
                        "agreement",
                        abs(row.snr_db_difference),
                        agree.snr_db,
                        "dB",
                        f"predicted {row.predicted.snr_db:.2f} dB, "
                        f"measured {row.measured.snr_db:.2f} dB",
                        basis="tolerance",
                        standard_error=agreeing[row.illumination].snr_db[j],
                        illumination=row.illumination,
                        subject=row.comparison,
                        quantity="snr_db",
                    )
                )
    if acc.ranking:
        if ranking is None:
            why = "one illumination measured, nothing to rank (leave out acceptance.ranking)"
            if unlit:
                why = f"no light reaches the camera under {', '.join(unlit)}: nothing to rank"
            checks.append(
                not_run(
                    "ranking: measured best is predicted best",
                    "ranking",
                    0.0,
                    "",
                    "≤",
                    why,
                    quantity="ranking",
                )
            )
        else:
            labels = [c.label for c in next(iter(measurements.values())).comparisons]
            checks.append(_ranking_check(ranking, errors, labels.index(ranking.comparison)))
    if acc.gain_relative is not None:
        if gain is None:
            checks.append(
                not_run(
                    "system gain K deviation from the camera's",
                    "gain",
                    100 * acc.gain_relative,
                    "%",
                    "≤",
                    gain_missing or "no photon-transfer estimate of K",
                    quantity="gain",
                )
            )
        else:
            # K from ≥ 3 points has the residuals' standard error (points − 1 degrees of
            # freedom); from fewer, the propagated sampling error (known).
            points = len(gain.points)
            checks.append(
                at_most(
                    "system gain K deviation from the camera's",
                    "gain",
                    100 * abs(gain.relative_deviation),
                    100 * acc.gain_relative,
                    "%",
                    f"K = {gain.value:.4g} ± {gain.standard_error:.2g} DN/e⁻, "
                    f"declared {gain.declared:.4g}",
                    basis="tolerance",
                    standard_error=100 * gain.standard_error / gain.declared,
                    df=points - 1 if points >= 3 else np.inf,
                    quantity="gain",
                )
            )
    return checks, skipped
