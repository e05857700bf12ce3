import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PAPERBOARD = ROOT / "sample_images" / "paperboard"


@pytest.fixture
def paperboard():
    return PAPERBOARD


@pytest.fixture
def simulator(tmp_path):
    """Start simulated controller processes: ``start(*args) -> (port, state_path, process)``."""
    procs = []

    def start(*args):
        state = tmp_path / f"state{len(procs)}.json"
        proc = subprocess.Popen(
            [
                sys.executable,
                "-m",
                "inspect_validate.camera.lights.simulator",
                "--state",
                str(state),
                *args,
            ],
            stdout=subprocess.PIPE,
            text=True,
        )
        procs.append(proc)
        return proc.stdout.readline().strip(), state, proc

    yield start
    for p in procs:
        p.kill()
        p.wait()
        p.stdout.close()


def run_cli(args) -> int | None:
    """Run the CLI in-process; its exit code (None when it returned without exiting)."""
    from inspect_validate.cli import main

    try:
        main([str(a) for a in args])
    except SystemExit as exc:
        return exc.code
    return None
