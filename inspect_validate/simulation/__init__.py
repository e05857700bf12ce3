"""Simulated stations in process: captures rendered without devices or files, for
measuring how often a verification errs (:mod:`.trials`)."""

from inspect_validate.simulation.trials import (
    Trial,
    WatchTrial,
    render_capture,
    run_trials,
    watch_trials,
)

__all__ = ["Trial", "WatchTrial", "render_capture", "run_trials", "watch_trials"]
