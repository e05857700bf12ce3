"""Reports of a prediction: the ranked table and the versioned JSON document."""

from __future__ import annotations

from inspect_validate import __version__
from inspect_validate.model import Ranking, predicted_kde_error
from inspect_validate.model.ranking import SATURATION_LIMIT
from inspect_validate.text import format_error, render_table

__all__ = [
    "PREDICTION_SCHEMA_VERSION",
    "format_prediction",
    "prediction_document",
    "prediction_rows",
]

PREDICTION_SCHEMA_VERSION = 2
"""2: ``key_comparison`` (the row's ranking comparison, an index into its complete
``comparisons``) replaces ``worst_comparison``; ``saturated``, ``exposure``
(``"absolute"``/``"relative"``) and the top-level ``skipped`` were added; later,
additively, ``skipped_work`` (what the scene and the ranking did not need computed: a
narrowed wavelength range, the cost of what the ranking left out)."""


def prediction_rows(p: Ranking, *, kde: bool = True) -> list[dict]:
    """The ranking's rows as dictionaries of plain numbers (the JSON ``ranking``).

    Every row lists every comparison; ``key_comparison`` indexes the one the row
    is ranked by. ε KDE is computed for that comparison only: it is the costly
    one, and the one the ranking is about.
    """
    rows = []
    for r, (li, oi, ci) in enumerate(p.index):
        absolute = bool(p.absolute[r])
        column = int(p.column[r])
        rows.append(
            {
                "rank": r + 1,
                "light": p.lights[li],
                "optics": p.optics[oi],
                "camera": p.cameras[ci],
                "exposure": "absolute" if absolute else "relative",
                "exposure_time_s": float(p.exposure_time[r]) if absolute else None,
                "key": float(p.key[r]),
                "key_comparison": column,
                "saturated": bool(p.saturated[r]),
                "classes": [
                    {
                        "name": name,
                        "mean": float(p.mean[r, k]),
                        "variance": float(p.variance[r, k]),
                        "spectral_variance": float(p.spectral_variance[r, k]),
                        "electrons": float(p.electrons[r, k]),
                        "saturated_fraction": float(p.saturated_fraction[r, k]),
                    }
                    for k, name in enumerate(p.classes)
                ],
                "comparisons": [
                    {
                        "first": list(first),
                        "second": list(second),
                        "snr_db": float(p.snr_db[r, j]),
                        "cnr_db": float(p.cnr_db[r, j]),
                        "fisher_db": float(p.fisher_db[r, j]),
                        "error_gaussian": float(p.error_gaussian[r, j]),
                        "log_error_gaussian": float(p.log_error_gaussian[r, j]),
                        "error_kde": predicted_kde_error(p, r, j) if kde and j == column else None,
                    }
                    for j, (first, second) in enumerate(p.comparisons)
                ],
            }
        )
    return rows


def format_prediction(p: Ranking, rows: list[dict] | None = None) -> str:
    """The ranking table ``inspect-validate predict`` prints: per row the light, optics and
    camera, exposure, each class's μ (DN) and σ² (DN²), and the key comparison's SNR_dB
    (36), CNR_dB, ε Gauss and ε KDE (37) (``rows``: :func:`~inspect_validate.report.prediction.prediction_rows` of ``p``,
    computed here when not given)."""
    if rows is None:
        rows = prediction_rows(p)
    by, comparison = p.by, p.comparison
    header = ["#", "light", "optics", "camera", "t_exp"]
    header += [f"μ {c}" for c in p.classes] + [f"σ² {c}" for c in p.classes]
    header += ["comparison", "SNR_dB (36)", "CNR_dB", "ε Gauss", "ε KDE", "sat"]
    table = []
    for row in rows:
        comp = row["comparisons"][row["key_comparison"]]
        sat = max(c["saturated_fraction"] for c in row["classes"])
        t_exp = row["exposure_time_s"]
        table.append(
            [
                str(row["rank"]),
                row["light"],
                row["optics"],
                row["camera"],
                f"{1e3 * t_exp:.3g} ms" if t_exp is not None else "rel.",
            ]
            + [f"{c['mean']:.1f}" for c in row["classes"]]
            + [f"{c['variance']:.1f}" for c in row["classes"]]
            + [
                f"{','.join(comp['first'])} vs {','.join(comp['second'])}",
                f"{comp['snr_db']:.2f}",
                f"{comp['cnr_db']:.2f}",
                format_error(comp["error_gaussian"], comp["log_error_gaussian"]),
                format_error(comp["error_kde"]),
                (f"{100 * sat:.2g} %" + (" !" if row["saturated"] else "")) if sat > 1e-6 else "-",
            ]
        )
    what = f"{comparison}" if comparison else "worst pair of classes"
    lines = [
        f"Ranked by {'ε Gauss' if by == 'error' else by} of the {what}; μ in DN, σ² in DN², "
        "ε_tot (37) with equal priors, a fraction (0 to ½)",
        render_table(header, table),
    ]
    if any(r["saturated"] for r in rows):
        lines.append(
            f"! more than {100 * SATURATION_LIMIT:g} % of a class saturated: ranked after every "
            "unsaturated combination (clipping shrinks the variance and flatters the separation)"
        )
    if any(r["exposure_time_s"] is None for r in rows):
        lines.append(
            "rel. = the light's SPD is relative (no irradiance): auto exposure puts the brightest "
            "class at the target, but the time in seconds is unknown"
        )
    return "\n".join(lines)


def prediction_document(p: Ranking, rows: list[dict], *, scene: str) -> dict:
    return {
        "schema": "inspect-validate/prediction",
        "schema_version": PREDICTION_SCHEMA_VERSION,
        "tool_version": __version__,
        "scene": scene,
        "wavelength_nm": {
            "start": float(p.grid[0]),
            "stop": float(p.grid[-1]),
            "step": float(p.grid[1] - p.grid[0]),
        },
        "lights": list(p.lights),
        "optics": list(p.optics),
        "cameras": list(p.cameras),
        "classes": list(p.classes),
        "rank_by": p.by,
        "rank_comparison": p.comparison,
        "combinations": p.combinations,
        "skipped": list(p.skipped),
        "skipped_work": list(p.skipped_work),
        "ranking": rows,
    }
