"""What a user waits for: the whole ``measure`` CLI on one 5 MP uint16 frame with 3 ROIs,
against a plain cv2 + numpy script doing the same means and variances, each in a fresh
process (imports included), with peak memory. The classes are Gaussian, so the default
``--kde auto`` skips ε KDE (it says so); ``--kde always`` computes it.

Run: ``python benchmarks/bench_measure.py [--runs 5]`` (about 30 s).

The frame (2448 × 2048, seeded) holds three overlapping classes, N(12500, 400²),
N(12000, 300²) and N(12250, 250²) DN, in three 2000 × 500 ROIs. Error: the largest
relative deviation of μ and σ² over the classes from the exact values (rational
arithmetic on the ROI's histogram).

Then the held-out corpus's hostile frame (uniform grey values: ε KDE is computed, over
classes whose densities cross hundreds of times). Then the memory of a stack: 10 frames of 20 MP uint16 (400 MB), as one multi-page
TIFF and as 10 files, measured with ``--kde never``; the peak RSS less that of the
same command on a 100 × 100 stack (the interpreter and libraries, numba loaded as the
big stack's compiled kernels load it), against the stack's size.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
from fractions import Fraction
from pathlib import Path

import numpy as np
import tifffile
import yaml
from machine import PEAK_LAUNCHER, compile_package, exact_moments, machine_line

PLAIN = """
import sys, cv2, yaml
img = cv2.imread(sys.argv[1], cv2.IMREAD_UNCHANGED)
for name, shapes in yaml.safe_load(open(sys.argv[2]))["classes"].items():
    x, y, w, h = shapes[0]["rect"]
    m, s = cv2.meanStdDev(img[y:y + h, x:x + w])
    print(name, repr(float(m[0, 0])), repr(float(s[0, 0]) ** 2 * w * h / (w * h - 1)))
"""

ROIS = {"A": [100, 100, 2000, 500], "B": [100, 800, 2000, 500], "C": [100, 1500, 2000, 500]}


def make_frame(folder: Path):
    rng = np.random.default_rng(1)
    img = rng.normal(12000, 300, (2048, 2448)).astype(np.uint16)
    img[:700] = rng.normal(12500, 400, (700, 2448)).astype(np.uint16)
    img[1400:] = rng.normal(12250, 250, (648, 2448)).astype(np.uint16)
    tifffile.imwrite(folder / "frame.tif", img)
    rois = {"classes": {k: [{"rect": v}] for k, v in ROIS.items()}}
    (folder / "rois.yaml").write_text(yaml.safe_dump(rois))
    exact = {}
    for name, (x, y, w, h) in ROIS.items():
        exact[name] = exact_moments(img[y : y + h, x : x + w])
    return exact


def timed(args, runs):
    """Median wall time (s) and peak RSS (MB) of ``args`` (``python script ...`` or
    ``python -m module ...``) in fresh processes; its stdout."""
    times, peaks = [], []
    with tempfile.TemporaryDirectory() as tmp:
        hwm = Path(tmp) / "hwm"
        launched = [args[0], "-c", PEAK_LAUNCHER, str(hwm), *args[1:]]
        for _ in range(runs):
            t0 = time.perf_counter()
            proc = subprocess.run(
                launched, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True
            )
            times.append(time.perf_counter() - t0)
            peaks.append(int(hwm.read_text()) / 2**20)
            out = proc.stdout
    return float(np.median(times)), float(max(peaks)), out


def error(values, exact) -> float:
    return max(
        abs(float((Fraction(v) - e) / e))
        for name, (mu, var) in values.items()
        for v, e in ((mu, exact[name][0]), (var, exact[name][1]))
    )


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--runs", type=int, default=5)
    args = parser.parse_args()
    compile_package()
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        exact = make_frame(tmp)
        frame, rois = str(tmp / "frame.tif"), str(tmp / "rois.yaml")
        (tmp / "plain.py").write_text(PLAIN)
        plain = timed([sys.executable, str(tmp / "plain.py"), frame, rois], args.runs)
        plain_values = {
            line.split()[0]: (float(line.split()[1]), float(line.split()[2]))
            for line in plain[2].splitlines()
        }
        rows = []
        for label, extra in (
            ("measure (default: --kde auto, skipped here)", []),
            ("measure --kde always", ["--kde", "always"]),
            ("measure --kde never", ["--kde", "never"]),
        ):
            json_path = tmp / "m.json"
            cmd = [sys.executable, "-m", "inspect_validate", "measure", frame, "--rois", rois]
            ours = timed([*cmd, "--json", str(json_path), *extra], args.runs)
            doc = json.loads(json_path.read_text())
            values = {c["name"]: (c["mean"], c["variance"]) for c in doc["classes"]}
            rows.append((label, ours, error(values, exact)))
        hostile_rows = hostile(tmp, args.runs)
        stack_rows = stack_memory(tmp)
    print(machine_line())
    print(f"median of {args.runs} fresh processes each; 5 MP uint16, 3 ROIs of 1 MP")
    print()
    print(
        "| task | ours | plain cv2 script | time ratio | peak RSS ours / plain | error ours | error plain |"
    )
    print("|---|---|---|---|---|---|---|")
    for label, (t, peak, _), err in rows:
        print(
            f"| {label} | {t:.2f} s | {plain[0]:.2f} s | {t / plain[0]:.2f} | "
            f"{peak:.0f} / {plain[1]:.0f} MB | {err:.1e} | {error(plain_values, exact):.1e} |"
        )
    print()
    print(
        "| 3 MP uint16 uniform over 0–65535, 3 ROIs of 0.84 MP (the KDE runs: "
        "no Gaussian fits) | ours | plain cv2 script | time ratio | peak RSS ours / plain |"
    )
    print("|---|---|---|---|---|")
    for label, (t, peak, _), (tp, peak_p, _) in hostile_rows:
        print(f"| {label} | {t:.2f} s | {tp:.2f} s | {t / tp:.1f} | {peak:.0f} / {peak_p:.0f} MB |")
    print()
    print("| stack of 10 × 20 MP uint16 | peak RSS | less the baseline | / stack |")
    print("|---|---|---|---|")
    for label, peak, baseline, size in stack_rows:
        print(
            f"| {label} | {peak:.0f} MB | {peak - baseline:.0f} MB | "
            f"{(peak - baseline) / size:.2f} |"
        )
    return 0


def hostile(tmp: Path, runs: int):
    """The held-out corpus's frame that hung measure (no result in 60 s): every class
    holds 65,536 distinct grey values, so the kernel densities cross hundreds of times."""
    rng = np.random.default_rng(3)
    tifffile.imwrite(tmp / "uniform.tif", rng.integers(0, 65535, (1500, 2000), dtype=np.uint16))
    rois = {"A": [10, 10, 600, 1400], "B": [700, 10, 600, 1400], "C": [1350, 10, 600, 1400]}
    (tmp / "uniform.yaml").write_text(
        yaml.safe_dump({"classes": {k: [{"rect": v}] for k, v in rois.items()}})
    )
    frame, roi_file = str(tmp / "uniform.tif"), str(tmp / "uniform.yaml")
    cmd = [sys.executable, "-m", "inspect_validate", "measure", frame, "--rois", roi_file]
    plain = timed([sys.executable, str(tmp / "plain.py"), frame, roi_file], runs)
    return [("measure (default: --kde auto)", timed(cmd, runs), plain)]


def stack_memory(tmp: Path):
    """Peak RSS of measure on a 400 MB stack, as one file and as ten, and the baseline."""
    # Frame by frame: a child forked while this process held the stack would report the
    # parent's pages in its peak RSS.
    rng = np.random.default_rng(2)
    shape = (10, 4000, 5000)

    def frames():
        for _ in range(shape[0]):
            yield rng.normal(30000, 50, shape[1:]).astype(np.uint16)

    tifffile.imwrite(tmp / "stack.tif", frames(), shape=shape, dtype=np.uint16)
    single = tmp / "frames"
    single.mkdir()
    for i, frame in enumerate(frames()):
        tifffile.imwrite(single / f"f{i:02d}.tif", frame)
    small = tmp / "small"
    small.mkdir()
    for i, frame in enumerate(frames()):
        if i < 2:
            tifffile.imwrite(small / f"s{i}.tif", frame[:100, :100].copy())
    size = np.prod(shape) * 2 / 2**20
    rois = {"A": [0, 0, 2500, 4000], "B": [2500, 0, 2500, 4000]}
    (tmp / "big.yaml").write_text(
        yaml.safe_dump({"classes": {k: [{"rect": v}] for k, v in rois.items()}})
    )
    small_rois = {"A": [0, 0, 50, 100], "B": [50, 0, 50, 100]}
    (tmp / "small.yaml").write_text(
        yaml.safe_dump({"classes": {k: [{"rect": v}] for k, v in small_rois.items()}})
    )
    cmd = [sys.executable, "-m", "inspect_validate", "measure", "--kde", "never", "--rois"]
    # The big stack is measured by the compiled kernels, a small one by numpy: the
    # baseline loads numba first, so that the libraries are the same in both.
    compiled = tmp / "compiled.py"
    compiled.write_text(
        "import runpy, sys\n"
        "import numba\n"
        "sys.argv = ['inspect_validate', *sys.argv[1:]]\n"
        "runpy.run_module('inspect_validate', run_name='__main__', alter_sys=True)\n"
    )
    baseline = timed(
        [sys.executable, str(compiled), *cmd[3:], str(tmp / "small.yaml"), str(small)], 1
    )[1]
    rows = []
    for label, frames in (
        ("one multi-page TIFF", [str(tmp / "stack.tif")]),
        ("ten single-frame TIFFs", [str(single)]),
    ):
        peak = timed([*cmd, str(tmp / "big.yaml"), *frames], 1)[1]
        rows.append((label, peak, baseline, size))
    return rows


if __name__ == "__main__":
    sys.exit(main())
