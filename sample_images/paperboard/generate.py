"""Generate the paperboard sample frames that reproduce the chapter's Tables 3 and 4.

Three paperboards, C (top), B (middle) and A (bottom) as in the chapter's Fig. 23,
imaged under the "optimized" (amber LED) and "non-optimized" (red LED)
illumination. Each board is 8-bit white noise whose ROI pixels are then nudged,
one grey level at a time, until their mean and unbiased variance equal Table 4
to within ±0.01 — so ``inspect-validate measure`` reproduces Table 4 and Table 3.

The ROI of B holds 62 % of the pixels of B and C together: with that share the
union "B,C" also reproduces Table 3's A vs B,C row (−18 / −26 dB); with equal
shares it would be −18.9 / −25.0 dB.

Run ``python sample_images/paperboard/generate.py`` to rewrite the files; the
output is deterministic.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

HERE = Path(__file__).parent
WIDTH, HEIGHT = 640, 480
TABLE4 = {  # chapter Table 4: (μ, σ²) per object
    "optimized": {"A": (127.0, 42.3), "B": (111.4, 41.0), "C": (119.3, 47.6)},
    "non_optimized": {"A": (113.2, 37.2), "B": (115.3, 34.8), "C": (120.5, 44.9)},
}
ROIS = {"C": (40, 30, 560, 100), "B": (40, 180, 560, 163), "A": (40, 375, 560, 80)}
BOARD_MARGIN = 12  # board extends beyond its ROI; the ROI keeps edges out
BACKGROUND = 30


def _match_moments(values: np.ndarray, mean: float, var: float, rng, tol: float = 0.01):
    """Nudge integer values by ±1 until sample mean and variance are within ``tol``."""
    x = values.astype(np.int64)
    n = x.size
    for _ in range(200_000):
        m = x.mean()
        v = x.var(ddof=1)
        if abs(m - mean) <= tol and abs(v - var) <= tol:
            return x
        i = rng.integers(n)
        if abs(m - mean) > tol:
            # Move a value near the mean, which changes the variance least.
            step = 1 if m < mean else -1
            near = np.flatnonzero(np.abs(x - m) <= 1)
            x[near[rng.integers(near.size)] if near.size else i] += step
        else:
            # Push a pair apart (or together) around the mean: the sum stays.
            above = np.flatnonzero(x > m)
            below = np.flatnonzero(x < m)
            j, k = above[rng.integers(above.size)], below[rng.integers(below.size)]
            d = 1 if v < var else -1
            if d < 0 and x[j] - 1 <= x[k] + 1:
                continue
            x[j] += d
            x[k] -= d
    raise RuntimeError("moment matching did not converge")


def make_frame(setting: str, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    frame = np.full((HEIGHT, WIDTH), BACKGROUND, dtype=np.int64)
    frame += rng.integers(-2, 3, frame.shape)
    for name, (x, y, w, h) in ROIS.items():
        mean, var = TABLE4[setting][name]
        y0, y1 = max(0, y - BOARD_MARGIN), min(HEIGHT, y + h + BOARD_MARGIN)
        x0, x1 = max(0, x - BOARD_MARGIN), min(WIDTH, x + w + BOARD_MARGIN)
        board = rng.normal(mean, np.sqrt(var), (y1 - y0, x1 - x0))
        frame[y0:y1, x0:x1] = np.rint(board)
        roi = frame[y : y + h, x : x + w]
        frame[y : y + h, x : x + w] = _match_moments(roi.ravel(), mean, var, rng).reshape(roi.shape)
    return np.clip(frame, 0, 255).astype(np.uint8)


def write_rois(path: Path) -> None:
    lines = [
        "# Paperboard ROIs: x, y (top-left pixel), width, height; see README 'ROI files'.",
        "classes:",
    ]
    for name in ("A", "B", "C"):
        lines += [f"  {name}:", f"    - rect: [{', '.join(map(str, ROIS[name]))}]"]
    path.write_text("\n".join(lines) + "\n")


def main() -> None:
    import cv2

    for seed, setting in enumerate(TABLE4):
        cv2.imwrite(str(HERE / f"{setting}.png"), make_frame(setting, seed))
    write_rois(HERE / "rois.yaml")


if __name__ == "__main__":
    main()
