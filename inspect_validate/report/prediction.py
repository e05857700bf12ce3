"""Reports of a prediction: the ranked table and the versioned JSON document."""

from __future__ import annotations

import numpy as np

from inspect_validate import __version__
from inspect_validate.model import Prediction, predicted_kde_error, rank
from inspect_validate.report.jsonfile import json_number
from inspect_validate.report.tables import format_error, render_table

__all__ = [
    "PREDICTION_SCHEMA_VERSION",
    "format_prediction",
    "prediction_document",
    "prediction_rows",
]

PREDICTION_SCHEMA_VERSION = 1


def prediction_rows(
    p: Prediction, *, by: str, comparison: str | None, top: int, kde: bool = True
) -> list[dict]:
    """The ``top`` best combinations as dictionaries (the JSON ``ranking`` entries)."""
    order, key, column = rank(p, by=by, comparison=comparison)
    rows = []
    for r, (li, oi, ci) in enumerate(order[:top]):
        idx = (li, oi, ci)
        cols = range(len(p.comparisons)) if column is None else [column]
        worst = column if column is not None else int(np.argmax(p.error_gaussian[idx]))
        rows.append(
            {
                "rank": r + 1,
                "light": p.lights[li],
                "optics": p.optics[oi],
                "camera": p.cameras[ci],
                "exposure_time_s": json_number(p.exposure_time[idx]),
                "key": json_number(key[r]),
                "classes": [
                    {
                        "name": name,
                        "mean": json_number(p.mean[idx][k]),
                        "variance": json_number(p.variance[idx][k]),
                        "spectral_variance": json_number(p.spectral_variance[idx][k]),
                        "electrons": json_number(p.electrons[idx][k]),
                        "saturated_fraction": json_number(p.saturated_fraction[idx][k]),
                    }
                    for k, name in enumerate(p.classes)
                ],
                "comparisons": [
                    {
                        "first": list(p.comparisons[j][0]),
                        "second": list(p.comparisons[j][1]),
                        "snr_db": json_number(p.snr_db[idx][j]),
                        "cnr_db": json_number(p.cnr_db[idx][j]),
                        "fisher_db": json_number(p.fisher_db[idx][j]),
                        "error_gaussian": json_number(p.error_gaussian[idx][j]),
                        "log_error_gaussian": json_number(p.log_error_gaussian[idx][j]),
                        "error_kde": json_number(predicted_kde_error(p, idx, j))
                        if kde and (j == worst or column is not None)
                        else None,
                    }
                    for j in cols
                ],
                "worst_comparison": worst,
            }
        )
    return rows


def format_prediction(p: Prediction, rows: list[dict], *, by: str, comparison: str | None) -> str:
    header = ["#", "light", "optics", "camera", "t_exp"]
    header += [f"μ {c}" for c in p.classes] + [f"σ² {c}" for c in p.classes]
    header += ["comparison", "SNR_dB (36)", "CNR_dB", "ε Gauss", "ε KDE", "sat"]
    table = []
    for row in rows:
        # With a chosen comparison the row holds only that one; else the worst pair.
        comp = row["comparisons"][0 if comparison else row["worst_comparison"]]
        sat = max(c["saturated_fraction"] for c in row["classes"])
        table.append(
            [
                str(row["rank"]),
                row["light"],
                row["optics"],
                row["camera"],
                f"{1e3 * row['exposure_time_s']:.3g} ms",
            ]
            + [f"{c['mean']:.1f}" for c in row["classes"]]
            + [f"{c['variance']:.1f}" for c in row["classes"]]
            + [
                f"{','.join(comp['first'])} vs {','.join(comp['second'])}",
                f"{comp['snr_db']:.2f}" if isinstance(comp["snr_db"], float) else comp["snr_db"],
                f"{comp['cnr_db']:.2f}" if isinstance(comp["cnr_db"], float) else comp["cnr_db"],
                format_error(comp["error_gaussian"], comp["log_error_gaussian"]),
                format_error(comp["error_kde"]),
                f"{100 * sat:.2g} %" if sat > 1e-6 else "-",
            ]
        )
    what = f"{comparison}" if comparison else "worst pair of classes"
    title = f"Ranked by {'ε Gauss' if by == 'error' else by} of the {what}; μ in DN, σ² in DN², ε_tot (37) with equal priors"
    return title + "\n" + render_table(header, table)


def prediction_document(
    p: Prediction, rows: list[dict], *, scene: str, by: str, comparison: str | None
) -> dict:
    return {
        "schema": "inspect-validate/prediction",
        "schema_version": PREDICTION_SCHEMA_VERSION,
        "tool_version": __version__,
        "scene": scene,
        "wavelength_nm": {
            "start": json_number(p.grid[0]),
            "stop": json_number(p.grid[-1]),
            "step": json_number(p.grid[1] - p.grid[0]),
        },
        "lights": list(p.lights),
        "optics": list(p.optics),
        "cameras": list(p.cameras),
        "classes": list(p.classes),
        "rank_by": by,
        "rank_comparison": comparison,
        "combinations": int(np.prod(p.shape)),
        "ranking": rows,
    }
