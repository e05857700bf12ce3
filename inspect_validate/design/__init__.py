"""Illumination design: the drive levels of a multi-channel controller that separate a
station's classes best (:mod:`.mix`)."""

from inspect_validate.design.mix import (
    ChannelResponse,
    Mix,
    channel_response,
    comparison_errors,
    mix_moments,
    optimise_mix,
)

__all__ = [
    "ChannelResponse",
    "Mix",
    "channel_response",
    "comparison_errors",
    "mix_moments",
    "optimise_mix",
]
