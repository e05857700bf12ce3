"""Charts a report's browser draws from their data: class histograms, component spectra,
ε per wavelength and predicted against measured, as in :mod:`~inspect_validate.report.plots`
but without a picture. The page carries each chart's numbers as JSON and
`uPlot <https://github.com/leeoniya/uPlot>`_ (1.6.32 from the npm registry, MIT licence,
50 kB, in ``static/``) with a small script of ours draws them: the value under the
pointer in the legend, drag to zoom, double-click to zoom out; the page stays one file
that opens offline.

Drawing figures in matplotlib cost a verification report about 2 s on the shipped
station (its import alone 0.4 s, then 0.1–0.2 s a figure) against 1.3 s for the whole
verification; these cost milliseconds (benchmarks/bench_report.py).
"""

from __future__ import annotations

import html
import json
import math
from functools import cache
from importlib import resources
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    from collections.abc import Iterable, Mapping, Sequence

    from inspect_validate.acceptance import Agreement
    from inspect_validate.characterization.analysis import Characterization
    from inspect_validate.characterization.series import Plan
    from inspect_validate.characterization.sharpness import EdgeMTF
    from inspect_validate.measurement import ClassMeasurement
    from inspect_validate.model.spectral_analysis import SpectralSeparation
    from inspect_validate.scene import Scene
    from inspect_validate.verification.results import ClassAgreement, ComparisonAgreement
    from inspect_validate.watch.history import HistoryLog

__all__ = [
    "agreement_charts",
    "characterization_charts",
    "chart",
    "error_charts",
    "histogram_chart",
    "history_charts",
    "mtf_chart",
    "runtime",
    "spectra_charts",
]

STATUS_COLOURS = {"pass": "#2e8b57", "drift": "#e69500", "fail": "#c8102e", "error": "#777777"}
"""A watch cycle's status as a colour, in charts and pictures alike."""
_UNITS = {
    "mean": "DN",
    "variance": "DN²",
    "snr_db": "dB",
    "log_error": "log₁₀ ε",
    "slope_x": "per 100 px",
    "slope_y": "per 100 px",
}

# matplotlib's default cycle (tab10), as the PNG figures have it.
COLOURS = [
    "#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd",
    "#8c564b", "#e377c2", "#7f7f7f", "#bcbd22", "#17becf",
]  # fmt: skip


def _colour(k: int) -> str:
    return COLOURS[k % len(COLOURS)]


def _alpha(colour: str, alpha: float) -> str:
    r, g, b = (int(colour[i : i + 2], 16) for i in (1, 3, 5))
    return f"rgba({r}, {g}, {b}, {alpha})"


def _numbers(values) -> list[float | None]:
    """Values to 5 significant digits (what a chart resolves; the page stays small),
    None where not finite."""
    # Python floats, not numpy scalars: a third of the time on a page's 10⁵ numbers.
    return [
        float(f"{v:.5g}") if math.isfinite(v) else None
        for v in np.asarray(values, dtype=float).ravel().tolist()
    ]


def chart_series(label: str, x: Iterable, y: Iterable, **options: Any) -> dict[str, Any]:
    """One series of a chart: its label, x and y as JSON numbers, and its drawing options."""
    return {"label": label, "x": _numbers(x), "y": _numbers(y), **options}


@cache
def runtime() -> str:
    """uPlot, its stylesheet and the drawing script, inline: once per page."""
    static = resources.files("inspect_validate.report") / "static"
    css = (static / "uPlot.min.css").read_text()
    library = (static / "uPlot.iife.min.js").read_text()
    script = (static / "charts.js").read_text()
    return (
        f"<style>{css}\n.chart {{ margin: 0.5em 0 1.5em; }}</style>\n"
        f"<script>/* uPlot 1.6.32, MIT licence (c) Leon Sorokin */\n{library}</script>\n"
        f"<script>{script}</script>"
    )


def chart(spec: dict[str, Any], *, alt: str) -> str:
    """A ``<div>`` the page's script draws ``spec`` into; ``alt`` describes it (for a
    screen reader, and where scripts are off)."""
    data = json.dumps(spec, separators=(",", ":"), allow_nan=False).replace("</", "<\\/")
    return (
        f'<div class="chart" role="img" aria-label="{html.escape(alt)}">'
        f'<script type="application/json">{data}</script>'
        f"<noscript>{html.escape(alt)}: the chart needs JavaScript</noscript></div>"
    )


def histogram_chart(
    classes: Sequence[ClassMeasurement],
    *,
    title: str,
    kde_bandwidths: Mapping[str, float] | None = None,
) -> dict[str, Any]:
    """Each class's grey-value histogram (as a density) with its Gaussian N(μ, σ²) (dashed)
    and its kernel density estimate (41) (solid), 1/DN against DN."""
    from inspect_validate.stats import LatticeSample
    from inspect_validate.stats.mixture import kernel_density

    series = []
    for k, c in enumerate(classes):
        sample = c.region.sample
        if isinstance(sample, LatticeSample):
            points = sample.points
            step = 1.0 / sample.denominator
            merge = max(1, int(np.ceil(points.size / 256)))  # ≤ 256 bars a class
            n_bins = int(np.ceil(points.size / merge))
            counts = np.add.reduceat(sample.counts, np.arange(0, points.size, merge))
            edges = points[0] - step / 2 + np.arange(n_bins + 1) * merge * step
            density = counts / (sample.n * merge * step)
        else:
            density, edges = np.histogram(sample, bins="auto", density=True)
            if density.size > 256:
                density, edges = np.histogram(sample, bins=256, density=True)
        colour = _colour(k)
        series.append(
            chart_series(
                f"{c.name} histogram",
                edges,
                np.append(density, density[-1]),
                kind="step",
                color=colour,
                fill=_alpha(colour, 0.3),
                width=1,
            )
        )
        sd = float(np.sqrt(c.variance))
        x = np.linspace(min(edges[0], c.mean - 4 * sd), max(edges[-1], c.mean + 4 * sd), 200)
        if sd > 0:
            gauss = np.exp(-0.5 * ((x - c.mean) / sd) ** 2) / (sd * np.sqrt(2 * np.pi))
            series.append(chart_series(f"{c.name} Gaussian", x, gauss, color=colour, dash=True))
        h = (kde_bandwidths or {}).get(c.name, c.kde_bandwidth)
        if h is not None and h > 0:
            series.append(
                chart_series(
                    f"{c.name} KDE", x, kernel_density(sample, h, x), color=colour, width=2
                )
            )
    return {
        "title": title,
        "xlabel": "grey value [DN]",
        "ylabel": "density [1/DN]",
        "series": series,
    }


def spectra_charts(scene: Scene, *, marked: dict[str, str] | None = None) -> list[dict[str, Any]]:
    """Lights (normalised), reflectances (mean and sample range), optics and QE: four
    charts, as the chapter's Fig. 18. ``marked`` (light name → a note, e.g. its channel)
    draws those lights bold, the other candidates thin and dashed."""
    marked = marked or {}
    lo, hi = scene.grid[0], scene.grid[-1]
    panels = [
        ("lights", "relative SPD", [(x.name, x.spd) for x in scene.lights], True),
        ("object reflectance", "reflectance", [(c.name, c.reflectance) for c in scene.classes], False),
        ("optics transmission", "transmission", [(o.name, o.transmission) for o in scene.optics], False),
        ("camera QE", "quantum efficiency [e⁻/photon]", [(c.name, c.qe) for c in scene.cameras], False),
    ]  # fmt: skip
    charts = []
    for title, ylabel, items, normalise in panels:
        series: list[dict[str, Any]] = []
        bands = []
        for k, (name, s) in enumerate(items):
            keep = (s.wavelengths >= lo) & (s.wavelengths <= hi)
            wl, v = s.wavelengths[keep], s.values[:, keep]
            if normalise:
                v = v / np.nanmax(v)
            colour = _colour(k)
            bold = normalise and name in marked
            label = f"{name} ({marked[name]})" if bold else name
            thin = normalise and bool(marked) and not bold
            leader = len(series)
            series.append(
                chart_series(
                    label,
                    wl,
                    np.nanmean(v, axis=0),
                    color=colour,
                    width=1 if thin else 2,
                    dash=thin,
                )
            )
            if v.shape[0] > 1:
                for edge, values in (("max", np.nanmax(v, axis=0)), ("min", np.nanmin(v, axis=0))):
                    series.append(
                        {
                            "label": f"{name} sample {edge}",
                            "xref": leader,
                            "y": _numbers(values),
                            "color": _alpha(colour, 0.5),
                            "width": 0.5,
                        }
                    )
                bands.append([leader + 1, leader + 2, _alpha(colour, 0.2)])
        charts.append(
            {
                "title": title,
                "xlabel": "wavelength [nm]",
                "ylabel": ylabel,
                "series": series,
                "bands": bands,
                "width": 560,
                "height": 280,
            }
        )
    return charts


def error_charts(
    separation: SpectralSeparation, *, marked: dict[str, float] | None = None
) -> list[dict[str, Any]]:
    """ε per wavelength for every comparison, parametric and (where computed) kernel
    density (Fig. 22), on a log axis; ``marked`` (label → wavelength, nm) as vertical
    lines. A complete separation (ε below 1e-16) is drawn at 1e-16."""
    floor = 1e-16
    charts = []
    for title, data in (
        ("parametric (Gaussian)", separation.error_gaussian),
        ("nonparametric (KDE, LSCV)", separation.error_kde),
    ):
        if data is None:
            continue
        series = [
            chart_series(
                f"{','.join(a)} vs {','.join(b)}",
                separation.wavelengths,
                np.maximum(eps, floor),
                color=_colour(k),
            )
            for k, ((a, b), eps) in enumerate(zip(separation.comparisons, data, strict=True))
        ]
        below = bool(np.nanmin(data) < floor)
        charts.append(
            {
                "title": f"ε_tot per wavelength, {title}"
                + (f" (ε < {floor:g}, complete separation, drawn at {floor:g})" if below else ""),
                "xlabel": "wavelength [nm]",
                "ylabel": "ε_tot",
                "logy": True,
                "series": series,
                "vlines": [{"x": float(x), "label": name} for name, x in (marked or {}).items()],
            }
        )
    return charts


def agreement_charts(
    class_rows: list[ClassAgreement],
    comparison_rows: list[ComparisonAgreement],
    *,
    agreement: Agreement | None = None,
) -> list[dict[str, Any]]:
    """Measured − predicted against predicted: μ (% of the signal above the dark level),
    σ² (%) per illumination and class, SNR_dB (dB) per comparison, the acceptance
    tolerance as a band. Comparisons predicted and measured below the agreement floor
    are not checked and drawn hollow."""
    illuminations = list(dict.fromkeys(r.illumination for r in class_rows))
    floor = getattr(agreement, "snr_floor_db", None)

    def pct(x):
        return None if x is None else 100.0 * x

    def panel(rows, get, tolerance, title, x_unit, y_unit, checked=lambda r: True):
        values = np.array([get(r) for r in rows], dtype=float).reshape(-1, 2)
        series = []
        for i, ill in enumerate(illuminations):
            for on in (True, False):
                sel = [j for j, r in enumerate(rows) if r.illumination == ill and checked(r) == on]
                if sel:
                    label = ill if on else f"{ill} (below floor, not checked)"
                    series.append(
                        chart_series(label, values[sel, 0], values[sel, 1], kind="points",
                                color=_colour(i), hollow=not on)
                    )  # fmt: skip
        finite = values[np.isfinite(values[:, 1]), 1]
        reach = max([*np.abs(finite), 1.5 * (tolerance or 0.0), 1e-3])
        xs = values[np.isfinite(values[:, 0]), 0]
        left, right = (float(xs.min()), float(xs.max())) if xs.size else (0.0, 1.0)
        pad = 0.06 * (right - left) or max(1.0, 0.06 * abs(left))  # no point on the frame
        return {
            "title": title,
            "xlabel": f"predicted [{x_unit}]",
            "ylabel": f"measured − predicted [{y_unit}]",
            "series": series,
            "xrange": [left - pad, right + pad],
            "yrange": [-1.15 * reach, 1.15 * reach],
            "zero": True,
            **({"hband": [-tolerance, tolerance]} if tolerance is not None else {}),
            "width": 380,
            "height": 300,
        }

    return [
        panel(
            class_rows,
            lambda r: (r.predicted.mean, 100.0 * r.mean_relative),
            pct(getattr(agreement, "mean_relative", None)),
            "class mean μ",
            "DN",
            "% of signal",
        ),
        panel(
            class_rows,
            lambda r: (r.predicted.variance, 100.0 * r.variance_relative),
            pct(getattr(agreement, "variance_relative", None)),
            "class variance σ²",
            "DN²",
            "%",
        ),
        panel(
            comparison_rows,
            lambda r: (r.predicted.snr_db, r.snr_db_difference),
            getattr(agreement, "snr_db", None),
            "SNR_dB per comparison",
            "dB",
            "dB",
            checked=lambda r: floor is None or max(r.predicted.snr_db, r.measured.snr_db) >= floor,
        ),
    ]


def characterization_charts(result: Characterization, plan: Plan) -> list[dict[str, Any]]:
    """The EMVA 1288 series as charts: photon transfer (with the fitted K and the 70 %
    limit of the fit), SNR against the photons' electrons (log–log, with the linear
    model), linearity, dark signal and dark noise against the series' abscissa."""
    r = result
    signal, noise = r.mean - r.dark_mean, r.variance - r.dark_variance
    x = r.exposure_us
    abscissa = "exposure [µs]" if plan.varies == "exposure" else "LED level [%]"
    top = float(signal[r.saturation_index])
    fit = np.linspace(0.0, top, 50)
    electrons = np.maximum(signal / r.gain, 1e-3)
    from inspect_validate.components.sensors import grey_value

    _, temporal = grey_value(electrons, r.gain, r.dark_noise, 0.0)
    model = r.gain * electrons / np.sqrt(temporal)  # the EMVA 1288 SNR of μ_e
    size = {"width": 520, "height": 300}
    return [
        {
            "title": f"Photon transfer: K = {r.gain:.4g} DN/e⁻",
            "xlabel": "μ_y − μ_y.dark [DN]",
            "ylabel": "σ²_y − σ²_y.dark [DN²]",
            "series": [
                chart_series("measured", signal, noise, kind="points", color=_colour(0)),
                chart_series("K · μ (fit)", fit, r.gain * fit, color=_colour(1)),
            ],
            "vlines": [{"x": 0.7 * top, "label": "70 % of saturation"}],
            **size,
        },
        {
            "title": "Signal-to-noise ratio",
            "xlabel": "μ_e [e⁻]",
            "ylabel": "SNR",
            "logx": True,
            "logy": True,
            "series": [
                chart_series(
                    "measured", electrons, np.maximum(r.snr, 1e-3), kind="points", color=_colour(0)
                ),
                chart_series("EMVA 1288 linear model", electrons, model, color=_colour(1)),
            ],
            **size,
        },
        {
            "title": f"Linearity (error {100 * r.linearity_error:.2g} %)",
            "xlabel": abscissa,
            "ylabel": "μ_y − μ_y.dark [DN]",
            "series": [chart_series("signal", x, signal, kind="points", color=_colour(0))],
            **size,
        },
        {
            "title": "Dark signal and dark noise",
            "xlabel": abscissa,
            "ylabel": "μ_y.dark [DN], σ²_y.dark [DN²]",
            "series": [
                chart_series("μ_y.dark [DN]", x, r.dark_mean, kind="points", color=_colour(0)),
                chart_series(
                    "σ²_y.dark [DN²]", x, r.dark_variance, kind="points", color=_colour(1)
                ),
            ],
            **size,
        },
    ]


def mtf_chart(
    name: str,
    edge: EdgeMTF,
    *,
    focus: np.ndarray | None = None,
    frequencies: np.ndarray | None = None,
) -> dict[str, Any]:
    """An edge's MTF to 1 cycle/px, beside the lens's in-focus MTF (``focus`` at
    ``frequencies``) where given."""
    keep = edge.frequencies <= 1.0
    series = [chart_series("measured", edge.frequencies[keep], edge.mtf[keep], color=_colour(0))]
    if focus is not None and frequencies is not None:
        series.append(
            chart_series("in focus (diffraction × pixel)", frequencies, focus, color=_colour(1))
        )
    return {
        "title": f"{name}: MTF (MTF50 {edge.mtf50:.3g} cycles/px)",
        "xlabel": "cycles/px",
        "ylabel": "MTF",
        "series": series,
        "width": 520,
        "height": 300,
    }


def history_charts(log: HistoryLog) -> list[tuple[str, list[dict[str, Any]]]]:
    """A watch history as charts, in sections (heading, charts): each cycle's status; per
    illumination every chart's smoothed value off its golden target in band half-widths
    (beyond ±1 is an alarm; charts that alarmed in colour, the others grey); then each
    illumination's EWMA charts: each cycle's value (dots), the smoothed value (line),
    the control band around the golden target (shaded) and the alarms (red)."""
    cycles = np.array([r.cycle for r in log.cycles], dtype=float)
    statuses = [r.status for r in log.cycles]
    status = {
        "title": "status per cycle",
        "xlabel": "cycle",
        "ylabel": "",
        "height": 140,
        "yrange": [0, 2],
        "xinteger": True,
        "series": [
            chart_series(
                f"{name} ({n})",
                cycles[at],
                np.ones(int(n)),
                kind="points",
                color=STATUS_COLOURS[name],
            )
            for name in STATUS_COLOURS
            if (n := (at := np.array([x == name for x in statuses], bool)).sum())
        ],
    }
    sections: list[tuple[str, list[dict[str, Any]]]] = [("status", [status])]
    overview: list[dict[str, Any]] = []
    for ill in log.illuminations:
        series: list[dict[str, Any]] = []
        k = 0
        for key, c in sorted(log.charts.items()):
            if key[0] != ill:
                continue
            alarmed = bool(c.alarm.any())
            series.append(
                chart_series(
                    f"{key[2]} {key[3]}",
                    c.cycle,
                    c.deviation,
                    color=_colour(k) if alarmed else "#b3b3b3",
                    width=1.5 if alarmed else 0.8,
                )
            )
            k += alarmed
        finite = [
            v
            for key, c in log.charts.items()
            if key[0] == ill
            for v in c.deviation
            if np.isfinite(v)
        ]
        lowest, highest = (min(finite), max(finite)) if finite else (0.0, 0.0)
        overview.append(
            {
                "title": f"illumination {ill}: charts off target",
                "xlabel": "cycle",
                "ylabel": "off target [band]",
                "hband": [-1, 1],
                "xinteger": True,
                # The band's edges (±1, an alarm beyond) stay in sight however close
                # the charts keep to their targets.
                "yrange": [min(-1.25, lowest), max(1.25, highest)],
                "series": series,
            }
        )
    sections.append(("off target", overview))
    band = _alpha("#2e8b57", 0.6)
    for ill in log.illuminations:
        charts: list[dict[str, Any]] = []
        for key, c in sorted(log.charts.items()):
            if key[0] != ill:
                continue
            alarm = c.alarm
            charts.append(
                {
                    "title": f"{key[2]} {key[3]}",
                    "xlabel": "cycle",
                    "xinteger": True,
                    "ylabel": _UNITS.get(key[3], ""),
                    "width": 420,
                    "height": 220,
                    "series": [
                        chart_series("band high", c.cycle, c.high, color=band, width=0.8),
                        *(
                            {"label": label, "xref": 0, "y": _numbers(y), **options}
                            for label, y, options in (
                                ("band low", c.low, {"color": band, "width": 0.8}),
                                ("value", c.value, {"kind": "points", "color": "#8c8c8c"}),
                                ("EWMA", c.ewma, {"color": COLOURS[0], "width": 1.5}),
                                (
                                    "alarm",
                                    np.where(alarm, c.ewma, np.nan),
                                    {"kind": "points", "color": STATUS_COLOURS["fail"]},
                                ),
                            )
                        ),
                    ],
                    "bands": [[0, 1, _alpha("#2e8b57", 0.12)]],
                }
            )
        sections.append((f"illumination {ill}: value, EWMA, control band, alarms", charts))
    return sections
