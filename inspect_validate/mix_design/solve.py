"""Solve a :class:`~inspect_validate.mix_design.problem.DesignProblem`: the optimal mix, the
best single channel, both predicted by ``predict`` for the mixed light, and how flat the
optimum is."""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    from collections.abc import Callable

    from inspect_validate.mix_design.catalogue import Choice
    from inspect_validate.mix_design.problem import DesignProblem
    from inspect_validate.model import Prediction

__all__ = ["Design", "decibel", "drive_percent", "solve"]

DRIVE_TOLERANCE = 0.10  # an LED controller's output is good to about ±10 %


@dataclass(frozen=True, eq=False)
class Design:
    """The designed mix and the best single channel.

    Attributes
    ----------
    problem : DesignProblem
    objective : str
        ``"error"`` (the worst ε was minimised) or ``"cnr"`` (the worst CNR maximised).
    exposure_time : float
        s: the problem's, or with auto exposure the designed one — the shortest at
        which neither the mix nor the best single channel needs a level above 100 %.
    levels : dict of channel to float
        Optimal drive level per channel, 0–1, at ``exposure_time``.
    single : tuple (channel, level)
        The best single channel and its level at ``exposure_time``.
    mix, single_prediction : Prediction
        ``predict`` of the mixed light and of the single channel at its level
        (every comparison of the problem), shape (1, 1, 1).
    flatness : list of dict
        For each channel moved by ±10 % of its level: the worst objective ε and CNR.
    path : dict of ndarray
        Along the straight path from the best single channel (``fraction`` 0) to the
        mix (1): ``errors`` and ``cnr`` (a ratio) of the objective's comparisons, (T, P).
    starts : int
    choice : Choice or None
        How the channels were chosen from a catalogue (``choose``), else None.
    """

    problem: DesignProblem
    objective: str
    exposure_time: float
    levels: dict
    single: tuple
    mix: Prediction
    single_prediction: Prediction
    flatness: list
    path: dict
    starts: int
    choice: Choice | None = None

    @property
    def percent(self) -> dict:
        """Drive levels in % to 3 significant digits (a very bright light may need 0.0001 %),
        channels below 1/1000 of the strongest left out."""
        top = max(self.levels.values(), default=0.0)
        return {c: drive_percent(w) for c, w in self.levels.items() if w > 1e-3 * top}


def drive_percent(level: float) -> float:
    """A drive level (0–1) as the % a station file's illumination gives, 3 significant digits."""
    return float(f"{100.0 * level:.3g}")


def solve(
    problem: DesignProblem,
    *,
    objective: str = "error",
    choose: int | None = None,
    progress: Callable[[int, int], None] | None = None,
    note: Callable[[str], None] | None = None,
) -> Design:
    """The mix of ``problem``'s channels that minimises its objective's worst ε (or, with
    ``objective="cnr"``, maximises the worst CNR); with ``choose``, of the best ``choose`` of
    them (:func:`~.catalogue.choose_channels`, ``progress`` its callback). ``note(message)``
    is told how the screening of a large catalogue goes. With the problem's
    auto exposure the levels are optimised up to the longest exposure over the reference
    one and rescaled to a designed exposure time."""

    from inspect_validate.mix_design.catalogue import choose_channels
    from inspect_validate.mix_design.mix import (
        JOINT_MAX,
        channel_response,
        comparison_cnr,
        comparison_errors,
        optimise_mix,
        single_losses,
    )

    response = channel_response(
        problem.channels,
        problem.optics,
        problem.sensor,
        problem.classes,
        grid=problem.grid,
        exposure_time=problem.exposure_time,
    )
    max_level = problem.max_exposure_time / problem.exposure_time if problem.auto_exposure else 1.0
    options: dict[str, Any] = {
        "objective": objective,
        "max_saturated": problem.max_saturated,
        "max_level": max_level,
    }
    labels = list(problem.channels)
    choice = None
    if choose is None:
        chosen = list(range(len(labels)))
        mix = optimise_mix(response, problem.objective, progress=note, **options)
        if len(labels) > JOINT_MAX:  # a screened catalogue: its lights at 0 are not in it
            chosen = [int(c) for c in np.flatnonzero(mix.levels > 0)]
            mix = replace(mix, levels=mix.levels[chosen])
    else:
        choice = choose_channels(response, problem.objective, choose, progress=progress, **options)
        chosen, mix = list(choice.channels), choice.mix

    def optimise(channels):
        return optimise_mix(channels, problem.objective, **options)

    candidates = list(range(len(labels)))
    if len(labels) > JOINT_MAX:  # a catalogue: optimise the lights best alone at their limit
        _, alone = single_losses(response, problem.objective, **options)
        candidates = [int(c) for c in np.argsort(alone.max(axis=1))[:JOINT_MAX]]
    singles = {int(c): optimise(response.subset([c])) for c in candidates}
    best = min(singles, key=lambda c: singles[c].loss)
    single_level = float(singles[best].levels[0])

    mixed = response.subset(chosen)

    def worst(w):
        """Worst ε and CNR of the objective over the chosen channels at levels ``w``."""
        return (
            float(comparison_errors(mixed, w, problem.objective).max()),
            float(comparison_cnr(mixed, w, problem.objective).min()),
        )

    flatness = []
    ceiling = response.ceiling(problem.max_saturated)
    for c, label in enumerate(labels[i] for i in chosen):
        for sign in (-1.0, 1.0):
            w = mix.levels.copy()
            w[c] = min(w[c] * (1.0 + sign * DRIVE_TOLERANCE), max_level)
            eps, cnr = worst(w)
            flatness.append(
                {
                    "channel": label,
                    "change": sign * DRIVE_TOLERANCE,
                    "worst_error": eps,
                    "worst_cnr_db": decibel(cnr),
                    "saturates": bool(mixed.signal(w).max() > ceiling),
                }
            )
    # The straight path stays feasible: both ends are, and the constraints are linear.
    start, end = np.zeros(len(labels)), np.zeros(len(labels))
    start[best] = single_level
    end[chosen] = mix.levels
    fraction = np.linspace(0.0, 1.0, _PATH_POINTS)
    on_path = [(1.0 - f) * start + f * end for f in fraction]
    path = {
        "fraction": fraction,
        "errors": np.array([comparison_errors(response, w, problem.objective) for w in on_path]),
        "cnr": np.array([comparison_cnr(response, w, problem.objective) for w in on_path]),
    }
    # Auto exposure: level × exposure is what counts; the longest-needing of the two
    # illuminations sets the exposure at 100 %.
    scale = max(float(mix.levels.max()), single_level) if problem.auto_exposure else 1.0
    levels = dict(zip([labels[i] for i in chosen], map(float, mix.levels / scale), strict=True))
    single = (labels[best], single_level / scale)
    exposure_time = problem.exposure_time * scale
    return Design(
        problem=problem,
        objective=objective,
        exposure_time=exposure_time,
        levels=levels,
        single=single,
        mix=_predict(problem, levels, "designed mix", exposure_time),
        single_prediction=_predict(
            problem, {single[0]: single[1]}, f"channel {single[0]}", exposure_time
        ),
        flatness=flatness,
        path=path,
        starts=mix.starts,
        choice=choice,
    )


_PATH_POINTS = 51  # a comparison's CNR can pass through 0 between the ends: not too coarse


def decibel(ratio: float) -> float:
    """A CNR in dB: 20·log10, −inf for 0 (as ``predict``'s ``cnr_db``)."""
    return float(20.0 * np.log10(ratio)) if ratio > 0 else float("-inf")


def _predict(problem, levels: dict, name: str, exposure_time: float):
    """``predict`` of the light ``levels`` mix at ``exposure_time`` s, with every comparison
    of the problem."""
    from inspect_validate.model import Exposure, predict
    from inspect_validate.station.model import illumination_light

    light = illumination_light(
        name,
        {c: 100.0 * w for c, w in levels.items()},
        problem.channels,
        grid=problem.grid,
    )
    return predict(
        [light],
        [problem.optics],
        [problem.sensor],
        list(problem.classes),
        exposure=Exposure("fixed", time=exposure_time),
        grid=problem.grid,
        comparisons=problem.comparisons,
    )
