"""
Design a mix of LED channels
============================

Three LED channels (blue, green, red) and three ink classes. ``iv.design`` finds the
drive levels that minimise the worst comparison's ε Gauss with no class saturating,
and compares the mix with the best single channel.
"""

from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

import inspect_validate as iv

scene_file = (
    Path(iv.__file__).resolve().parents[1] / "sample_images" / "scenes" / "mix" / "scene.yaml"
)
d = iv.design(scene_file)
labels = d.mix.comparison_set.labels

# %%
print("mix:", ", ".join(f"{d.problem.channels[k].name} {v:.1f} %" for k, v in d.percent.items()))
print("best single channel:", d.problem.channels[d.single[0]].name)
print("worst ε Gauss, single:", f"{d.single_prediction.error_gaussian.max():.3g}")
print("worst ε Gauss, mix:   ", f"{d.mix.error_gaussian.max():.3g}")

# %%
fig, ax = plt.subplots(figsize=(7, 3))
x = np.arange(len(labels))
ax.bar(x - 0.2, d.single_prediction.error_gaussian[0, 0, 0], width=0.4, label="best single")
ax.bar(x + 0.2, d.mix.error_gaussian[0, 0, 0], width=0.4, label="mix")
ax.set_xticks(x, labels)
ax.set_yscale("log")
ax.set_ylabel("ε Gauss (fraction)")
ax.legend()
fig.tight_layout()
