"""The design of a mix as a versioned JSON document (schema ``inspect-validate/design`` v1)."""

from __future__ import annotations

from inspect_validate import __version__

__all__ = ["DESIGN_SCHEMA_VERSION", "design_document"]

DESIGN_SCHEMA_VERSION = 1


def design_document(d) -> dict:
    """Levels, the best single channel, per comparison μ/σ²/SNR/ε of both, the flatness."""
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
        "exposure_time_s": p.exposure_time,
        "objective": {"minimise": "worst error_gaussian", "comparisons": list(p.objective.labels)},
        "channels": {str(c): light.name for c, light in p.channels.items()},
        "levels": {str(c): w for c, w in d.levels.items()},
        "illumination": {"name": "design", "channels": {str(c): v for c, v in d.percent.items()}},
        "mix": predicted(d.mix),
        "best_single": {"channel": str(channel), "level": level, **predicted(d.single_prediction)},
        "drive_tolerance": d.flatness,
        "starts": d.starts,
    }
