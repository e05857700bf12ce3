"""Speed of `predict` and its accuracy against the wavelength grid step.

Run: ``python benchmarks/bench_predict.py`` (about 40 s on 2 cores).

1. 10 lights × 10 optics × 10 cameras, 3 classes × 20 reflectance samples, 1 nm
   grid: the vectorised model against a straightforward colour-science loop
   (one ``SpectralDistribution`` product and integral per combination and
   sample), with the largest relative difference of the predicted electrons.
2. ``sweep`` of 10³ … 10⁷ combinations (up to 1000 × 100 × 100), same classes,
   each in a fresh process: run time, time per combination against 10³'s, peak
   RSS, blocks and the share of the matrix products. (``predict``, which holds
   every array and every group comparison's ε, is not run at these sizes.)
3. Predicted SNR_dB of the shipped scenes against grid step 1, 2, 5, 10 nm,
   each compared with a 0.1 nm grid: the error that sets the default step.
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np

from inspect_validate.components import Optics, SensorModel, led
from inspect_validate.components.lights import C, H
from inspect_validate.model import Exposure, ObjectClass, predict, sweep
from inspect_validate.spectra import Spectrum

ROOT = Path(__file__).resolve().parents[1]
GRID = np.arange(380.0, 1001.0, 1.0)


def components(n_l, n_o, n_c, rng):
    lights = [
        led(rng.uniform(400, 900), rng.uniform(10, 60), grid=GRID, name=f"L{i}", irradiance=1.0)
        for i in range(n_l)
    ]
    optics = []
    for i in range(n_o):
        t = 0.6 + 0.35 * np.sin(GRID / rng.uniform(60, 200) + rng.uniform(0, 6)) ** 2
        optics.append(Optics(f"O{i}", Spectrum(GRID, t, "transmission", f"O{i}", "bench"), 4.0))
    cameras = []
    for i in range(n_c):
        qe = 0.7 * np.exp(-0.5 * ((GRID - rng.uniform(450, 800)) / rng.uniform(80, 200)) ** 2)
        cameras.append(
            SensorModel(f"C{i}", Spectrum(GRID, qe, "qe", f"C{i}", "bench"), 0.4, 2.5, 10000, 12)
        )
    classes = []
    for k in range(3):
        base = 0.4 + 0.2 * np.sin(GRID / (90 + 30 * k)) ** 2
        samples = base * (1 + rng.normal(0, 0.02, (20, 1))) + rng.normal(0, 0.003, (20, GRID.size))
        classes.append(
            ObjectClass(f"K{k}", Spectrum(GRID, samples, "reflectance", f"K{k}", "bench"))
        )
    return lights, optics, cameras, classes


def colour_loop(lights, optics, cameras, classes):
    """μ_e rate per combination and sample with colour-science objects, one at a time."""
    import colour

    shape = colour.SpectralShape(GRID[0], GRID[-1], 1)

    def sd(s, row=0):
        return colour.SpectralDistribution(
            dict(zip(s.wavelengths, s.values[row], strict=True))
        ).align(shape)

    out = np.empty(
        (len(lights), len(optics), len(cameras), sum(c.reflectance.n_samples for c in classes))
    )
    refl = [sd(c.reflectance, r) for c in classes for r in range(c.reflectance.n_samples)]
    for li, light in enumerate(lights):
        e = sd(light.spd)
        # The irradiance (1 W/m²) is stated over 380–780 nm.
        band = (e.wavelengths >= 380) & (e.wavelengths <= 780)
        e = e * (light.irradiance / np.trapezoid(e.values[band], e.wavelengths[band]))
        for oi, o in enumerate(optics):
            eo = e * sd(o.transmission) / (4 * o.f_number**2)
            for ci, cam in enumerate(cameras):
                chain = eo * sd(cam.qe)
                for s, r in enumerate(refl):
                    prod = chain * r
                    out[li, oi, ci, s] = (
                        (cam.pixel_pitch * 1e-6) ** 2
                        / (H * C)
                        * np.trapezoid(prod.values * prod.wavelengths * 1e-9, prod.wavelengths)
                    )
    return out


def rows_speed():
    rng = np.random.default_rng(0)
    parts = components(10, 10, 10, rng)
    t0 = time.perf_counter()
    sweep(*parts, exposure=Exposure("fixed", time=1.0), grid=GRID, top=10)
    t_ours = time.perf_counter() - t0
    p = predict(*parts, exposure=Exposure("fixed", time=1.0), grid=GRID)  # every μ_e, to compare
    sub = [parts[0][:2], parts[1][:5], parts[2][:5], parts[3]]
    t0 = time.perf_counter()
    ref = colour_loop(*sub)
    t_loop = (time.perf_counter() - t0) * 1000 / (2 * 5 * 5)
    onehot = np.zeros((60, 3))
    onehot[np.arange(60), np.repeat(np.arange(3), 20)] = 1 / 20
    rel = np.abs(p.electrons[:2, :5, :5] - ref @ onehot) / (ref @ onehot)
    yield (
        "sweep 10×10×10, 3×20 samples, 1 nm",
        "colour-science loop",
        t_ours,
        t_loop,
        rel.max(),
        "rel μ_e (loop extrapolated from 50 combos)",
    )


_SCALE = """
import sys, time
sys.path.insert(0, {bench!r})
import numpy as np
from bench_predict import GRID, components, matmul_seconds
from machine import peak_rss
from inspect_validate.model import sweep
n_l, n_o, n_c = {shape}
parts = components(n_l, n_o, n_c, np.random.default_rng(0))
t0 = time.perf_counter()
r = sweep(*parts, grid=GRID, top=10)
elapsed = time.perf_counter() - t0
print(elapsed, matmul_seconds(parts), r.blocks, peak_rss())
"""


def matmul_seconds(parts) -> float:
    """The sweep's matrix products alone: one block's two, timed, times the blocks."""
    from machine import best_time

    from inspect_validate.model.acquisition import Exposure, prepare
    from inspect_validate.model.sweep import MEMORY, _blocks

    chain = prepare(*parts, exposure=Exposure(), grid=GRID, comparisons=None)
    blocks = list(_blocks(chain, memory=MEMORY))
    ls, os, cs = blocks[0]
    lo = (chain.e[ls][:, None, :] * chain.t[os][None, :, :]).reshape(-1, GRID.size)
    mean_rows, centred_rows = chain.camera_rows(cs)
    return best_time(lambda: (lo @ mean_rows.T, lo @ centred_rows.T), 3) * len(blocks)


SHAPES = ((10, 10, 10), (10, 10, 100), (100, 10, 100), (100, 100, 100), (1000, 100, 100))


def scale_runs(shapes=SHAPES):
    """sweep at each (lights, optics, cameras), each in a fresh process (peak RSS is the
    process's): dicts of combinations, seconds, seconds per combination and its ratio to
    the first size's, peak bytes, blocks, and the matrix products' share."""
    import subprocess
    import sys

    per_first = None
    for shape in shapes:
        n = int(np.prod(shape))
        out = subprocess.run(
            [sys.executable, "-c", _SCALE.format(bench=str(Path(__file__).parent), shape=shape)],
            capture_output=True,
            text=True,
            check=True,
        ).stdout.split()
        elapsed, matmul, blocks, peak = float(out[0]), float(out[1]), int(out[2]), int(out[3])
        per = elapsed / n
        per_first = per_first or per
        yield {
            "combinations": n,
            "seconds": elapsed,
            "per": per,
            "ratio": per / per_first,
            "peak": peak,
            "blocks": blocks,
            "products": matmul / elapsed,
        }


def rows_scale():
    for run in scale_runs():
        n = run["combinations"]
        yield (
            f"sweep 10^{int(np.log10(n))} combinations",
            "sweep at 10³",
            run["seconds"],
            run["per"] / run["ratio"] * n,
            float("nan"),
            f"{1e6 * run['per']:.2f} µs/combination ({run['ratio']:.2f}× 10³'s), peak RSS "
            f"{run['peak'] / 2**20:.0f} MB, {run['blocks']} blocks, matrix products "
            f"{100 * run['products']:.0f} %",
        )


def rows_grid_step():
    from inspect_validate.scene import read_scene

    for name in ("paperboard", "chapter_table2"):
        sc = read_scene(ROOT / "sample_images/scenes" / name / "scene.yaml")
        ref = sc.predict(grid=np.arange(380.0, 780.0 + 1e-9, 0.1))
        for step in (1.0, 2.0, 5.0, 10.0):
            grid = np.arange(380.0, 780.0 + 1e-9, step)
            t0 = time.perf_counter()
            got = sc.predict(grid=grid)
            elapsed = time.perf_counter() - t0
            d_snr = np.abs(got.snr_db - ref.snr_db)
            d_mu = np.max(np.abs(got.mean - ref.mean) / ref.mean)
            worst = np.unravel_index(np.argmax(d_snr), d_snr.shape)
            note = (
                f"max |Δ SNR_dB| dB (at SNR_dB {ref.snr_db[worst]:.1f}); max rel μ error {d_mu:.1e}"
            )
            yield (
                f"SNR_dB {name}, step {step:g} nm",
                "0.1 nm grid",
                elapsed,
                float("nan"),
                d_snr.max(),
                note,
            )


def main():
    header = f"{'task':40} {'reference':20} {'t ours':>10} {'t ref':>10} {'t ratio':>8} {'error':>10}  note"
    print(header)
    print("-" * len(header))
    for task, ref, t1, t2, err, note in [*rows_speed(), *rows_scale(), *rows_grid_step()]:

        def fmt(t):
            return "—" if not np.isfinite(t) else (f"{t * 1e3:.1f} ms" if t < 10 else f"{t:.0f} s")

        ratio = t1 / t2 if np.isfinite(t2) else float("nan")
        err_s = "—" if not np.isfinite(err) else f"{err:.2e}"
        print(f"{task:40} {ref:20} {fmt(t1):>10} {fmt(t2):>10} {ratio:>8.4f} {err_s:>10}  {note}")


if __name__ == "__main__":
    main()
