"""Sweeps of any size: the prediction in blocks of combinations, the ranking streamed.

:func:`~inspect_validate.model.predict` holds every combination's arrays, the
per-sample ones included (about 1.5 kB a combination with 60 reflectance
samples, several times that in temporaries): fine for a station, not for a
catalogue. :func:`sweep` predicts blocks of combinations that fit ``memory``
bytes, ranks each block, and keeps only its best ``top`` rows and its worst
one; merging two blocks' rows is again a ranking, so the result does not
depend on the blocks and memory does not grow with the number of combinations.

What a ranking does not need is not computed for every combination: the ε of a
comparison between groups of classes (a Gaussian mixture each side, a root
search of about 1 ms per combination) is computed for the rows kept, unless
the ranking is by that comparison's ε. :attr:`Ranking.skipped_work` says what
was left out and the time it would have taken.

Blocks are independent, so a sweep that outgrows one machine runs them on a
Dask cluster (``client``, :func:`dask_client`): the components go to each
worker once, the blocks' kept rows come back and are merged as they arrive.
"""

from __future__ import annotations

import contextlib
import itertools
import time
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from inspect_validate.comparisons import Comparisons, RankBy
from inspect_validate.errors import DeviceError, InputError
from inspect_validate.model.acquisition import (
    MAX_REASONS,
    Chain,
    Combinations,
    Exposure,
    nothing_predictable,
    predict_block,
    prepare,
    skipped_reasons,
)
from inspect_validate.model.ranking import rank_keys, ranked
from inspect_validate.separations import gaussian_separation
from inspect_validate.stats.gaussian_error import LOAD_MIN, load_kernel

if TYPE_CHECKING:
    from inspect_validate.components.lights import Light
    from inspect_validate.components.optics import Optics
    from inspect_validate.components.sensors import SensorModel
    from inspect_validate.model.acquisition import ObjectClass

__all__ = ["Ranking", "dask_client", "sweep"]

MEMORY = 256 * 2**20
"""Default bytes for one block's arrays (the sweep's peak is about this plus the inputs)."""

# Per-combination and per-sample arrays of a block, in float64 values: the rate, its
# grey values and variances, the spread (per sample); the separation's double-double
# passes (per comparison); the class moments (per class).
_VALUES_PER_SAMPLE, _VALUES_PER_COMPARISON, _VALUES_PER_CLASS = 8, 48, 16

# A prediction's arrays that a ranking keeps for its rows (with the per-sample mean and
# variance, which a block computes for those rows only).
_ROW_FIELDS = (
    "exposure_time",
    "electrons",
    "mean",
    "variance",
    "spectral_variance",
    "saturated_fraction",
    "snr_db",
    "cnr_db",
    "fisher_db",
    "error_gaussian",
    "log_error_gaussian",
)


@dataclass(frozen=True, eq=False, repr=False)  # a short repr: __repr__
class Ranking(Combinations):
    """The best rows of a sweep, best first, with what the whole sweep found.

    Row arrays are indexed ``[row, ...]`` with the fields of
    :class:`~inspect_validate.model.Prediction` (the last axis the class, the
    comparison or the reflectance sample); ``index`` gives each row's
    (light, optics, camera).
    """

    def _rows(self):
        """The rows, best first (``predict`` prints its own table of the key comparison)."""
        for row, (li, oi, ci) in enumerate(self.index):
            yield row, (int(li), int(oi), int(ci))

    def _repr_html_(self) -> str:
        import html

        return f"<pre>{html.escape(self.table())}</pre>"

    by: RankBy
    comparison: str | None
    index: np.ndarray  # (N, 3) int
    key: np.ndarray  # ranking value (ε, or dB), (N,)
    column: np.ndarray  # key comparison of each row, (N,)
    saturated: np.ndarray  # (N,) bool
    absolute: np.ndarray  # the row's light has an absolute irradiance, (N,) bool
    exposure_time: np.ndarray
    electrons: np.ndarray
    mean: np.ndarray
    variance: np.ndarray
    spectral_variance: np.ndarray
    saturated_fraction: np.ndarray
    snr_db: np.ndarray
    cnr_db: np.ndarray
    fisher_db: np.ndarray
    error_gaussian: np.ndarray
    log_error_gaussian: np.ndarray
    sample_mean: np.ndarray
    sample_variance: np.ndarray
    sample_class: np.ndarray
    worst: tuple[int, int, int]  # the last-ranked combination
    predicted: int  # combinations predicted (not skipped)
    skipped: tuple[str, ...]  # why combinations were skipped (20 named, then a count)
    blocks: int
    skipped_work: tuple[str, ...] = ()  # what the ranking did not need, and its cost

    @property
    def combinations(self) -> int:
        return int(np.prod(self.shape))


def sweep(
    lights: Sequence[Light],
    optics: Sequence[Optics],
    cameras: Sequence[SensorModel],
    classes: Sequence[ObjectClass],
    *,
    exposure: Exposure | None = None,
    grid: np.ndarray,
    comparisons: Comparisons | None = None,
    by: RankBy = "error",
    comparison: str | None = None,
    top: int = 10,
    memory: int = MEMORY,
    client: Any = None,
) -> Ranking:
    """Predict every light × optics × camera combination in blocks and rank them.

    The same numbers as :func:`~inspect_validate.model.predict` followed by
    :func:`~inspect_validate.model.rank`, up to rounding (a block's matrix
    product may sum in another order: relative differences of about 1e-15 in μ
    and σ², which a small ε's conditioning turns into about 1e-13), in memory
    bounded by ``memory`` whatever the number of combinations.

    Parameters
    ----------
    lights, optics, cameras, classes, exposure, grid, comparisons
        As for :func:`~inspect_validate.model.predict`.
    by : {"error", "snr_db", "cnr_db"}, keyword-only
    comparison : str, keyword-only, optional
        Rank by this comparison (default: each combination's worst pair).
    top : int, keyword-only
        Rows to keep.
    memory : int, keyword-only
        Bytes for one block's arrays.
    client : dask.distributed.Client, keyword-only, optional
        Compute the blocks on this cluster's workers (each holds one block's
        arrays at a time); the ranking is merged here as their rows arrive.
        See :func:`dask_client`.
    """
    chain = prepare(
        lights,
        optics,
        cameras,
        classes,
        exposure=exposure or Exposure(),
        grid=grid,
        comparisons=comparisons,
    )
    comparison_set = chain.comparisons
    key_column = comparison_set.index(comparison) if comparison is not None else None
    groups = [j for j in range(len(comparison_set.groups)) if j not in comparison_set.pairs]
    # A group's ε is needed for every combination only when the ranking is by it.
    mixtures = [key_column] if by == "error" and key_column in groups else []
    total = int(np.prod(chain.shape))
    options = {
        "by": by,
        "comparison": comparison,
        "top": top,
        "mixtures": mixtures,
        # ε of the blocks' pairs compiled where its load pays for itself; decided once for
        # the sweep, so every block (on any worker) computes it the same way.
        "compiled": len(comparison_set.pairs) * total >= LOAD_MIN,
    }
    blocks = list(_blocks(chain, memory=memory))
    if client is None:
        results = ((i, _block_rows(chain, b, **options)) for i, b in enumerate(blocks))
    else:
        results = _on_dask(client, chain, blocks, options)
    kept: dict[str, np.ndarray] | None = None
    why_by_block: dict[int, list[str]] = {}
    n_bad = 0
    for i, (rows, bad, why) in results:  # merged as they arrive: the order cannot matter
        n_bad += bad
        if why:
            why_by_block[i] = why
        kept = rows if kept is None else _merge(kept, rows, top)
    reasons = [r for i in sorted(why_by_block) for r in why_by_block[i]][:MAX_REASONS]
    if n_bad == total:
        raise nothing_predictable(reasons, n_bad)
    assert kept is not None  # a block ran, or nothing_predictable was raised
    order = _order(kept)
    best = order[:top]
    worst = int(kept["flat"][order[-1]])
    rows = {name: values[best] for name, values in kept.items()}

    # The rows' other group ε: the same function on the same moments as a full prediction.
    left = [j for j in groups if j not in mixtures]
    skipped_work: tuple[str, ...] = ()
    if left:
        started = time.perf_counter()
        sep = gaussian_separation(rows["mean"], rows["variance"], comparison_set, mixtures=left)
        per = (time.perf_counter() - started) / max(1, best.size * len(left))
        rows["error_gaussian"][:, left] = sep.error_gaussian[:, left]
        rows["log_error_gaussian"][:, left] = sep.log_error_gaussian[:, left]
        n_other = total - n_bad - best.size
        if n_other > 0:
            labels = ", ".join(comparison_set.labels[j] for j in left)
            skipped_work = (
                f"ε Gauss of {labels} (a Gaussian mixture each side) for the {best.size} rows "
                f"listed only, not for {n_other} other combinations: {n_other * len(left)} "
                f"root searches, about {_duration(n_other * len(left) * per)} at "
                f"{1e3 * per:.2g} ms each (rank by one of them to compute it everywhere)",
            )
    names = chain.names
    return Ranking(
        lights=names[0],
        optics=names[1],
        cameras=names[2],
        classes=names[3],
        comparison_set=comparison_set,
        grid=chain.grid,
        by=by,
        comparison=comparison,
        index=np.stack(np.unravel_index(rows["flat"], chain.shape), axis=1),
        key=rows["key"],
        column=rows["column"],
        saturated=rows["saturated"],
        absolute=rows["absolute"],
        **{name: rows[name] for name in (*_ROW_FIELDS, "sample_mean", "sample_variance")},
        sample_class=chain.sample_class,
        worst=_triple(np.unravel_index(worst, chain.shape)),
        predicted=total - n_bad,
        skipped=skipped_reasons(reasons, n_bad),
        blocks=len(blocks),
        skipped_work=skipped_work,
    )


def _duration(seconds: float) -> str:
    if seconds < 120:
        return f"{seconds:.2g} s"
    if seconds < 2 * 3600:
        return f"{seconds / 60:.0f} min"
    return f"{seconds / 3600:.1f} h"


def _blocks(chain: Chain, *, memory: int):
    """(lights, optics, cameras) slices whose block arrays fit ``memory`` bytes; cameras
    are split only when one light × optics row of them does not fit, and so on."""
    n_l, n_o, n_c = chain.shape
    n_s, n_k = chain.sample_class.size, chain.per_class.size
    n_p = len(chain.comparisons.groups)
    per = 8 * (_VALUES_PER_SAMPLE * n_s + _VALUES_PER_COMPARISON * n_p + _VALUES_PER_CLASS * n_k)
    fit = max(1, memory // per)  # combinations in a block
    bc = min(n_c, fit)
    bo = min(n_o, max(1, fit // bc))
    bl = min(n_l, max(1, fit // (bc * bo)))
    for li, oi, ci in itertools.product(range(0, n_l, bl), range(0, n_o, bo), range(0, n_c, bc)):
        yield slice(li, li + bl), slice(oi, oi + bo), slice(ci, ci + bc)


def _block_rows(chain, block, *, by, comparison, top, mixtures, compiled):
    """One block's best ``top`` rows and its worst, with their global flat indices and sort
    keys; the number of combinations it skipped, and why."""
    if compiled:
        load_kernel()
    ls, os, cs = block
    computed = predict_block(chain, ls, os, cs, mixtures=mixtures)
    p = computed.prediction
    keys, key, column, saturated = rank_keys(p, by=by, comparison=comparison)
    pick = _kept(ranked(keys, p.valid), top)
    li, oi, ci = np.unravel_index(pick, p.valid.shape)
    _, n_o, n_c = chain.shape
    flat = ((li + ls.start) * n_o + (oi + os.start)) * n_c + (ci + cs.start)
    rows = {
        "flat": flat,
        "tiebreak": keys[0][pick],
        "sort_key": keys[1][pick],
        "saturated": saturated[pick],
        "key": key[pick],
        "column": column[pick],
        "absolute": p.absolute[li],
    }
    for name in _ROW_FIELDS:
        rows[name] = getattr(p, name)[li, oi, ci]
    _, rows["sample_mean"], rows["sample_variance"], _ = computed.signal.samples(li, oi, ci)
    return rows, computed.n_bad, computed.reasons


def _on_dask(client, chain, blocks, options):
    """``(block index, block rows)`` computed on a Dask cluster, as they complete."""
    from dask.distributed import as_completed

    remote = client.scatter(chain, broadcast=True)  # the components once per worker
    futures = [client.submit(_block_rows, remote, b, pure=False, **options) for b in blocks]
    index = {f.key: i for i, f in enumerate(futures)}
    for future, result in as_completed(futures, with_results=True):
        yield index[future.key], result
        future.release()  # its rows are merged; the worker may forget them


@contextlib.contextmanager
def dask_client(address: str) -> Any:
    """A Dask client: ``"local"`` starts a LocalCluster on this machine (a worker
    process per core), anything else is a scheduler's address (``tcp://host:8786``).

    Raises
    ------
    InputError
        Dask is not installed.
    DeviceError
        The scheduler cannot be reached.
    """
    try:
        from dask.distributed import Client, LocalCluster
    except ImportError:
        raise InputError(
            "--dask needs Dask: pip install 'inspect-validate[dask]'", source="--dask"
        ) from None
    if address == "local":
        with LocalCluster(threads_per_worker=1, dashboard_address=":0") as cluster:
            with Client(cluster) as client:
                yield client
        return
    try:
        client = Client(address, timeout=5)
    except (OSError, TimeoutError, ValueError) as exc:
        raise DeviceError(
            f"dask scheduler {address}: cannot connect ({exc}); check the address and that "
            "the scheduler runs"
        ) from None
    with client:
        yield client


def _order(rows) -> np.ndarray:
    """Best first: unsaturated, then by key, log ε and (as a full prediction's stable sort)
    position in the sweep."""
    return np.lexsort((rows["flat"], rows["tiebreak"], rows["sort_key"], rows["saturated"]))


def _merge(a: dict, b: dict, top: int) -> dict:
    """Two blocks' kept rows as one: the best ``top`` and the worst of both."""
    both = {name: np.concatenate([a[name], b[name]]) for name in a}
    pick = _kept(_order(both), top)
    return {name: values[pick] for name, values in both.items()}


def _kept(order: np.ndarray, top: int) -> np.ndarray:
    """Positions of the best ``top`` and the worst of rows ranked ``order``, ascending."""
    return np.unique(np.concatenate([order[:top], order[-1:]]))


def _triple(index) -> tuple[int, int, int]:
    """A (light, optics, camera) index as ints."""
    light, optics, camera = (int(i) for i in index)
    return light, optics, camera
