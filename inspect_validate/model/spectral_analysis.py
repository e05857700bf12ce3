"""Per-wavelength separability of the classes' reflectances (chapter §4.2.1, Fig. 22).

At each wavelength the reflectance samples of each class are a small sample of
numbers; ε_tot (37) between two classes (or a class and the union of the rest)
shows which bands separate them — before any light, lens or camera is chosen.
Parametric: the exact two-Gaussian error from the samples' μ (38) and σ² (39),
vectorised over wavelengths. Nonparametric: kernel densities with the LSCV
bandwidth (42)–(43), also every wavelength at once.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from inspect_validate.comparisons import Comparisons
from inspect_validate.errors import InputError
from inspect_validate.model.acquisition import ObjectClass
from inspect_validate.separations import gaussian_separation

__all__ = ["SpectralSeparation", "analyse_spectra"]


@dataclass(frozen=True, eq=False)
class SpectralSeparation:
    """ε per wavelength for every comparison, arrays (P, W)."""

    wavelengths: np.ndarray
    comparisons: tuple[tuple[tuple[str, ...], tuple[str, ...]], ...]
    error_gaussian: np.ndarray
    error_kde: np.ndarray | None


def analyse_spectra(
    classes: list[ObjectClass],
    *,
    grid: np.ndarray | None = None,
    kde: bool = True,
    resolution: float = 1e-3,
    comparisons: Comparisons | None = None,
) -> SpectralSeparation:
    """ε_tot per wavelength between the classes' reflectance samples.

    Parameters
    ----------
    classes : list of ObjectClass
        Each with at least two reflectance samples.
    grid : ndarray, keyword-only, optional
        Wavelengths, nm; default the first class's own wavelengths within the
        range every class covers.
    kde : bool, keyword-only
        Also the nonparametric error (an LSCV per class and wavelength; about 0.1 s for
        three classes of 20 spectra at 81 wavelengths).
    resolution : float, keyword-only
        Reflectance resolution of the measurement, the KDE bandwidth floor and the
        Gaussian standard deviation's. LSCV on a handful of spectra otherwise runs to
        h → 0 and spiky densities that promise errors no measurement can support.
    comparisons : Comparisons, keyword-only, optional
        Groups and their weighting (default every pair and each class against
        the rest, equal weights): a group is the mixture of its classes.
    """
    if len(classes) < 2:
        raise InputError("spectral analysis needs at least two classes")
    for c in classes:
        if c.reflectance.n_samples < 2:
            raise InputError(
                f"class {c.name!r} has one spectrum: its spread (39) needs at least two",
                source=c.reflectance.source,
            )
    lo = max(c.reflectance.range[0] for c in classes)
    hi = min(c.reflectance.range[1] for c in classes)
    if grid is None:
        w = classes[0].reflectance.wavelengths
        grid = w[(w >= lo) & (w <= hi)]
    grid = np.asarray(grid, float)
    if grid.size == 0 or grid[0] < lo or grid[-1] > hi:
        raise InputError(f"the classes' reflectances share only {lo:g}–{hi:g} nm")
    values = [c.reflectance.resample(grid) for c in classes]  # (S_k, W)
    names = [c.name for c in classes]
    comparisons = comparisons or Comparisons.of(names)
    valid = np.all([np.all(np.isfinite(v), axis=0) for v in values], axis=0)
    means = np.stack([v.mean(0) for v in values], axis=-1)  # (W, K)
    # A spread below the measurement's resolution is not resolved: raised to it, as the
    # KDE's bandwidth is (else reflectances of 1e-300 gave ε Gauss 0 beside ε KDE ½).
    variances = np.maximum(np.stack([v.var(0, ddof=1) for v in values], axis=-1), resolution**2)
    gauss = gaussian_separation(means, variances, comparisons, valid=valid).error_gaussian.T
    gauss = np.where(valid[None, :], gauss, np.nan)
    kde_err = np.full(gauss.shape, np.nan)
    if kde and valid.any():
        from inspect_validate.stats.bandwidth import lscv_bandwidths
        from inspect_validate.stats.mixture_batch import class_mixture_errors

        # Every wavelength at once; identical samples are a kernel of the resolution's
        # width (the bandwidth's floor), not undefined.
        kernels = [
            (
                v[:, valid].T,
                np.full((int(valid.sum()), v.shape[0]), 1.0 / v.shape[0]),
                np.array([b.h for b in lscv_bandwidths(v[:, valid], quantum=resolution)]),
            )
            for v in values
        ]
        w = comparisons.class_weights()
        kde_err[:, valid] = class_mixture_errors(
            kernels,
            [
                [(list(g), w[list(g)] / w[list(g)].sum()) for g in pair]
                for pair in comparisons.groups
            ],
        )
    return SpectralSeparation(
        grid,
        comparisons.named,
        gauss,
        kde_err if kde else None,
    )
