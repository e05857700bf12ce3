"""PNG plots: component spectra, per-wavelength errors, ranked separation (a prediction);
a frame with its regions (a verification's page, whose charts are
:mod:`~inspect_validate.report.charts`);
the mixed spectrum and the path from the best single channel to the mix (a design);
a watch history's trends.

Each function draws to ``target``, a path or a binary file object (the HTML
report embeds the bytes). matplotlib is imported here only (figures drawn by Agg,
without pyplot: no display needed).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import TYPE_CHECKING, Any, BinaryIO, TypeVar

import numpy as np

if TYPE_CHECKING:
    from typing import BinaryIO

    from matplotlib.figure import Figure

    from inspect_validate.mix_design.solve import Design
    from inspect_validate.model.spectral_analysis import SpectralSeparation
    from inspect_validate.scene import Scene
    from inspect_validate.watch.history import HistoryLog


Target = TypeVar("Target", bound=str | Path | BinaryIO)  # a file, returned as given

__all__ = [
    "plot_component_spectra",
    "plot_design_path",
    "plot_design_spectrum",
    "plot_frame_regions",
    "plot_history_charts",
    "plot_history_overview",
    "plot_ranked_separation",
    "plot_spectral_errors",
]


def subplots(
    nrows: int = 1, ncols: int = 1, *, figsize: tuple[float, float], **options: Any
) -> tuple[Figure, Any]:
    """pyplot's ``subplots`` without pyplot: a :class:`matplotlib.figure.Figure` of its own,
    drawn by Agg and freed with its last reference (no figure manager, nothing to close)."""
    from matplotlib.figure import Figure

    fig = Figure(figsize=figsize)
    return fig, fig.subplots(nrows, ncols, **options)


def save_figure(
    fig: Figure,
    target: Target,
    *,
    rect: tuple[float, float, float, float] | None = None,
) -> Target:
    fig.tight_layout(rect=rect)
    fig.savefig(target, dpi=110, format="png")
    return target


def _colour(k: int) -> str:
    return f"C{k % 10}"


def plot_component_spectra(
    scene: Scene, path: Target, *, marked: dict[str, str] | None = None
) -> Target:
    """Lights (normalised), reflectances (mean ± sample range), optics and QE, as the chapter's Fig. 18.

    ``marked`` maps light names to a note (e.g. the controller channel driving
    it): those are drawn bold and labelled with it, the other candidates thin.
    """
    marked = marked or {}
    fig, axes = subplots(2, 2, figsize=(11, 7), sharex=True)
    panels = [
        ("lights (relative SPD)", [(x.name, x.spd) for x in scene.lights], True),
        ("object reflectance", [(c.name, c.reflectance) for c in scene.classes], False),
        ("optics transmission", [(o.name, o.transmission) for o in scene.optics], False),
        ("camera QE", [(c.name, c.qe) for c in scene.cameras], False),
    ]
    lo, hi = scene.grid[0], scene.grid[-1]
    for ax, (title, items, normalise) in zip(axes.ravel(), panels, strict=True):
        for name, s in items:
            keep = (s.wavelengths >= lo) & (s.wavelengths <= hi)
            wl, v = s.wavelengths[keep], s.values[:, keep]
            if normalise:
                v = v / np.nanmax(v)
            if normalise and marked:
                bold = name in marked
                label = f"{name} ({marked[name]})" if bold else name
                line = ax.plot(
                    wl,
                    np.nanmean(v, axis=0),
                    label=label,
                    lw=2.2 if bold else 0.8,
                    ls="-" if bold else "--",
                )[0]
            else:
                line = ax.plot(wl, np.nanmean(v, axis=0), label=name)[0]
            if v.shape[0] > 1:
                ax.fill_between(
                    wl,
                    np.nanmin(v, axis=0),
                    np.nanmax(v, axis=0),
                    color=line.get_color(),
                    alpha=0.25,
                )
        ax.set_title(title)
        ax.legend(fontsize=7)
    for ax in axes[1]:
        ax.set_xlabel("wavelength [nm]")
    axes[0][0].set_ylabel("relative SPD")
    axes[0][1].set_ylabel("reflectance")
    axes[1][0].set_ylabel("transmission")
    axes[1][1].set_ylabel("quantum efficiency [e⁻/photon]")
    return save_figure(fig, path)


def plot_spectral_errors(
    separation: SpectralSeparation, path: Target, *, marked: dict[str, float] | None = None
) -> Target:
    """ε per wavelength for every comparison, parametric and kernel density (Fig. 22).

    ``marked`` maps labels to wavelengths (nm) drawn as vertical lines, e.g. the
    peaks of the lights a station uses.
    """
    fig, axes = subplots(
        1,
        2 if separation.error_kde is not None else 1,
        figsize=(11, 4.6),
        squeeze=False,
        sharey=True,
    )
    floor = 1e-16  # a log axis cannot show 0: complete separation is drawn here, and said so
    for ax, (title, data) in zip(
        axes[0],
        [
            (title, errors)
            for title, errors in (
                ("parametric (Gaussian)", separation.error_gaussian),
                ("nonparametric (KDE, LSCV)", separation.error_kde),
            )
            if errors is not None
        ],
        strict=True,
    ):
        for (a, b), eps in zip(separation.comparisons, data, strict=True):
            ax.semilogy(
                separation.wavelengths,
                np.maximum(eps, floor),
                label=f"{','.join(a)} vs {','.join(b)}",
            )
        if np.nanmin(data) < floor:
            ax.axhline(floor, color="0.5", ls="--", lw=0.8)
            ax.annotate(
                f"ε < {floor:g} (complete separation) drawn at {floor:g}",
                (0.01, floor),
                xycoords=("axes fraction", "data"),
                xytext=(0, 3),
                textcoords="offset points",
                fontsize=7,
                color="0.3",
            )
        for k, (name, wl) in enumerate((marked or {}).items()):
            ax.axvline(wl, color="0.3", ls=":", lw=1)
            # Above the plot, not over the curves; alternate heights keep close lights apart.
            ax.annotate(
                name,
                (wl, 1.0),
                xycoords=("data", "axes fraction"),
                ha="center",
                va="bottom",
                fontsize=7,
                xytext=(0, 2 + 9 * (k % 2)),
                textcoords="offset points",
            )
        ax.set_title(f"ε_tot per wavelength, {title}", pad=24 if marked else 6)
        ax.set_xlabel("wavelength [nm]")
        ax.legend(fontsize=7)
    axes[0][0].set_ylabel("classification error ε_tot")
    return save_figure(fig, path)


def plot_ranked_separation(rows: list[dict], path: Target, *, by: str = "error") -> Target:
    """The ranked combinations, best first, by the value the table ranks them by: each
    row's key comparison's ε Gauss (log scale), SNR_dB or CNR_dB, written at each bar."""
    labels = [f"{r['rank']}: {r['light']} / {r['optics']} / {r['camera']}" for r in rows]
    keys = [r["comparisons"][r["key_comparison"]] for r in rows]
    quantity = {"error": "error_gaussian"}.get(by, by)
    values = np.array([k[quantity] for k in keys], dtype=float)
    names = sorted({f"{','.join(k['first'])} vs {','.join(k['second'])}" for k in keys})
    fig, ax = subplots(figsize=(9, 0.35 * len(rows) + 1.5))
    if by == "error":
        shown = np.maximum(values, 1e-300)
        ax.barh(range(len(rows)), shown, color="tab:blue")
        wide = shown.max() > 10 * shown.min()  # else a log axis exaggerates the differences
        if wide:
            ax.set_xscale("log")
        texts = [f"{v:.3g}" for v in values]
        what = f"predicted ε Gauss (a fraction{', log scale' if wide else ''})"
    else:
        shown = values
        ax.barh(range(len(rows)), shown, color="tab:blue")
        texts = [f"{v:.2f} dB" for v in values]
        what = f"predicted {'SNR_dB' if by == 'snr_db' else 'CNR_dB'} [dB]"
    for y, (x, text) in enumerate(zip(shown, texts, strict=True)):
        ax.annotate(
            text, (x, y), xytext=(3, 0), textcoords="offset points", va="center", fontsize=7
        )
    ax.set_yticks(range(len(rows)), labels, fontsize=7)
    ax.invert_yaxis()
    ax.set_xlabel(f"{what} of {', '.join(names)}: the table's ranking")
    return save_figure(fig, path)


def plot_frame_regions(
    frame: np.ndarray, masks: dict[str, np.ndarray], target: str | Path | BinaryIO
) -> tuple[float, float]:
    """One frame with each class's region outlined and named (a JPEG, by OpenCV: a picture
    of pixels needs no plotting library), contrast-stretched to the 0.5–99.5 percentiles
    of the regions' pixels (the background does not set the stretch). Returns that
    stretch, DN, for the caption."""
    import cv2

    from inspect_validate.roi.overlay import draw_regions

    frame = np.asarray(frame)
    inside = np.logical_or.reduce(list(masks.values())) if masks else np.ones(frame.shape, bool)
    values = frame[inside]
    if frame.dtype.kind == "f":
        values = values[np.isfinite(values)]
        frame = np.nan_to_num(frame)
    step = max(1, values.size // 2**18)  # percentiles of ≤ 256 k pixels suffice
    lo, hi = np.percentile(values[::step], [0.5, 99.5]) if values.size else (0.0, 1.0)
    if not hi > lo:
        hi = lo + 1.0
    picture = draw_regions(frame, masks, limits=(float(lo), float(hi)))
    # JPEG: a noisy frame does not compress as PNG (2.5 MB a 5 MP frame's picture).
    encoded, jpeg = cv2.imencode(".jpg", picture, [cv2.IMWRITE_JPEG_QUALITY, 90])
    if not encoded:
        raise RuntimeError("OpenCV could not encode the frame as JPEG")
    data = jpeg.tobytes()
    if isinstance(target, str | Path):
        Path(target).write_bytes(data)
    else:
        target.write(data)
    return float(lo), float(hi)


def plot_design_spectrum(design: Design, path: Target) -> Target:
    """The designed mix's irradiance at the object, stacked by channel, over the classes'
    reflectances (mean and sample range) and the camera's relative sensitivity (optics
    transmission × QE)."""
    from inspect_validate.errors import InputError
    from inspect_validate.station.model import illumination_light

    p = design.problem
    grid = p.grid
    fig, ax = subplots(figsize=(10, 4.5))
    parts, labels = [], []
    for c, percent in design.percent.items():
        try:
            light = illumination_light(str(c), {c: percent}, p.channels, grid=grid)
        except InputError:
            continue  # a channel with no light on the grid adds nothing
        parts.append(light.spd.values[0])
        labels.append(f"channel {c} ({p.channels[c].name}) {percent:g} %")
    if parts:
        ax.stackplot(grid, np.array(parts), labels=labels, alpha=0.8)
    ax.set_xlabel("wavelength [nm]")
    ax.set_ylabel("irradiance at the object [W m⁻² nm⁻¹]")
    ax.set_title(
        f"designed mix at {1e3 * design.exposure_time:.4g} ms exposure"
        + (" (auto)" if p.auto_exposure else "")
    )
    ax.legend(loc="upper left", fontsize=7)
    right = ax.twinx()
    for k, cls in enumerate(p.classes):
        r = cls.reflectance.resample(grid)
        right.plot(
            grid, np.nanmean(r, axis=0), color=_colour(k + len(parts)), lw=1.2, label=cls.name
        )
        if r.shape[0] > 1:
            right.fill_between(
                grid,
                np.nanmin(r, axis=0),
                np.nanmax(r, axis=0),
                color=_colour(k + len(parts)),
                alpha=0.15,
            )
    sensitivity = np.nan_to_num(p.optics.transmission.resample(grid)[0]) * np.nan_to_num(
        p.sensor.qe.resample(grid)[0]
    )
    if sensitivity.max() > 0:
        right.plot(
            grid, sensitivity / sensitivity.max(), "k--", lw=1, label="optics × QE (relative)"
        )
    right.set_ylabel("reflectance; relative sensitivity")
    right.set_ylim(0, None)
    right.legend(loc="upper right", fontsize=7)
    return save_figure(fig, path)


def plot_design_path(design: Design, path: Target) -> Target:
    """ε and CNR_dB of the objective's comparisons along the straight path from the best
    single channel (0) to the designed mix (1): how much the mix gains, and where."""
    p = design.problem
    fraction, errors, cnr = (design.path[k] for k in ("fraction", "errors", "cnr"))
    fig, (left, right) = subplots(1, 2, figsize=(11, 4), sharex=True)
    with np.errstate(divide="ignore"):
        cnr_db = 20.0 * np.log10(cnr)
    for j, label in enumerate(p.objective.labels):
        left.semilogy(fraction, np.maximum(errors[:, j], 1e-300), color=_colour(j), label=label)
        right.plot(fraction, cnr_db[:, j], color=_colour(j), label=label)
    if design.objective == "error":  # the objective's worst, on its own panel
        left.semilogy(
            fraction, np.maximum(errors.max(axis=1), 1e-300), "k", lw=2.2, alpha=0.35, label="worst"
        )
    else:
        right.plot(fraction, cnr_db.min(axis=1), "k", lw=2.2, alpha=0.35, label="worst")
    channel = design.single[0]
    for ax in (left, right):
        ax.set_xlabel(f"0: channel {channel} alone  →  1: designed mix")
        ax.legend(fontsize=7)
    left.set_ylabel("predicted ε_tot")
    right.set_ylabel("predicted CNR [dB]")
    left.set_title("classification error along the path")
    right.set_title("contrast-to-noise ratio along the path")
    return save_figure(fig, path)


def plot_history_overview(log: HistoryLog, target: Target) -> Target:
    """A watch history at a glance: each cycle's status, and per illumination every chart's
    smoothed value off its golden target in band half-widths (beyond ±1 is an alarm;
    charts that alarmed are labelled, the others grey)."""
    illuminations = log.illuminations
    fig, axes = subplots(
        1 + len(illuminations),
        1,
        figsize=(10, 1.2 + 2.6 * len(illuminations)),
        sharex=True,
        gridspec_kw={"height_ratios": [0.35] + [1] * len(illuminations)},
        squeeze=False,
    )
    axes = axes[:, 0]
    strip = axes[0]
    cycles = np.array([r.cycle for r in log.cycles])
    from inspect_validate.report.charts import STATUS_COLOURS

    for status, colour in STATUS_COLOURS.items():
        at = cycles[[r.status == status for r in log.cycles]] if cycles.size else cycles
        if at.size:
            strip.bar(at, 1.0, width=1.0, color=colour, label=f"{status} ({at.size})")
    strip.set_yticks([])
    strip.set_title(f"{Path(log.station).name}: status per cycle", fontsize=9)
    strip.legend(loc="upper left", bbox_to_anchor=(1.0, 1.3), fontsize=7, frameon=False)
    for ax, ill in zip(axes[1:], illuminations, strict=True):
        k = 0
        for key, s in sorted(log.charts.items()):
            if key[0] != ill:
                continue
            if s.alarm.any():
                ax.plot(s.cycle, s.deviation, color=_colour(k), lw=1.4, label=_chart_title(key))
                k += 1
            else:
                ax.plot(s.cycle, s.deviation, color="0.7", lw=0.8)
        ax.axhspan(-1, 1, color="#2e8b57", alpha=0.07)
        for y in (-1, 1):
            ax.axhline(y, color="k", ls="--", lw=0.8)
        ax.set_ylabel("off target [band]")
        ax.set_title(f"illumination {ill}", fontsize=9)
        if k:
            ax.legend(loc="upper left", bbox_to_anchor=(1.0, 1.0), fontsize=7, frameon=False)
    axes[-1].set_xlabel("cycle")
    _whole_cycles(axes[-1])
    return save_figure(fig, target)


def _chart_title(key: tuple) -> str:
    """``[camera] name quantity`` of a history chart's key (the camera, of several)."""
    return " ".join(filter(None, (key[4], key[2], key[3])))


def _whole_cycles(ax) -> None:
    """Ticks at whole cycles only (a history of three cycles had ticks at 0.5, 1.5)."""
    from matplotlib.ticker import MaxNLocator

    ax.xaxis.set_major_locator(MaxNLocator(integer=True))


def plot_history_charts(log: HistoryLog, illumination: str, target: Target) -> Target:
    """The EWMA charts of one illumination: each cycle's value (dots), the smoothed value
    (line), the control band around the golden target (shaded) and alarms (red)."""
    charts = sorted((k, s) for k, s in log.charts.items() if k[0] == illumination)
    ncols = min(4, max(len(charts), 1))
    nrows = max(math.ceil(len(charts) / ncols), 1)
    fig, axes = subplots(
        nrows, ncols, figsize=(3.2 * ncols, 2.4 * nrows + 0.4), sharex=True, squeeze=False
    )
    units = {"mean": "DN", "variance": "DN²", "snr_db": "dB", "log_error": "log₁₀ ε"}
    for ax, (key, s) in zip(axes.flat, charts, strict=False):
        ax.fill_between(s.cycle, s.low, s.high, color="#2e8b57", alpha=0.12, step="mid")
        ax.axhline(s.target, color="#2e8b57", lw=0.8)
        ax.plot(s.cycle, s.value, ".", color="0.55", ms=3)
        ax.plot(s.cycle, s.ewma, color="C0", lw=1.3)
        alarm = s.alarm
        ax.plot(s.cycle[alarm], s.ewma[alarm], "o", color="#c8102e", ms=3.5)
        ax.set_title(_chart_title(key), fontsize=8)
        ax.set_ylabel(units.get(key[3], ""), fontsize=7)
        ax.tick_params(labelsize=7)
    for ax in list(axes.flat)[len(charts) :]:
        ax.set_visible(False)
    for ax in axes[-1]:
        ax.set_xlabel("cycle", fontsize=8)
        _whole_cycles(ax)  # the axes share x
    fig.suptitle(f"illumination {illumination}: value, EWMA, control band, alarms", fontsize=10)
    return save_figure(fig, target, rect=(0, 0, 1, 0.96))
