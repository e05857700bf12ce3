"""What every benchmark shares: the line naming the machine, timing, exact moments, and
the peak memory of a child."""

from __future__ import annotations

import os
import platform
import time
from fractions import Fraction
from pathlib import Path

import numpy as np


def cpu_name() -> str:
    info = Path("/proc/cpuinfo")
    if info.exists():
        for line in info.read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    return platform.processor() or platform.machine()


def machine_line() -> str:
    """``machine: <CPU>, <n> cores, Python <version>``."""
    return f"machine: {cpu_name()}, {os.cpu_count()} cores, Python {platform.python_version()}"


# Run as ``python -c PEAK_LAUNCHER OUT argv...``: runs argv (a script path, or ``-m
# module``) and writes its VmHWM in bytes to OUT at exit. A child's ru_maxrss is not
# its own: exec keeps the high-water mark of the address space it replaced, which
# for a child spawned by vfork is the *parent's* peak.
PEAK_LAUNCHER = """
import atexit, runpy, sys
out = sys.argv[1]
def _write():
    for line in open("/proc/self/status"):
        if line.startswith("VmHWM:"):
            open(out, "w").write(str(int(line.split()[1]) * 1024))
atexit.register(_write)
if sys.argv[2] == "-m":
    sys.argv = [sys.argv[3], *sys.argv[4:]]
    runpy.run_module(sys.argv[0], run_name="__main__", alter_sys=True)
else:
    sys.argv = sys.argv[2:]
    runpy.run_path(sys.argv[0], run_name="__main__")
"""


def peak_rss() -> int:
    """This process's own peak resident memory (VmHWM), bytes."""
    for line in Path("/proc/self/status").read_text().splitlines():
        if line.startswith("VmHWM:"):
            return int(line.split()[1]) * 1024
    import resource

    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024


def compile_package() -> None:
    """Write the bytecode of the project's packages, as installing them does.

    A fresh process timed on a checkout otherwise compiles every module it imports
    from source when bytecode is not written (``PYTHONDONTWRITEBYTECODE``, set in many
    containers): about 25 ms of a 0.3 s measure run, which no installed copy pays.
    """
    import compileall

    root = Path(__file__).resolve().parent.parent
    for package in ("inspect_validate", "camera"):
        compileall.compile_dir(root / package, quiet=1)


def best_time(fn, repeat=5) -> float:
    """The fastest of ``repeat`` calls of ``fn``, s, after one warm-up call."""
    fn()
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return min(times)


def exact_moments(values: np.ndarray) -> tuple[Fraction, Fraction]:
    """Mean and unbiased variance of integer ``values`` as exact rationals (the reference
    every moment is measured against), from their histogram."""
    values = np.ravel(values)
    if values.dtype.kind == "u":
        counts = np.bincount(values)
        v = np.flatnonzero(counts)
        counts = counts[v]
    else:
        v, counts = np.unique(values, return_counts=True)
    n = int(counts.sum())
    s1 = sum(int(x) * int(c) for x, c in zip(v, counts, strict=True))
    s2 = sum(int(x) ** 2 * int(c) for x, c in zip(v, counts, strict=True))
    return Fraction(s1, n), Fraction(n * s2 - s1 * s1, n * (n - 1))
