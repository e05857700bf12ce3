"""A simulated camera: frames of a scene under whichever LED channels are on right now.

The station maps controller channels to lights of a scene file. On every frame
the camera reads the (simulated) controller's state file, computes each class's
photo-electrons with the acquisition model for the lights that are on, at their
intensities, and renders the frame with the EMVA 1288 noise model
(:mod:`inspect_validate.model.render`). Like a real camera it has a pipeline: a
frame delivered now was exposed ``latency`` frames ago, under the light of that
moment, and carries that moment's timestamp — so a capture that does not
discard and verify records stale frames.
"""

from __future__ import annotations

import json
import time
from collections import deque
from pathlib import Path

import numpy as np
from inspect_validate.camera.frame import Frame
from inspect_validate.camera.grabbers.base import Grabber

from inspect_validate.errors import DeviceError, InputError
from inspect_validate.model.render import class_bands, expose

__all__ = ["SimulatedCamera"]


class SimulatedCamera(Grabber):
    """Render frames of ``scene`` lit by the channels in ``state_path``.

    Parameters
    ----------
    scene : Scene
        Classes (reflectances), optics and camera (the first of each is used).
    channel_lights : dict
        Controller channel → name of a light in the scene.
    irradiance : dict, optional
        Channel → irradiance at the object at 100 %, W/m² (default: the scene
        light's own ``irradiance``).
    state_path : Path
        JSON written by the controller (``{"channels": {"1": percent, ...}}``).
    """

    def __init__(
        self,
        scene,
        channel_lights: dict[int, str],
        state_path: Path,
        *,
        irradiance: dict[int, float] | None = None,
        width: int = 320,
        height: int = 240,
        latency: int = 2,
        frame_interval_s: float = 0.01,
        seed: int = 0,
    ):
        from inspect_validate.model import Exposure, predict

        self.name = f"simulated camera ({scene.cameras[0].name})"
        self.missing = set()
        self.state_path = Path(state_path)
        self.camera = scene.cameras[0]
        self.width, self.height = width, height
        self.latency = latency
        self.interval = frame_interval_s
        self.rng = np.random.default_rng(seed)
        self.exposure_us = 10_000.0
        self.gain_db = 0.0
        self.frame_id = 0
        names = {light.name: light for light in scene.lights}
        self.channels = {}
        for ch, light_name in channel_lights.items():
            if light_name not in names:
                raise InputError(
                    f"channel {ch}: the scene has no light {light_name!r} (it has {', '.join(names)})"
                )
            light = names[light_name]
            if irradiance and int(ch) in irradiance:
                from dataclasses import replace

                light = replace(light, irradiance=float(irradiance[int(ch)]))
            if light.irradiance is None:
                raise InputError(
                    f"light {light_name!r} needs 'irradiance' (W/m² at 100 %) for the simulated station"
                )
            self.channels[int(ch)] = light
        # Electrons per second per reflectance sample for each light alone at 100 %.
        p = predict(
            list(self.channels.values()),
            [scene.optics[0]],
            [self.camera],
            list(scene.classes),
            exposure=Exposure("fixed", time=1.0),
            grid=scene.grid,
        )
        self.rates = p.sample_electrons[:, 0, 0]  # (channels, samples), e⁻/s at 100 %, unclipped
        self.sample_class = p.sample_class
        self.classes = p.classes
        # 6-pixel gaps: the shipped station's rois.yaml is drawn for this layout.
        self.bands = class_bands(self.classes, height=height, width=width, gap=6)
        # Each object pixel shows one of its class's reflectance samples, fixed
        # over time: the spectral spread is spatial, as on a real object.
        self._objects = []
        for k, (x, y, w, h) in enumerate(self.bands.values()):
            samples = np.flatnonzero(self.sample_class == k)
            self._objects.append(
                ((slice(y, y + h), slice(x, x + w)), self.rng.choice(samples, size=(h, w)))
            )
        self.pipeline: deque = deque()

    def configure(self, *, exposure_us=None, gain_db=None, pixel_format=None, region=None) -> None:
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
        if region is not None:
            raise DeviceError(
                f"{self.name}: a region cannot be set; the frame is {self.width}×{self.height}"
            )
        self.pipeline.clear()  # a settings change restarts the pipeline, as on real cameras

    def light_state(self) -> dict[int, float]:
        """The channels the controller has on now (channel → %), from its state file."""
        try:
            doc = json.loads(self.state_path.read_text())
        except (OSError, ValueError):
            return {}
        return {int(c): float(v) for c, v in doc.get("channels", {}).items()}

    def _expose(self) -> tuple[dict[int, float], int]:
        time.sleep(self.interval)
        return self.light_state(), time.monotonic_ns()

    def grab(self, n: int, *, timeout_s: float = 2.0) -> list[Frame]:
        frames = []
        while len(frames) < n:
            self.pipeline.append(self._expose())
            if len(self.pipeline) <= self.latency:
                continue
            state, stamp = self.pipeline.popleft()
            frames.append(self._render(state, stamp))
        return frames

    def render(self, state: dict[int, float]) -> np.ndarray:
        """One noisy frame (uint16 DN) under ``state`` (channel → %), EMVA 1288 model."""
        percent = np.array([state.get(ch, 0.0) for ch in self.channels])
        rate = percent / 100.0 @ self.rates  # e⁻/s per reflectance sample
        electrons = np.zeros((self.height, self.width))
        for where, pick in self._objects:
            electrons[where] = rate[pick] * (self.exposure_us * 1e-6)
        return expose(
            electrons, self.camera, rng=self.rng, gain=self.camera.gain * 10 ** (self.gain_db / 20)
        )

    def _render(self, state: dict[int, float], stamp: int) -> Frame:
        data = self.render(state)
        self.frame_id += 1
        cam = self.camera
        return Frame(
            data,
            self.frame_id,
            stamp,
            self.exposure_us,
            self.gain_db,
            "Mono16",
            cam.bit_depth,
            self.name,
            "exposure",
            {"lights": state},
        )
