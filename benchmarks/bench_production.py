"""Production mode keeping up with a line (issue 48, item 9): a part located, its regions
moved and measured on 2448 × 2048 8-bit frames with 3 classes, per stage, against the
line's pace of 30 parts/s; and, as the reference in the same run, what OpenCV alone takes
for the same search done the plain way (``findTransformECC`` once at full resolution from
the true pose, no pyramid).

The part is scikit-image's photograph of a cameraman, enlarged to 1536 × 1536 px on a
darker belt; each frame moves and turns it (up to 40 px, 3°) with 2 DN of noise.

Run: ``python benchmarks/bench_production.py [--parts 20]`` (about half a minute).
"""

from __future__ import annotations

import argparse
import statistics
import time

import cv2
import numpy as np
from machine import machine_line
from skimage import data

HEIGHT, WIDTH = 2048, 2448
TEMPLATE = (440, 240, 1568, 1568)
TARGET = 30.0  # parts/s


def scene():
    """The reference frame and three class regions in it."""
    part = cv2.resize(data.camera(), (1536, 1536), interpolation=cv2.INTER_CUBIC)
    reference = np.full((HEIGHT, WIDTH), 30, np.uint8)
    reference[256:1792, 456:1992] = part
    masks = {k: np.zeros((HEIGHT, WIDTH), bool) for k in "ABC"}
    masks["A"][500:800, 1000:1300] = True
    masks["B"][1000:1400, 800:1200] = True
    masks["C"][350:550, 550:950] = True
    return reference, masks


def frames(reference, n, seed=0):
    rng = np.random.default_rng(seed)
    for _ in range(n):
        m = cv2.getRotationMatrix2D((WIDTH / 2, HEIGHT / 2), rng.uniform(-3, 3), 1.0)
        m[:, 2] += rng.uniform(-40, 40, 2)
        moved = cv2.warpAffine(reference.astype(np.float32), m, (WIDTH, HEIGHT),
                               flags=cv2.INTER_CUBIC, borderValue=30)  # fmt: skip
        noise = rng.normal(0, 2, moved.shape)
        yield np.clip(moved + noise, 0, 255).astype(np.uint8), m


def main() -> None:
    from inspect_validate.comparisons import Comparisons
    from inspect_validate.measurement import compare_many
    from inspect_validate.station.production import PartLocator, part_classes, part_focus

    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--parts", type=int, default=20)
    args = parser.parse_args()
    reference, masks = scene()
    comparisons = Comparisons.of(list(masks))
    stages: dict[str, list[float]] = {k: [] for k in ("locate", "place", "statistics", "focus")}
    plain: list[float] = []
    classes = []
    x, y, w, h = TEMPLATE
    patch = reference[y : y + h, x : x + w].astype(np.float32)
    # Prepared once, as a station's part locator is (the production default's rotation
    # sweep, which these parts, found unturned, never run).
    locator = PartLocator(reference, masks, TEMPLATE, "euclidean", 0.8, 100, 30.0)
    locator.search, locator.bounds, locator.blank_shares  # noqa: B018 (made before any part)
    for i, (frame, truth) in enumerate(frames(reference, args.parts + 1)):
        # "place": the regions moved onto the located part and the part's checks (pixels
        # kept, blank blocks), timed on their own.
        t0 = time.perf_counter()
        pose = locator.search.locate(frame, motion=locator.motion)
        t1 = time.perf_counter()
        placement = locator.place_at(frame, pose)
        t2 = time.perf_counter()
        assert placement.regions is not None, placement.reason
        classes.append(part_classes(frame, placement))
        t3 = time.perf_counter()
        part_focus(frame, placement.regions)
        t4 = time.perf_counter()
        # The reference: ECC once at full resolution, started at the true translation.
        start = np.array([[1, 0, x + truth[0, 2]], [0, 1, y + truth[1, 2]]], np.float32)
        criteria = (cv2.TERM_CRITERIA_EPS | cv2.TERM_CRITERIA_COUNT, 100, 1e-6)
        t5 = time.perf_counter()
        cv2.findTransformECC(patch, frame.astype(np.float32), start, cv2.MOTION_EUCLIDEAN,
                             criteria, None, 1)  # fmt: skip
        t6 = time.perf_counter()
        if i == 0:  # first use: imports and caches
            continue
        for name, seconds in zip(stages, (t1 - t0, t2 - t1, t3 - t2, t4 - t3), strict=True):
            stages[name].append(seconds)
        plain.append(t6 - t5)
    # The comparisons of a batch are computed at once (as a verdict's batch is): their
    # share of a part is the batch's time over its parts.
    t0 = time.perf_counter()
    compare_many(classes[1:], comparisons)
    compared = (time.perf_counter() - t0) / args.parts
    medians = {k: statistics.median(v) for k, v in stages.items()}
    medians["statistics"] += compared
    total = sum(medians.values())
    print(machine_line())
    print(f"median over {args.parts} parts, one thread, 2448 × 2048 8-bit, 3 classes\n")
    print("| stage (place: the regions moved, the part's checks; statistics: the classes, "
          "and the batch's comparisons over its parts) | ms a part |")  # fmt: skip
    print("|---|---|")
    for name, seconds in medians.items():
        print(f"| {name} | {1e3 * seconds:.1f} |")
    print(f"| **a part** | **{1e3 * total:.1f}** |")
    ecc = statistics.median(plain)
    print()
    print("| | parts/s | target | holds | locate ÷ plain full-resolution ECC |")
    print("|---|---|---|---|---|")
    print(f"| locate + place + statistics + focus | {1 / total:.1f} | ≥ {TARGET:g} | "
          f"{'yes' if 1 / total >= TARGET else 'no'} | {medians['locate'] / ecc:.3f} "
          f"({1e3 * medians['locate']:.1f} ms against {1e3 * ecc:.0f} ms) |")  # fmt: skip


if __name__ == "__main__":
    main()
