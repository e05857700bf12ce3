"""Aravis' GigE Vision fake camera, run as a process of its own, optionally showing the
station's scene.

``python -m inspect_validate.simulation.fake_gige SERIAL`` answers GVCP and
streams GVSP on the loopback interface like a real camera (discovered as
``Aravis-Fake-SERIAL``), with Aravis' own test pattern: a diagonal ramp.

With ``--station FILE --state FILE`` every frame it streams is instead the station's
scene rendered with the EMVA 1288 model (:class:`~inspect_validate.simulation.camera.SimulatedGrabber`,
world deviations included) under the lights the simulated controller has on *when the
frame is filled*, at the exposure in the camera's ``ExposureTimeAbs`` register. This is
what ``camera: {backend: aravis, simulate: true}`` starts: capture, verify and watch
then run on a real GVCP/GVSP implementation, its trigger and its UDP packets, and see
the scene they predict.

The fake camera is driven through ``libaravis-0.8`` with :mod:`ctypes`, because its
fill-pattern callback is called from Aravis' streaming thread, which PyGObject's
callback marshalling does not support. The camera has no dB gain (``GainRaw`` only):
the scene is rendered at 0 dB.
"""

from __future__ import annotations

import argparse
import ctypes
import signal
import sys
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from inspect_validate.simulation.camera import SimulatedGrabber

__all__ = ["SENSOR", "main", "scene_fill"]

# arvfakecamera.h (0.8): register addresses and PFNC pixel-format codes
_REGISTER_WIDTH, _REGISTER_HEIGHT = 0x100, 0x104
_MONO8, _MONO16 = 0x01080001, 0x01100007
SENSOR = 2048  # the fake camera's sensor is 2048 × 2048 pixels
_FILL = ctypes.CFUNCTYPE(
    None, ctypes.c_void_p, ctypes.c_void_p, ctypes.c_uint32, ctypes.c_uint32, ctypes.c_uint32
)


def _library():
    try:
        lib = ctypes.CDLL("libaravis-0.8.so.0")
    except OSError as exc:
        raise SystemExit(
            f"Aravis is not installed ({exc}): install Debian's libaravis-0.8-0"
        ) from None
    lib.arv_gv_fake_camera_new.restype = ctypes.c_void_p
    lib.arv_gv_fake_camera_new.argtypes = (ctypes.c_char_p, ctypes.c_char_p)
    lib.arv_gv_fake_camera_is_running.argtypes = (ctypes.c_void_p,)
    lib.arv_gv_fake_camera_get_fake_camera.restype = ctypes.c_void_p
    lib.arv_gv_fake_camera_get_fake_camera.argtypes = (ctypes.c_void_p,)
    lib.arv_fake_camera_set_fill_pattern.argtypes = (ctypes.c_void_p, _FILL, ctypes.c_void_p)
    lib.arv_fake_camera_set_trigger_frequency.argtypes = (ctypes.c_void_p, ctypes.c_double)
    lib.arv_fake_camera_write_register.argtypes = (
        ctypes.c_void_p,
        ctypes.c_uint32,
        ctypes.c_uint32,
    )
    lib.arv_buffer_get_data.restype = ctypes.c_void_p
    lib.arv_buffer_get_data.argtypes = (ctypes.c_void_p, ctypes.POINTER(ctypes.c_size_t))
    for name in ("arv_buffer_get_image_width", "arv_buffer_get_image_height"):
        getattr(lib, name).argtypes = (ctypes.c_void_p,)
    return lib


def _drop_packets(gv: int, share: float) -> None:
    """Make the fake camera drop each GVSP packet with probability ``share`` (its
    ``gvsp-lost-ratio`` property): lost packets a real link would lose, which the receiving
    stream counts, asks to be resent, and reports its frames incomplete for."""
    try:
        gobject = ctypes.CDLL("libgobject-2.0.so.0")
    except OSError as exc:
        raise SystemExit(f"GObject is not installed ({exc})") from None
    gobject.g_object_set(
        ctypes.c_void_p(gv), b"gvsp-lost-ratio", ctypes.c_double(min(max(share, 0.0), 1.0)), None
    )


def scene_fill(lib: ctypes.CDLL, renderer: SimulatedGrabber) -> Callable[..., None]:
    """A fill-pattern callback that writes ``renderer``'s frame of the scene under the
    controller's current lights into each buffer (Mono8: clipped to 255; Mono16: the
    DN as rendered), cropped or zero-padded to the buffer's width and height."""

    def fill(buffer, _data, exposure_us, _gain_raw, pixel_format) -> None:
        try:
            w = lib.arv_buffer_get_image_width(buffer)
            h = lib.arv_buffer_get_image_height(buffer)
            if exposure_us and exposure_us != renderer.exposure_us:
                renderer.configure(exposure_us=float(exposure_us))
            image = renderer.render(renderer.light_state())
            dtype = np.uint8 if pixel_format == _MONO8 else np.uint16
            out = np.zeros((h, w), dtype)
            rh, rw = min(h, image.shape[0]), min(w, image.shape[1])
            out[:rh, :rw] = np.minimum(image[:rh, :rw], np.iinfo(dtype).max)
            dest = lib.arv_buffer_get_data(buffer, ctypes.byref(ctypes.c_size_t()))
            ctypes.memmove(dest, out.ctypes.data, out.nbytes)
        except Exception as exc:  # an exception cannot cross into Aravis' thread
            print(f"fake camera: frame not rendered ({exc})", file=sys.stderr, flush=True)

    return _FILL(fill)


def main(argv: Sequence[str] | None = None) -> None:
    """Run Aravis' GigE Vision fake camera until killed; prints ``ready`` once it listens."""
    parser = argparse.ArgumentParser(description=(main.__doc__ or "").splitlines()[0])
    parser.add_argument("serial")
    parser.add_argument("--interface", default="lo")
    parser.add_argument("--station", type=Path, help="show this station's scene")
    parser.add_argument("--state", type=Path, help="the simulated controller's state file")
    parser.add_argument("--target", choices=("scene", "flat", "edge"), default="scene")
    parser.add_argument("--world", help="the simulated world (JSON), instead of the file's")
    parser.add_argument(
        "--packet-loss",
        type=float,
        default=None,
        help="the share of GVSP packets dropped (default: the world's packet_loss, else 0)",
    )
    parser.add_argument("--parent", type=int, metavar="PID", help="the starting process's id")
    args = parser.parse_args(argv)
    from inspect_validate.simulation.controller import end_with_parent

    end_with_parent(parent=args.parent)
    lib = _library()
    gv = lib.arv_gv_fake_camera_new(args.interface.encode(), args.serial.encode())
    if not gv or not lib.arv_gv_fake_camera_is_running(gv):
        raise SystemExit(f"the fake camera could not start on {args.interface}")
    fake = lib.arv_gv_fake_camera_get_fake_camera(gv)
    keep = None
    loss = args.packet_loss or 0.0
    if args.station is not None:
        from inspect_validate.simulation.camera import scene_grabber
        from inspect_validate.station.file import read_station
        from inspect_validate.station.world import World

        station = read_station(args.station)
        if args.world:
            world = World.model_validate_json(args.world)
            camera = station.camera.model_copy(update={"world": world})
            station = station.model_copy(update={"camera": camera})
        renderer = scene_grabber(station, args.state, args.target)
        if args.packet_loss is None:
            loss = renderer.world.packet_loss
            # the fake camera drops the packets; the renderer must not lose frames too
            renderer.world = renderer.world.model_copy(update={"packet_loss": 0.0})
        lib.arv_fake_camera_write_register(fake, _REGISTER_WIDTH, renderer.width)
        lib.arv_fake_camera_write_register(fake, _REGISTER_HEIGHT, renderer.height)
        keep = scene_fill(lib, renderer)  # referenced for the process's life
        lib.arv_fake_camera_set_fill_pattern(fake, keep, None)
    if loss:
        _drop_packets(gv, loss)
    # A software trigger is noticed at the trigger frequency's period (25 Hz by default).
    lib.arv_fake_camera_set_trigger_frequency(fake, 500.0)
    print("ready", flush=True)
    try:
        while True:
            signal.pause()  # SIGTERM (or the parent's death) ends the process
    except KeyboardInterrupt:
        pass
    del keep


if __name__ == "__main__":
    main()
