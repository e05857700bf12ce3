"""``report.html``: one self-contained page of a verification that opens offline.

The verdict and the checks (failures first) come first, then the calibration,
then per illumination the first frame contrast-stretched with the classes'
regions outlined, the class histograms with their Gaussian and kernel
densities, and predicted against measured per class; then predicted against
measured across illuminations with the acceptance tolerances as bands, the
spectra with the station's lights marked among the scene's candidates, and the
per-wavelength ε of the classes' reflectances; given a ``watch`` history, its
trends last. Figures are PNGs embedded as ``data:`` URIs; the page has no
script and loads nothing.
"""

from __future__ import annotations

import base64
import html
import io
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from inspect_validate import __version__

if TYPE_CHECKING:
    from collections.abc import Sequence

    from inspect_validate.model.spectral_analysis import SpectralSeparation
    from inspect_validate.scene import Scene
    from inspect_validate.verification.checks import Check
    from inspect_validate.verification.results import Verification
    from inspect_validate.verification.rig import RigVerification
    from inspect_validate.watch.history import HistoryLog

__all__ = [
    "charts",
    "history_html",
    "page",
    "prediction_html",
    "table",
    "verification_html",
    "write_charts_page",
    "write_verification_html",
]

_STYLE = """
body { font-family: system-ui, sans-serif; margin: 2em auto; max-width: 1200px; color: #222; }
h1 { margin-bottom: 0.2em; } h2 { border-bottom: 1px solid #ccc; margin-top: 2em; }
.charts { display: flex; flex-wrap: wrap; gap: 1em; } .charts > .chart { flex: 0 0 auto; }
.verdict { font-size: 1.6em; font-weight: bold; padding: 0.3em 0.6em; display: inline-block; }
.pass { color: #0a6b2d; } .fail { color: #b00020; }
.verdict.pass { background: #e3f5e8; } .verdict.fail { background: #fde7ea; }
table { border-collapse: collapse; margin: 0.8em 0; font-size: 0.9em; }
th, td { border: 1px solid #ccc; padding: 0.25em 0.6em; text-align: left; }
td.num { text-align: right; font-variant-numeric: tabular-nums; }
tr.fail td { background: #fde7ea; }
tr.skipped td { color: #666; background: #f6f6f6; }
img { max-width: 100%; display: block; margin: 0.5em 0; }
.meta { color: #555; font-size: 0.9em; }
"""


def write_verification_html(
    v: Verification, path: str | Path, *, history: HistoryLog | None = None
) -> Path:
    """Write :func:`verification_html` of ``v`` to ``path`` (atomically)."""
    from inspect_validate.files import atomic_write

    return atomic_write(path, verification_html(v, history=history).encode())


def write_rig_html(v: RigVerification, path: str | Path) -> Path:
    """Write the page of a station of several cameras to ``path`` (atomically): the one
    verdict, each camera's with a link to its page (``<camera>/report.html`` beside it),
    and the checks across cameras."""
    from inspect_validate.files import atomic_write
    from inspect_validate.report.verification import count_failed, rig_rate_line, rig_summary

    e = html.escape
    verdict = "pass" if v.passed else "fail"
    cameras = [
        f'<li><a href="{e(name)}/report.html">{e(name)}</a>: '
        f"{'PASS' if r.passed else 'FAIL'} — {e(count_failed(r.checks))}</li>"
        for name, r in v.cameras.items()
    ]
    parts = [
        f"<h1>{e(v.station.name)}</h1>",
        f'<div class="verdict {verdict}">{verdict.upper()}: {e(rig_summary(v))}</div>',
        f'<p class="meta">station {e(str(v.station.path))}, inspect-validate {e(__version__)}</p>',
        "<h2>Cameras</h2>",
        "<ul>",
        *cameras,
        "</ul>",
        "<h2>Across cameras</h2>",
        f'<p class="meta">{e(rig_rate_line(v))}. Each camera\'s irradiance scale of a light '
        "against the first camera's: the same light, so a gain, exposure or lens changed "
        "on one camera alone where they differ.</p>",
        checks_table(v.across, v.skipped),
    ]
    text = page(f"verify {v.station.name}: {verdict.upper()}", parts)
    return atomic_write(path, text.encode())


def page(title: str, body: list[str]) -> str:
    """A whole report page: ``title``, the report style, ``body`` (HTML fragments) and the
    chart script, in one self-contained file."""
    from inspect_validate.report.charts import runtime

    head = [
        "<!DOCTYPE html>",
        '<html lang="en"><head><meta charset="utf-8">',
        f"<title>{html.escape(title)}</title>",
        f"<style>{_STYLE}</style></head><body>",
    ]
    return "\n".join([*head, *body, runtime(), "</body></html>"])


def write_charts_page(path: str | Path, title: str, body: list[str]) -> Path:
    """Write a :func:`page` of ``body`` (HTML fragments, charts among them) to ``path``
    (atomically): what ``--plot`` writes."""
    from inspect_validate.files import atomic_write

    return atomic_write(path, page(title, [f"<h1>{html.escape(title)}</h1>", *body]).encode())


def charts(specs: list[dict], *, what: str) -> str:
    """``specs`` drawn side by side, each described as ``what: its title``."""
    from inspect_validate.report.charts import chart

    drawn = (chart(spec, alt=f"{what}: {spec['title']}") for spec in specs)
    return "\n".join(['<div class="charts">', *drawn, "</div>"])


def prediction_html(
    scene: Scene, separation: SpectralSeparation | None, rows: list[dict], *, by: str
) -> list[str]:
    """``predict --plot``'s page: the scene's component spectra, ε per wavelength (where
    ``separation`` is given) and the ranked combinations by the value ranked by."""
    from inspect_validate.report.charts import error_charts, spectra_charts

    e = html.escape
    out = ["<h2>Components</h2>", charts(spectra_charts(scene), what="component spectra")]
    if separation is not None:
        out += [
            "<h2>ε per wavelength</h2>",
            "<p>ε_tot between the classes' reflectance samples at each wavelength: where a "
            "narrow light would separate them.</p>",
            charts(error_charts(separation), what="ε per wavelength"),
        ]
    quantity = {"error": "error_gaussian"}.get(by, by)
    shown = {"error": "ε Gauss", "snr_db": "SNR_dB [dB]", "cnr_db": "CNR_dB [dB]"}.get(by, by)
    cells = []
    for r in rows:
        key = r["comparisons"][r["key_comparison"]]
        value = key[quantity]
        cells.append(
            [
                str(r["rank"]),
                f"{r['light']} / {r['optics']} / {r['camera']}",
                f"{','.join(key['first'])} vs {','.join(key['second'])}",
                f"{value:.3g}" if by == "error" else f"{value:.2f}",
            ]
        )
    out += [
        f"<h2>Ranking by {e(shown)}</h2>",
        table(["rank", "light / optics / camera", "key comparison", shown], cells),
    ]
    return out


def verification_html(v: Verification, *, history: HistoryLog | None = None) -> str:
    """The page of a :class:`~inspect_validate.verification.results.Verification`, as text;
    ``history``, a :class:`~inspect_validate.watch.history.HistoryLog` of the station,
    adds its trends."""
    from inspect_validate.report.charts import agreement_charts, chart
    from inspect_validate.report.verification import (
        count_failed,
        describe_acquisition,
        false_alarm_line,
    )

    e = html.escape
    verdict = "pass" if v.passed else "fail"
    parts = [
        f"<h1>{e(v.station.name)}</h1>",
        f'<div class="verdict {verdict}">{verdict.upper()}: {e(count_failed(v.checks))}</div>',
        f'<p class="meta">station {e(str(v.inputs["station"]))} (SHA-256 '
        f"{e(str(v.inputs['station_sha256'])[:16])}…), capture {e(str(v.inputs['capture']))}, "
        f"inspect-validate {e(__version__)}</p>",
        "<h2>Checks</h2>",
        f'<p class="meta">{e(false_alarm_line(v))}: statistical limits come from the '
        "rate and what was measured, tolerance limits are widened by the value's own "
        "uncertainty, fixed limits are held as given.</p>",
        checks_table(v.checks, v.skipped),
    ]
    parts += [f"<p>note: {e(n)}</p>" for n in v.notes]
    if v.cause:
        parts.append(f"<p><b>likely cause:</b> {e(v.cause)}</p>")
    if v.acquisition:
        parts += ["<h2>Frames</h2>", "<ul>"]
        parts += [f"<li>{e(describe_acquisition(a))}</li>" for a in v.acquisition]
        parts += ["</ul>"]
    parts += ["<h2>Calibration</h2>", _calibration(v)]
    parts += _illuminations(v)
    parts += [
        "<h2>Predicted against measured</h2>",
        "<p>Deviation of the measurement from the calibrated prediction; the band is the "
        "acceptance section's tolerance (none drawn where it sets none).</p>",
        '<div class="charts">',
        *(
            chart(spec, alt=f"measured against predicted: {spec['title']}")
            for spec in agreement_charts(
                v.classes, v.comparisons, agreement=v.station.acceptance.agreement
            )
        ),
        "</div>",
        _comparisons_table(v),
    ]
    parts += _spectra(v)
    if history is not None:
        parts += history_html(history)
    return page(f"verify {v.station.name}: {verdict.upper()}", parts)


def table(
    header: Sequence[str],
    rows: Sequence[Sequence[str]],
    *,
    failed: Sequence[bool] | None = None,
    classes: Sequence[str] | None = None,
) -> str:
    """``rows`` under ``header``; a row is marked ``fail`` where ``failed[i]``, else with
    ``classes[i]`` (a CSS class) where given."""
    e = html.escape
    out = ["<table><tr>" + "".join(f"<th>{e(h)}</th>" for h in header) + "</tr>"]
    for i, row in enumerate(rows):
        mark = "fail" if failed and failed[i] else (classes[i] if classes else "")
        cls = f' class="{mark}"' if mark else ""
        cells = "".join(
            f'<td class="num">{e(c)}</td>' if _numeric(c) else f"<td>{e(c)}</td>" for c in row
        )
        out.append(f"<tr{cls}>{cells}</tr>")
    out.append("</table>")
    return "\n".join(out)


def _numeric(text: str) -> bool:
    """A cell that is a number (with its unit): right-aligned; a sentence that starts
    with one ("4 delivered, 0 incomplete") is text."""
    words = text.split()
    if not 1 <= len(words) <= 2:
        return False
    try:
        float(words[0].replace("−", "-"))
    except ValueError:
        return False
    return True


def _g(x, digits: int = 4) -> str:
    return "—" if x is None or not np.isfinite(x) else f"{x:.{digits}g}"


def checks_table(checks: Sequence[Check], skipped_items: Sequence[str]) -> str:
    """``checks`` (a verdict's, :class:`~inspect_validate.verification.verdict.Verdict`),
    failures marked, and what was not checked as rows of their own."""
    from inspect_validate.report.verification import CHECK_COLUMNS, check_rows

    rows = check_rows(checks)
    if not rows and not skipped_items:
        return "<p>The station's acceptance section asks for no check.</p>"
    # What was not computed, and why, is read where the checks are: rows of their own,
    # whole (a "what: why" split at a colon would cut "amber: C vs A,B" apart).
    skipped = [["skipped", item, "", "", "", "", ""] for item in skipped_items]
    return table(
        CHECK_COLUMNS,
        [cells for _, cells in rows] + skipped,
        failed=[not c.passed for c, _ in rows] + [False] * len(skipped),
        classes=[""] * len(rows) + ["skipped"] * len(skipped),
    )


def _calibration(v) -> str:
    e = html.escape
    out = []
    g = v.gain
    if g is not None:
        out.append(
            f"<p>System gain K by photon transfer ({len(g.points)} points): "
            f"{g.value:.4g} ± {g.standard_error:.2g} DN/e⁻; the camera declares "
            f"{g.declared:.4g} DN/e⁻ ({100 * g.relative_deviation:+.1f} %).</p>"
        )
    rows = [
        [
            s.illumination,
            s.method,
            _g(s.scale),
            _g(s.standard_error, 2),
            _g(s.irradiance),
            ", ".join(
                f"{c} {100 * r:+.2g} %" for c, r in zip(s.classes, s.residuals, strict=False)
            ),
        ]
        for s in v.scales.values()
    ]
    out.append(
        table(
            [
                "illumination",
                "method",
                "irradiance scale",
                "± (1 s.e.)",
                "irradiance at the object [W/m²]",
                "residuals per class",
            ],
            rows,
        )
    )
    if v.ranking:
        r = v.ranking
        out.append(
            f"<p>Ranking by {e(r.comparison)} ({e(r.by)}): predicted best "
            f"{e(r.predicted_best)}, measured best {e(r.measured_best)}, "
            f"{e(r.tau_text)}.</p>"
        )
    return "\n".join(out)


def _illuminations(v) -> list[str]:
    from inspect_validate.images import read_image
    from inspect_validate.report.charts import chart, histogram_chart
    from inspect_validate.report.plots import plot_frame_regions
    from inspect_validate.roi import class_masks

    masks = {}  # frame shape → class masks: every illumination has the same frames
    out = []
    for ill, m in v.measurements.items():
        out.append(f"<h2>Illumination {html.escape(ill)}</h2>")
        first = v.inputs["frames"][ill][0]
        frame = read_image(first)
        if frame.shape not in masks:
            masks[frame.shape] = class_masks(v.rois, frame.shape)
        buffer = io.BytesIO()
        lo, hi = plot_frame_regions(frame, masks[frame.shape], buffer)
        data = base64.b64encode(buffer.getvalue()).decode("ascii")
        out.append(
            f'<figure><img src="data:image/jpeg;base64,{data}" '
            f'alt="{html.escape(ill)}: frame with regions"><figcaption>'
            f"{html.escape(ill)}: {html.escape(Path(first).name)} with the class regions "
            f"(display stretched to {lo:.4g}–{hi:.4g} DN)</figcaption></figure>"
        )
        out.append(
            chart(
                histogram_chart(
                    m.classes,
                    title=f"{ill}: grey values of the classes over {m.classes[0].n_frames} frames",
                    kde_bandwidths=_bandwidths(m.classes),
                ),
                alt=f"{ill}: class histograms",
            )
        )
        rows = [
            [
                r.class_name,
                _g(r.predicted.mean),
                _g(r.measured.mean),
                _g(100 * r.mean_relative, 3),
                _g(r.predicted.temporal_variance),
                _g(r.measured.temporal_variance),
                _g(r.predicted.spatial_variance),
                _g(r.measured.spatial_variance),
                _g(100 * r.measured.saturated_fraction, 3),
            ]
            for r in v.classes
            if r.illumination == ill
        ]
        out.append(
            table(
                [
                    "class",
                    "μ predicted [DN]",
                    "μ measured [DN]",
                    "μ deviation [% of signal]",
                    "σ² temporal predicted [DN²]",
                    "σ² temporal measured [DN²]",
                    "σ² spatial predicted [DN²]",
                    "σ² spatial measured [DN²]",
                    "saturated [%]",
                ],
                rows,
            )
        )
    return out


def _bandwidths(classes) -> dict[str, float]:
    """Each class's LSCV bandwidth: the one ε KDE used, else computed for the plot."""
    from inspect_validate.stats import lscv_bandwidth

    return {
        c.name: c.kde_bandwidth
        if c.kde_bandwidth is not None
        else lscv_bandwidth(c.region.sample).h
        for c in classes
    }


def _comparisons_table(v) -> str:
    rows = [
        [
            r.illumination,
            r.comparison,
            _g(r.predicted.snr_db),
            _g(r.measured.snr_db),
            _g(r.predicted.cnr_db),
            _g(r.measured.cnr_db),
            _g(r.predicted.error_gaussian, 3),
            _g(r.measured.error_gaussian, 3),
            _g(r.predicted.error_kde, 3),
            _g(r.measured.error_kde, 3),
        ]
        for r in v.comparisons
    ]
    return table(
        [
            "illumination",
            "comparison",
            "SNR_dB predicted",
            "SNR_dB measured",
            "CNR_dB predicted",
            "CNR_dB measured",
            "ε Gauss predicted",
            "ε Gauss measured",
            "ε KDE predicted",
            "ε KDE measured",
        ],
        rows,
    )


def _spectra(v) -> list[str]:
    from inspect_validate.errors import InputError
    from inspect_validate.model import analyse_spectra
    from inspect_validate.report.charts import chart, error_charts, spectra_charts

    model = v.model
    marked = {}
    peaks = {}
    for ch, light in sorted(model.channels.items()):
        marked[light.name] = f"channel {ch}"
        s = light.spd
        peaks[f"{light.name} peak"] = float(s.wavelengths[np.argmax(np.nanmean(s.values, axis=0))])
    out = [
        "<h2>Spectra</h2>",
        "<p>The scene's candidate lights (dashed), those the station's channels drive (bold); "
        "the classes' reflectances (mean and range of the samples); the station's optics and "
        "camera among the scene's.</p>",
        '<div class="charts">',
        *(
            chart(spec, alt=f"component spectra: {spec['title']}")
            for spec in spectra_charts(model.scene, marked=marked)
        ),
        "</div>",
    ]
    try:
        separation = analyse_spectra(
            list(model.scene.classes),
            kde=False,
            comparisons=v.prediction.comparison_set,
        )
    except InputError as exc:
        out.append(f"<p>ε per wavelength not drawn: {html.escape(str(exc))}</p>")
        return out
    out += [
        "<p>ε_tot (Gaussian) between the classes' reflectance samples at each wavelength: "
        "where a narrow light would separate them; dotted lines mark the peaks of the "
        "station's lights.</p>",
        *(
            chart(spec, alt=f"classification error per wavelength, {spec['title']}")
            for spec in error_charts(separation, marked=peaks)
        ),
    ]
    return out


def history_html(log: HistoryLog) -> list[str]:
    """The watch history's statuses and charts (``history --plot``'s page, and a report's
    trends): the overview, the 12 charts furthest from their target (off target in
    half-widths of the band), and every illumination's charts."""
    from inspect_validate.report.charts import history_charts
    from inspect_validate.report.history import status_counts, trend_table

    e = html.escape
    out = ["<h2>Trends (watch history)</h2>"]
    out.append(
        f'<p class="meta">history {e(str(log.path))}: {len(log.cycles)} cycles '
        f"({status_counts(log)})</p>"
    )
    if not log.cycles:
        return out
    last = log.cycles[-1]
    out.append(
        f"<p>last cycle {last.cycle}: {e(last.status.upper())}"
        + (f" — {e(last.cause)}" if last.cause else "")
        + "</p>"
    )
    if not log.charts:
        return out
    (_, status), (_, overview), *illuminations = history_charts(log)
    out.append(charts([*status, *overview], what="watch history"))
    header, cells, alarmed = trend_table(log, limit=12)
    out.append(table(header, cells, failed=alarmed))
    for heading, specs in illuminations:
        out += [f"<h3>{e(heading)}</h3>", charts(specs, what=heading)]
    return out
