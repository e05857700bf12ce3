"""What every benchmark shares: the line naming the machine, and peak memory of a child."""

from __future__ import annotations

import os
import platform
from pathlib import Path


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
