"""The EMVA 1288 capture of ``characterize``: an exposure series from dark to past
saturation, dark pairs at every exposure, and spatial stacks.

Through the station's own camera and controller, with the capture machinery of
``capture`` (verified frames, sidecars, resumable):

1. a probe: one lit and one dark pair at the station's exposure, shortened by 4×
   until the lit pair is below 90 % of the bit depth's range, gives the exposure that
   would saturate (linear in the exposure above dark);
2. ``points`` exposures evenly spaced up to 1.2 × that, each a lit pair ``b_NNN``
   and a dark pair ``d_NNN``; then ten more between the neighbours of the point
   where σ²_y peaks (the 1288 saturation, found to a tenth of a step: a full well
   may clip well below the bit depth's range);
3. ``frames_spatial`` frames lit at half the saturation signal (``b_spatial``) and as
   many dark (``d_spatial``) for DSNU and PRNU.

A camera without an exposure setting gets a series of LED levels instead (0–100 % of
the illumination's channels at the station's exposure); its dark signal does not
change along it, so no dark current is measured. The plan is written to
``characterize.json`` in the capture folder before the series starts, so a resumed
run takes the same points.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, replace
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from inspect_validate.errors import DeviceError, InputError

if TYPE_CHECKING:
    from pydantic import BaseModel

    from inspect_validate.camera.capture import Progress
    from inspect_validate.characterization.analysis import Characterization
    from inspect_validate.station.file import Station

__all__ = ["Plan", "capture_series", "expected_rate", "read_series"]

PLAN_FILE = "characterize.json"
_PROBES = 6  # each 4× shorter: 4096× the station's exposure at most
_NEAR_SATURATION = 10  # extra exposures between 90 % and 110 % of the saturating one


@dataclass(frozen=True)
class Plan:
    """The series: each point's exposure (µs) and light level (0–1 of the illumination),
    the spatial stacks' exposure, the bit depth, and which it varies."""

    exposure_us: tuple[float, ...]
    level: tuple[float, ...]
    spatial_exposure_us: float
    spatial_level: float
    bits: int
    varies: str  # "exposure" or "level"
    illumination: str
    refined: bool = False  # the points near saturation and the spatial stacks are planned

    def abscissa(self) -> np.ndarray:
        """What the signal is linear in: the exposure, or the LED level (%)."""
        if self.varies == "exposure":
            return np.array(self.exposure_us)
        return 100 * np.array(self.level)


def _channels(station, level: float) -> dict:
    ill = _illumination(station)
    return {ch: pct * level for ch, pct in ill.channels.items()}


def _illumination(station):
    wanted = station.characterize.illumination or station.illuminations[0].name
    return next(i for i in station.illuminations if i.name == wanted)


def _mean(folder: Path, mask) -> float:
    from inspect_validate.images import read_frames

    frames = read_frames([folder])
    return float(frames[:, mask].mean())


def capture_series(
    station: Station, out: Path, *, resume: bool = False, progress: Progress | None = None
) -> Plan:
    """Probe, plan and capture the series into ``out`` (module docstring); the plan."""
    from inspect_validate.camera.capture import Step
    from inspect_validate.images import recorded_bit_depth
    from inspect_validate.station.capture import capture
    from inspect_validate.station.devices import open_devices

    def run(steps):
        opened = open_devices(station, target="flat")
        return capture(
            station,
            out,
            resume=resume or (out / "manifest.json").exists(),
            steps=steps,
            devices=opened,
            progress=progress,
        )

    if not resume and (out / "manifest.json").exists():
        raise InputError(
            "this folder already holds a capture: add --resume to continue its series, or "
            "give a new --out",
            source=str(out),
        )
    plan_path = out / PLAN_FILE
    if resume and (out / "manifest.json").exists():
        _audit(out)  # frames changed since they were written are not built on
    if resume and plan_path.exists():  # refused if it is not a regular file
        plan = _read_plan(plan_path)
        _check_plan(out, plan, station)  # as audited as the frames it planned
    else:
        t0 = station.camera.exposure_us or 10_000.0
        first = run(
            [Step("probe_b_0", _channels(station, 1.0), 2, t0), Step("probe_d_0", {}, 2, t0)]
        )
        fixed = "exposure" in first.not_applied or station.camera.exposure_us is None
        bits = recorded_bit_depth(next((out / "probe_b_0").glob("frame_*.tif")))
        if bits is None:
            from inspect_validate.station.model import station_model

            bits = station_model(station).sensor.bit_depth
        top = 2**bits - 1
        if station.scene:  # a full well below the format's range: the declared camera's
            from inspect_validate.station.model import station_model

            top = min(top, station_model(station).sensor.max_dn)
        mask = region_mask(station, out / "probe_b_0")
        t, k = t0, 0
        lit, dark = _mean(out / "probe_b_0", mask), _mean(out / "probe_d_0", mask)
        while not fixed and lit > 0.9 * top and k < _PROBES:
            k, t = k + 1, t / 4
            run(
                [
                    Step(f"probe_b_{k}", _channels(station, 1.0), 2, t),
                    Step(f"probe_d_{k}", {}, 2, t),
                ]
            )
            lit, dark = _mean(out / f"probe_b_{k}", mask), _mean(out / f"probe_d_{k}", mask)
        if lit - dark < 1.0:
            raise InputError(
                f"the illumination {_illumination(station).name!r} gives {lit - dark:.2g} DN above "
                "dark at the station's exposure: nothing to characterise with — check that its "
                "light reaches the camera, or choose another with characterize.illumination",
                source=str(station.path),
            )
        if lit > 0.9 * top:
            raise DeviceError(
                f"the camera saturates even at {t:.3g} µs: lower the illumination's level"
            )
        n = station.characterize.points
        if fixed:
            levels = tuple(float(x) for x in np.linspace(0, 1, n + 1)[1:])
            exposures = (t0,) * n
            spatial = (t0, 0.5 * min(1.0, (top - dark) / (lit - dark)))
        else:
            # The bit depth's range bounds the saturating exposure from above (a full
            # well may clip first): evenly spaced to 1.2× that.
            t_sat = t * (top - dark) / (lit - dark)
            exposures = tuple(float(x) for x in np.linspace(0, 1.2 * t_sat, n + 1)[1:])
            levels = (1.0,) * n
            spatial = (0.5 * t_sat, 1.0)
        plan = Plan(
            exposures,
            levels,
            spatial[0],
            spatial[1],
            int(bits),
            "level" if fixed else "exposure",
            _illumination(station).name,
        )
        _write_plan(plan_path, plan)
    run(_pair_steps(station, plan))
    while not plan.refined:
        plan = _refine(station, out, plan)
        _write_plan(plan_path, plan)
        run(_pair_steps(station, plan))
    l_frames = station.characterize.frames_spatial
    run(
        [
            Step(
                "b_spatial",
                _channels(station, plan.spatial_level),
                l_frames,
                plan.spatial_exposure_us,
            ),
            Step("d_spatial", {}, l_frames, plan.spatial_exposure_us),
        ]
    )
    return plan


def _pair_steps(station, plan: Plan) -> list:
    """A lit and a dark pair at every point of ``plan``."""
    from inspect_validate.camera.capture import Step

    steps = []
    for i, (t, level) in enumerate(zip(plan.exposure_us, plan.level, strict=True)):
        steps += [
            Step(f"b_{i:03d}", _channels(station, level), 2, t),
            Step(f"d_{i:03d}", {}, 2, t),
        ]
    return steps


def _refine(station, out: Path, plan: Plan) -> Plan:
    """``plan`` with ten more points between the measured saturation point's neighbours
    (so the peak of σ²_y, the 1288 saturation, is found to a tenth of a step), and the
    spatial stacks at half the measured saturation signal."""
    from dataclasses import replace as replaced

    from inspect_validate.characterization.analysis import locate_saturation, pair_statistics
    from inspect_validate.images import read_frames

    mask = region_mask(station, out / "b_000")
    pairs = []
    for i in range(len(plan.exposure_us)):
        b = read_frames([out / f"b_{i:03d}"])[:, mask]
        pairs.append(pair_statistics(b[0], b[1]))
    x = plan.abscissa()
    variance = np.array([p.variance for p in pairs])
    sat = locate_saturation(variance)
    grown = len(x) > station.characterize.points
    if plan.varies == "exposure" and sat == len(x) - 1 and not grown:
        # Not saturated yet (the camera's full well is above what its file declares):
        # half as many points again, up to twice the longest exposure, once.
        more = np.linspace(x[-1], 2 * x[-1], station.characterize.points // 2 + 1)[1:]
        return replaced(
            plan,
            exposure_us=(*plan.exposure_us, *map(float, more)),
            level=(*plan.level, *([1.0] * len(more))),
        )
    lo, hi = x[max(sat - 1, 0)], x[min(sat + 1, len(x) - 1)]
    near = np.linspace(lo, hi, _NEAR_SATURATION + 2)[1:-1]
    dark = float(read_frames([out / "d_000"])[:, mask].mean())
    signal = np.array([p.mean for p in pairs]) - dark
    # Half the saturation signal, interpolated on the rising part (made monotonic: noise
    # must not send the interpolation outside the series).
    rising = np.maximum.accumulate(signal[: sat + 1])
    middle = float(np.interp(0.5 * signal[sat], rising, x[: sat + 1]))
    middle = min(max(middle, x[0]), x[sat])
    if plan.varies == "exposure":
        return replaced(
            plan,
            exposure_us=(*plan.exposure_us, *map(float, near)),
            level=(*plan.level, *([1.0] * len(near))),
            spatial_exposure_us=middle,
            refined=True,
        )
    return replaced(
        plan,
        exposure_us=(*plan.exposure_us, *([plan.exposure_us[0]] * len(near))),
        level=(*plan.level, *(float(v) / 100 for v in near)),
        spatial_level=middle / 100,
        refined=True,
    )


def _write_plan(path: Path, plan: Plan) -> None:
    from dataclasses import asdict

    from inspect_validate.files import atomic_write

    atomic_write(path, json.dumps(asdict(plan), indent=2).encode())


def _plan_model() -> type[BaseModel]:
    """The plan file's schema: the bounds a camera's settings have (exposure as a station
    may set it, bit depths a camera may have), so an edited plan is refused before it
    captures, not after it wrote a camera file its reader refuses."""
    from typing import Annotated, Literal

    from pydantic import Field, model_validator

    from inspect_validate.components.sensors import BIT_DEPTHS
    from inspect_validate.config import StrictModel
    from inspect_validate.constants import LONGEST_EXPOSURE_S

    Exposure = Annotated[float, Field(gt=0, le=LONGEST_EXPOSURE_S * 1e6, allow_inf_nan=False)]  # µs
    Level = Annotated[float, Field(ge=0, le=1, allow_inf_nan=False)]

    class PlanFile(StrictModel):
        exposure_us: Annotated[tuple[Exposure, ...], Field(min_length=1, max_length=10_000)]
        level: Annotated[tuple[Level, ...], Field(min_length=1, max_length=10_000)]
        spatial_exposure_us: Exposure
        spatial_level: Level
        bits: Annotated[int, Field(ge=BIT_DEPTHS[0], le=BIT_DEPTHS[1], strict=True)]
        varies: Literal["exposure", "level"]
        illumination: str
        refined: bool = False

        @model_validator(mode="after")
        def _paired(self):
            if len(self.exposure_us) != len(self.level):
                raise ValueError(f"{len(self.exposure_us)} exposures but {len(self.level)} levels")
            return self

    return PlanFile


def _audit(out: Path, steps=None) -> None:
    """Check the frames of ``steps`` (default: every complete step) are the ones the
    capture wrote, as verify checks its captures (:func:`~inspect_validate.camera.storage.
    audit_capture`)."""
    from inspect_validate.camera.storage import audit_capture, read_manifest

    manifest = read_manifest(out / "manifest.json")
    if steps is None:
        steps = [k for k, v in manifest["steps"].items() if v.get("complete")]
    else:
        missing = [k for k in steps if not manifest["steps"].get(k, {}).get("complete")]
        if missing:
            raise InputError(
                f"step {missing[0]} was not captured completely; rerun characterize with --resume",
                source=str(out),
            )
    audit_capture(out, manifest, steps)


def _check_plan(out: Path, plan: Plan, station: Station) -> None:
    """Refuse a plan that contradicts what was captured by it: every complete step's
    recorded exposure (the frames' sidecars) and channel levels (the manifest), the bit
    depth of the frames, the illumination. An edited plan (exposures doubled: a
    linearity error of 35 %, QE 0.62 where it is 0.97) is not built on."""
    from inspect_validate.camera.storage import read_manifest, step_record
    from inspect_validate.errors import listed
    from inspect_validate.images import recorded_bit_depth

    path = out / PLAN_FILE
    manifest = read_manifest(out / "manifest.json")
    steps = manifest["steps"]
    problems = []
    if plan.illumination != _illumination(station).name:
        problems.append(
            f"illumination {plan.illumination!r}, where the station characterizes with "
            f"{_illumination(station).name!r}"
        )
    if plan.varies == "level" and len(set(plan.exposure_us)) > 1:
        problems.append("varies the level, but its exposures differ")
    if plan.varies == "exposure" and set(plan.level) != {1.0}:
        problems.append("varies the exposure, but its levels are not all 1")
    probe = next((out / "probe_b_0").glob("frame_*.tif"), None)
    bits = recorded_bit_depth(probe) if probe is not None else None
    if bits is not None and bits != plan.bits:
        problems.append(f"bits {plan.bits}, where the frames were recorded at {bits} bits")
    points = {f"{k}_{i:03d}": (t, lv if k == "b" else 0.0)
              for i, (t, lv) in enumerate(zip(plan.exposure_us, plan.level, strict=True))
              for k in "bd"}  # fmt: skip
    points["b_spatial"] = (plan.spatial_exposure_us, plan.spatial_level)
    points["d_spatial"] = (plan.spatial_exposure_us, 0.0)
    for name, record in steps.items():
        if name.startswith("probe_") or not record.get("complete"):
            continue
        if name not in points:
            problems.append(f"step {name} was captured, but the plan has no such point")
            continue
        exposure, level = points[name]
        want = {ch: round(pct, 6) for ch, pct in _channels(station, level).items() if pct > 0}
        recorded = step_record(out, manifest, name)
        got = {ch: round(pct, 6) for ch, pct in recorded.channels.items()}
        if want != got:
            problems.append(
                f"step {name} was lit at {got or 'nothing'}, the plan says {want or 'dark'}"
            )
        differs = recorded.exposure_differs(exposure) if plan.varies == "exposure" else None
        if differs is not None:
            problems.append(
                f"step {name} was exposed {differs:g} µs, the plan says {exposure:g} µs"
            )
    if problems:
        raise InputError(
            f"the characterization plan contradicts the frames captured by it "
            f"({listed(problems, 3)}): it was edited since; start again without --resume "
            "and a new --out",
            source=str(path),
        )


def _read_plan(path: Path) -> Plan:
    from pydantic import ValidationError

    from inspect_validate.config import explain
    from inspect_validate.files import regular_text

    try:
        doc = json.loads(regular_text(path))
        checked = _plan_model().model_validate(doc, strict=False)  # JSON lists as tuples
    except (OSError, ValueError, RecursionError) as exc:  # ValidationError is a ValueError
        why = explain(exc) if isinstance(exc, ValidationError) else str(exc)
        if isinstance(exc, RecursionError):
            why = "nested too deeply"
        raise InputError(
            f"the characterization plan is not as characterize wrote it ({why}); start again "
            "without --resume and a new --out",
            source=str(path),
        ) from None
    return Plan(**dict(checked))


def region_mask(station: Station, folder: Path) -> np.ndarray:
    """The analysed pixels: ``characterize.region`` or the whole frame (checked against
    the frames' size)."""
    from inspect_validate.images import read_frames

    h, w = read_frames([folder]).shape[1:]
    mask = np.zeros((h, w), bool)
    region = station.characterize.region
    if region is None:
        mask[:] = True
        return mask
    x, y, rw, rh = region
    if x + rw > w or y + rh > h:
        raise InputError(
            f"characterize.region {list(region)} lies outside the {w}×{h} frame",
            source=str(station.path),
        )
    mask[y : y + rh, x : x + rw] = True
    return mask


def read_series(station: Station, out: Path) -> tuple[Plan, Characterization]:
    """The :class:`~.analysis.Characterization` of a captured series in ``out``."""
    from inspect_validate.characterization.analysis import (
        analyse,
        pair_statistics,
        stack_statistics,
    )
    from inspect_validate.images import read_frames

    plan = _read_plan(out / PLAN_FILE)
    steps = [f"{k}_{i:03d}" for i in range(len(plan.exposure_us)) for k in "bd"]
    _audit(out, [*steps, "b_spatial", "d_spatial"])  # a resumed series' frames included
    _check_plan(out, plan, station)
    mask = region_mask(station, out / "b_000")

    def frames(step):
        return read_frames([out / step])[:, mask]

    bright, dark = [], []
    for i in range(len(plan.exposure_us)):
        b, d = frames(f"b_{i:03d}"), frames(f"d_{i:03d}")
        bright.append(pair_statistics(b[0], b[1]))
        dark.append(pair_statistics(d[0], d[1]))
    bs, ds = read_frames([out / "b_spatial"]), read_frames([out / "d_spatial"])
    region = station.characterize.region
    if region is not None:
        x, y, w, h = region
        bs, ds = bs[:, y : y + h, x : x + w], ds[:, y : y + h, x : x + w]
    result = analyse(
        plan.abscissa(),
        bright,
        dark,
        bright_stack=stack_statistics(bs),
        dark_stack=stack_statistics(ds),
        bits=plan.bits,
    )
    if plan.varies == "level":  # one exposure throughout: no dark current to see
        result = replace(result, dark_current=math.nan, dark_current_se=math.nan)
    return plan, result


def expected_rate(station: Station, plan: Plan) -> float | None:
    """Photo-electrons per µs the station's model expects from a white target (R = 1)
    under the series' illumination at its level, through the scene's optics and camera
    QE: what the measured responsivity is held against for an absolute QE. None where
    an illumination's channel has no stated irradiance (its light is then nominal)."""
    from inspect_validate.model import Exposure, ObjectClass, predict
    from inspect_validate.spectra import Spectrum, SpectrumKind
    from inspect_validate.station.model import station_model

    model = station_model(station)
    ill = _illumination(station)
    if any(ch in model.nominal for ch in ill.channels) or plan.varies != "exposure":
        return None
    light = next(lt for lt in model.illumination_lights(station) if lt.name == ill.name)
    grid = model.scene.grid
    flat = [
        ObjectClass(
            name, Spectrum(grid, np.full((1, grid.size), r), SpectrumKind.REFLECTANCE, name, "flat")
        )
        for name, r in (("white", 1.0), ("grey", 0.5))
    ]
    p = predict(
        [light],
        [model.optics],
        [model.scene_sensor],
        flat,
        exposure=Exposure("fixed", time=1e-6),
        grid=grid,
    )
    return float(p.electrons[0, 0, 0, 0]) * plan.level[0]
