"""Solve a :class:`~inspect_validate.design.problem.DesignProblem`: the optimal mix, the
best single channel, both predicted by ``predict`` for the mixed light, and how flat the
optimum is."""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["Design", "drive_percent", "solve"]

DRIVE_TOLERANCE = 0.10  # an LED controller's output is good to about ±10 %


@dataclass(frozen=True, eq=False)
class Design:
    """The designed mix and the best single channel.

    Attributes
    ----------
    problem : DesignProblem
    levels : dict of channel to float
        Optimal drive level per channel, 0–1.
    single : tuple (channel, level)
        The best single channel and its level.
    mix, single_prediction : Prediction
        ``predict`` of the mixed light and of the single channel at its level
        (every comparison of the problem), shape (1, 1, 1).
    flatness : list of dict
        For each channel moved by ±10 % of its level: the worst objective ε.
    starts : int
    choice : Choice or None
        How the channels were chosen from a catalogue (``choose``), else None.
    """

    problem: object
    levels: dict
    single: tuple
    mix: object
    single_prediction: object
    flatness: list
    starts: int
    choice: object = None

    @property
    def percent(self) -> dict:
        """Drive levels in % to 3 significant digits (a very bright light may need 0.0001 %),
        channels below 1/1000 of the strongest left out."""
        top = max(self.levels.values(), default=0.0)
        return {c: drive_percent(w) for c, w in self.levels.items() if w > 1e-3 * top}


def drive_percent(level: float) -> float:
    """A drive level (0–1) as the % a station file's illumination gives, 3 significant digits."""
    return float(f"{100.0 * level:.3g}")


def solve(problem, *, choose: int | None = None, progress=None) -> Design:
    """The mix of ``problem``'s channels that minimises its objective's worst ε; with
    ``choose``, of the best ``choose`` of them (:func:`~.catalogue.choose_channels`,
    ``progress`` its callback)."""
    from inspect_validate.design.catalogue import choose_channels
    from inspect_validate.design.mix import channel_response, comparison_errors, optimise_mix

    response = channel_response(
        problem.channels,
        problem.optics,
        problem.camera,
        problem.classes,
        grid=problem.grid,
        exposure_time=problem.exposure_time,
    )
    labels = list(problem.channels)
    choice = None
    if choose is None:
        chosen = list(range(len(labels)))
        mix = optimise_mix(response, problem.objective, max_saturated=problem.max_saturated)
    else:
        choice = choose_channels(
            response,
            problem.objective,
            choose,
            max_saturated=problem.max_saturated,
            progress=progress,
        )
        chosen, mix = list(choice.channels), choice.mix
    singles = []
    for c in range(len(labels)):
        best = optimise_mix(
            response.subset([c]), problem.objective, max_saturated=problem.max_saturated
        )
        singles.append((best.objective, labels[c], float(best.levels[0])))
    _, single_label, single_level = min(singles, key=lambda s: s[0])

    flatness = []
    mixed = response.subset(chosen)
    ceiling = response.ceiling(problem.max_saturated)
    for c, label in enumerate(labels[i] for i in chosen):
        for sign in (-1.0, 1.0):
            w = mix.levels.copy()
            w[c] *= 1.0 + sign * DRIVE_TOLERANCE
            w[c] = min(w[c], 1.0)
            eps = comparison_errors(mixed, w, problem.objective).max()
            flatness.append(
                {
                    "channel": label,
                    "change": sign * DRIVE_TOLERANCE,
                    "worst_error": float(eps),
                    "saturates": bool(mixed.signal(w).max() > ceiling),
                }
            )
    levels = dict(zip([labels[i] for i in chosen], map(float, mix.levels), strict=True))
    return Design(
        problem=problem,
        levels=levels,
        single=(single_label, single_level),
        mix=_predict(problem, levels, "designed mix"),
        single_prediction=_predict(
            problem, {single_label: single_level}, f"channel {single_label}"
        ),
        flatness=flatness,
        starts=mix.starts,
        choice=choice,
    )


def _predict(problem, levels: dict, name: str):
    """``predict`` of the light ``levels`` mix, with every comparison of the problem."""
    from inspect_validate.model import Exposure, predict
    from inspect_validate.model.illumination import illumination_light

    light = illumination_light(
        name,
        {c: 100.0 * w for c, w in levels.items()},
        problem.channels,
        grid=problem.grid,
    )
    return predict(
        [light],
        [problem.optics],
        [problem.camera],
        list(problem.classes),
        exposure=Exposure("fixed", time=problem.exposure_time),
        grid=problem.grid,
        comparisons=problem.comparisons,
    )
