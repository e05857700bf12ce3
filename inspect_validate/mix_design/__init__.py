"""Illumination design: the drive levels of a multi-channel controller that separate a
station's classes best.

==================  ==========================================================================
:mod:`.problem`     what ``design`` optimises, from a station or a scene file
:mod:`.mix`         the best mix of the channels' lights
:mod:`.solve`       the optimal mix and the best single channel, predicted
:mod:`.catalogue`   choosing k lights of a catalogue of M
:mod:`.station`     the station that closes a design by a measurement
==================  ==========================================================================
"""

from inspect_validate.mix_design.mix import (
    OBJECTIVES,
    ChannelResponse,
    Mix,
    channel_response,
    comparison_cnr,
    comparison_errors,
    comparison_losses,
    mix_moments,
    optimise_mix,
)

__all__ = [
    "OBJECTIVES",
    "ChannelResponse",
    "Mix",
    "channel_response",
    "comparison_cnr",
    "comparison_errors",
    "comparison_losses",
    "mix_moments",
    "optimise_mix",
]
