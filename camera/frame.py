"""A grabbed frame and its metadata."""

from __future__ import annotations

from dataclasses import dataclass, field, fields
from functools import cached_property

import numpy as np

__all__ = ["Frame"]


@dataclass(frozen=True, eq=False, kw_only=True)
class Frame:
    """One monochrome frame, owning its pixels (made by keywords: ten fields are too many to
    tell apart by position).

    Attributes
    ----------
    data : ndarray of uint8 or uint16, shape (H, W)
    frame_id : int
        The camera's frame counter (or block id).
    timestamp_ns : int
        When the exposure started, ns, on the host's monotonic clock where the
        camera's own clock cannot be related to it (see ``clock``).
    exposure_us, gain_db : float or None
        The settings read back from the camera; None where it has no such node.
    pixel_format : str
    bit_depth : int
    device : str
    clock : str
        What ``timestamp_ns`` is: ``"exposure"`` (host monotonic clock at the
        start of the exposure — comparable with the time of a light switch),
        ``"arrival"`` (host monotonic clock when the frame arrived) or
        ``"device"`` (the camera's own clock). Only ``"exposure"`` proves a frame
        was exposed after a switch; for the others the capture flushes frames.
    """

    data: np.ndarray
    frame_id: int
    timestamp_ns: int
    exposure_us: float | None
    gain_db: float | None
    pixel_format: str
    bit_depth: int
    device: str
    clock: str = "arrival"
    extra: dict = field(default_factory=dict)

    @cached_property
    def mean(self) -> float:
        """Mean grey value, DN; computed once (the capture's checks ask for it repeatedly)."""
        return float(self.data.mean())

    def metadata(self) -> dict:
        # Not dataclasses.asdict: it would deep-copy the pixels only to drop them.
        d = {f.name: getattr(self, f.name) for f in fields(self) if f.name != "data"}
        d["extra"] = dict(self.extra)
        d["shape"] = list(self.data.shape)
        d["dtype"] = str(self.data.dtype)
        return d
