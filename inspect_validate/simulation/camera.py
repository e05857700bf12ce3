"""A simulated camera: frames of a scene under whichever LED channels are on right now.

The station maps controller channels to lights of its scene. On every frame
the camera reads the (simulated) controller's state file, computes each class's
photo-electrons with the acquisition model for the lights that are on, at their
intensities, and renders the frame with the EMVA 1288 noise model
(:mod:`inspect_validate.model.render`). Like a real camera it has a pipeline: a
frame delivered now was exposed ``latency`` frames ago, under the light of that
moment, and carries that moment's timestamp — so a capture that does not
discard and verify records stale frames.

The world it renders need not be the scene: the station's ``camera.world``
gives irradiance factors, drifted or widened LED spectra, another draw of the
reflectance samples, a lens transmission factor, vignetting, ambient light and
a gain error (:func:`world_components`), an exposure factor and defocus blur,
so that verification has a reality to notice; and faults: a camera that
times out, or one that repeats a frame. ``watch`` evolves the world over its
cycles (:meth:`~inspect_validate.station.world.World.at`).

It triggers as a GenICam camera does (:meth:`SimulatedGrabber.arm`): free-running
through its pipeline, one frame per :meth:`~SimulatedGrabber.trigger` exposed at
the trigger, or one per pulse of the controller (each ``TR`` command counts in the
controller's state) on ``Line1``. A channel in pulse mode lights a frame only when
it fires — on that trigger, or on the camera's ``ExposureActive`` strobe output
(``Line2``) — and only for the part of the exposure its pulse covers. With chunks
on, each frame carries the exposure, gain, timestamp and frame id it was made with
(``Frame.extra["chunk"]``); the world's ``exposure_glitch_every`` and
``chunk_lag`` make them disagree as faulty firmware does.
"""

from __future__ import annotations

import functools
import json
import time
from collections import deque
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from inspect_validate.camera.frame import Frame
from inspect_validate.camera.grabbers.base import Features, Grabber
from inspect_validate.components.sensors import gain_factor
from inspect_validate.errors import DeviceError, FrameTimeout, IncompleteFrame, InputError

if TYPE_CHECKING:
    from inspect_validate.components.optics import Optics
    from inspect_validate.components.sensors import SensorModel
    from inspect_validate.model import ObjectClass
    from inspect_validate.station.file import Station
    from inspect_validate.station.model import StationModel
    from inspect_validate.station.world import World
from inspect_validate.model.render import class_bands, expected_grey, expose, sensor_pattern

__all__ = [
    "EDGE_ANGLE_DEG",
    "EDGE_DARK",
    "SimulatedGrabber",
    "edge_target",
    "lit_by_simulator",
    "scene_grabber",
]

EDGE_ANGLE_DEG = 5.0
"""The simulated edge target's turn from the frame's columns, degrees (ISO 12233 and MTF
Mapper use 2–10°: every pixel column samples the edge at another phase)."""
EDGE_DARK = 0.1
"""The edge target's dark square's reflectance (the white's is 1)."""
_SUPERSAMPLE = 8  # sub-pixels a side: the pixel's area as the sensor integrates it


def world_components(
    model: StationModel, world: World, *, draw: np.random.Generator | None = None
) -> tuple[dict, Optics, SensorModel, list[ObjectClass]]:
    """The simulated world: the station's components with ``world``'s deviations.

    Returns the channel lights (with an always-on ambient light as channel 0
    when ``world.ambient`` > 0), the optics, the camera (gain error applied, and the
    world's black level, dark current, DSNU and PRNU where it gives them)
    and the object classes (another draw of the reflectance samples when
    ``world.reflectance_seed`` is set, or by ``draw``: parts redrawn at this opening).
    """
    from dataclasses import replace

    from inspect_validate.components.lights import Light
    from inspect_validate.model import ObjectClass
    from inspect_validate.spectra import Spectrum, SpectrumKind

    lights = {}
    for ch, light in model.channels.items():
        # A dead channel (factor 0) is rendered at its stated power and its signal then
        # zeroed by the camera (a Light has a positive irradiance).
        irradiance = light.irradiance * (world.irradiance.get(ch, 1.0) or 1.0)
        shift, stretch = world.peak_shift_nm.get(ch, 0.0), world.width_scale.get(ch, 1.0)
        if shift or stretch != 1.0:
            # The same power as before, emitted at the shifted/stretched wavelengths:
            # stated over the whole new range instead of the old band.
            spd = light.spd
            peak = spd.wavelengths[int(np.nanargmax(spd.values[0]))]
            spd = replace(spd, wavelengths=peak + (spd.wavelengths - peak) * stretch + shift)
            irradiance *= _power(light) / light.band_power()
            light = replace(
                light, spd=spd, band=(float(spd.wavelengths[0]), float(spd.wavelengths[-1]))
            )
        lights[ch] = replace(light, irradiance=irradiance)
    if world.ambient > 0:
        grid = np.arange(380.0, 781.0)
        flat = Spectrum(grid, np.ones((1, grid.size)), SpectrumKind.SPD, "ambient", "world.ambient")
        lights[0] = Light("ambient", flat, irradiance=world.ambient)
    t = model.optics.transmission
    optics = replace(
        model.optics,
        transmission=replace(t, values=np.minimum(t.values * world.transmission, 1.0)),
    )
    sensor = {  # the real sensor's values where the world gives them
        field: getattr(world, name)
        for field, name in (
            ("dark_offset", "black_level"),
            ("dark_current", "dark_current"),
            ("dsnu", "dsnu"),
            ("prnu", "prnu"),
        )
        if getattr(world, name) is not None
    }
    camera = replace(
        model.scene_sensor, gain=model.scene_sensor.gain * (1.0 + world.gain_error), **sensor
    )
    classes = list(model.scene.classes)
    if world.reflectance_seed is not None or draw is not None:
        rng = draw if draw is not None else np.random.default_rng(world.reflectance_seed)
        classes = [
            ObjectClass(
                c.name,
                replace(
                    c.reflectance,
                    values=c.reflectance.values[
                        rng.integers(0, c.reflectance.n_samples, c.reflectance.n_samples)
                    ],
                ),
            )
            for c in classes
        ]
    return lights, optics, camera, classes


def _power(light) -> float:
    """∫ SPD over the light's whole range (what a shift or stretch must conserve)."""
    return float(np.trapezoid(np.nan_to_num(light.spd.values[0]), light.spd.wavelengths))


class SimulatedGrabber(Grabber):
    """Render frames of a station's scene lit by the channels in ``state_path``.

    Parameters
    ----------
    model : StationModel
        The station's scene components (:func:`inspect_validate.station.model.station_model`).
    state_path : Path
        JSON written by the controller (``{"channels": {"1": percent, ...}}``).
    world : World, optional
        Deviations of the simulated world from the scene.
    seed : int
        Which reflectance sample each object pixel shows (the parts themselves).
    sensor_seed : int, optional
        The sensor's fixed pattern (PRNU, DSNU); default drawn after the parts from
        ``seed`` (parts re-placed on one camera: a new ``seed``, the same ``sensor_seed``).
    noise_seed : int, optional
        The sensor noise; default new entropy for every camera opened.
    target : {"scene", "flat", "edge"}
        What is in front of the camera: the scene's objects, a white diffuse target
        filling the frame (a flat field), or a slanted edge (:data:`EDGE_ANGLE_DEG`): a
        dark square (reflectance :data:`EDGE_DARK`) on white, its left edge through the
        frame's centre, each pixel the share of its area on either side.
    """

    def __init__(
        self,
        model: StationModel,
        state_path: Path,
        *,
        world: World | None = None,
        width: int = 320,
        height: int = 240,
        latency: int = 2,
        frame_interval_s: float = 0.01,
        seed: int = 0,
        sensor_seed: int | None = None,
        noise_seed: int | None = None,
        target: str = "scene",
    ) -> None:
        from inspect_validate.model import Exposure, ObjectClass, predict
        from inspect_validate.spectra import Spectrum, SpectrumKind
        from inspect_validate.station.world import World

        self.world: World = world or World()
        world = self.world
        self.name = f"simulated camera ({model.scene_sensor.name})"
        self.missing = set()
        self.state_path = Path(state_path)
        self.noise = np.random.default_rng(noise_seed)
        # Parts redrawn: this opening's parts come from the noise's entropy (new in every
        # capture, reproducible from noise_seed); the camera's own pattern stays fixed.
        draw = (
            np.random.default_rng(self.noise.integers(2**63)) if world.parts == "redrawn" else None
        )
        lights, optics, self.sensor, classes = world_components(model, world, draw=draw)
        self.width, self.height = width, height
        self.latency = latency
        self.interval = frame_interval_s
        # The objects (which reflectance sample each pixel shows) are the same every
        # time, as the parts on a station are, unless they are redrawn; the noise is new
        # in every capture, as a sensor's is (repeats of 'train' must not be copies).
        objects = draw if draw is not None else np.random.default_rng(seed)
        self.exposure_us = 10_000.0
        self.gain_db = 0.0
        self.pixel_format = "Mono8"
        self.frame_id = 0
        self.channels = lights
        # Electrons per second per reflectance sample for each light alone at 100 %.
        # A white diffuse target (R = 1) rides along: what a uniform field shows.
        grid = model.scene.grid
        white = ObjectClass(
            "white target",
            Spectrum(grid, np.ones((1, grid.size)), SpectrumKind.REFLECTANCE, "white", "target"),
        )
        p = predict(
            list(lights.values()),
            [optics],
            [self.sensor],
            [*classes, white],
            exposure=Exposure("fixed", time=1.0),
            grid=grid,
        )
        assert p.sample_electrons is not None  # a full prediction keeps its samples
        rates = p.sample_electrons[:, 0, 0]  # (channels, samples), e⁻/s at 100 %, unclipped
        dead = np.array([world.irradiance.get(ch, 1.0) == 0 for ch in lights])
        rates = np.where(dead[:, None], 0.0, rates)  # the light never reaches the objects
        if world.irradiance_jitter:  # this capture's light levels, drawn once per opening
            level = np.exp(self.noise.normal(0.0, world.irradiance_jitter, len(lights)))
            rates = rates * np.where(np.array(list(lights)) == 0, 1.0, level)[:, None]
        scene = p.sample_class < len(classes)
        self.rates = rates[:, scene]
        self.white_rate = rates[:, ~scene][:, 0]  # (channels,)
        self.sample_class = p.sample_class[scene]
        self.classes = p.classes[:-1]
        self.target = target
        self._edge: np.ndarray | None = None  # the edge target's reflectance, made once
        line = world.line
        # The part's box in the frame (its home on a line), or the whole frame.
        pw, ph = (round(width * line.part), round(height * line.part)) if line else (width, height)
        ox, oy = (width - pw) // 2, (height - ph) // 2
        # 6-pixel gaps: the shipped station's rois.yaml is drawn for this layout.
        self.bands = {
            name: (x + ox, y + oy, w, h)
            for name, (x, y, w, h) in class_bands(self.classes, height=ph, width=pw, gap=6).items()
        }
        # Each object pixel shows one of its class's reflectance samples, fixed
        # over time: the spectral spread is spatial, as on a real object.
        self._objects = []
        self._samples = [np.flatnonzero(self.sample_class == k) for k in range(len(self.bands))]
        for samples, (x, y, w, h) in zip(self._samples, self.bands.values(), strict=True):
            self._objects.append(
                ((slice(y, y + h), slice(x, x + w)), objects.choice(samples, size=(h, w)))
            )
        self.part_box = (ox, oy, pw, ph)
        self._on = np.zeros((height, width), np.uint8)  # the part's object pixels at home
        for where, _ in self._objects:
            self._on[where] = 1
        self.pose: tuple[float, float, float] | None = (0.0, 0.0, 0.0)
        """The part's pose in the frame last rendered (dx, dy px; degrees), None: no part."""
        self._line = None if line is None else np.random.default_rng(line.seed)
        # The sensor's own fixed pattern (PRNU, DSNU), as fixed as the objects.
        if sensor_seed is not None:
            sensor = np.random.default_rng(sensor_seed)
        else:
            sensor = objects if draw is None else np.random.default_rng(seed)
        self._pattern = sensor_pattern(self.sensor, (height, width), rng=sensor)
        yy, xx = np.mgrid[0:height, 0:width]
        r2 = ((yy - (height - 1) / 2) ** 2 + (xx - (width - 1) / 2) ** 2) / (
            ((height - 1) / 2) ** 2 + ((width - 1) / 2) ** 2
        )
        self._falloff = (1.0 - world.vignetting * r2) * world.exposure
        for speck in world.dust:  # on the lens: fixed in the frame, whatever moves under it
            d2 = (xx - speck.x * (width - 1)) ** 2 + (yy - speck.y * (height - 1)) ** 2
            self._falloff *= 1.0 - speck.depth * np.exp(-d2 / (2 * speck.radius_px**2))
        self._frozen: np.ndarray | None = None  # the frame a frozen camera repeats
        self.pipeline: deque = deque()
        self.acquisition, self.chunks = "free-run", False
        self.strobe_line: str | None = None
        self.trigger_delay_us = 0.0
        self._triggered: deque = deque()  # software triggers not yet delivered
        self._pulses_seen = 0  # the controller's trigger count already exposed
        self._last_chunk: dict | None = None  # a lagging chunk's values (world.chunk_lag)
        # Its own generator, seeded: frames lost on the way leave the sensor noise's draws
        # as they were, and a world loses the same frames whenever the camera opens.
        self._loss = np.random.default_rng(0x1055)
        self._counts = {"frames_delivered": 0, "frames_incomplete": 0}
        self._triggers = 0

    _TRIGGER_LINE, _STROBE_LINE = "Line1", "Line2"

    def features(self) -> Features:
        return Features(
            software_trigger=True,
            trigger_lines=(self._TRIGGER_LINE,),
            strobe_lines=(self._STROBE_LINE,),
            chunks=("ExposureTime", "Gain", "Timestamp", "FrameID"),
            health=tuple(self.health()),
        )

    def arm(
        self,
        acquisition: str,
        *,
        trigger_line: str | None = None,
        strobe_line: str | None = None,
        chunks: bool = False,
        trigger_delay_us: float = 0.0,
    ) -> None:
        self.acquisition, self.strobe_line, self.chunks = acquisition, strobe_line, chunks
        self.trigger_delay_us = float(trigger_delay_us)
        self.pipeline.clear()
        self._triggered.clear()
        self._pulses_seen = self._controller_state().get("triggers", 0)

    def trigger(self) -> int:
        sent = time.monotonic_ns()
        if self.acquisition != "software-trigger":
            raise DeviceError(f"{self.name}: TriggerSoftware while not armed for it")
        self._triggers += 1
        every = self.world.missed_trigger_every
        if every and self._triggers % every == 0:
            return sent  # not taken: no frame follows
        self._triggered.append(self._expose(fired="strobe" if self.strobe_line else None))
        return sent

    def increments(self) -> dict[str, float]:
        return {"exposure_us": 1.0, "gain_db": 0.01}

    def health(self) -> dict[str, float]:
        """Frames delivered and incomplete (``world.packet_loss``), and the temperature
        ``world.temperature_c`` where given: this camera's own counts, since it opened."""
        out: dict[str, float] = dict(self._counts)
        if self.world.temperature_c is not None:
            out["temperature_c"] = self.world.temperature_c
        return out

    def _arrives_whole(self, data: np.ndarray) -> bool:
        """Whether this frame survives ``world.packet_loss``: as a GigE Vision frame of its
        size in 1440-byte packets does when each packet is lost with that probability."""
        loss = self.world.packet_loss
        if not loss:
            return True
        packets = -(-data.size * (1 if self.pixel_format == "Mono8" else 2) // 1440) + 2
        return bool(self._loss.random() >= -np.expm1(packets * np.log1p(-loss)))

    def settings(self) -> dict[str, str]:
        values = {
            "PixelFormat": self.pixel_format,
            "Width": str(self.width),
            "Height": str(self.height),
            "ExposureTime": f"{self.exposure_us:g}",
            "Gain": f"{self.gain_db:g}",
            "TriggerMode": "Off" if self.acquisition == "free-run" else "On",
            "Gamma": "1",
        }
        return {**values, **self.world.nodes}

    def configure(
        self,
        *,
        exposure_us: float | None = None,
        gain_db: float | None = None,
        pixel_format: str | None = None,
        region: tuple[int, int, int, int] | None = None,
    ) -> None:
        if exposure_us is not None:
            if not exposure_us > 0:
                raise DeviceError(f"{self.name}: exposure {exposure_us} µs must be positive")
            self.exposure_us = float(exposure_us)
        if gain_db is not None:
            self.gain_db = float(gain_db)
        if pixel_format not in (None, "Mono16", "Mono12", "Mono8"):
            raise DeviceError(
                f"{self.name}: pixel format {pixel_format!r} not available (Mono8, Mono12, Mono16)"
            )
        if pixel_format is not None:
            self.pixel_format = pixel_format
        if region is not None:
            raise DeviceError(
                f"{self.name}: a region cannot be set; the frame is {self.width}×{self.height}"
            )
        self.pipeline.clear()  # a settings change restarts the pipeline, as on real cameras

    def _controller_state(self) -> dict:
        try:
            doc = json.loads(self.state_path.read_text())
        except (OSError, ValueError):
            return {}
        return doc if isinstance(doc, dict) else {}

    def light_state(self, *, fired: str | None = None) -> dict[int, float]:
        """The channels' light during an exposure starting now (channel → % of full output),
        from the controller's state file.

        A channel in pulse mode lights the exposure only when it fires — ``"strobe"``:
        on this camera's exposure-active output, ``"controller"``: on the controller's
        trigger, which also started the exposure ``trigger_delay_us`` later — and then
        in proportion to the part of the exposure its pulse covers.
        """
        doc = self._controller_state()
        levels = {int(c): float(v) for c, v in doc.get("channels", {}).items()}
        if not fired and self.strobe_line:
            fired = "strobe"
        for c, mode in doc.get("mode", {}).items():
            if mode != "pulse":
                continue
            width, delay = doc.get("pulse", {}).get(c, (0.0, 0.0))
            start = self.trigger_delay_us if fired == "controller" else 0.0
            end = start + self.exposure_us
            covered = max(0.0, min(end, delay + width) - max(start, delay))
            levels[int(c)] *= covered / self.exposure_us if fired else 0.0
        return levels

    def _expose(self, *, fired: str | None = None) -> tuple[dict[int, float], int]:
        time.sleep(self.interval)
        return self.light_state(fired=fired), time.monotonic_ns()

    def grab(self, n: int, *, timeout_s: float = 2.0) -> list[Frame]:
        if self.world.camera_timeout:
            time.sleep(timeout_s)
            raise FrameTimeout(f"{self.name}: no frame within {timeout_s:g} s (timeout)")
        frames: list[Frame] = []
        while len(frames) < n:
            if self.acquisition == "free-run":
                self.pipeline.append(self._expose())
                if len(self.pipeline) <= self.latency:
                    continue
                state, stamp = self.pipeline.popleft()
            elif self.acquisition == "software-trigger":
                if not self._triggered:
                    time.sleep(timeout_s)
                    raise FrameTimeout(
                        f"{self.name}: no frame within {timeout_s:g} s; it waits for TriggerSoftware"
                    )
                state, stamp = self._triggered.popleft()
            else:
                state, stamp = self._wait_for_pulse(timeout_s)
            frame = self._render(state, stamp)
            if not self._arrives_whole(frame.data):
                self._counts["frames_incomplete"] += 1
                raise IncompleteFrame(
                    f"{self.name}: frame {frame.frame_id} arrived incomplete (packets lost); "
                    "check the network (packet size, bandwidth, a switch dropping packets)"
                )
            self._counts["frames_delivered"] += 1
            frames.append(frame)
        return frames

    def _wait_for_pulse(self, timeout_s: float) -> tuple[dict[int, float], int]:
        """Expose on the controller's next trigger pulse (its state's trigger count)."""
        deadline = time.monotonic() + timeout_s
        while self._controller_state().get("triggers", 0) <= self._pulses_seen:
            if time.monotonic() > deadline:
                raise FrameTimeout(
                    f"{self.name}: no frame within {timeout_s:g} s; no pulse arrived on "
                    f"{self._TRIGGER_LINE} (check the controller's trigger output wiring)"
                )
            time.sleep(0.001)
        self._pulses_seen += 1
        return self._expose(fired="controller")

    def render(self, state: dict[int, float], *, exposure_us: float | None = None) -> np.ndarray:
        """One noisy frame (uint16 DN) under ``state`` (channel → %), EMVA 1288 model with
        the sensor's dark current and fixed pattern."""
        electrons = self._electrons(state)
        exposure_us = self.exposure_us if exposure_us is None else exposure_us
        if exposure_us != self.exposure_us:
            electrons *= exposure_us / self.exposure_us
        return expose(
            electrons,
            self.sensor,
            rng=self.noise,
            gain=self._gain(),
            exposure_s=exposure_us * 1e-6,
            pattern=self._pattern,
        )

    def expected(self, state: dict[int, float]) -> tuple[np.ndarray, np.ndarray]:
        """The truth behind :meth:`render`: each pixel's expected grey value (DN) and
        temporal variance (DN²) under ``state`` (:func:`expected_grey`)."""
        return expected_grey(
            self._electrons(state),
            self.sensor,
            gain=self._gain(),
            exposure_s=self.exposure_us * 1e-6,
            pattern=self._pattern,
        )

    def _gain(self) -> float:
        return self.sensor.gain * gain_factor(self.gain_db)

    def _electrons(self, state: dict[int, float]) -> np.ndarray:
        """Mean photo-electrons of each pixel (e⁻) under ``state``, world deviations included."""
        percent = np.array([100.0 if ch == 0 else state.get(ch, 0.0) for ch in self.channels])
        gradient = self.world.light_gradient
        if not any(
            gradient.get(ch, 0.0) and p for ch, p in zip(self.channels, percent, strict=True)
        ):
            electrons = self._lit(percent)
        else:  # each light across the frame as it falls off: one image per light
            x = np.arange(self.width) / max(self.width - 1, 1)
            electrons = np.zeros((self.height, self.width))
            for k, ch in enumerate(self.channels):
                if percent[k]:
                    alone = np.where(np.arange(percent.size) == k, percent, 0.0)
                    electrons += self._lit(alone) * (1.0 - gradient.get(ch, 0.0) * x)
        electrons *= self._falloff
        if self.world.blur_px > 0 and self.target != "edge":  # the edge's is sub-pixel
            from scipy import ndimage

            kernel = _blur_kernel(self.world.blur_px)
            for axis in (0, 1):
                electrons = ndimage.convolve1d(electrons, kernel, axis=axis, mode="nearest")
        return electrons

    def _lit(self, percent: np.ndarray) -> np.ndarray:
        """Mean photo-electrons of each pixel (e⁻) with the lights at ``percent``, before
        the lens's falloff and blur: the target's or the scene's objects."""
        t = self.exposure_us * 1e-6
        if self.target == "flat":
            return np.full((self.height, self.width), percent / 100.0 @ self.white_rate * t)
        if self.target == "edge":
            if self._edge is None:
                self._edge = edge_target(self.height, self.width, blur_px=self.world.blur_px)
            return self._edge * (percent / 100.0 @ self.white_rate * t)
        rate = percent / 100.0 @ self.rates  # e⁻/s per reflectance sample
        electrons = np.zeros((self.height, self.width))
        for where, pick in self._objects:
            electrons[where] = rate[pick] * t
        if self.world.line is not None:
            belt = self.world.line.belt * (percent / 100.0 @ self.white_rate)
            electrons = self._moved(electrons, belt * t)
        return electrons

    def _moved(self, part: np.ndarray, belt: float) -> np.ndarray:
        """The part (electrons at its home, 0 off it) at :attr:`pose` on the belt: each
        frame pixel shows the part's pixel its centre falls on (nearest), so that every
        pixel still shows one reflectance sample whatever the pose."""
        import cv2

        if self.pose is None:
            return np.full(part.shape, belt)
        dx, dy, degrees = self.pose
        x, y, w, h = self.part_box
        # About the part's centre (pixel centres), then shifted.
        matrix = cv2.getRotationMatrix2D((x + w / 2 - 0.5, y + h / 2 - 0.5), -degrees, 1.0)
        matrix[:, 2] += np.array([dx, dy])
        moved = cv2.warpAffine(part, matrix, part.shape[::-1], flags=cv2.INTER_NEAREST)
        on = cv2.warpAffine(self._on, matrix, part.shape[::-1], flags=cv2.INTER_NEAREST)
        # The part's own gaps between bands are the belt's colour too.
        return np.where(on == 1, moved, belt)

    def _next_pose(self) -> tuple[float, float, float] | None:
        """A new part's pose on the line (None: a gap on the belt)."""
        line, rng = self.world.line, self._line
        assert line is not None and rng is not None
        if rng.random() < line.missing:
            return None
        reach = np.array([self.width, self.height]) * line.shift
        dx, dy = rng.uniform(-reach, reach)
        if rng.random() < line.cut:
            # Against an edge: up to a fifth of the part beyond it.
            axis, side = int(rng.integers(2)), 1 if rng.random() < 0.5 else -1
            size, box = (self.width, self.height)[axis], self.part_box[2 + axis]
            over = (size - box) / 2 + rng.uniform(0.02, 0.2) * box
            dx, dy = (side * over, dy) if axis == 0 else (dx, side * over)
        cx, cy = line.camera_shift_px
        return float(dx + cx), float(dy + cy), float(rng.uniform(-1, 1) * line.rotation_deg)

    def _render(self, state: dict[int, float], stamp: int) -> Frame:
        self.frame_id += 1
        if self._line is not None:  # another part: another pose, another draw of its classes
            self.pose = self._next_pose()
            self._objects = [
                (where, self._line.choice(self._samples[k], size=pick.shape))
                for k, (where, pick) in enumerate(self._objects)
            ]
        exposure = self.exposure_us
        every = self.world.exposure_glitch_every
        if every and self.frame_id % every == 0:  # a stale setting applied to this frame
            exposure *= 0.5
        if self.world.frozen:  # a hung driver hands out its last buffer again
            if self._frozen is None:
                self._frozen = self.render(state)
            data = self._frozen.copy()
        else:
            data = self.render(state, exposure_us=exposure)
        extra: dict = {"lights": state}
        if self._line is not None:  # the truth a production verification estimates
            extra["part_pose"] = None if self.pose is None else list(self.pose)
        if self.chunks:
            chunk: dict = {
                "ExposureTime": exposure,
                "Gain": self.gain_db,
                "Timestamp": stamp,
                "FrameID": self.frame_id,
            }
            if self.world.chunk_lag:  # firmware that appends the previous frame's values
                chunk, self._last_chunk = self._last_chunk or chunk, chunk
            extra["chunk"] = chunk
        sensor = self.sensor
        return Frame(
            data=data,
            frame_id=self.frame_id,
            timestamp_ns=stamp,
            exposure_us=self.exposure_us,
            gain_db=self.gain_db,
            pixel_format="Mono16",
            bit_depth=sensor.bit_depth,
            device=self.name,
            clock="exposure",
            extra=extra,
        )


def lit_by_simulator(station: Station, state_path: Path | None) -> None:
    """Refuse a camera that renders the scene without the simulated controller, whose
    state file says which lights are on."""
    if state_path is None:
        raise InputError(
            f"a camera that renders the scene ({station.camera.backend}) needs the simulated "
            "controller (controller.backend: simulated)",
            source=str(station.path),
        )


@functools.lru_cache(maxsize=8)
def _blur_kernel(blur_px: float, *, n: int = 64) -> np.ndarray:
    """What each pixel at offset −m…m collects of one pixel's patch of the scene through
    a Gaussian blur of σ ``blur_px`` (1-D): the lens blurs the light before the pixels
    integrate it, so the patch's box, the blur and the pixel's box, summed on a grid of
    ``n`` points a pixel (the edge target is drawn the same way). Not the blur's
    kernel sampled at whole pixels: that leaves σ 0.5 px twice the texture."""
    m = int(np.ceil(6 * blur_px)) + 2
    x = (np.arange(-(m + 2) * n, (m + 2) * n + 1)) / n
    gauss = np.exp(-0.5 * (x / blur_px) ** 2)
    box = (np.abs(x) < 0.5).astype(float) + 0.5 * (np.abs(x) == 0.5)
    spread = np.convolve(np.convolve(box, gauss / gauss.sum(), "same"), box / n, "same")
    kernel = spread[(np.arange(-m, m + 1) + m + 2) * n]
    return kernel / kernel.sum()


def edge_target(height: int, width: int, *, blur_px: float = 0.0) -> np.ndarray:
    """The slanted-edge target's reflectance as each pixel sees it, (height, width): a
    dark square (:data:`EDGE_DARK`, side 0.6 of the frame's smaller side) on white, its
    left edge through the frame's centre, turned by :data:`EDGE_ANGLE_DEG` about it. Each
    pixel is the mean of its area (8 × 8 sub-pixels, the pixel aperture a sensor
    integrates) after a Gaussian blur of σ ``blur_px`` px: the truth's MTF is
    |sinc(f)|·exp(−2π²σ²f²), f in cycles/pixel."""
    from scipy import ndimage

    n = _SUPERSAMPLE
    y = (np.arange(height * n) + 0.5) / n - height / 2
    x = (np.arange(width * n) + 0.5) / n - width / 2
    a = np.deg2rad(EDGE_ANGLE_DEG)
    u = x[None, :] * np.cos(a) + y[:, None] * np.sin(a)  # across the edge
    v = -x[None, :] * np.sin(a) + y[:, None] * np.cos(a)  # along it
    side = 0.6 * min(height, width)
    inside = (u >= 0) & (u <= side) & (np.abs(v) <= side / 2)
    fine = np.where(inside, EDGE_DARK, 1.0)
    if blur_px > 0:
        fine = ndimage.gaussian_filter(fine, blur_px * n, mode="nearest")
    return fine.reshape(height, n, width, n).mean(axis=(1, 3))


def scene_grabber(
    station: Station, state_path: Path | None, target: str = "scene"
) -> SimulatedGrabber:
    """The simulated camera of the station's scene, lit by the simulated controller's state."""
    spec = station.camera
    lit_by_simulator(station, state_path)
    from inspect_validate.errors import sourced
    from inspect_validate.station.model import station_model

    assert state_path is not None  # lit_by_simulator refused a station without it
    with sourced(str(station.path)):  # a frame too small for the classes: the file's fault
        return SimulatedGrabber(
            station_model(station),
            state_path,
            world=spec.world,
            width=spec.width,
            height=spec.height,
            latency=spec.latency,
            target=target,
        )
