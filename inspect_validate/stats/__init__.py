"""Grey-value statistics: class moments, separation measures and classification error.

Shared by measurement (from images) and prediction (from spectra).

=======================  ==========================================================
:func:`region_statistics`  one pass over a frame stack under a mask (38), (39), EMVA noise
:func:`sample_moments`     exact μ (38) and σ² (39) of a grey-value sample
:func:`weighted_moments`   μ (38) and σ² (39) of pixels counted by their share of a region
:func:`snr_db`, ...        SNR (35)/(36), CNR, Fisher ratio
:func:`gaussian_error`     exact two-Gaussian ε_tot (37) from (38)–(40)
:func:`lscv_bandwidth`     LSCV bandwidth (42)–(43) with a quantisation floor
:func:`kde_error`          ε_tot (37) of two kernel density estimates (41)
:func:`kendall_tau`        agreement of two rankings (predicted against measured)
=======================  ==========================================================
"""

from inspect_validate.stats.bandwidth import Bandwidth, lscv_bandwidth, lscv_objective, pair_counts
from inspect_validate.stats.gaussian_error import (
    gaussian_error,
    gaussian_error_and_log,
    log_gaussian_error,
)
from inspect_validate.stats.kde_error import KdeError, kde_error
from inspect_validate.stats.ranking import kendall_tau
from inspect_validate.stats.region import RegionStatistics, Shading, region_statistics
from inspect_validate.stats.sample import (
    LatticeSample,
    Moments,
    as_sample,
    merge_samples,
    sample_moments,
    weighted_moments,
)
from inspect_validate.stats.separation import cnr_db, fisher_db, snr, snr_db

__all__ = [
    "Bandwidth",
    "KdeError",
    "LatticeSample",
    "Moments",
    "RegionStatistics",
    "Shading",
    "as_sample",
    "cnr_db",
    "fisher_db",
    "gaussian_error",
    "gaussian_error_and_log",
    "kde_error",
    "kendall_tau",
    "log_gaussian_error",
    "lscv_bandwidth",
    "lscv_objective",
    "merge_samples",
    "pair_counts",
    "region_statistics",
    "sample_moments",
    "snr",
    "snr_db",
    "weighted_moments",
]
