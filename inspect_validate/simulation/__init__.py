"""Simulated stations: devices that render a scene (no hardware needed), and captures
rendered in process for measuring how often a verification errs.

===================  =========================================================================
:mod:`.camera`       a simulated camera: frames of a scene under the LED channels now on
:mod:`.controller`   a simulated Gardasoft RT controller on a pseudo-terminal
:mod:`.devices`      the simulated devices, registered as backends like any other
:mod:`.fake_gige`    Aravis' GigE Vision fake camera, run as a process of its own
:mod:`.trials`       verifications of a simulated station, many times over
===================  =========================================================================
"""

from inspect_validate.simulation.trials import (
    Trial,
    WatchTrial,
    render_capture,
    run_trials,
    watch_trials,
)

__all__ = ["Trial", "WatchTrial", "render_capture", "run_trials", "watch_trials"]
