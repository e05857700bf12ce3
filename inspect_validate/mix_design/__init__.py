"""Illumination design: the drive levels of a multi-channel controller that separate a
station's classes best (:mod:`.mix`)."""

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
