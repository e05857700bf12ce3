"""The simulated world of a station file: how what its simulated camera renders differs
from the scene (``camera.world``), and how it changes over the cycles of ``watch``.

A simulator rendered from the very scene it is checked against can only agree with it;
these deviations make the simulated station a reality that the verification has to
notice or calibrate away (:mod:`inspect_validate.simulation.camera` renders them).
"""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import Field, model_validator

from inspect_validate.camera.settings import Channel
from inspect_validate.config import StrictModel

__all__ = ["Dust", "Line", "Rendered", "World", "WorldChange"]

Factor = Annotated[float, Field(gt=0, le=100, allow_inf_nan=False)]
# A channel's irradiance factor: 0 is a light that never reaches the objects (a dead
# LED, a cut cable, a channel wired to nothing).
Level = Annotated[float, Field(ge=0, le=100, allow_inf_nan=False)]
Percent = Annotated[float, Field(gt=-100, lt=100, allow_inf_nan=False)]
ShiftNm = Annotated[float, Field(ge=-200, le=200, allow_inf_nan=False)]
Transmission = Annotated[float, Field(gt=0, le=2, allow_inf_nan=False)]
BlurPx = Annotated[float, Field(ge=0, le=50, allow_inf_nan=False)]


class Dust(StrictModel):
    """A speck of dust on the lens: a dim, blurred blob that stays where it is in the frame
    while the parts move under it."""

    x: Annotated[float, Field(ge=0, le=1, allow_inf_nan=False)]
    """Its centre across the frame, as a fraction of the width."""
    y: Annotated[float, Field(ge=0, le=1, allow_inf_nan=False)]
    """Its centre down the frame, as a fraction of the height."""
    radius_px: Annotated[float, Field(gt=0, le=2000, allow_inf_nan=False)] = 20.0
    """The blob's Gaussian σ, px."""
    depth: Annotated[float, Field(gt=0, le=1, allow_inf_nan=False)] = 0.3
    """The light it takes at its centre (0.3: 30 %)."""


class Line(StrictModel):
    """A running line in front of the simulated camera: every frame shows a new part (the
    scene's classes as bands on a part covering ``part`` of the frame, on a dark belt;
    each part another draw of its classes' reflectance samples) at a random pose, under
    whatever light is on; nothing waits for the camera.

    The camera samples the moving part at its pixels' centres (each pixel shows one
    reflectance sample, as on the bench, whatever the pose): a part's statistics do not
    depend on where it lies to the fraction of a pixel, as an object's texture finer than
    the optics resolve would not."""

    part: Annotated[float, Field(ge=0.2, le=0.9, allow_inf_nan=False)] = 0.6
    """The part's size, as a fraction of the frame's (each side)."""
    shift: Annotated[float, Field(ge=0, le=0.5, allow_inf_nan=False)] = 0.1
    """The largest shift from the part's home, as a fraction of the frame (each axis)."""
    rotation_deg: Annotated[float, Field(ge=0, le=45, allow_inf_nan=False)] = 5.0
    """The largest rotation, degrees."""
    cut: Annotated[float, Field(ge=0, le=1, allow_inf_nan=False)] = 0.0
    """The share of parts pushed against the frame's edge, partly out of the frame."""
    missing: Annotated[float, Field(ge=0, le=1, allow_inf_nan=False)] = 0.0
    """The share of frames with no part (a gap on the belt)."""
    camera_shift_px: tuple[
        Annotated[float, Field(ge=-2000, le=2000, allow_inf_nan=False)],
        Annotated[float, Field(ge=-2000, le=2000, allow_inf_nan=False)],
    ] = (0.0, 0.0)
    """The camera (or the fixture) moved: every part lands this far off, px (x, y)."""
    belt: Annotated[float, Field(ge=0, le=1, allow_inf_nan=False)] = 0.05
    """The belt's reflectance, the same at every wavelength."""
    seed: Annotated[int, Field(ge=0)] | None = None
    """The parts' poses; default new ones on every opening of the camera."""


class WorldChange(StrictModel):
    """A change of the simulated world from cycle ``start`` of ``watch`` on (to ``stop``,
    exclusive, if given): a step (factors), a gradual drift (% per cycle or per hour,
    compounding from the start) or a device fault. A station that is ageing, soiled or
    faulty on a schedule, for ``watch`` to notice."""

    start: Annotated[int, Field(ge=0)] = 0
    """The first cycle of ``watch`` with the change."""
    stop: Annotated[int, Field(ge=1)] | None = None
    """The first cycle without it again (default: it stays)."""
    irradiance: dict[Channel, Level] = {}
    """Step: factor on the channel's irradiance (an LED replaced by a weaker one; 0 dead)."""
    percent_per_cycle: dict[Channel, Percent] = {}
    """Drift: the channel's output changes by this % every cycle (LED ageing: negative)."""
    percent_per_hour: dict[Channel, Percent] = {}
    """Drift: the channel's output changes by this % every hour of the watch."""
    peak_shift_nm: dict[Channel, ShiftNm] = {}
    """Step: the channel's spectrum shifted by this many nm more."""
    exposure: Factor | None = None
    """Step: factor on the light every frame collects (someone changed exposure or gain)."""
    transmission: Transmission | None = None
    """Step: factor on the lens transmission (a soiled lens)."""
    blur_px: BlurPx | None = None
    """Step: Gaussian blur σ in pixels (defocus: the classes bleed into each other)."""
    camera_timeout: bool = False
    """Fault: the camera delivers no frame (its grab times out)."""
    frozen: bool = False
    """Fault: the camera repeats one frame (a stale image from a hung driver)."""
    packet_loss: Annotated[float, Field(ge=0, le=0.5, allow_inf_nan=False)] | None = None
    """Fault: the link loses packets with this probability (:attr:`World.packet_loss`)."""
    missed_trigger_every: Annotated[int, Field(ge=0, le=1000)] | None = None
    """Fault: every n-th software trigger brings no frame (:attr:`World.missed_trigger_every`)."""
    temperature_c: Annotated[float, Field(ge=-60, le=200, allow_inf_nan=False)] | None = None
    """Step: the camera reports this temperature, °C (it warms up)."""
    controller_faults: list[str] = []
    """Fault: arguments for the simulated controller, e.g. ``["--garbage-after", "2"]``."""

    def active(self, cycle: int) -> bool:
        return cycle >= self.start and (self.stop is None or cycle < self.stop)


class World(StrictModel):
    """How the simulated world differs from the station's scene.

    A simulator rendered from the very scene it is checked against can only
    agree with it; these deviations make the simulated station a reality that
    the verification has to notice or calibrate away. Per-channel entries are
    keyed by controller channel.
    """

    irradiance: dict[Channel, Level] = {}
    """Factor on the channel's irradiance at the object (a dimmer or farther light; 0: no
    light of the channel reaches the objects)."""
    peak_shift_nm: dict[Channel, ShiftNm] = {}
    """The channel's spectrum shifted by this many nm (an LED drifted from its datasheet)."""
    width_scale: dict[Channel, Annotated[float, Field(ge=0.2, le=5, allow_inf_nan=False)]] = {}
    """The channel's spectrum stretched about its peak (FWHM × this factor)."""
    reflectance_seed: Annotated[int, Field(ge=0)] | None = None
    """The objects are another draw (bootstrap) from each class's reflectance samples."""
    parts: Literal["fixed", "redrawn"] = "fixed"
    """``fixed``: the same parts in every capture. ``redrawn``: every opening of the camera
    (each repeat of ``train``, each ``verify``) shows other parts of the same classes:
    another draw (bootstrap) of each class's reflectance samples, placed anew, as parts
    re-placed from a production would be (the part-to-part spread a golden file's repeats
    learn). Not with ``reflectance_seed``, which fixes one draw."""
    irradiance_jitter: Annotated[float, Field(ge=0, le=0.5, allow_inf_nan=False)] = 0.0
    """Relative standard deviation of each channel's irradiance from one capture to the
    next (a driver's current, an LED's temperature): the spread between captures that a
    golden file's repeats must learn."""
    transmission: Transmission = 1.0
    """Factor on the lens transmission."""
    vignetting: Annotated[float, Field(ge=0, lt=1, allow_inf_nan=False)] = 0.0
    """Relative irradiance lost at the frame's corners (quadratic in the radius)."""
    light_gradient: dict[
        Channel, Annotated[float, Field(ge=-0.9, le=0.9, allow_inf_nan=False)]
    ] = {}
    """Per channel, the relative irradiance its light loses across the frame from the left
    edge to the right (linear in x; negative: brighter to the right), as a bar light to one
    side gives."""
    ambient: Annotated[float, Field(ge=0, le=1000, allow_inf_nan=False)] = 0.0
    """W/m² of equal-energy light over 380–780 nm at the object, always on (also in darks)."""
    gain_error: Annotated[float, Field(gt=-0.9, lt=10, allow_inf_nan=False)] = 0.0
    """Relative error of the system gain K against the camera's declared one."""
    black_level: Annotated[float, Field(ge=0, le=60_000, allow_inf_nan=False)] | None = None
    """The sensor's real black level (dark offset), DN; default the declared one."""
    dark_current: Annotated[float, Field(ge=0, le=1e7, allow_inf_nan=False)] | None = None
    """The sensor's real dark current, e⁻/s; default the declared one."""
    dsnu: Annotated[float, Field(ge=0, le=1e5, allow_inf_nan=False)] | None = None
    """The sensor's real dark signal non-uniformity, e⁻ rms; default the declared one."""
    prnu: Annotated[float, Field(ge=0, le=0.5, allow_inf_nan=False)] | None = None
    """The sensor's real photo-response non-uniformity, relative rms; default the declared."""
    exposure: Factor = 1.0
    """Factor on the light every frame collects (the exposure the camera really uses)."""
    blur_px: BlurPx = 0.0
    """Gaussian blur σ of the image, pixels (defocus)."""
    camera_timeout: bool = False
    """The camera delivers no frame."""
    frozen: bool = False
    """The camera repeats its first frame."""
    exposure_glitch_every: Annotated[int, Field(ge=0, le=1000)] = 0
    """Every n-th frame is exposed at half the set exposure (a setting applied late),
    its chunk saying so; 0: never."""
    chunk_lag: bool = False
    """Chunks carry the previous frame's values (a known firmware fault)."""
    packet_loss: Annotated[float, Field(ge=0, le=0.5, allow_inf_nan=False)] = 0.0
    """The probability that a packet of a frame is lost on the way (a GigE Vision link
    that drops packets). Aravis' fake GigE camera drops its GVSP packets so; the simulated
    camera delivers a frame incomplete as often as a frame of its size in 1440-byte
    packets would be (the same frames on every opening: the loss is drawn from a fixed
    seed)."""
    missed_trigger_every: Annotated[int, Field(ge=0, le=1000)] = 0
    """Every n-th software trigger brings no frame (a camera still reading out, a trigger
    lost on the way): the simulated camera ignores it; 0: never."""
    temperature_c: Annotated[float, Field(ge=-60, le=200, allow_inf_nan=False)] | None = None
    """The temperature the simulated camera reports (``DeviceTemperature``), °C; default
    none reported."""
    nodes: dict[
        Annotated[str, Field(pattern=r"^[A-Za-z][A-Za-z0-9_]{0,63}$")],
        Annotated[str, Field(max_length=200)],
    ] = {}
    """Node values another program left on the camera (``{Gamma: "0.7"}``): reported in
    the camera's settings snapshot as a real node map would, not rendered."""
    dust: list[Dust] = []
    """Specks of dust on the lens."""
    line: Line | None = None
    """A running line of parts instead of the scene's still target (production mode)."""
    changes: list[WorldChange] = []
    """Changes over the cycles of ``watch`` (:meth:`at`)."""

    @model_validator(mode="after")
    def _one_draw(self):
        if self.parts == "redrawn" and self.reflectance_seed is not None:
            raise ValueError(
                "parts: redrawn draws other parts at every capture; reflectance_seed fixes "
                "one draw: give one of the two"
            )
        return self

    def at(self, cycle: int, *, hours: float = 0.0) -> World:
        """This world at ``watch``'s cycle ``cycle``, ``hours`` after it started: every
        active change applied, none left to apply."""
        import math

        w = self.model_dump(exclude={"changes"})
        for c in self.changes:
            if not c.active(cycle):
                continue
            n = cycle - c.start
            for ch in {*c.irradiance, *c.percent_per_cycle, *c.percent_per_hour}:
                factor = c.irradiance.get(ch, 1.0)
                factor *= (1 + c.percent_per_cycle.get(ch, 0.0) / 100) ** n
                # hours since the change began, as far as the cycles tell (uniform cycles)
                since = hours * n / cycle if cycle else 0.0
                factor *= math.exp(math.log1p(c.percent_per_hour.get(ch, 0.0) / 100) * since)
                w["irradiance"][ch] = w["irradiance"].get(ch, 1.0) * factor
            for ch, nm in c.peak_shift_nm.items():
                w["peak_shift_nm"][ch] = w["peak_shift_nm"].get(ch, 0.0) + nm
            if c.exposure is not None:
                w["exposure"] *= c.exposure
            if c.transmission is not None:
                w["transmission"] = min(w["transmission"] * c.transmission, 2.0)
            if c.blur_px is not None:
                w["blur_px"] = max(w["blur_px"], c.blur_px)
            w["camera_timeout"] |= c.camera_timeout
            w["frozen"] |= c.frozen
            for key in ("packet_loss", "missed_trigger_every", "temperature_c"):
                if getattr(c, key) is not None:
                    w[key] = getattr(c, key)
        # a drift schedule may not push a factor out of its range
        w["irradiance"] = {
            ch: 0.0 if f == 0 else min(max(f, 1e-6), 100.0) for ch, f in w["irradiance"].items()
        }
        return World(**w)

    def controller_faults(self, cycle: int) -> list[str]:
        """The simulated controller's fault arguments at ``cycle``."""
        return [a for c in self.changes if c.active(cycle) for a in c.controller_faults]


class Rendered(StrictModel):
    """A camera that renders the station's scene (simulated, fed into pylon's emulator, or
    streamed by Aravis' fake GigE Vision camera)."""

    width: Annotated[int, Field(ge=16, le=20000)] = 320
    """Frame width, pixels."""
    height: Annotated[int, Field(ge=16, le=20000)] = 240
    """Frame height, pixels."""
    latency: Annotated[int, Field(ge=0, le=100)] = 2
    """Frames in the camera's pipeline: a frame delivered now was exposed this many ago."""
    world: World = World()
    """How the simulated world differs from the scene."""
