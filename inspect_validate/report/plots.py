"""PNG plots of a prediction: component spectra, per-wavelength errors, ranked separation.

matplotlib is imported here only (Agg backend, no display needed).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

__all__ = ["plot_component_spectra", "plot_ranked_separation", "plot_spectral_errors"]


def _pyplot():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def plot_component_spectra(scene, path: Path) -> Path:
    """Lights (normalised), reflectances (mean ± sample range), optics and QE, as the chapter's Fig. 18."""
    plt = _pyplot()
    fig, axes = plt.subplots(2, 2, figsize=(11, 7), sharex=True)
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
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def plot_spectral_errors(separation, path: Path) -> Path:
    """ε per wavelength for every comparison, parametric and kernel density (Fig. 22)."""
    plt = _pyplot()
    fig, axes = plt.subplots(
        1, 2 if separation.error_kde is not None else 1, figsize=(11, 4), squeeze=False, sharey=True
    )
    for ax, (title, data) in zip(
        axes[0],
        [
            ("parametric (Gaussian)", separation.error_gaussian),
            ("nonparametric (KDE, LSCV)", separation.error_kde),
        ],
        strict=False,
    ):
        for (a, b), eps in zip(separation.comparisons, data, strict=True):
            ax.semilogy(
                separation.wavelengths,
                np.maximum(eps, 1e-16),
                label=f"{','.join(a)} vs {','.join(b)}",
            )
        ax.set_title(f"ε_tot per wavelength, {title}")
        ax.set_xlabel("wavelength [nm]")
        ax.legend(fontsize=7)
    axes[0][0].set_ylabel("classification error ε_tot")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def plot_ranked_separation(rows: list[dict], path: Path) -> Path:
    """ε Gauss of the ranked combinations (log scale), best first."""
    plt = _pyplot()
    labels = [f"{r['rank']}: {r['light']} / {r['optics']} / {r['camera']}" for r in rows]
    eps = [max(c["error_gaussian"] for c in r["comparisons"]) for r in rows]
    fig, ax = plt.subplots(figsize=(9, 0.35 * len(rows) + 1.5))
    ax.barh(range(len(rows)), np.maximum(eps, 1e-300), color="tab:blue")
    ax.set_xscale("log")
    ax.set_yticks(range(len(rows)), labels, fontsize=7)
    ax.invert_yaxis()
    ax.set_xlabel("predicted ε_tot (worst listed comparison)")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path
