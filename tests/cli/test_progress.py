"""The capture progress bar's ETA counts from the first frame, not from the camera's opening."""

import io
import time

from inspect_validate.cli.common import FrameProgress


def run_bar(*, opening_s: float, already: int = 0, frames: int = 25, frame_s: float = 0.06):
    with FrameProgress(100, label="capturing", file=io.StringIO()) as advance:
        time.sleep(opening_s)  # the camera opening, configuring and flushing
        for done in range(already + 1, already + frames + 1):
            advance(done, "amber")
            time.sleep(frame_s)
        advance(already + frames + 1, "amber")
        bar = advance.bar  # read only: the bar's own estimate
        return bar.eta, bar.length - bar.pos


def test_eta_is_not_charged_the_opening():
    eta, left = run_bar(opening_s=1.2)
    # 0.06 s a frame (time.sleep overshoots a little): the ETA is near left × 0.06 s,
    # where click's own clock, from the bar's creation, makes it 11× that (49 s for the
    # 74 frames left, measured with this loop and bar.update alone).
    assert left * 0.05 < eta < left * 0.09, (eta, left)


def test_a_resumed_run_counts_only_the_frames_it_grabs():
    eta, left = run_bar(opening_s=0.0, already=60, frames=20)
    assert left == 100 - 81
    assert left * 0.05 < eta < left * 0.09, (eta, left)
