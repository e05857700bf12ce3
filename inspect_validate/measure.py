"""Measure object classes in frames: per-class statistics and class separation.

The chapter's Table 4 (μ, σ² per class) and Table 3 (SNR_dB between classes,
in pairs and one class against the union of the others), plus CNR, Fisher ratio
and the classification error ε_tot (37), parametric and nonparametric.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from inspect_validate.comparisons import default_groups, label
from inspect_validate.stats import (
    Moments,
    RegionStatistics,
    cnr_db,
    fisher_db,
    gaussian_error_and_log,
    kde_error,
    merge_samples,
    region_statistics,
    sample_moments,
    snr_db,
)

__all__ = ["ClassMeasurement", "Comparison", "Measurement", "compare", "measure_classes"]


@dataclass(frozen=True)
class ClassMeasurement:
    """Grey-value statistics of one class (Table 4), DN and DN².

    ``temporal_variance`` and ``spatial_variance`` are the EMVA 1288 components
    (:class:`~inspect_validate.stats.RegionStatistics`); ``variance`` is σ² (39)
    of all pixel values pooled over the frames, what a classifier sees.
    """

    name: str
    mean: float
    variance: float
    n_pixels: int
    n_frames: int
    saturated_fraction: float
    zero_fraction: float
    temporal_variance: float | None
    spatial_variance: float | None
    region: RegionStatistics


@dataclass(frozen=True)
class Comparison:
    """Separation of two groups of classes (Table 3); a group of several is their union."""

    first: tuple[str, ...]
    second: tuple[str, ...]
    snr_db: float
    cnr_db: float
    fisher_db: float
    error_gaussian: float
    log_error_gaussian: float
    error_kde: float | None
    kde_bandwidth: tuple[float, float] | None
    kde_bandwidth_at_floor: tuple[bool, bool] | None

    @property
    def label(self) -> str:
        return label(self.first, self.second)


@dataclass(frozen=True)
class Measurement:
    classes: tuple[ClassMeasurement, ...]
    comparisons: tuple[Comparison, ...]


def measure_classes(
    frames: np.ndarray,
    masks: dict[str, np.ndarray],
    *,
    dark: np.ndarray | None = None,
    saturation_level: float | None = None,
) -> tuple[ClassMeasurement, ...]:
    """Per-class statistics of a frame stack (N, H, W) under class masks."""
    out = []
    for name, mask in masks.items():
        region = region_statistics(frames, mask, dark=dark, saturation_level=saturation_level)
        m = sample_moments(region.sample)
        out.append(
            ClassMeasurement(
                name=name,
                mean=m.mean,
                variance=m.variance,
                n_pixels=region.n_pixels,
                n_frames=region.n_frames,
                saturated_fraction=region.saturated_fraction,
                zero_fraction=region.zero_fraction,
                temporal_variance=region.temporal_variance,
                spatial_variance=region.spatial_variance,
                region=region,
            )
        )
    return tuple(out)


def compare(
    classes: tuple[ClassMeasurement, ...], *, kde: bool = True, quantum: float | None = None
) -> tuple[Comparison, ...]:
    """Every pair of classes, then (with three or more) each class against all others.

    Parameters
    ----------
    classes : tuple of ClassMeasurement
    kde : bool, keyword-only
        Also compute the nonparametric ε (kernel densities with LSCV bandwidth).
    quantum : float, keyword-only, optional
        Quantisation step of the grey values (the KDE bandwidth floor), DN.
    """
    groups = default_groups(len(classes))
    return tuple(_compare(classes, a, b, kde=kde, quantum=quantum) for a, b in groups)


def _compare(classes, first, second, *, kde, quantum) -> Comparison:
    samples = [merge_samples([classes[i].region.sample for i in g]) for g in (first, second)]
    m1, m2 = (
        sample_moments(s) if len(g) > 1 else _moments_of(classes[g[0]])
        for s, g in zip(samples, (first, second), strict=True)
    )
    args = (m1.mean, m1.variance, m2.mean, m2.variance)
    err, log_err = gaussian_error_and_log(*args)
    kde_result = kde_error(*samples, quantum=quantum) if kde else None
    return Comparison(
        first=tuple(classes[i].name for i in first),
        second=tuple(classes[i].name for i in second),
        snr_db=float(snr_db(*args)),
        cnr_db=float(cnr_db(*args)),
        fisher_db=float(fisher_db(*args)),
        error_gaussian=float(err),
        log_error_gaussian=float(log_err),
        error_kde=kde_result.error if kde_result else None,
        kde_bandwidth=(kde_result.bandwidth1.h, kde_result.bandwidth2.h) if kde_result else None,
        kde_bandwidth_at_floor=(
            (bool(kde_result.bandwidth1.at_floor), bool(kde_result.bandwidth2.at_floor))
            if kde_result
            else None
        ),
    )


def _moments_of(c: ClassMeasurement) -> Moments:
    return Moments(c.n_pixels * c.n_frames, c.mean, c.variance)
