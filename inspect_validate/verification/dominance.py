"""Illuminations not worth capturing: those the prediction shows clearly worse than
another where no check needs them, and whether what was captured bears the prediction
out."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from inspect_validate.station.file import Station
    from inspect_validate.station.prediction import StationPrediction
    from inspect_validate.verification.results import Verification

__all__ = ["dominance_unconfirmed", "dominated_illuminations"]


def dominated_illuminations(station: Station, prediction: StationPrediction) -> dict[str, str]:
    """Illuminations that need not be captured: no acceptance check needs them, and the
    prediction shows another illumination clearly better on every comparison.

    ``prediction`` is the plan's (:attr:`~.plan.Plan.prediction`: before any region is
    measured, a group of ``pixels`` weights is weighted equally). Illumination X is
    dominated by Y when, on every comparison, Y's predicted SNR_dB
    exceeds X's by at least twice the agreement tolerance ``acceptance.agreement.snr_db``
    (3 dB if not given) — so even if each measures that far from its prediction, in
    opposite directions, Y still measures better — or both are below
    ``snr_floor_db``, where SNR_dB says nothing (as in the agreement check); and on at
    least one comparison Y is ahead. Every illumination is needed (nothing is
    dominated) when the acceptance ranks them (``ranking``), compares them with a golden
    file (``drift``) or checks separation on all of them (no ``illumination``);
    ``acceptance.illumination`` itself is always needed.

    Returns
    -------
    dict
        Name → why, in station order.
    """
    acc = station.acceptance
    names = [i.name for i in station.illuminations]
    if len(names) < 2 or acc.ranking or acc.drift or (acc.separation and not acc.illumination):
        return {}
    tolerance, floor = _dominance_tolerance(acc)
    margin = 2.0 * tolerance
    snr = prediction.select(names).snr_db
    out: dict[str, str] = {}
    for x, name in enumerate(names):
        if name == acc.illumination:
            continue
        for y, other in enumerate(names):
            if y == x or other in out:
                continue
            lead = snr[y] - snr[x]
            ahead = lead >= margin
            silent = (snr[x] < floor) & (snr[y] < floor)
            if np.all(ahead | silent) and np.any(ahead):
                out[name] = (
                    f"predicted dominated by {other!r}: its SNR_dB is at least "
                    f"{lead[ahead].min():.1f} dB higher on every comparison above {floor:g} dB "
                    f"(margin {margin:g} dB, twice the agreement tolerance)"
                )
                break
    return out


def _dominance_tolerance(acc) -> tuple[float, float]:
    """How far (dB) each illumination's SNR_dB may miss its prediction for a dominance to
    stand (the agreement tolerance; its default when the station sets none), and the
    floor below which SNR_dB says nothing."""
    from inspect_validate.acceptance import Agreement

    agreement = acc.agreement or Agreement()
    default = Agreement.model_fields["snr_db"].default
    return agreement.snr_db or default, agreement.snr_floor_db


def dominance_unconfirmed(result: Verification) -> list[str]:
    """Where the captured illuminations miss their predicted SNR_dB by more than the
    tolerance :func:`dominated_illuminations` assumed when it left others out.

    The dominance is a prediction; the captured illuminations are the only evidence of
    how far the prediction holds on this station. When one of them misses by more than
    the tolerance, the margin no longer guarantees the order, and what was left out has
    to be captured after all. (A deviation of a left-out light alone leaves no trace
    in the others: only ``--all-illuminations`` shows it.)

    Returns
    -------
    list of str
        "illumination: comparison measured … dB from its prediction", worst first;
        empty when every captured comparison is within the tolerance (or both
        predicted and measured are below the floor).
    """
    tolerance, floor = _dominance_tolerance(result.station.acceptance)
    misses = [
        (abs(r.snr_db_difference), f"{r.illumination}: {r.comparison}")
        for r in result.comparisons
        if max(r.predicted.snr_db, r.measured.snr_db) >= floor
        and abs(r.snr_db_difference) > tolerance
    ]
    return [
        f"{where} measured {miss:.1f} dB from its prediction (more than {tolerance:g} dB)"
        for miss, where in sorted(misses, reverse=True)
    ]
