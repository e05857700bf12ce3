"""Measure object classes in frames: per-class statistics and class separation.

The chapter's Table 4 (μ, σ² per class) and Table 3 (SNR_dB between classes,
in pairs and one class against the union of the others), plus CNR, Fisher ratio
and the classification error ε_tot (37), parametric and nonparametric.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import TYPE_CHECKING, Literal

import numpy as np

from inspect_validate.comparisons import Comparisons, label
from inspect_validate.errors import InputError, sourced
from inspect_validate.separations import (
    GaussianSeparation,
    counted_separation,
    gaussian_separation,
    kde_separation,
)
from inspect_validate.stats import (
    LatticeSample,
    RegionStatistics,
    Shading,
    region_statistics,
    sample_moments,
)
from inspect_validate.stats.sample import gaussian_misfit

if TYPE_CHECKING:
    from inspect_validate.images import FramePaths
    from inspect_validate.roi.roiset import RoiSet
    from inspect_validate.scene_file import ComparisonsSpec

__all__ = [
    "GAUSSIAN_AGREEMENT",
    "MISFIT_MAX",
    "ClassMeasurement",
    "Comparison",
    "Limits",
    "Measurement",
    "compare",
    "compare_many",
    "measure_classes",
    "measure_files",
    "measure_stack",
    "two_populations",
]


KdeMode = Literal["auto", "always", "never"]
GAUSSIAN_AGREEMENT = 0.1
"""``kde="auto"`` skips ε KDE of a comparison where the Gaussians fit: its counted
error (the Gaussians' decision rule applied to the pixels) agrees with ε Gauss
within this fraction of it or within 3 standard errors of a count, and every class
in it is within :data:`MISFIT_MAX` of its Gaussian. ε KDE then repeats ε Gauss
within about this fraction (tested on Gaussian, skewed and bimodal classes), and it
costs most of a measurement's run time."""
MISFIT_MAX = 0.02
"""Largest Kolmogorov distance of a class from its Gaussian
(:func:`~inspect_validate.stats.sample.gaussian_misfit`) for ``kde="auto"`` to trust
the Gaussian: 2 % of the class's pixels anywhere. A Gaussian class of n pixels is on
average at 0.87/√n, so classes of fewer than about 2,000 pixels mostly get ε KDE
(it is cheap there)."""


@dataclass(frozen=True)
class ClassMeasurement:
    """Grey-value statistics of one class (Table 4), DN and DN².

    ``temporal_variance`` and ``spatial_variance`` are the EMVA 1288 components
    (:class:`~inspect_validate.stats.RegionStatistics`); ``variance`` is σ² (39)
    of all pixel values pooled over the frames, what a classifier sees.
    ``kde_bandwidth`` is the class's LSCV bandwidth (42)–(43), DN, once a
    comparison's ε KDE has needed it. ``gaussian_misfit`` is the Kolmogorov distance
    of the pooled pixel values from N(μ, σ²)
    (:func:`~inspect_validate.stats.sample.gaussian_misfit`).
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
    gaussian_misfit: float = float("nan")
    kde_bandwidth: float | None = None
    kde_bandwidth_at_floor: bool | None = None


@dataclass(frozen=True)
class Comparison:
    """Separation of two groups of classes (Table 3); a group of several is a weighted
    mixture of its classes (:mod:`inspect_validate.comparisons`).

    ``error_counted`` is the fraction of pixels the Gaussians' Bayes rule
    misclassifies (equal priors), ``error_counted_se`` the standard error such a
    count would have were the classes Gaussian
    (:class:`~inspect_validate.separations.CountedSeparation`); ``error_kde`` is
    None where it was not computed (:attr:`Measurement.skipped` says why).
    """

    first: tuple[str, ...]
    second: tuple[str, ...]
    snr_db: float
    cnr_db: float
    fisher_db: float
    error_gaussian: float
    log_error_gaussian: float
    error_kde: float | None
    error_counted: float = float("nan")
    error_counted_se: float = float("nan")

    @property
    def label(self) -> str:
        return label(self.first, self.second)


@dataclass(frozen=True)
class Limits:
    """Largest acceptable fractions of saturated and of zero (underexposed) pixels per class."""

    max_saturated: float = 0.001
    max_zero: float = 0.001

    def violations(self, classes: Sequence[ClassMeasurement]) -> tuple[str, ...]:
        """One message per class and limit exceeded."""
        return tuple(
            f"class {c.name}: {100 * frac:.3g} % {what} pixels (limit {100 * limit:.3g} %)"
            for c in classes
            for what, frac, limit in (
                ("saturated", c.saturated_fraction, self.max_saturated),
                ("zero", c.zero_fraction, self.max_zero),
            )
            if frac > limit
        )


@dataclass(frozen=True)
class Measurement:
    """Classes, comparisons and limit violations of one frame stack.

    ``weighting`` says how groups of several classes were weighted
    (``equal``, ``pixels`` or ``priors``); ``inputs`` names what was read;
    ``skipped`` says what was not computed, and why; ``warnings``, what the frames
    themselves make doubtful (:func:`~inspect_validate.measurement.unsteady_classes`).
    """

    classes: tuple[ClassMeasurement, ...]
    comparisons: tuple[Comparison, ...]
    weighting: str = "equal"
    violations: tuple[str, ...] = ()
    inputs: dict = field(default_factory=dict)
    skipped: tuple[str, ...] = ()
    warnings: tuple[str, ...] = ()

    def __repr__(self) -> str:
        classes = ", ".join(
            f"{c.name} μ {c.mean:.4g} DN σ² {c.variance:.4g} DN²" for c in self.classes[:4]
        )
        more = f", … {len(self.classes) - 4} more" if len(self.classes) > 4 else ""
        return (
            f"<Measurement: {len(self.classes)} classes ({classes}{more}), "
            f"{len(self.comparisons)} comparisons; .table() for the chapter's Tables 3–4>"
        )

    def table(self, *, saturation_limit: float | None = None) -> str:
        """The class table (μ, σ² (38)–(39)) and the separation table (SNR_dB (36), ε (37))
        as text, as ``measure`` prints them; a class saturated beyond ``saturation_limit``
        (a fraction) is marked."""
        import math
        import sys

        from inspect_validate.text import format_error, labelled, render_table

        stack = any(c.n_frames > 1 for c in self.classes)
        header = ["class", "mean [DN]", "var [DN²]", "pixels", "saturated"]
        if stack:
            header += ["temporal var", "spatial var"]
        kde = any(c.kde_bandwidth is not None for c in self.classes)
        if kde:
            header += ["KDE h [DN]"]
        rows = []
        for c in self.classes:
            flag = (
                " !"
                if saturation_limit is not None and c.saturated_fraction > saturation_limit
                else ""
            )
            row = [
                c.name,
                f"{c.mean:.2f}",
                f"{c.variance:.2f}",
                f"{c.n_pixels}",
                f"{100 * c.saturated_fraction:.2f} %{flag}",
            ]
            if stack:  # a one-pixel region has a temporal variance but no spatial one
                row += [
                    "-" if v is None else f"{v:.2f}"
                    for v in (c.temporal_variance, c.spatial_variance)
                ]
            if kde:
                h = c.kde_bandwidth
                row += ["-" if h is None else f"{h:.3g}{'*' if c.kde_bandwidth_at_floor else ''}"]
            rows.append(row)
        out = ["Classes (chapter Table 4: μ (38), σ² (39))", render_table(header, rows), ""]
        header = ["classes", "SNR_dB (36)", "CNR_dB", "Fisher_dB", "ε Gauss", "ε counted", "ε KDE"]
        rows = [
            [
                c.label,
                f"{c.snr_db:.2f}",
                f"{c.cnr_db:.2f}",
                f"{c.fisher_db:.2f}",
                format_error(c.error_gaussian, c.log_error_gaussian),
                format_error(None if math.isnan(c.error_counted) else c.error_counted),
                format_error(c.error_kde),
            ]
            for c in self.comparisons
        ]
        if not rows:
            out.append("Separation: one class, nothing to compare (give the ROIs of two or more)")
            return "\n".join(out)
        groups = {
            "equal": "equal weights",
            "pixels": "weighted by pixels",
            "priors": "class priors",
        }
        out += [
            labelled(
                "Separation",
                "chapter Table 3; ε_tot (37), a fraction, with equal priors between the sides; "
                f"a group of classes is their mixture, {groups[self.weighting]}",
                stream=sys.stdout,
            ),
            render_table(header, rows),
        ]
        if any(c.kde_bandwidth_at_floor for c in self.classes):
            out.append(
                "* KDE bandwidth at its floor of one quantisation step: LSCV wants a narrower "
                "kernel than the grey levels resolve."
            )
        return "\n".join(out)

    def _repr_html_(self) -> str:
        import html

        return f"<pre>{html.escape(self.table())}</pre>"

    def comparison(self, text: str) -> Comparison:
        """The comparison written ``text`` (``"A vs B,C"``)."""
        from inspect_validate.comparisons import find_comparison

        return self.comparisons[
            find_comparison([(c.first, c.second) for c in self.comparisons], text)
        ]


def measure_classes(
    frames: np.ndarray,
    masks: dict[str, np.ndarray],
    *,
    dark: np.ndarray | None = None,
    saturation_level: float | None = None,
    misfit: bool = True,
    shading: Shading | None = None,
) -> tuple[ClassMeasurement, ...]:
    """Per-class statistics of a frame stack (N, H, W) under class masks.

    ``misfit=False`` leaves each class's ``gaussian_misfit`` NaN (what only
    :func:`compare`'s ``kde="auto"`` reads): a production part's, a fifth of its
    statistics' time. ``shading``: the frames' shading corrected first
    (:class:`~inspect_validate.stats.Shading`).

    With ``dark`` (M frames), each pixel's dark mean carries its own temporal noise,
    σ²_dark/M, the same in every frame: it would pass for spatial variance. The
    spatial variance is corrected by it (σ²_dark the dark stack's temporal variance
    in the region); σ² (39), the variance of the dark-subtracted values a classifier
    sees, keeps it.
    """
    out = []
    for name, mask in masks.items():
        try:
            region = region_statistics(
                frames, mask, dark=dark, saturation_level=saturation_level, shading=shading
            )
            if dark is not None and dark.shape[0] > 1 and region.spatial_variance is not None:
                noise = region_statistics(dark, mask).temporal_variance
                region = replace(
                    region, spatial_variance=region.spatial_variance - noise / dark.shape[0]
                )
        except InputError as exc:
            raise InputError(f"class {name}: {exc}", source=exc.source) from None
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
                gaussian_misfit=(
                    gaussian_misfit(region.cdf, m.mean, m.variance) if misfit else math.nan
                ),
            )
        )
    return tuple(out)


def compare(
    classes: tuple[ClassMeasurement, ...],
    comparisons: Comparisons | None = None,
    *,
    kde: KdeMode = "auto",
    quantum: float | None = None,
    counted: bool = True,
) -> Measurement:
    """Separation of the classes in every comparison.

    Parameters
    ----------
    classes : tuple of ClassMeasurement
    comparisons : Comparisons, optional
        Which groups, and how a group of several classes is weighted; default
        every pair and each class against the rest, equal weights.
    kde : {"auto", "always", "never"}, keyword-only
        The nonparametric ε (kernel densities with LSCV bandwidth): for every
        comparison, for none, or (``auto``) where the Gaussians do not fit
        (:data:`GAUSSIAN_AGREEMENT`).
    quantum : float, keyword-only, optional
        Quantisation step of the grey values (the KDE bandwidth floor), DN.
    counted : bool, keyword-only
        Also the error the Gaussians' decision rule makes on the pixels (``error_counted``,
        NaN without; ``kde="auto"`` needs it). A production part leaves it out: half its
        statistics' time, and no verdict on the line reads it.
    """
    if kde == "auto" and not counted:
        raise ValueError('kde="auto" decides by the counted error: give counted=True')
    names = tuple(c.name for c in classes)
    comparisons = comparisons or Comparisons.of(names)
    if comparisons.classes != names:
        raise InputError(
            f"the comparisons are of classes {', '.join(comparisons.classes)}, "
            f"the regions of {', '.join(names)}"
        )
    pixels = [c.n_pixels for c in classes]
    means, variances = [c.mean for c in classes], [c.variance for c in classes]
    g = gaussian_separation(means, variances, comparisons, pixels=pixels)
    counted_ = None
    if counted:
        cdfs = [c.region.cdf for c in classes]  # the misfit's: a float sample sorted once
        counted_ = counted_separation(cdfs, means, variances, comparisons, pixels=pixels)
    wanted = {"always": range(len(comparisons.groups)), "never": ()}.get(kde)
    if wanted is None:
        shaped = np.array([c.gaussian_misfit <= MISFIT_MAX for c in classes])
        # Typed: one class has no comparison, and an empty list would be float.
        assert counted_ is not None  # refused above without it
        fits = counted_.fits(relative=GAUSSIAN_AGREEMENT) & np.array(
            [all(shaped[list(g1 + g2)]) for g1, g2 in comparisons.groups], dtype=bool
        )
        wanted = np.flatnonzero(~fits).tolist()
    skipped = _kde_skipped(kde, comparisons, wanted)
    k = None
    if len(wanted):
        samples = [c.region.sample for c in classes]
        k = kde_separation(samples, comparisons, pixels=pixels, quantum=quantum, only=wanted)
        classes = tuple(
            c
            if np.isnan(k.bandwidth[i])
            else replace(c, kde_bandwidth=k.bandwidth[i], kde_bandwidth_at_floor=k.at_floor[i])
            for i, c in enumerate(classes)
        )
    out = tuple(
        replace(
            c,
            error_kde=k.error[p] if k and p in wanted else None,
            error_counted=float(counted_.error[p]) if counted_ else math.nan,
            error_counted_se=float(counted_.standard_error[p]) if counted_ else math.nan,
        )
        for p, c in enumerate(_gaussian_comparisons(g, comparisons))
    )
    return Measurement(classes, out, comparisons.weighting, skipped=skipped)


def compare_many(
    classes: Sequence[tuple[ClassMeasurement, ...]], comparisons: Comparisons
) -> tuple[Measurement, ...]:
    """:func:`compare` of many measurements of the same classes at once (a batch of
    parts), Gaussian only: SNR_dB (36) and ε Gauss (37) of every comparison, the
    ε of a group's mixture one root search for the whole batch rather than one a part
    (a part's comparisons in a sixth of the time); no counted error, no KDE.
    """
    if not classes:
        return ()
    means = np.array([[c.mean for c in row] for row in classes], dtype=np.float64)
    variances = np.array([[c.variance for c in row] for row in classes], dtype=np.float64)
    pixels = np.array([[c.n_pixels for c in row] for row in classes], dtype=np.float64)
    g = gaussian_separation(means, variances, comparisons, pixels=pixels)
    skipped = _kde_skipped("never", comparisons, ())
    return tuple(
        Measurement(
            row,
            _gaussian_comparisons(g, comparisons, row=n),
            comparisons.weighting,
            skipped=skipped,
        )
        for n, row in enumerate(classes)
    )


def _gaussian_comparisons(
    g: GaussianSeparation, comparisons: Comparisons, *, row: int | None = None
) -> tuple[Comparison, ...]:
    """The comparisons of ``g`` (of combination ``row``, where it has many)."""
    at = () if row is None else (row,)
    return tuple(
        Comparison(
            first=first,
            second=second,
            snr_db=float(g.snr_db[(*at, p)]),
            cnr_db=float(g.cnr_db[(*at, p)]),
            fisher_db=float(g.fisher_db[(*at, p)]),
            error_gaussian=float(g.error_gaussian[(*at, p)]),
            log_error_gaussian=float(g.log_error_gaussian[(*at, p)]),
            error_kde=None,
        )
        for p, (first, second) in enumerate(comparisons.named)
    )


def _kde_skipped(kde: KdeMode, comparisons: Comparisons, wanted) -> tuple[str, ...]:
    left = [comparisons.labels[p] for p in range(len(comparisons.groups)) if p not in wanted]
    if not left:
        return ()
    if kde == "never":
        return ("ε KDE: not asked for (--kde never)",)
    return (
        f"ε KDE of {', '.join(left)}: the Gaussians fit (each class within "
        f"{MISFIT_MAX:.0%} of its Gaussian's distribution, the rule's counted error within "
        f"{GAUSSIAN_AGREEMENT:.0%} or 3 standard errors of ε Gauss); --kde always computes it",
    )


def measure_files(
    frames: FramePaths,
    rois: str | Path | RoiSet,
    *,
    dark: FramePaths = (),
    comparisons: Comparisons | ComparisonsSpec | None = None,
    saturation_level: float | None = None,
    limits: Limits = Limits(),
    kde: KdeMode = "auto",
    shading: Shading | None = None,
    sidecars: Mapping[Path, dict] | None = None,
) -> Measurement:
    """Measure the classes of an ROI file in a stack of frame files.

    The one measuring path of ``measure`` and ``verify``.

    Parameters
    ----------
    frames : sequence of path
        Frame files, folders or glob patterns of one camera setting (a stack).
    rois : path or RoiSet
        ROI file (YAML, ImageJ ``.roi`` / RoiSet ``.zip``) or a set already read.
    dark : sequence of path, keyword-only
        Dark frames at the same exposure and gain (subtracted per pixel).
    comparisons : Comparisons or ComparisonsSpec, keyword-only, optional
        What to compare; default every pair and each class against the rest.
    saturation_level : float, keyword-only, optional
        Raw value counted as saturated, DN; default 2^bits − 1 of the bit depth the
        frames were captured with (their sidecar or TIFF description: a Mono12 frame
        stored in uint16 saturates at 4095), else the data type's maximum.
    limits : Limits, keyword-only
        Saturated and zero fractions; exceeded ones are listed in ``violations``.
    kde : {"auto", "always", "never"}, keyword-only
        The nonparametric ε: see :func:`compare`.
    shading : Shading, keyword-only, optional
        The frames' shading corrected before measuring
        (:class:`~inspect_validate.stats.Shading`).
    sidecars : mapping, keyword-only, optional
        The frames' sidecars as a capture's audit read them (not read again).

    Raises
    ------
    InputError
        An unreadable frame or ROI file, darks of another size, an ROI outside
        the frame (each message names the file).
    """
    from inspect_validate.images import expand_paths, read_frames, recorded_bit_depth
    from inspect_validate.roi import read_rois

    # One file, folder or pattern, not its letters.
    frames = [frames] if isinstance(frames, (str, Path)) else list(frames)
    dark = [dark] if isinstance(dark, (str, Path)) else list(dark)
    # Only the regions' pixels must be numbers: NaN elsewhere (a masked border) is fine.
    stack = read_frames(frames, finite=False, sidecars=sidecars)
    if saturation_level is None and stack.dtype.kind in "ui":
        bits = recorded_bit_depth(expand_paths(frames)[0])
        if bits is not None and bits < 8 * stack.dtype.itemsize:
            saturation_level = 2**bits - 1
    dark_stack = read_frames(dark, finite=False) if dark else None
    if dark_stack is not None and dark_stack.shape[1:] != stack.shape[1:]:
        raise InputError(
            f"dark frames are {dark_stack.shape[2]}×{dark_stack.shape[1]}, frames are "
            f"{stack.shape[2]}×{stack.shape[1]}: take darks with the same camera region",
            source=str(dark[0]),
        )
    roi_set = read_rois(rois) if isinstance(rois, (str, Path)) else rois
    more = f" and {len(frames) - 1} more" if len(frames) > 1 else ""
    with sourced(f"{frames[0]}{more}"):  # errors of the pixels (a NaN in a region)
        result = measure_stack(
            stack,
            roi_set,
            dark=dark_stack,
            comparisons=comparisons,
            saturation_level=saturation_level,
            limits=limits,
            kde=kde,
            shading=shading,
        )
    inputs = {
        "frames": [str(p) for p in frames],
        "dark": [str(p) for p in dark],
        "rois": str(getattr(roi_set, "source", rois)),
        "frame_shape": list(stack.shape[1:]),
        "n_frames": stack.shape[0],
        "dtype": str(stack.dtype),
    }
    return replace(result, inputs=inputs)


def measure_stack(
    stack: np.ndarray,
    rois: RoiSet,
    *,
    dark: np.ndarray | None = None,
    comparisons: Comparisons | ComparisonsSpec | None = None,
    saturation_level: float | None = None,
    limits: Limits = Limits(),
    kde: KdeMode = "auto",
    shading: Shading | None = None,
) -> Measurement:
    """Measure the classes of a :class:`~inspect_validate.roi.RoiSet` in a frame stack
    already in memory, (N, H, W) DN: what :func:`measure_files` does once the files are
    read (a simulation's frames need none). Parameters as there; ``dark`` is the dark
    stack, (M, H, W)."""
    from inspect_validate.roi import class_masks

    masks = class_masks(rois, stack.shape[1:])
    classes = measure_classes(
        stack, masks, dark=dark, saturation_level=saturation_level, shading=shading
    )
    if not isinstance(comparisons, Comparisons):
        source = str(getattr(rois, "source", "the ROI file"))
        names = [c.name for c in classes]
        comparisons = (
            Comparisons.of(names, source=source)
            if comparisons is None
            else Comparisons.of(names, comparisons.groups, comparisons.weights, source=source)
        )
    result = compare(classes, comparisons, kde=kde)
    return replace(
        result,
        violations=limits.violations(result.classes),
        warnings=unsteady_classes(classes) + two_populations(classes, rois=rois),
    )


#: Ashman's D between the two halves of a class split at its Otsu threshold above which it
#: counts as two populations. The halves of one normal population give 2.65 whatever its
#: width; two populations 4σ apart give about 4.2 and 6σ apart about 6.
BIMODAL_D = 5.0


def two_populations(
    classes: Sequence[ClassMeasurement], *, rois: RoiSet | None = None
) -> tuple[str, ...]:
    """Classes whose grey values look like two populations: a region reaching over an
    object's edge, or drawn on a frame of another size or framing. Each class's values
    (its measured sample: every pixel of every frame, no second pass over the frames)
    are split at their Otsu threshold; where both parts hold at least 1 % of them (and
    10) and lie more than :data:`BIMODAL_D` apart in Ashman's D
    (|μ₁ − μ₂| / √((σ₁² + σ₂²)/2)), the class is named.
    """

    out = []
    recorded = getattr(rois, "frame", None) is not None
    for c in classes:
        sample = c.region.sample
        if isinstance(sample, LatticeSample):  # each lattice point its own bin: exact
            centres, counts = np.asarray(sample.points, float), np.asarray(sample.counts, float)
        else:
            values = np.asarray(sample, float)
            values = values[np.isfinite(values)]
            low_end, span = (float(values.min()), float(np.ptp(values))) if values.size else (0, 0)
            if not (np.isfinite(span) and span > 0):
                continue  # one grey value, or a range beyond floating point: nothing to split
            # Binned on [0, 1]: the histogram of values near ±1e308 has no finite bins.
            counts, edges = np.histogram((values - low_end) / span, bins=256, range=(0.0, 1.0))
            centres = low_end + span * (edges[:-1] + edges[1:]) / 2
            counts = counts.astype(float)
        n = counts.sum()
        if n < 40 or centres.size < 2:
            continue
        w0 = np.cumsum(counts)[:-1]
        m0 = np.cumsum(counts * centres)[:-1]
        total = m0[-1] + counts[-1] * centres[-1]
        with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
            between = w0 * (n - w0) * (m0 / w0 - (total - m0) / (n - w0)) ** 2
        if not np.any(np.isfinite(between)):
            continue
        cut = int(np.nanargmax(between)) + 1
        parts = [(centres[:cut], counts[:cut]), (centres[cut:], counts[cut:])]
        sizes = [float(w.sum()) for _, w in parts]
        if min(sizes) < max(0.01 * n, 10):
            continue  # a few hot or dead pixels are not a second population
        moments = []
        for x, w in parts:
            mean = float(np.average(x, weights=w))
            moments.append((mean, float(np.average((x - mean) ** 2, weights=w))))
        (m_low, v_low), (m_high, v_high) = moments
        spread = np.sqrt((v_low + v_high) / 2)
        d = abs(m_high - m_low) / spread if spread > 0 else np.inf
        if d > BIMODAL_D:
            why = (
                "a region over an object's edge?"
                if recorded
                else "a region drawn on a frame of another size or framing, or over an "
                "object's edge? (an ROI file that records its frame: [width, height] refuses "
                "another frame)"
            )
            out.append(
                f"class {c.name}: its pixels look like two populations ({sizes[0]:.0f} around "
                f"{m_low:.4g} DN, {sizes[1]:.0f} around {m_high:.4g} DN; Ashman's D "
                f"{d:.3g}): {why}"
            )
    return tuple(out)


def unsteady_classes(classes: tuple[ClassMeasurement, ...]) -> tuple[str, ...]:
    """Classes whose frames differ from each other more than their temporal noise allows:
    a stack of more than one setting or light (files without a capture's sidecars, whose
    settings cannot be compared), or a light that flickers.

    The spatial variance s²_y.spatial = s²(ȳ) − σ²_t/F (EMVA 1288) of a steady stack
    scatters about a value ≥ 0 with a standard deviation of about
    (σ²_t/F)·√(2F/(n(F − 1))) when the temporal noise dominates (n pixels, F frames);
    an estimate below −6 of them is flagged (chance: about 1e-9 per class).
    """
    out = []
    for c in classes:
        t, s, n, f = c.temporal_variance, c.spatial_variance, c.n_pixels, c.n_frames
        if t is None or s is None or f < 2 or n < 2 or t <= 0:
            continue
        if s < -6 * (t / f) * (2 * f / (n * (f - 1))) ** 0.5:
            out.append(
                f"class {c.name}: the frames differ from each other more than their noise "
                f"allows (spatial variance {s:.4g} DN², below 0; temporal {t:.4g} DN²): "
                "frames of different settings or lights in one stack, or a flickering light? "
                "Measure one setting at a time"
            )
    return tuple(out)
