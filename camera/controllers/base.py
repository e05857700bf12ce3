"""The LED controller interface: channels with an intensity in percent."""

from __future__ import annotations

from abc import ABC, abstractmethod

from inspect_validate.errors import DeviceError

__all__ = ["LedController", "describe_setting"]


def describe_setting(setting: dict[int, float]) -> str:
    """``channel 1 at 100 %, channel 3 at 40 %`` for the channels that are on."""
    on = sorted((int(c), float(v)) for c, v in setting.items() if v)
    return ", ".join(f"channel {c} at {v:g} %" for c, v in on) or "all lights off"


class LedController(ABC):
    """A light controller with numbered output channels (1-based).

    Implementations raise :class:`~inspect_validate.errors.DeviceError` with the
    device, the command and what to check whenever the controller does not
    confirm a command. Usable as a context manager (closes and, if asked,
    switches all channels off).
    """

    name: str = "controller"
    channels: int = 1
    applied: dict[int, float] | None = None  # the last setting apply() confirmed (channels on)

    def check(self, channel: int, percent: float | None = None) -> None:
        """Refuse a channel the controller lacks or an intensity outside 0–100 % before sending."""
        if not 1 <= channel <= self.channels:
            raise DeviceError(f"{self.name}: channel {channel} does not exist (1–{self.channels})")
        if percent is not None and not 0 <= percent <= 100:
            raise DeviceError(f"{self.name}: intensity {percent:g} % is outside 0–100 %")

    @abstractmethod
    def set_intensity(self, channel: int, percent: float) -> None:
        """Continuous output at ``percent`` (0–100) on ``channel``; 0 is off."""

    def pulse(self, channel: int, *, width_us: float, delay_us: float, percent: float) -> None:
        """Strobe ``channel`` on each trigger: ``width_us`` long after ``delay_us``."""
        raise DeviceError(f"{self.name}: has no pulse mode")

    def trigger(self, channel: int) -> None:
        """Fire ``channel``'s trigger once, as a pulse on its trigger input would."""
        raise DeviceError(f"{self.name}: cannot be triggered by a command")

    def apply_pulsed(self, setting: dict[int, float], *, width_us: float, delay_us: float) -> None:
        """Put the given channels in pulse mode at their percentages, every other channel off:
        each trigger (the camera's strobe, :meth:`trigger`) then flashes them."""
        for ch in range(1, self.channels + 1):
            percent = float(setting.get(ch, 0.0))
            if percent:
                self.pulse(ch, width_us=width_us, delay_us=delay_us, percent=percent)
            else:
                self.set_intensity(ch, 0.0)
        self.applied = {c: float(v) for c, v in setting.items() if v}

    def status(self) -> str:
        """The controller's own status text."""
        return ""

    def all_off(self) -> None:
        self.apply({})

    def apply(self, setting: dict[int, float]) -> None:
        """Set the given channels and switch every other channel off."""
        for ch in range(1, self.channels + 1):
            self.set_intensity(ch, float(setting.get(ch, 0.0)))
        self.applied = {c: float(v) for c, v in setting.items() if v}

    def close(self) -> None:  # noqa: B027 - optional for controllers without a connection
        """Release the connection."""

    def __enter__(self):
        return self

    def __exit__(self, *exc) -> None:
        self.close()
