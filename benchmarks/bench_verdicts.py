"""How often `verify` errs: its false-alarm rate on known-good simulated stations beside
the rate it states, and its detection power on changed ones.

Run: ``python benchmarks/bench_verdicts.py [--runs 200] [--jobs 2] [--cli-runs 100]
[--out DIR]`` (about 80 minutes on 2 cores at the defaults; ``--runs 20 --cli-runs 10``
for a look).

Every run is a world of its own (the parts placed anew, another sensor's fixed pattern,
fresh noise), trained into a golden file by ``--repeats`` captures and verified on one
more, in process (:mod:`inspect_validate.simulation.trials`: the station's simulated
camera renders the frames, the one measuring path measures them, ``verify_capture``
decides, with the station's acceptance and the manual's drift block).

1. **False alarms.** Known-good stations: the shipped one, the inks station (12-bit,
   prints other than the spectra measured), the paperboard parts on a 12-bit camera
   (Mono12), and the shipped one whose lights vary 0.5 % from capture to capture (what
   a golden file's repeats must learn). The observed rate of failed verdicts with its
   Clopper–Pearson 95 % interval, beside the stated family-wise rate. The inks station is
   verified on the mix ``design`` finds for it (its separation checks apply there).
   Also the shipped station whose every capture shows other parts of its classes
   (``world.parts: redrawn``: another draw of the reflectance samples, as parts re-placed
   from a production), trained with that part-to-part spread at 5 and 20 repeats and
   held to the prediction as other parts (``agreement.parts: other``).
2. **Detection power.** The shipped station changed: the amber LED at 98, 95 and 90 %,
   its peak 3 and 6 nm off, K 5 % high, the lens at 95 %, ambient light on; steady, and
   with lights varying 0.5 % between captures at 5 and 20 repeats, and with other parts
   every capture. The detection probability with its interval, and which kind of check
   caught it most often.
3. **Operating characteristic.** The probability of passing against the amber LED's
   level, the three shipped stations; plotted to ``docs/_static/oc_curve.png``.
4. **One golden file, as a line has.** Each run above trains its own golden file, so
   its rate is an average over trainings. Here one golden file is trained through the
   CLI (``train``, 5 repeats) and ``--cli-runs`` verifications through the CLI
   (``verify``) are held against it, for the shipped station and for other parts every
   capture: the rate that golden file has.
5. **How good is one golden file.** Over 20,000 golden files of n repeats (a normal
   spread), each file's own per-check false-alarm rate against the check's share, as
   ``verify`` sets its limits (:func:`~inspect_validate.verification.golden_checks.
   drift_limit`): the prediction interval alone, and the default (the wider of it and a
   tolerance interval at ``drift.confidence`` 0.95): the mean (what the stated rate
   promises), the median and the 95th and 99.6th percentiles of rate/share, and the share
   of golden files above their share (what the confidence bounds).
"""

from __future__ import annotations

import argparse
import multiprocessing
import shutil
import time
from collections import Counter, defaultdict
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np
import yaml
from machine import machine_line
from scenes import twelve_bit_scene

ROOT = Path(__file__).resolve().parents[1]
STATION = ROOT / "sample_images" / "station"
SCENES = ROOT / "sample_images" / "scenes"

JITTER = 0.005
CHANGES = {
    "amber LED at 98 %": {"irradiance": {1: 0.98}},
    "amber LED at 95 %": {"irradiance": {1: 0.95}},
    "amber LED at 90 %": {"irradiance": {1: 0.90}},
    "amber peak +3 nm": {"peak_shift_nm": {1: 3.0}},
    "amber peak +6 nm": {"peak_shift_nm": {1: 6.0}},
    "K 5 % high": {"gain_error": 0.05},
    "lens at 95 %": {"transmission": 0.95},
    "ambient light 0.1 W/m²": {"ambient": 0.1},
}
OC_LEVELS = (0.9995, 0.999, 0.998, 0.995, 0.99, 0.98, 0.95, 0.9)


def oc_case(level: float) -> str:
    return f"amber at {100 * level:.4g} %"


def stations(folder: Path) -> dict[str, tuple[Path, int]]:
    """Name → (station file, repeats) of every station benchmarked; the 12-bit paperboard
    scene and the varying-light stations are written into ``folder``."""
    shipped = STATION / "station.yaml"
    doc = yaml.safe_load(shipped.read_text())
    scene12 = twelve_bit_scene(folder)

    def write(name, *, scene=SCENES / "paperboard" / "scene.yaml", camera=(), parts=None):
        d = yaml.safe_load(yaml.safe_dump(doc))
        d["scene"], d["rois"] = str(scene), str(STATION / "rois.yaml")
        d["camera"].update(camera)
        if parts:
            d["acceptance"]["agreement"]["parts"] = parts
        path = folder / f"{name}.yaml"
        path.write_text(yaml.safe_dump(d))
        return path

    # The inks station as `design inks.yaml` leaves it: its separation checks on the
    # designed mix (no single LED separates all three inks, by design).
    inks = yaml.safe_load((STATION / "inks.yaml").read_text())
    inks["scene"], inks["rois"] = str(SCENES / "mix" / "scene.yaml"), str(STATION / "rois.yaml")
    inks["illuminations"].append({"name": "design", "channels": {1: 100, 3: 64.1}})
    inks["acceptance"]["illumination"] = "design"
    (folder / "inks.yaml").write_text(yaml.safe_dump(inks))
    mono12 = write(
        "mono12",
        scene=scene12,
        camera={"pixel_format": "Mono12", "exposure_us": 20000},
    )
    # SNR_dB (36) divides by variances, so it falls with the gain: ε is the gain-free limit.
    d = yaml.safe_load(mono12.read_text())
    d["acceptance"]["separation"] = [{"comparison": "A vs B,C", "max_error": 0.1}]
    mono12.write_text(yaml.safe_dump(d))
    return {
        "shipped station (8-bit)": (shipped, 5),
        "inks station on its designed mix (12-bit, other prints)": (folder / "inks.yaml", 5),
        "paperboard on a 12-bit camera (Mono12)": (mono12, 5),
        "shipped, lights ±0.5 % between captures, 5 repeats": (
            write("jitter", camera={"world": {"irradiance_jitter": JITTER}}),
            5,
        ),
        "shipped, lights ±0.5 % between captures, 20 repeats": (folder / "jitter.yaml", 20),
        "shipped, other parts every capture, 5 repeats": (
            write("redrawn", camera={"world": {"parts": "redrawn"}}, parts="other"),
            5,
        ),
        "shipped, other parts every capture, 20 repeats": (folder / "redrawn.yaml", 20),
    }


def with_drift(path: Path, folder: Path) -> Path:
    """The station with the manual's drift block (k: 3), in ``folder``."""
    doc = yaml.safe_load(path.read_text())
    for key in ("scene", "rois"):
        doc[key] = str((path.parent / doc[key]).resolve())
    doc.setdefault("acceptance", {})["drift"] = {"golden": "golden.json", "k": 3}
    out = folder / f"{path.stem}-drift.yaml"
    out.write_text(yaml.safe_dump(doc))
    return out


def cli_false_alarms(path: Path, runs: int) -> tuple[int, int, float]:
    """One golden file trained through the CLI (5 repeats), then ``runs`` verifications
    through the CLI against it: (failed, runs, seconds a verification)."""
    import subprocess
    import sys

    folder = path.parent
    folder.mkdir(parents=True, exist_ok=True)
    station = folder / "station.yaml"
    doc = yaml.safe_load(path.read_text())
    station.write_text(yaml.safe_dump(doc))
    cli = [sys.executable, "-m", "inspect_validate"]
    subprocess.run(
        [*cli, "train", station, "--repeats", "5", "--out", folder / "golden.json"],
        check=True,
        capture_output=True,
    )
    failed, t = 0, time.perf_counter()
    for i in range(runs):
        r = subprocess.run(
            [*cli, "verify", station, "--out", folder / f"v{i}"], capture_output=True
        )
        if r.returncode not in (0, 1):
            raise SystemExit(f"verify exited {r.returncode}: {r.stderr.decode()[-500:]}")
        failed += r.returncode == 1
        shutil.rmtree(folder / f"v{i}")
    return failed, runs, (time.perf_counter() - t) / max(runs, 1)


def golden_file_rates(
    repeats: int, share: float, confidence: float | None, *, draws: int = 20_000
) -> np.ndarray:
    """Each of ``draws`` golden files' own false-alarm rate over its share: ``repeats``
    repeats of a unit normal spread (their own standard error a tenth of it), the limit
    :func:`drift_limit` sets, a new value of the unchanged station N(0, 1)."""
    from scipy.stats import norm

    from inspect_validate.verification.golden import Spread
    from inspect_validate.verification.golden_checks import drift_limit

    rng = np.random.default_rng(repeats)
    rates = np.empty(draws)
    for i, row in enumerate(rng.normal(0.0, 1.0, (draws, repeats))):
        spread = Spread(values=list(row), standard_errors=[0.1] * repeats)
        limit = drift_limit(spread, share, confidence=confidence)
        rates[i] = norm.sf(limit - spread.mean) + norm.sf(limit + spread.mean)
    return rates / share


def report_cli(cli: dict, rate: float) -> None:
    print("\nOne golden file reused, through the CLI (train once, verify many times)\n")
    print("| station | verifications | failed | observed rate (95 % interval) | stated | s each |")
    print("|---|---|---|---|---|---|")
    for name, (k, n, seconds) in cli.items():
        lo, hi = clopper_pearson(k, n)
        print(
            f"| {name} | {n} | {k} | {percent(k / n)} ({percent(lo)}–{percent(hi)}) | "
            f"{percent(rate)} | {seconds:.2f} |"
        )


def report_golden_files() -> None:
    share = 0.0027 / 25  # the shipped station's share with its drift block
    print(f"\nHow good is one golden file: its own rate over its share ({share:.2g} a check)\n")
    print(
        "| repeats | limits | mean | median | 95th percentile | 99.6th percentile | "
        "files above their share |"
    )
    print("|---|---|---|---|---|---|---|")
    for repeats in (5, 9, 20):
        for label, confidence in (("prediction interval", None), ("default (γ 0.95)", 0.95)):
            r = golden_file_rates(repeats, share, confidence)
            q50, q95, q996 = np.quantile(r, [0.5, 0.95, 0.996])
            print(
                f"| {repeats} | {label} | {r.mean():.2f} | {q50:.2g} | {q95:.2g} | {q996:.2g} | "
                f"{percent(float(np.mean(r > 1)))} |"
            )


def work(args) -> list:
    """One process's share of the runs of one station."""
    path, repeats, runs, changes = args
    from inspect_validate.simulation import run_trials
    from inspect_validate.station.file import read_station

    station = read_station(path)
    return list(run_trials(station, runs=runs, repeats=repeats, changes=changes))


def clopper_pearson(k: int, n: int, level: float = 0.95) -> tuple[float, float]:
    """The exact binomial interval of k successes in n trials."""
    from scipy.stats import beta

    a = (1 - level) / 2
    lo = 0.0 if k == 0 else float(beta.ppf(a, k, n - k + 1))
    hi = 1.0 if k == n else float(beta.ppf(1 - a, k + 1, n - k))
    return lo, hi


def percent(x: float) -> str:
    return f"{100 * x:.3g} %"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=200)
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--cli-runs", type=int, default=100)
    parser.add_argument("--out", type=Path, default=ROOT / "docs" / "_static")
    args = parser.parse_args()

    import tempfile

    from inspect_validate.station.file import read_station

    print(machine_line())
    t0 = time.perf_counter()
    results = {}
    # Spawned workers: a forked one would inherit numba's OpenMP threads if any had run.
    spawn = multiprocessing.get_context("spawn")
    with (
        tempfile.TemporaryDirectory() as tmp,
        ProcessPoolExecutor(args.jobs, mp_context=spawn) as pool,
    ):
        tmp = Path(tmp)
        for name, (path, repeats) in stations(tmp).items():
            path = with_drift(path, tmp)
            changes = {}
            if name.startswith("shipped"):
                changes = {k: dict(v) for k, v in CHANGES.items()}
                if "other parts" not in name:  # the figure's three stations
                    changes.update({oc_case(x): {"irradiance": {1: x}} for x in OC_LEVELS})
                for change in changes.values():
                    if "between captures" in name:
                        change["irradiance_jitter"] = JITTER
                    if "other parts" in name:
                        change["parts"] = "redrawn"
            chunks = [range(i, args.runs, args.jobs * 4) for i in range(args.jobs * 4)]
            t = time.perf_counter()
            trials = [
                trial
                for part in pool.map(work, [(path, repeats, c, changes) for c in chunks])
                for trial in part
            ]
            results[name] = trials
            rate = read_station(path).acceptance.false_alarm_rate
            print(f"{name}: {len(trials)} verifications in {time.perf_counter() - t:.0f} s")
        cli = {}
        for i, (name, path) in enumerate(
            (
                ("shipped station", STATION / "station.yaml"),
                ("shipped, other parts every capture", tmp / "redrawn.yaml"),
            )
        ):
            (tmp / f"cli{i}").mkdir()
            cli[name] = cli_false_alarms(with_drift(path, tmp / f"cli{i}"), args.cli_runs)
    print(f"total {time.perf_counter() - t0:.0f} s; stated false-alarm rate {percent(rate)}\n")
    report(results, rate, runs=args.runs, out=args.out)
    report_cli(cli, rate)
    report_golden_files()


def report(results: dict, rate: float, *, runs: int, out: Path) -> None:
    print("False alarms: verifications of the unchanged station that failed")
    print()
    print("| known-good station | runs | failed | observed rate (95 % interval) | stated | holds |")
    print("|---|---|---|---|---|---|")
    for name, trials in results.items():
        good = [t for t in trials if t.case == "unchanged"]
        k = sum(not t.passed for t in good)
        lo, hi = clopper_pearson(k, len(good))
        holds = "yes" if lo <= rate else "NO"
        print(
            f"| {name} | {len(good)} | {k} | {percent(k / len(good))} "
            f"({percent(lo)}–{percent(hi)}) | {percent(rate)} | {holds} |"
        )
    print()
    print("Detection: verifications of the changed station that failed")
    print()
    names = [n for n in results if n.startswith("shipped")]
    print("| change | " + " | ".join(names) + " |")
    print("|---|" + "---|" * len(names))
    for case in CHANGES:
        cells = []
        for name in names:
            rows = [t for t in results[name] if t.case == case]
            k = sum(not t.passed for t in rows)
            lo, hi = clopper_pearson(k, len(rows))
            kinds = Counter(kind for t in rows for kind in set(t.kinds))
            by = kinds.most_common(1)[0][0] if kinds else "—"
            cells.append(f"{percent(k / len(rows))} ({percent(lo)}–{percent(hi)}), {by}")
        print(f"| {case} | " + " | ".join(cells) + " |")
    print()
    oc = defaultdict(dict)
    print("Operating characteristic: probability of passing against the amber LED's level")
    print()
    names = [n for n in names if "other parts" not in n]  # the figure's three stations
    print("| amber level | " + " | ".join(names) + " |")
    print("|---|" + "---|" * len(names))
    for level in (1.0, *OC_LEVELS):
        case = "unchanged" if level == 1.0 else oc_case(level)
        cells = []
        for name in names:
            rows = [t for t in results[name] if t.case == case]
            p = sum(t.passed for t in rows) / len(rows)
            oc[name][level] = (p, *clopper_pearson(sum(t.passed for t in rows), len(rows)))
            cells.append(f"{p:.3f}")
        print(f"| {100 * level:.4g} % | " + " | ".join(cells) + " |")
    plot(oc, out / "oc_curve.png", runs=runs)
    print(f"\nfigure: {out / 'oc_curve.png'}")


def plot(oc: dict, path: Path, *, runs: int) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7, 4), dpi=100)
    for name, points in oc.items():
        levels = sorted(points)
        loss = [100 * (1 - x) for x in levels]
        p = [points[x][0] for x in levels]
        lo = [points[x][0] - points[x][1] for x in levels]
        hi = [points[x][2] - points[x][0] for x in levels]
        ax.errorbar(
            [max(x, 0.02) for x in loss], p, yerr=[lo, hi], marker="o", capsize=3, label=name
        )
    ax.set_xscale("log")
    ax.set_xlabel("amber LED's light lost [%] (0 drawn at 0.02)")
    ax.set_ylabel("probability of passing")
    ax.set_ylim(-0.03, 1.03)
    ax.set_title(f"verify's operating characteristic ({runs} runs a point, 95 % intervals)")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8, loc="lower left")
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path)
    plt.close(fig)


if __name__ == "__main__":
    main()
