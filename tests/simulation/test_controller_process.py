"""The simulated controller process on its own: a parent that removes its temporary folder
while the process is still starting (a watch stopped by SIGTERM between two cycles) ends
it quietly; its traceback used to reach the parent's terminal (seen in .ci/run, once, in
test_watch_stops_on_sigterm_at_every_moment)."""

import subprocess
import sys


def test_a_vanished_state_folder_ends_the_process_without_a_traceback(tmp_path):
    gone = tmp_path / "iv-sim-gone"  # never made: removed before the first save
    run = subprocess.run(
        [sys.executable, "-m", "inspect_validate.simulation.controller",
         "--state", str(gone / "state.json")],
        capture_output=True, text=True, timeout=60,
    )  # fmt: skip
    assert run.returncode == 0 and "Traceback" not in run.stderr, run.stderr


def test_a_missing_state_folder_the_parent_still_has_is_an_error(tmp_path):
    """Only a folder that is gone ends it quietly: a state file in a folder that exists
    but cannot take it still fails loudly."""
    (tmp_path / "state.json").mkdir()  # a folder where the state file goes
    (tmp_path / "state.tmp").mkdir()
    run = subprocess.run(
        [sys.executable, "-m", "inspect_validate.simulation.controller",
         "--state", str(tmp_path / "state.json")],
        capture_output=True, text=True, timeout=60,
    )  # fmt: skip
    assert run.returncode != 0 and "Error" in run.stderr


def test_a_parent_gone_before_the_process_started_ends_it(tmp_path):
    """The tool gives its own id (``--parent``): a process whose parent died while it
    started ends, its folder removed, whichever process then took it in (init, or a
    service manager that reaps orphans, whose id is not 1)."""
    folder = tmp_path / "iv-sim-orphan"
    folder.mkdir()
    run = subprocess.run(
        [sys.executable, "-m", "inspect_validate.simulation.controller",
         "--state", str(folder / "state.json"), "--parent", "999999999"],
        capture_output=True, text=True, timeout=60,
    )  # fmt: skip
    assert run.returncode == 0 and run.stdout == "", (run.stdout, run.stderr)
    assert not folder.exists()


def test_its_parent_keeps_it_running(tmp_path):
    """The same process given its true parent serves: it prints its port."""
    import os

    proc = subprocess.Popen(
        [sys.executable, "-m", "inspect_validate.simulation.controller",
         "--state", str(tmp_path / "state.json"), "--parent", str(os.getpid())],
        stdout=subprocess.PIPE, text=True,
    )  # fmt: skip
    try:
        assert proc.stdout.readline().startswith("/dev/")
    finally:
        proc.kill()
        proc.wait()
        proc.stdout.close()
