"""Run time against error for every knob that trades one for the other, in one report.

Run: ``python benchmarks/report.py [--out benchmarks/results] [--quick]`` (about 3
minutes on 2 cores; ``--quick``, smaller sizes, about 20 s). Writes
``report.md`` (Markdown tables, the machine named) and one PNG per knob: run time
against error, ours beside an independent reference computed in the same run.

Knobs:

* spectral grid step (0.2–10 nm) → μ and SNR_dB error against a 0.1 nm grid;
* LSCV bandwidth, continuous data, n = 20 … 10⁶: ours against the exact O(n²)
  optimum and statsmodels' ``cv_ls`` (where they finish);
* ε KDE, n = 20 … 10⁵ pixels a class: ours (closed-form regions) against
  adaptive quadrature of min(p̂1, p̂2);
* ε Gauss: the compiled kernel and the numpy path against a careful scipy
  version and the textbook 1 − Φ, errors against mpmath;
* region statistics, 1–20 MP, uint8/uint16: ours against numpy and
  ``cv2.meanStdDev``, errors against exact rational moments;
* frames averaged per illumination (1–16) → error of μ and σ² over repeated
  captures of the simulated station, against the simulator's own truth;
* prediction 10³ … 10⁷ combinations → time per combination and peak memory;
* skipped work: each skip against the same work done in full (ε KDE where the
  Gaussians fit, wavelengths nothing responds at, comparisons not named, a blind
  camera, a dominated candidate not captured).
"""

from __future__ import annotations

import argparse
import itertools
import sys
import time
from dataclasses import dataclass, field
from fractions import Fraction
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
import bench_predict  # noqa: E402
import bench_stats  # noqa: E402
from machine import best_time, exact_moments, machine_line  # noqa: E402


@dataclass
class Knob:
    """One section of the report: a table, and the points to plot (time, error, label)."""

    title: str
    note: str
    header: list[str]
    rows: list[list[str]] = field(default_factory=list)
    points: dict[str, list[tuple[float, float, str]]] = field(default_factory=dict)
    x_label: str = "run time [s]"
    y_label: str = "error"

    def point(self, series: str, t: float, err: float, label: str) -> None:
        if np.isfinite(t) and np.isfinite(err):
            self.points.setdefault(series, []).append((t, max(err, 1e-17), label))


def fmt_t(t: float) -> str:
    if not np.isfinite(t):
        return "—"
    return f"{t * 1e3:.3g} ms" if t < 1 else f"{t:.3g} s"


def fmt_e(e: float) -> str:
    return "—" if not np.isfinite(e) else f"{e:.1e}"


def ratio(a: float, b: float) -> str:
    return f"{a / b:.3g}" if np.isfinite(a) and np.isfinite(b) and b > 0 else "—"


# --- knobs -----------------------------------------------------------------------


def grid_step(quick: bool) -> Knob:
    from inspect_validate.scene import read_scene

    knob = Knob(
        "Spectral grid step",
        "Predicted μ and SNR_dB of the shipped scenes on each grid against a 0.1 nm grid "
        "(trapezoidal rule). The scene default is 1 nm.",
        ["scene", "step", "time", "time / 0.1 nm", "max rel μ error", "max |Δ SNR_dB| [dB]"],
        y_label="max |Δ SNR_dB| [dB]",
    )
    root = HERE.parent / "sample_images/scenes"
    steps = (1.0, 10.0) if quick else (0.2, 0.5, 1.0, 2.0, 5.0, 10.0)
    for name in ("paperboard", "chapter_table2"):
        sc = read_scene(root / name / "scene.yaml")
        fine = np.arange(380.0, 780.0 + 1e-9, 0.1)
        t_ref = best_time(lambda sc=sc, g=fine: sc.predict(grid=g), 1)
        ref = sc.predict(grid=fine)
        for step in steps:
            grid = np.arange(380.0, 780.0 + 1e-9, step)
            t = best_time(lambda sc=sc, g=grid: sc.predict(grid=g), 1)
            got = sc.predict(grid=grid)
            d_mu = float(np.nanmax(np.abs(got.mean - ref.mean) / ref.mean))
            finite = np.isfinite(ref.snr_db) & np.isfinite(got.snr_db)
            d_snr = float(np.max(np.abs(got.snr_db - ref.snr_db)[finite]))
            knob.rows.append(
                [name, f"{step:g} nm", fmt_t(t), ratio(t, t_ref), fmt_e(d_mu), f"{d_snr:.3g}"]
            )
            knob.point(name, t, d_snr, f"{step:g} nm")
    return knob


def lscv(quick: bool) -> Knob:
    from statsmodels.nonparametric.kernel_density import KDEMultivariate

    from inspect_validate.stats import lscv_bandwidth

    knob = Knob(
        "LSCV bandwidth, continuous data",
        "Relative error of h against the exact O(n²) optimum (computed where it finishes "
        "in reasonable time); statsmodels' cv_ls up to n = 2000. Ours bins at h/1000 above "
        "2¹⁴ values.",
        [
            "n",
            "ours",
            "exact O(n²)",
            "statsmodels",
            "ours / statsmodels",
            "err ours",
            "err statsmodels",
        ],
        y_label="relative error of h",
    )
    sizes = (20, 200, 2000) if quick else (20, 200, 2000, 10_000, 100_000, 1_000_000)
    rng = np.random.default_rng(2)
    for n in sizes:
        x = np.concatenate([rng.normal(0, 1, n - n // 3), rng.normal(4, 0.5, n // 3)])
        t_ours = best_time(lambda x=x: lscv_bandwidth(x), 1 if n > 10**5 else 3)
        h = lscv_bandwidth(x).h
        t_exact = exact = float("nan")
        if n <= 10_000:
            t0 = time.perf_counter()
            exact = lscv_bandwidth(x, method="exact").h
            t_exact = time.perf_counter() - t0
        t_sm = h_sm = float("nan")
        if n <= 2000:
            t0 = time.perf_counter()
            h_sm = KDEMultivariate(x, "c", bw="cv_ls").bw[0]
            t_sm = time.perf_counter() - t0
        e_ours = abs(h - exact) / exact if np.isfinite(exact) else float("nan")
        e_sm = abs(h_sm - exact) / exact if np.isfinite(exact) else float("nan")
        knob.rows.append(
            [
                f"{n:,}",
                fmt_t(t_ours),
                fmt_t(t_exact),
                fmt_t(t_sm),
                ratio(t_ours, t_sm),
                fmt_e(e_ours),
                fmt_e(e_sm),
            ]
        )
        knob.point("ours", t_ours, e_ours, f"n={n}")
        knob.point("statsmodels cv_ls", t_sm, e_sm, f"n={n}")
    return knob


def kde_error(quick: bool) -> Knob:
    from inspect_validate.stats import as_sample
    from inspect_validate.stats import kde_error as ours

    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests" / "stats"))
    from test_kde_error import reference  # the tests' quadrature, the one ε KDE reference

    knob = Knob(
        "ε KDE",
        "Two classes of integer grey values, N(100, 6²) and N(115, 9²), n pixels each. "
        "Reference: adaptive quadrature (scipy quad, 400 panels split where p̂1 = p̂2, "
        "rel. tol. 1e-12) of ½ min(p̂1, p̂2) with the same bandwidths; the crossings are "
        "the reference's own (brentq on a 0.01-wide scan).",
        ["n a class", "ours", "quadrature", "ratio", "rel. difference"],
        y_label="|ours − quadrature| / quadrature",
    )
    sizes = (20, 2000) if quick else (20, 200, 2000, 20_000, 100_000)
    rng = np.random.default_rng(5)
    for n in sizes:
        a = as_sample(np.rint(rng.normal(100, 6, n)).astype(int))
        b = as_sample(np.rint(rng.normal(115, 9, n)).astype(int))
        t_ours = best_time(lambda a=a, b=b: ours(a, b), 3)
        r = ours(a, b)
        t0 = time.perf_counter()
        ref = reference(a, b, r.bandwidth1.h, r.bandwidth2.h, 0, 230)
        t_ref = time.perf_counter() - t0
        err = abs(r.error - ref) / ref
        knob.rows.append([f"{n:,}", fmt_t(t_ours), fmt_t(t_ref), ratio(t_ours, t_ref), fmt_e(err)])
        knob.point("ours", t_ours, err, f"n={n}")
    return knob


def gaussian_error(quick: bool) -> Knob:
    knob = Knob(
        "ε Gauss",
        "10⁶ pairs of unequal variances (σ ratio up to 10); errors against mpmath (60 digits) "
        "on the tests' corpus with σ ratio ≤ 100.",
        ["implementation", "time", "careful scipy", "ratio", "max rel error", "scipy's"],
        y_label="max relative error vs mpmath",
    )
    rows = []
    bench_stats.general_gaussian_error_rows(rows)
    for task, _, t, t_ref, e, e_ref, _ in rows:
        name = task.split("(")[-1].rstrip(")")
        knob.rows.append([name, fmt_t(t), fmt_t(t_ref), ratio(t, t_ref), fmt_e(e), fmt_e(e_ref)])
        knob.point(name, t, e, name)
    knob.point("careful scipy", rows[0][3], rows[0][5], "careful scipy")
    return knob


def region(quick: bool) -> Knob:
    import cv2

    from inspect_validate.stats import region_statistics, sample_moments

    knob = Knob(
        "Region statistics",
        "μ and σ² of a region of 90 % of the frame; errors of σ² against exact rational "
        "moments (from the region's histogram). numpy: float64 mean and var(ddof=1) of "
        "the masked pixels.",
        ["frame", "ours", "numpy", "cv2", "ours / cv2", "err ours", "err numpy", "err cv2"],
        y_label="relative error of σ²",
    )
    sizes = (1,) if quick else (1, 5, 20)
    rng = np.random.default_rng(0)
    for mp, dtype in itertools.product(sizes, (np.uint8, np.uint16)):
        h = int(np.sqrt(mp * 1e6 * 0.8))
        w = int(mp * 1e6 / h)
        top = np.iinfo(dtype).max
        frame = np.clip(np.rint(rng.normal(0.9 * top, 1.5, (h, w))), 0, top).astype(dtype)
        mask = np.zeros(frame.shape, bool)
        mask[h // 20 : h - h // 20, w // 20 : w - w // 20] = True
        exact = exact_moments(frame[mask])[1]
        n = int(mask.sum())

        def ours(frame=frame, mask=mask):
            return sample_moments(region_statistics(frame, mask).sample).variance

        def plain(frame=frame, mask=mask):
            return frame[mask].astype(np.float64).var(ddof=1)

        mask8 = mask.astype(np.uint8)

        def opencv(frame=frame, mask8=mask8, n=n):
            return float(cv2.meanStdDev(frame, mask=mask8)[1][0, 0]) ** 2 * n / (n - 1)

        times = [best_time(f, 3) for f in (ours, plain, opencv)]
        errs = [abs(float((Fraction(f()) - exact) / exact)) for f in (ours, plain, opencv)]
        label = f"{mp} MP {np.dtype(dtype).name}"
        knob.rows.append([label, *map(fmt_t, times), ratio(times[0], times[2]), *map(fmt_e, errs)])
        for series, t, e in zip(("ours", "numpy", "cv2"), times, errs, strict=True):
            knob.point(series, t, e, label)
    return knob


def frames_averaged(quick: bool) -> Knob:
    from inspect_validate.roi import class_masks, read_rois
    from inspect_validate.station.devices import open_devices
    from inspect_validate.station.file import read_station
    from inspect_validate.station.stopping import SequentialStop
    from inspect_validate.stats import region_statistics, sample_moments

    knob = Knob(
        "Frames per illumination",
        "The simulated station under its amber light, class A, against the simulator's "
        "truth: each pixel's expected grey value and temporal variance (EMVA 1288, with "
        "the rounding's 1/12 DN²), so μ* is their mean over the region and σ²* the mean "
        "temporal variance plus the spatial variance of the expected values (the pooled "
        "(39) over N frames has expectation exactly that, with N P/(N P − 1) on the "
        "spatial part). For each number of frames N, consecutive captures of N frames; "
        "the error is the RMS over the captures of the error relative to the truth. "
        "Time is the grab time of N frames. The station default is 4. The last "
        "row stops each capture once every class's σ² is known to the given relative "
        "standard error (station precision:, at most 16 frames); its frames are the "
        "mean number taken.",
        ["frames", "grab time", "μ: RMS error", "σ²: RMS error", "captures"],
        y_label="RMS relative error of σ² against the truth",
    )
    total = 64 if quick else 256  # frames grabbed, split into captures of N
    station = read_station(HERE.parent / "sample_images/station/station.yaml")
    rois = read_rois(HERE.parent / "sample_images/station/rois.yaml")
    with open_devices(station) as (controller, camera):
        # Seeded (a camera opened for the station draws new noise every time), so the
        # committed report, and the README's figures from it, come out again.
        camera.noise = np.random.default_rng(1288)
        camera.configure(exposure_us=station.camera.exposure_us, gain_db=0)
        controller.apply({1: 100})
        camera.grab(4)  # past the pipeline and the switch
        t0 = time.perf_counter()
        frames = np.stack([f.data for f in camera.grab(total)])
        per_frame = (time.perf_counter() - t0) / total
        expected_mean, expected_variance = camera.expected(camera.light_state())
    mask = class_masks(rois, frames.shape[1:])["A"]
    pixels = int(mask.sum())
    truth_mean = expected_mean[mask].mean()
    temporal, spatial = expected_variance[mask].mean(), expected_mean[mask].var()

    def moments(stack):
        m = sample_moments(region_statistics(stack, mask).sample)
        return m.mean, m.variance

    def relative_errors(values, used):
        n = np.array(used, dtype=float) * pixels
        truth = np.stack([np.full(n.size, truth_mean), temporal + spatial * n / (n - 1)], 1)
        return np.array(values) / truth - 1

    def row(label, values, used, t):
        rms = np.sqrt(np.mean(relative_errors(values, used) ** 2, axis=0))
        knob.rows.append([label, fmt_t(t), fmt_e(rms[0]), fmt_e(rms[1]), str(len(values))])
        return rms

    # The truth is checked, not assumed: all frames together against it, in units of
    # the standard error that the single-frame captures' scatter gives.
    single = relative_errors([moments(f[np.newaxis]) for f in frames], [1] * total)
    whole = relative_errors([moments(frames)], [total])[0]
    se = single.std(axis=0, ddof=1) / np.sqrt(total)
    knob.note += (
        f" All {total} frames together are {whole[0]:+.1e} off μ* and {whole[1]:+.1e} off "
        f"σ²* ({whole[0] / se[0]:+.1f} and {whole[1] / se[1]:+.1f} standard errors)."
    )

    for n in (1, 2, 4, 8, 16) if not quick else (1, 4):
        values = [moments(frames[i : i + n]) for i in range(0, total - n + 1, n)]
        rms = row(str(n), values, [n] * len(values), n * per_frame)
        knob.point("σ²", n * per_frame, rms[1], f"N={n}")
        knob.point("μ", n * per_frame, rms[0], f"N={n}")
    # Sequential stopping (station precision:): consecutive captures, each taking frames
    # until every class's σ² is known to the target (at most 16).
    target = 0.004
    values, used, i = [], [], 0
    while i + 16 <= total:
        stop = SequentialStop(rois, mean=0.001, variance=target, min_frames=3)
        k = next((k for k in range(1, 17) if stop.add(frames[i + k - 1])), 16)
        values.append(moments(frames[i : i + k]))
        used.append(k)
        i += k
    n = float(np.mean(used))
    label = f"sequential, σ² ±{100 * target:g} % (mean {n:.1f})"
    rms = row(label, values, used, n * per_frame)
    knob.point("sequential σ²", n * per_frame, rms[1], f"{n:.1f}")
    return knob


def prediction(quick: bool) -> Knob:
    knob = Knob(
        "Prediction size",
        "sweep of 3 classes × 20 samples on a 1 nm grid, each size in a fresh process: "
        "time per combination against 10³'s, peak memory (the process's VmHWM).",
        ["sweep", "time", "per combination", "× 10³'s", "peak RSS", "blocks", "products"],
        x_label="combinations",
        y_label="time per combination [µs]",
    )
    shapes = bench_predict.SHAPES[:2] if quick else bench_predict.SHAPES
    for run in bench_predict.scale_runs(shapes):
        n = run["combinations"]
        knob.rows.append(
            [
                f"10^{int(np.log10(n))}",
                fmt_t(run["seconds"]),
                f"{1e6 * run['per']:.3g} µs",
                f"{run['ratio']:.2f}",
                f"{run['peak'] / 2**20:.0f} MB",
                str(run["blocks"]),
                f"{100 * run['products']:.0f} %",
            ]
        )
        knob.point("sweep", n, 1e6 * run["per"], f"{run['peak'] / 2**20:.0f} MB")
    return knob


def skipped_work(quick: bool) -> Knob:
    """What the skips save, measured with and without them, and what the results lose
    (sequential stopping: the frames knob's last row)."""
    import tempfile

    import yaml

    from inspect_validate.measurement import measure_files
    from inspect_validate.station.capture import capture
    from inspect_validate.station.file import read_station
    from inspect_validate.verification.dominance import dominated_illuminations
    from inspect_validate.verification.plan import plan_verification
    from inspect_validate.verification.verify import verify_folder

    knob = Knob(
        "Skipped work",
        "Each skip against the same work done in full, in this process. ε KDE: measure "
        "of the paperboard sample frame (Gaussian classes), --kde auto against --kde "
        "always, best of 5 warm runs; the difference is the largest |ε KDE − ε Gauss| "
        "relative to ε KDE over the comparisons, what auto reports in place of the KDE. "
        "predict's skips on the shipped inks scene (3 LEDs, 3 classes), best of 5 warm "
        "runs: its wavelength: line removed, the grid where a light, a lens and a camera "
        "all respond (one step more each side) against the spectra's joined range; the one "
        "comparison named against all six (pairs, and each class against the rest: root "
        "searches); a camera blind to some lights in the sweep, its combinations skipped "
        "with their reasons, against the scene without it (the others' numbers). "
        "Dominated candidate: verify's capture of the simulated station with the ranking "
        "off, without the red LED (predicted dominated) against with it "
        "(--all-illuminations), each once; the difference is amber's largest |Δ SNR_dB| "
        "between the two runs (new noise in each) and whether every amber verdict is the "
        "same.",
        ["skip", "with the skip", "without", "ratio", "difference in results"],
        x_label="run time [s]",
        y_label="difference in results",
    )
    sample = HERE.parent / "sample_images" / "paperboard"
    frame, rois = [sample / "optimized.png"], sample / "rois.yaml"
    results = {}
    times = {}
    for mode in ("auto", "always"):

        def run(mode=mode):
            results[mode] = measure_files(frame, rois, kde=mode)

        times[mode] = best_time(run)
    auto, always = results["auto"], results["always"]
    assert all(c.error_kde is None for c in auto.comparisons)
    worst = max(
        abs(g.error_gaussian - k.error_kde) / k.error_kde
        for g, k in zip(auto.comparisons, always.comparisons, strict=True)
        if k.error_kde
    )
    knob.rows.append(
        [
            "ε KDE where the Gaussians fit (measure --kde auto)",
            fmt_t(times["auto"]),
            fmt_t(times["always"]),
            ratio(times["auto"], times["always"]),
            f"ε {worst:.1e} relative",
        ]
    )
    knob.point("ε KDE skipped", times["auto"], worst, "auto")
    knob.rows += _prediction_skips(knob)

    station_dir = HERE.parent / "sample_images" / "station"
    doc = yaml.safe_load((station_dir / "station.yaml").read_text())
    doc["scene"] = str((station_dir / doc["scene"]).resolve())
    doc["rois"] = str(station_dir / doc["rois"])
    doc["acceptance"]["ranking"] = False
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        path = tmp / "station.yaml"
        path.write_text(yaml.safe_dump(doc, sort_keys=False))
        full = read_station(path)
        plan = plan_verification(full)
        dominated = dominated_illuminations(full, plan.prediction)
        kept = full.model_copy(
            update={"illuminations": [i for i in full.illuminations if i.name not in dominated]}
        )
        runs = {}
        for label, st in (("skip", kept), ("all", full)):
            t0 = time.perf_counter()
            capture(st, tmp / label)
            runs[label] = (time.perf_counter() - t0, verify_folder(st, tmp / label, plan=plan))
    (t_skip, v_skip), (t_all, v_all) = runs["skip"], runs["all"]

    def amber(v):
        snr = {r.comparison: r.measured.snr_db for r in v.comparisons if r.illumination == "amber"}
        verdicts = {c.name: c.passed for c in v.checks if c.name.startswith("amber")}
        return snr, verdicts

    (snr_skip, verdicts_skip), (snr_all, verdicts_all) = amber(v_skip), amber(v_all)
    delta = max(abs(snr_skip[k] - snr_all[k]) for k in snr_skip)
    same = "same" if verdicts_skip == verdicts_all else "DIFFERENT"
    knob.rows.append(
        [
            f"dominated candidate ({', '.join(dominated)}) not captured (verify)",
            fmt_t(t_skip),
            fmt_t(t_all),
            ratio(t_skip, t_all),
            f"amber SNR_dB within {delta:.2f} dB, verdicts {same}",
        ]
    )
    return knob


def _prediction_skips(knob: Knob) -> list[list[str]]:
    """predict's skips on the shipped inks scene (3 LEDs, 3 classes), best of 5 warm runs:
    the wavelength range (its ``wavelength:`` line removed), named comparisons, a blind
    camera."""
    import dataclasses
    import tempfile

    from inspect_validate.scene import read_scene

    mix = HERE.parent / "sample_images" / "scenes" / "mix"
    text = (mix / "scene.yaml").read_text().replace("file: ", f"file: {mix}/")
    undeclared = "".join(
        line for line in text.splitlines(True) if not line.startswith("wavelength:")
    )
    blind = text.replace("cameras:\n", "cameras:\n  - ingaas-swir\n")
    with tempfile.TemporaryDirectory() as tmp:
        scenes = {}
        for name, body in (("shipped", text), ("undeclared", undeclared), ("blind", blind)):
            (Path(tmp) / f"{name}.yaml").write_text(body)
            scenes[name] = read_scene(Path(tmp) / f"{name}.yaml")
    results = {}

    def timed(label, scene, grid=None):
        def run():
            results[label] = scene.predict(grid=grid)

        return best_time(run)

    def relative(a, b):
        return float(np.nanmax(np.abs(a / b - 1)))

    def absolute(a, b):
        return float(np.nanmax(np.abs(a - b)))

    rows = []
    sc = scenes["undeclared"]
    spectra = [c.reflectance for c in sc.classes] + [x.spd for x in sc.lights]
    spectra += [x.transmission for x in sc.optics] + [x.qe for x in sc.cameras]
    joined = np.arange(
        min(s.range[0] for s in spectra), max(s.range[1] for s in spectra) + 0.5, 1.0
    )
    t_narrow, t_joined = timed("narrow", sc), timed("joined", sc, joined)
    narrow, full = results["narrow"], results["joined"]
    mean = relative(narrow.mean, full.mean)
    rows.append(
        [
            f"wavelengths no light, lens and camera all see (predict: {sc.grid[0]:g}–"
            f"{sc.grid[-1]:g} nm of {joined[0]:g}–{joined[-1]:g})",
            fmt_t(t_narrow),
            fmt_t(t_joined),
            ratio(t_narrow, t_joined),
            f"μ {mean:.1e} relative, SNR_dB within {absolute(narrow.snr_db, full.snr_db):.1e} dB",
        ]
    )
    knob.point("wavelength range", t_narrow, mean, "narrowed")

    sc = scenes["shipped"]
    named = dataclasses.replace(sc, comparisons=sc.comparisons.subset(["A vs B"]))
    t_named, t_all = timed("named", named), timed("all", sc)
    one, every = results["named"], results["all"]
    column = sc.comparisons.index("A vs B")
    snr = absolute(one.snr_db[..., 0], every.snr_db[..., column])
    eps = relative(one.error_gaussian[..., 0], every.error_gaussian[..., column])
    rows.append(
        [
            f"comparisons not named (predict 'A vs B' of {len(sc.comparisons.groups)})",
            fmt_t(t_named),
            fmt_t(t_all),
            ratio(t_named, t_all),
            f"A vs B: SNR_dB within {snr:.1e} dB, ε {eps:.1e} relative",
        ]
    )
    knob.point("named comparisons", t_named, max(snr, eps), "A vs B")

    t_blind = timed("blind", scenes["blind"])
    p = results["blind"]
    keep = [p.cameras.index(name) for name in every.cameras]
    rows.append(
        [
            f"a camera blind to some lights (ingaas-swir) skipped with its reasons, not the "
            f"sweep stopped (predict, {int((~p.valid).sum())} of {p.valid.size} combinations)",
            fmt_t(t_blind),
            f"{fmt_t(t_all)} (without the camera)",
            ratio(t_blind, t_all),
            f"the others' μ {relative(p.mean[:, :, keep], every.mean):.1e} relative, "
            f"SNR_dB within {absolute(p.snr_db[:, :, keep], every.snr_db):.1e} dB",
        ]
    )
    return rows


KNOBS = (
    grid_step,
    lscv,
    kde_error,
    gaussian_error,
    region,
    frames_averaged,
    prediction,
    skipped_work,
)


def plot(knob: Knob, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6, 4), dpi=100)
    for series, pts in knob.points.items():
        x, y, _ = zip(*pts, strict=True)
        ax.plot(x, y, "o-", label=series)
        for xi, yi, lab in pts:
            ax.annotate(lab, (xi, yi), fontsize=7, xytext=(3, 3), textcoords="offset points")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel(knob.x_label)
    ax.set_ylabel(knob.y_label)
    ax.set_title(knob.title)
    ax.grid(True, which="both", alpha=0.3)
    if knob.points:
        ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", type=Path, default=HERE / "results")
    parser.add_argument("--quick", action="store_true", help="smaller sizes (a smoke run)")
    args = parser.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    started = time.perf_counter()
    lines = [
        "# Run time against error",
        "",
        machine_line() + ("; quick run (smaller sizes)" if args.quick else ""),
        "",
    ]
    for make in KNOBS:
        knob = make(args.quick)
        png = args.out / f"{make.__name__}.png"
        plot(knob, png)
        lines += [f"## {knob.title}", "", knob.note, ""]
        lines += ["| " + " | ".join(knob.header) + " |", "|" + "---|" * len(knob.header)]
        lines += ["| " + " | ".join(row) + " |" for row in knob.rows]
        lines += ["", f"![{knob.title}]({png.name})", ""]
        print(f"{knob.title}: {len(knob.rows)} rows", flush=True)
    lines.append(f"Report written in {time.perf_counter() - started:.0f} s.")
    (args.out / "report.md").write_text("\n".join(lines) + "\n")
    print(f"wrote {args.out / 'report.md'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
