"""The line every benchmark prints first: which machine measured it."""

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
