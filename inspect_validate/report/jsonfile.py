"""The measurement as a versioned JSON document (schema in the manual, "JSON documents").

JSON has no infinities: ±inf (e.g. SNR_dB of classes with equal means) are
written as the strings ``"inf"`` and ``"-inf"``; missing and undefined (NaN)
values as ``null``.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from inspect_validate import __version__
from inspect_validate.files import json_number, json_ready, write_json
from inspect_validate.measurement import Measurement

if TYPE_CHECKING:
    from inspect_validate.measurement import Limits

__all__ = [
    "SCHEMA_VERSION",
    "json_number",
    "json_ready",
    "measurement_document",
    "write_json",
]

SCHEMA_VERSION = 2
"""Measurement JSON: 2 moved the KDE bandwidth to the classes and added ``weights``;
later, additively, each class's ``gaussian_misfit``, each comparison's ``error_counted``
and ``error_counted_se`` and the top-level ``skipped`` (``error_kde`` is null where it was not computed)."""


def measurement_document(m: Measurement, *, limits: Limits) -> dict:
    """The document of a measurement (:func:`write_json` makes its numbers JSON-safe)."""
    classes = [
        {
            "name": c.name,
            "mean": c.mean,
            "variance": c.variance,
            "n_pixels": c.n_pixels,
            "n_frames": c.n_frames,
            "saturated_fraction": c.saturated_fraction,
            "zero_fraction": c.zero_fraction,
            "temporal_variance": c.temporal_variance,
            "spatial_variance": c.spatial_variance,
            "gaussian_misfit": c.gaussian_misfit,
            "kde_bandwidth": c.kde_bandwidth,
            "kde_bandwidth_at_floor": c.kde_bandwidth_at_floor,
        }
        for c in m.classes
    ]
    comparisons = [
        {
            "first": list(c.first),
            "second": list(c.second),
            "snr_db": c.snr_db,
            "cnr_db": c.cnr_db,
            "fisher_db": c.fisher_db,
            "error_gaussian": c.error_gaussian,
            "log_error_gaussian": c.log_error_gaussian,
            "error_kde": c.error_kde,
            "error_counted": c.error_counted,
            "error_counted_se": c.error_counted_se,
        }
        for c in m.comparisons
    ]
    return {
        "schema": "inspect-validate/measurement",
        "schema_version": SCHEMA_VERSION,
        "tool_version": __version__,
        "inputs": m.inputs,
        "limits": {
            "max_saturated_fraction": limits.max_saturated,
            "max_zero_fraction": limits.max_zero,
            "violations": list(m.violations),
        },
        "weights": m.weighting,
        "classes": classes,
        "comparisons": comparisons,
        "skipped": list(m.skipped),
        "warnings": list(m.warnings),
    }
