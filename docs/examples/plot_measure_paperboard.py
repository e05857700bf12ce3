"""
Measure the chapter's paperboards (Tables 3–4)
==============================================

Three paperboards, C (top), B and A (bottom), photographed under the chapter's
"optimized" (amber LED) and "non-optimized" (red LED) illumination. ``iv.measure``
gives each class's μ (38) and σ² (39) in DN and the separation of every comparison;
weighting groups by pixel count reproduces how the chapter computes "A vs B,C".
"""

from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

import inspect_validate as iv
from inspect_validate.images import read_image
from inspect_validate.roi import class_masks
from inspect_validate.scene_file import ComparisonsSpec

samples = Path(iv.__file__).resolve().parents[1] / "sample_images" / "paperboard"
rois = iv.read_rois(samples / "rois.yaml")
by_pixels = ComparisonsSpec(weights="pixels")

# %%
# The class table and the separations, as ``inspect-validate measure`` prints them.
for frame in ("optimized.png", "non_optimized.png"):
    m = iv.measure(samples / frame, rois, comparisons=by_pixels)
    print(frame)
    for c in m.classes:
        print(f"  {c.name}: μ = {c.mean:7.2f} DN, σ² = {c.variance:6.2f} DN²")
    for c in m.comparisons:
        print(f"  {c.label:9s} SNR_dB {c.snr_db:7.2f} dB, ε Gauss {c.error_gaussian:.3g}")

# %%
# Each class's grey values and its Gaussian: under the amber LED the three classes sit
# apart; under the red one they overlap.
fig, axes = plt.subplots(1, 2, figsize=(9, 3.2), sharey=True)
for ax, frame in zip(axes, ("optimized.png", "non_optimized.png"), strict=True):
    image = read_image(samples / frame)
    masks = class_masks(rois, image.shape)
    for name, mask in masks.items():
        values = image[mask].astype(float)
        mu, var = values.mean(), values.var(ddof=1)
        edges = np.arange(values.min() - 0.5, values.max() + 1.5)
        ax.hist(values, bins=edges, density=True, alpha=0.45, label=name)
        x = np.linspace(edges[0], edges[-1], 300)
        ax.plot(x, np.exp(-((x - mu) ** 2) / (2 * var)) / np.sqrt(2 * np.pi * var), lw=1)
    ax.set_title(frame)
    ax.set_xlabel("grey value [DN]")
axes[0].set_ylabel("density")
axes[0].legend(title="class")
fig.tight_layout()
