"""
Predict the paperboards from their spectra
==========================================

The same three paperboards, this time from spectrometer readings of each board, the
two LEDs' spectra, the lens and the camera's quantum efficiency. ``iv.predict`` gives
every combination's μ, σ² and ε; the amber LED separates A from B and C far better
than the red one, as the images of the previous example show.
"""

from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

import inspect_validate as iv

scene_file = (
    Path(iv.__file__).resolve().parents[1]
    / "sample_images"
    / "scenes"
    / "paperboard"
    / "scene.yaml"
)
scene = iv.read_scene(scene_file)
p = iv.predict(scene)

# %%
# ε Gauss of every comparison under each light (one lens, one camera here).
labels = p.comparison_set.labels
for i, light in enumerate(p.lights):
    row = ", ".join(f"{lab} {p.error_gaussian[i, 0, 0, j]:.3g}" for j, lab in enumerate(labels))
    print(f"{light}: {row}")

# %%
# What the light sees: the LEDs' spectra over the classes' mean reflectances.
fig, ax = plt.subplots(figsize=(7, 3.2))
for c in scene.classes:
    r = c.reflectance
    ax.plot(r.wavelengths, np.mean(r.values, axis=0), label=f"class {c.name}")
ax.set_xlabel("wavelength [nm]")
ax.set_ylabel("reflectance")
ax.set_xlim(400, 700)
twin = ax.twinx()
for light in scene.lights:
    spd = light.spd
    twin.fill_between(spd.wavelengths, spd.values[0] / spd.values[0].max(), alpha=0.2)
    twin.text(spd.wavelengths[np.argmax(spd.values[0])], 1.02, light.name, ha="center")
twin.set_ylim(0, 1.15)
twin.set_ylabel("relative SPD")
ax.legend(loc="lower right")
fig.tight_layout()

# %%
# ε Gauss per comparison and light, on a log axis.
fig, ax = plt.subplots(figsize=(7, 3))
x = np.arange(len(labels))
for i, light in enumerate(p.lights):
    ax.bar(x + 0.4 * i - 0.2, p.error_gaussian[i, 0, 0], width=0.4, label=light)
ax.set_xticks(x, labels)
ax.set_yscale("log")
ax.set_ylabel("ε Gauss (fraction)")
ax.legend()
fig.tight_layout()
