"""The station that closes a design by a measurement: the designed mix and the best single
channel as its illuminations, its acceptance checks on the mix."""

from __future__ import annotations

from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from inspect_validate.mix_design.solve import Design
    from inspect_validate.station.file import Station

__all__ = ["DESIGN_ILLUMINATION", "design_station"]

DESIGN_ILLUMINATION = "design"


def design_station(station: Station, design: Design) -> Station:
    """``station`` (a :class:`~inspect_validate.station.file.Station`) lit by ``design``'s mix and its best
    single channel instead of its own illuminations.

    The acceptance's separation limits apply to the mix; agreement, saturation
    and gain checks to both; the drift check and the ranking are dropped (the
    golden file and the ranking are about the station's own illuminations).
    The single channel is left out when the mix is that channel alone. The
    camera's exposure is the design's (with auto exposure, the designed one).
    """
    from inspect_validate.mix_design.solve import drive_percent
    from inspect_validate.station.file import Illumination

    illuminations = [Illumination(name=DESIGN_ILLUMINATION, channels=design.percent)]
    channel, level = design.single
    single = {channel: drive_percent(level)}
    if single != design.percent:
        illuminations.append(Illumination(name=f"single-{channel}", channels=single))
    acceptance = station.acceptance.model_copy(
        update={"illumination": DESIGN_ILLUMINATION, "drift": None, "ranking": False}
    )
    camera = station.camera.model_copy(update={"exposure_us": 1e6 * design.exposure_time})
    return station.model_copy(
        update={"illuminations": illuminations, "acceptance": acceptance, "camera": camera}
    )
