"""Sequential stopping: grab an illumination's frames only until its classes are known.

A station with ``precision:`` treats ``frames`` as a maximum. After each
verified frame k (from ``min_frames`` on), every class's grey-value mean μ_k and
variance σ²_k in that frame are added to its series, and the step ends once,
for every class,

    SE(μ)  = sd(μ_1 … μ_k) / √k  ≤ precision.mean     · max(|μ̄|, 1 DN)
    SE(σ²) = sd(σ²_1 … σ²_k) / √k ≤ precision.variance · max(σ̄², 1 DN²)

(sd with k − 1 degrees of freedom). These are the standard errors of the
averages over the frames: what repeating the step would scatter by. The
classes' texture is the same in every frame, so it does not average away and
is not part of either error; the camera's temporal noise and the light's
flicker are. ``min_frames`` (at least 3) keeps two frames that happen to agree
from ending a step.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from inspect_validate.roi.roiset import RoiSet

__all__ = ["Known", "SequentialStop"]


@dataclass(frozen=True)
class Known:
    """How well the frames so far know every class: the largest relative standard
    errors over the classes (of μ and of σ²) after ``frames`` frames, and whether
    they reach the station's precision."""

    frames: int
    mean: float
    variance: float
    reached: bool

    def describe(self) -> str:
        return (
            f"μ known to ±{100 * self.mean:.2g} %, σ² to ±{100 * self.variance:.2g} % "
            f"(relative standard errors over {self.frames} frames)"
        )


class SequentialStop:
    """Per-frame class statistics of one step and the precision they reach.

    Parameters
    ----------
    rois : RoiSet
        The classes (rasterised on the first frame).
    mean, variance : float
        Relative standard errors to reach for μ and σ².
    min_frames : int
        Frames before the first check.
    """

    def __init__(self, rois: RoiSet, *, mean: float, variance: float, min_frames: int) -> None:
        self._rois = rois
        self._masks: dict[str, np.ndarray] | None = None
        self._target = (mean, variance)
        self._min = min_frames
        self._rows: list[np.ndarray] = []  # per frame: (classes, [μ, σ²])

    def add(self, data: np.ndarray) -> bool:
        """Add a frame (DN); whether the step may stop now.

        Raises
        ------
        InputError
            A class outside the frame (on the first frame).
        """
        from inspect_validate.stats import region_statistics, sample_moments

        if self._masks is None:
            from inspect_validate.roi import class_masks

            self._masks = class_masks(self._rois, data.shape[-2:])
        masks: dict[str, np.ndarray] = self._masks
        # measure's own statistics (exact for integer frames), class by class.
        moments = [sample_moments(region_statistics(data, m).sample) for m in masks.values()]
        self._rows.append(np.array([(m.mean, m.variance) for m in moments]))
        known = self.known()
        return known is not None and known.reached and len(self._rows) >= self._min

    def known(self) -> Known | None:
        """The relative standard errors after the frames so far (None before the second)."""
        k = len(self._rows)
        if k < 2:
            return None
        rows = np.stack(self._rows)  # (frames, classes, 2)
        scale = np.maximum(np.abs(rows.mean(axis=0)), 1.0)
        relative = rows.std(axis=0, ddof=1) / np.sqrt(k) / scale
        mean, variance = (float(x) for x in relative.max(axis=0))
        return Known(k, mean, variance, mean <= self._target[0] and variance <= self._target[1])
