"""Predicted against measured: per illumination the rows of each class and comparison,
and the ranking of the illuminations by the key comparison."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from inspect_validate.verification.results import (
    ClassAgreement,
    ComparisonAgreement,
    ComparisonValues,
    MeasuredClass,
    NominalClass,
    PredictedClass,
    RankingAgreement,
)

if TYPE_CHECKING:
    from inspect_validate.acceptance import Acceptance
    from inspect_validate.comparisons import Comparisons
    from inspect_validate.measurement import Measurement
    from inspect_validate.scene import Scene
    from inspect_validate.station.prediction import StationPrediction
    from inspect_validate.verification.results import ClassAgreement, ComparisonAgreement

__all__ = ["agreement_rows", "ranking_agreement", "ranking_comparison"]


def agreement_rows(
    measurements: dict[str, Measurement],
    p: StationPrediction,
    nominal: StationPrediction,
    dark_means: dict[str, float] | None,
    offset: float,
    *,
    need_kde: bool,
) -> tuple[list[ClassAgreement], list[ComparisonAgreement]]:
    """Rows of predicted (calibrated; and ``nominal``, at the stated irradiances, as
    ``predict`` gives them) against measured, per illumination and class / comparison."""
    from inspect_validate.model import predicted_kde_error

    class_rows, comparison_rows = [], []
    temporal = p.variance - p.spectral_variance  # σ² = temporal (mean over samples) + spectral
    for ill, m in measurements.items():
        li = p.index(ill)
        for k, c in enumerate(m.classes):
            pm, pv = float(p.mean[li, k]), float(p.variance[li, k])
            level = (dark_means or {}).get(c.name, offset)
            signal = pm - offset
            class_rows.append(
                ClassAgreement(
                    illumination=ill,
                    class_name=c.name,
                    predicted=PredictedClass(
                        mean=pm,
                        variance=pv,
                        temporal_variance=float(temporal[li, k]),
                        spatial_variance=float(p.spectral_variance[li, k]),
                        saturated_fraction=float(p.saturated_fraction[li, k]),
                    ),
                    nominal=NominalClass(
                        mean=float(nominal.mean[li, k]),
                        variance=float(nominal.variance[li, k]),
                    ),
                    measured=MeasuredClass(
                        mean=c.mean,
                        variance=c.variance,
                        temporal_variance=c.temporal_variance,
                        spatial_variance=c.spatial_variance,
                        saturated_fraction=c.saturated_fraction,
                        zero_fraction=c.zero_fraction,
                        dark_mean=level,
                    ),
                    # Relative to the signal above the dark level, which the model predicts.
                    mean_relative=(c.mean - pm) / signal if signal > 0 else float("nan"),
                    variance_relative=(c.variance - pv) / pv if pv > 0 else float("nan"),
                )
            )
        for j, comp in enumerate(m.comparisons):
            predicted_kde = predicted_kde_error(p, li, j) if need_kde else None
            comparison_rows.append(
                ComparisonAgreement(
                    illumination=ill,
                    comparison=comp.label,
                    predicted=ComparisonValues(
                        snr_db=float(p.snr_db[li, j]),
                        cnr_db=float(p.cnr_db[li, j]),
                        error_gaussian=float(p.error_gaussian[li, j]),
                        error_kde=predicted_kde,
                    ),
                    nominal=ComparisonValues(
                        snr_db=float(nominal.snr_db[li, j]),
                        cnr_db=float(nominal.cnr_db[li, j]),
                        error_gaussian=float(nominal.error_gaussian[li, j]),
                    ),
                    measured=ComparisonValues(
                        snr_db=comp.snr_db,
                        cnr_db=comp.cnr_db,
                        error_gaussian=comp.error_gaussian,
                        error_kde=comp.error_kde,
                    ),
                    snr_db_difference=comp.snr_db - float(p.snr_db[li, j]),
                )
            )
    return class_rows, comparison_rows


def ranking_agreement(
    measurements: dict[str, Measurement],
    p: StationPrediction,
    scene: Scene,
    acc: Acceptance,
    comparisons: Comparisons,
) -> tuple[RankingAgreement | None, tuple[str, ...]]:
    """The illuminations ranked by the key comparison, measured against predicted, and
    why not (None and the reason) with one illumination."""
    from inspect_validate.stats.ranking import kendall_tau

    if len(measurements) < 2:
        return None, ("ranking: one illumination, nothing to rank",)
    j = comparisons.index(ranking_comparison(scene, acc, comparisons))
    by = scene.rank_by if scene.rank_by in ("snr_db", "cnr_db") else "error"
    names = list(measurements)
    if by == "error":
        predicted = np.array([p.log_error_gaussian[p.index(n), j] for n in names])
        measured = np.array([measurements[n].comparisons[j].log_error_gaussian for n in names])
        best_p, best_m = names[int(np.argmin(predicted))], names[int(np.argmin(measured))]
    else:
        predicted = np.array([getattr(p, by)[p.index(n), j] for n in names])
        measured = np.array([getattr(measurements[n].comparisons[j], by) for n in names])
        best_p, best_m = names[int(np.argmax(predicted))], names[int(np.argmax(measured))]
    tau = kendall_tau(predicted, measured)
    ranking = RankingAgreement(
        comparison=comparisons.labels[j],
        by="log_error_gaussian" if by == "error" else by,
        predicted=dict(zip(names, map(float, predicted), strict=True)),
        measured=dict(zip(names, map(float, measured), strict=True)),
        predicted_best=best_p,
        measured_best=best_m,
        agree=best_p == best_m,
        kendall_tau=tau,
    )
    return ranking, ()


def ranking_comparison(scene: Scene, acc: Acceptance, comparisons: Comparisons) -> str:
    """The comparison the illuminations are ranked by: the first separation check's, else
    the scene's ``rank:`` comparison, else the first (the worst pair decides, as predict
    ranks by default)."""
    if acc.separation:
        return acc.separation[0].comparison
    if scene.rank_comparison in comparisons.labels:
        return scene.rank_comparison
    return comparisons.labels[0]
