"""The part's pose against its physical limit: the spread of the pose over noisy frames of
one part at one pose, per template size and noise level, against the Cramér–Rao bound of
the template (Robinson & Milanfar 2004).

For a template s(x) seen with white noise of variance σ_n², an unbiased estimate of the
pose θ = (x, y, φ) (the template's centre and its rotation about it) has a covariance of
at least J⁻¹, J = σ_n⁻² Σ ∇_θ s ∇_θ sᵀ over the template's pixels, with ∂s/∂x = −s_x,
∂s/∂y = −s_y and ∂s/∂φ = (y − y_c) s_x − (x − x_c) s_y. The part is drawn exactly under
its pose (a texture of cosines, soft edges: ``tests/conftest.py``'s ``rendered_part``), the
reference without noise, each frame with its own noise and rounded to 8 bits (σ_n² the
noise's and 1/12 DN²'s). The target: the spread within 2 × the bound.

Run: ``python benchmarks/bench_pose.py [--frames 200]`` (about five minutes at 200).
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

import numpy as np
from machine import machine_line

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from conftest import rendered_part

SIZES = (64, 256, 512, 1280, 2000)
NOISE = (2.0, 8.0)  # DN
TARGET = 2.0


def bound(reference: np.ndarray, template: tuple, sigma: float) -> np.ndarray:
    """The Cramér–Rao bound's standard deviations of (x px, y px, φ °) for the template
    window of a noise-free ``reference`` seen with noise of standard deviation
    ``sigma``."""
    x, y, w, h = template
    s = reference[y - 1 : y + h + 1, x - 1 : x + w + 1]
    gy, gx = (g[1:-1, 1:-1] for g in np.gradient(s))
    v, u = np.mgrid[0:h, 0:w].astype(float)
    u, v = u - (w - 1) / 2, v - (h - 1) / 2
    grads = np.stack([-gx, -gy, v * gx - u * gy]).reshape(3, -1)
    fisher = grads @ grads.T / sigma**2
    sd = np.sqrt(np.diag(np.linalg.inv(fisher)))
    return np.array([sd[0], sd[1], math.degrees(sd[2])])


def main() -> None:
    from inspect_validate.roi.pose import TemplateSearch

    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--frames", type=int, default=200)
    args = parser.parse_args()
    print(machine_line())
    print(f"{args.frames} frames a row, one part at one pose (5.3, −3.1 px, 6°), 8-bit\n")
    print(
        "| template | noise | spread x, y, φ | bound x, y, φ | spread ÷ bound | holds | ms a frame |"
    )
    print("|---|---|---|---|---|---|---|")
    for size in SIZES:
        identity = np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
        clean, template = rendered_part(size, identity, noise=0.0, quantised=False)
        n = clean.shape[0]
        t = math.radians(6.0)
        a = np.array([[math.cos(t), -math.sin(t)], [math.sin(t), math.cos(t)]])
        want = np.column_stack([a, np.array([n / 2 + 5.3, n / 2 - 3.1]) - a @ np.full(2, n / 2)])
        moved, _ = rendered_part(size, want, noise=0.0, quantised=False)
        search = TemplateSearch.of(clean.astype(np.float32), template)
        x, y, w, h = template
        centre = np.array([x + w / 2, y + h / 2])
        for sigma in NOISE:
            rng = np.random.default_rng(int(size * 10 + sigma))
            poses, seconds = [], []
            for _ in range(args.frames):
                frame = np.clip(np.rint(moved + rng.normal(0, sigma, moved.shape)), 0, 255)
                start = time.perf_counter()
                pose = search.locate(frame.astype(np.uint8))
                seconds.append(time.perf_counter() - start)
                poses.append([*pose.apply(centre[None])[0], pose.angle_deg])
            spread = np.std(np.array(poses), axis=0, ddof=1)
            limit = bound(clean, template, math.sqrt(sigma**2 + 1 / 12))
            ratio = spread / limit
            print(
                f"| {size} px | {sigma:g} DN | {spread[0]:.2g}, {spread[1]:.2g} px, "
                f"{spread[2]:.2g}° | {limit[0]:.2g}, {limit[1]:.2g} px, {limit[2]:.2g}° | "
                f"{ratio[0]:.2f}, {ratio[1]:.2f}, {ratio[2]:.2f} | "
                f"{'yes' if ratio.max() <= TARGET else 'no'} | "
                f"{1e3 * float(np.median(seconds)):.0f} |",
                flush=True,
            )


if __name__ == "__main__":
    main()
