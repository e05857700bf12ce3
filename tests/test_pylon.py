"""Basler backend against pypylon's camera emulator (PYLON_CAMEMU), in a subprocess.

pylon reads PYLON_CAMEMU when its transport layers start, so each check runs
in a fresh interpreter with the variable set.
"""

import os
import subprocess
import sys
import textwrap

import pytest

pytest.importorskip("pypylon")


def run_with_emulator(code: str, tmp_path):
    env = {**os.environ, "PYLON_CAMEMU": "1"}
    script = tmp_path / "check.py"
    script.write_text(textwrap.dedent(code))
    done = subprocess.run(
        [sys.executable, str(script)], env=env, capture_output=True, text=True, timeout=120
    )
    assert done.returncode == 0, done.stdout + done.stderr
    return done.stdout


def test_emulator_serves_files_pixel_exactly(tmp_path):
    out = run_with_emulator(
        f"""
        import numpy as np, cv2
        from camera.grabbers.pylon import PylonCamera
        img = (np.arange(48 * 64).reshape(48, 64) * 7 % 256).astype(np.uint8)
        cv2.imwrite("{tmp_path}/a.png", img)
        with PylonCamera(index=0) as cam:
            cam.configure(pixel_format="Mono8", region=(0, 0, 64, 48), exposure_us=5000, gain_db=0)
            cam.nodes.TestImageSelector.Value = "Off"
            cam.nodes.ImageFileMode.Value = "On"
            cam.nodes.ImageFilename.Value = "{tmp_path}/a.png"
            frames = cam.grab(3)
            assert all(np.array_equal(f.data, img) for f in frames), "not pixel-exact"
            assert frames[0].exposure_us == 5000 and frames[0].pixel_format == "Mono8"
            assert len({{f.frame_id for f in frames}}) == 3
            print("ok", cam.name)
        """,
        tmp_path,
    )
    assert out.startswith("ok Basler Emulation")


def test_emulator_errors(tmp_path):
    out = run_with_emulator(
        """
        from camera.grabbers.pylon import PylonCamera
        from inspect_validate.errors import DeviceError
        try:
            PylonCamera(serial="nope")
        except DeviceError as e:
            print("serial:", e)
        with PylonCamera() as cam:
            try:
                cam.configure(pixel_format="RGB8Packed")
            except DeviceError as e:
                print("format:", e)
            cam.nodes.TriggerMode.Value = "On"  # no trigger will come
            try:
                cam.grab(1, timeout_s=0.2)
            except DeviceError as e:
                print("timeout:", e)
        """,
        tmp_path,
    )
    assert "serial: no pylon camera with serial nope; found: 0815-0000" in out
    assert "format: " in out and "RGB8Packed not offered as monochrome" in out
    assert "timeout: " in out and "no frame within 0.2 s" in out
