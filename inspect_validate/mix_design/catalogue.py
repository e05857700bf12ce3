"""Choosing k lights of a catalogue of M for a k-channel controller.

Every k-subset has its own optimal mix (:func:`~inspect_validate.mix_design.mix.optimise_mix`);
the choice is the subset whose optimum is best (lowest worst ε, or highest worst CNR). A subset is
*screened* by optimising its mix from one start: the neighbouring subset's mix
(warm), else the equal mix; the best few screened subsets are then optimised
from every structured start, and the best of those is the choice. Where M
choose k is small every subset is screened. Beyond, the search is:

1. *greedy*: the best single light, then repeatedly the light whose addition
   lowers the optimum most, up to k;
2. the *support* of the optimal mix of all M lights: its k strongest;
3. from each of these, *swaps*: replace one chosen light by one not chosen
   (at the level of the one it replaces) while that lowers the optimum (first
   improvement, until no swap does).

Steps 1 and 3 try the 12 most promising lights only, ranked by the first-order
change of the worst log ε (−log CNR) when a little of the light is added to the current
mix (scaled to keep its brightest sample where it was); the best end is then
swapped against every light until no single swap improves it, so the choice
is swap-optimal.

A catalogue of more than :data:`POOL_MAX` lights is first narrowed to a pool of
that many: the lights of the optimal mix of all M (found by column generation,
:func:`~inspect_validate.mix_design.mix.optimise_mix`), the best lights alone for each
comparison, then the best alone for the worst comparison. The search above runs
on the pool; a light outside it could only enter a swap if it were among the
most promising, which a light neither in the optimal mix nor good alone rarely is.

This is a local search; it reports how far from exhaustive it may be by the
optimum of all M lights mixed together, a lower bound on every k-subset's
optimum (a k-subset's mixes are mixes of the M lights with the others at 0),
exact up to the optimiser's own tolerance.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from inspect_validate.errors import InputError

if TYPE_CHECKING:
    from collections.abc import Callable

    from inspect_validate.comparisons import Comparisons
    from inspect_validate.mix_design.mix import ChannelResponse, Mix

__all__ = ["EXHAUSTIVE_MAX", "POOL_MAX", "Choice", "choose_channels"]

EXHAUSTIVE_MAX = 400  # subsets optimised one by one; beyond, the local search
_REFINED = 4  # best screened subsets re-optimised from every structured start
_CANDIDATES = 12  # channels tried per greedy step and per swap pass, by first-order score
POOL_MAX = 48
"""Most lights the subset search runs on; a larger catalogue is narrowed to a pool first."""


@dataclass(frozen=True, eq=False)
class Choice:
    """The chosen channels and their mix.

    Attributes
    ----------
    channels : tuple of int
        Indices of the chosen channels, ascending.
    mix : Mix
        The optimal mix of the chosen channels (levels in their order).
    evaluated : int
        Subsets optimised (screened from a warm start and the equal mix).
    exhaustive : bool
        Every subset was optimised.
    bound : float
        Worst ε (CNR) of the optimal mix of *all* channels: no subset does better.
    """

    channels: tuple
    mix: Mix
    evaluated: int
    exhaustive: bool
    bound: float


def choose_channels(
    response: ChannelResponse,
    comparisons: Comparisons,
    k: int,
    *,
    objective: str = "error",
    max_saturated: float = 1e-3,
    max_level: float = 1.0,
    exhaustive_max: int = EXHAUSTIVE_MAX,
    progress: Callable[[int, int], None] | None = None,
) -> Choice:
    """The ``k`` channels of ``response`` whose optimal mix is best: lowest worst ε, or
    highest worst CNR.

    Parameters
    ----------
    response : ChannelResponse
        Every candidate light (M channels).
    comparisons : Comparisons
        The objective's comparisons.
    k : int
        Channels of the controller, 1 ≤ k ≤ M.
    objective, max_saturated, max_level : keyword-only
        As :func:`~inspect_validate.mix_design.mix.optimise_mix`'s.
    exhaustive_max : int, keyword-only
        Largest M choose k optimised subset by subset.
    progress : callable, keyword-only, optional
        ``progress(done, total)`` after each subset (total is an estimate for the
        local search).

    Raises
    ------
    InputError
        ``k`` outside 1…M.
    """
    from functools import partial

    from inspect_validate.mix_design.mix import optimise_mix

    optimise = partial(
        optimise_mix,
        comparisons=comparisons,
        objective=objective,
        max_saturated=max_saturated,
        max_level=max_level,
    )
    m = response.electrons.shape[0]
    if not 1 <= k <= m:
        raise InputError(f"cannot choose {k} of {m} lights: give --choose between 1 and {m}")
    if m > max(POOL_MAX, k):
        return _from_pool(response, comparisons, k, optimise, exhaustive_max, progress)
    cache: dict[tuple, Mix] = {}
    total = math.comb(m, k)
    exhaustive = total <= exhaustive_max
    if not exhaustive:
        # singles, greedy steps and about two swap passes from each of two seeds
        total = m + (k - 1) * _CANDIDATES + 4 * k * _CANDIDATES + k * (m - k)
    total += _REFINED

    def optimum(channels, warm=None) -> float:
        """Loss of the subset's mix, screened: from ``warm`` (levels by channel) only,
        else from the equal mix."""
        key = tuple(sorted(int(c) for c in channels))
        if key not in cache:
            w0 = np.array([(warm or {}).get(c, 0.0) for c in key])
            cache[key] = optimise(
                response.subset(key), starts=[w0 if w0.any() else np.ones(len(key))]
            )
            if progress:
                progress(min(len(cache), total), total)
        return cache[key].loss

    def levels(key):
        return dict(zip(key, cache[key].levels, strict=True))

    full = optimise(response)
    if exhaustive:
        for subset in itertools.combinations(range(m), k):
            optimum(subset)
    else:
        score = _first_order_score(response, comparisons, objective)
        chosen: tuple = ()
        while len(chosen) < k:
            if chosen:
                warm = levels(chosen)
                rest = score(warm)[:_CANDIDATES]
            else:
                warm, rest = None, range(m)
            best = min(rest, key=lambda c, w=warm: optimum([*chosen, c], w))  # type: ignore[misc]
            chosen = tuple(sorted([*chosen, int(best)]))
        support = np.argsort(-full.levels * response.electrons.sum(axis=1))[:k]
        optimum(support, dict(enumerate(full.levels)))
        ends = [
            _swap_search(seed, optimum, levels, lambda w: score(w)[:_CANDIDATES])
            for seed in (chosen, tuple(sorted(int(c) for c in support)))
        ]
        # The best end, made swap-optimal against every channel, not only the promising.
        _swap_search(min(ends, key=optimum), optimum, levels, score)
    # The screened optima rank the subsets; the best few get the full multi-start.
    top = sorted(cache, key=lambda key: cache[key].loss)[:_REFINED]
    best, mix = min(
        ((key, mix) for key in top for mix in (cache[key], optimise(response.subset(key)))),
        key=lambda pair: pair[1].loss,
    )
    if progress:
        progress(total, total)
    return Choice(best, mix, len(cache), exhaustive, full.objective)


def _from_pool(response, comparisons, k, optimise, exhaustive_max, progress) -> Choice:
    """:func:`choose_channels` on a catalogue narrowed to :data:`POOL_MAX` lights (module
    notes), its channels mapped back to the catalogue's."""
    from inspect_validate.mix_design.mix import single_losses

    options = {key: optimise.keywords[key] for key in ("objective", "max_saturated", "max_level")}
    full = optimise(response)
    _, alone = single_losses(
        response,
        comparisons,
        objective=options["objective"],
        max_saturated=options["max_saturated"],
        max_level=options["max_level"],
    )
    pool = [int(c) for c in np.argsort(-full.levels)[: np.count_nonzero(full.levels)]]
    ranked = [np.argsort(alone[:, p]) for p in range(alone.shape[1])]
    ranked.append(np.argsort(alone.max(axis=1)))
    for depth in range(response.electrons.shape[0]):
        for order in ranked:
            if len(pool) < max(POOL_MAX, k) and int(order[depth]) not in pool:
                pool.append(int(order[depth]))
    pool = sorted(pool[: max(POOL_MAX, k)])
    choice = choose_channels(
        response.subset(pool),
        comparisons,
        k,
        exhaustive_max=exhaustive_max,
        progress=progress,
        **options,
    )
    channels = tuple(pool[c] for c in choice.channels)
    return Choice(channels, choice.mix, choice.evaluated, False, full.objective)


def _swap_search(chosen, optimum, levels, candidates):
    """Swap one chosen channel for one of ``candidates(levels)`` while that lowers
    ``optimum``, each trial warm-started with the new channel at the old one's level."""
    chosen = tuple(chosen)
    current = optimum(chosen)
    improved = True
    while improved:
        improved = False
        for i, j in itertools.product(range(len(chosen)), candidates(levels(chosen))):
            warm = levels(chosen)
            warm[int(j)] = warm.pop(chosen[i])
            trial = tuple(sorted([*chosen[:i], int(j), *chosen[i + 1 :]]))
            value = optimum(trial, warm)
            if value < current:
                chosen, current, improved = trial, value, True
                break
    return chosen


def _first_order_score(response, comparisons, objective):
    """``score(levels)``: the channels not in ``levels`` (channel → level), most promising
    first, by :func:`~inspect_validate.mix_design.mix.first_order_slopes`."""
    from inspect_validate.mix_design.mix import first_order_slopes

    def score(levels):
        w = np.zeros(response.electrons.shape[0])
        w[list(levels)] = list(levels.values())
        slope = first_order_slopes(response, w, comparisons, objective=objective)
        return [c for c in np.argsort(slope) if c not in levels]

    return score
