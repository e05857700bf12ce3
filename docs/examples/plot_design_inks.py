"""
Design the inks station's mix
=============================

The shipped inks station: a blue, a green and a red LED on a three-channel
controller, and three inks no single LED separates. ``iv.design`` on the station file
uses its channels, exposure and camera, and the comparisons its acceptance section
names; ``inspect-validate design inks.yaml --verify`` then captures the mix on the
simulated station and checks it.
"""

from pathlib import Path

import matplotlib.pyplot as plt

import inspect_validate as iv

station = Path(iv.__file__).resolve().parents[1] / "sample_images" / "station" / "inks.yaml"
d = iv.design(station)

# %%
names = {c: light.name for c, light in d.problem.channels.items()}
print("mix:", ", ".join(f"channel {c} ({names[c]}) {p:g} %" for c, p in d.percent.items()))
ch, _ = d.single
print(f"best single channel: {ch} ({names[ch]})")
print(
    f"worst ε Gauss: mix {d.mix.error_gaussian.max():.3g}, single {d.single_prediction.error_gaussian.max():.3g}"
)

# %%
fig, ax = plt.subplots(figsize=(5, 3))
ax.bar([names[c] for c in names], [d.percent.get(c, 0.0) for c in names])
ax.set_ylabel("drive level [%]")
fig.tight_layout()
