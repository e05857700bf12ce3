"""
The chapter's simulated study (Table 2)
=======================================

Two lights (daylight D65 and a 450 nm LED), two optics and two cameras: eight
combinations, ranked by ``iv.sweep`` as ``inspect-validate predict`` ranks them.
"""

from pathlib import Path

import matplotlib.pyplot as plt

import inspect_validate as iv

scene_file = (
    Path(iv.__file__).resolve().parents[1]
    / "sample_images"
    / "scenes"
    / "chapter_table2"
    / "scene.yaml"
)
ranking = iv.sweep(scene_file, by="snr_db", top=8)

# %%
# Best first: which light, optics and camera, and the SNR_dB (36) of object 1 vs 2.
names = []
for row, (li, oi, ci) in enumerate(ranking.index):
    name = f"{ranking.lights[li]} · {ranking.optics[oi]} · {ranking.cameras[ci]}"
    names.append(name)
    print(f"{row + 1}. {name}: SNR_dB {ranking.snr_db[row, 0]:.2f} dB")

# %%
fig, ax = plt.subplots(figsize=(7, 3.4))
ax.barh(names[::-1], ranking.snr_db[::-1, 0])
ax.set_xlabel("SNR_dB, object1 vs object2 [dB]")
fig.tight_layout()
