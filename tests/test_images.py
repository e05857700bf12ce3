"""Frame input from real files: 8/16-bit PNG and TIFF, stacks, and refused inputs."""

import numpy as np
import pytest

from inspect_validate.errors import InputError
from inspect_validate.images import read_frames, read_image


def test_16bit_png_and_tiff_round_trip(tmp_path):
    import cv2
    import tifffile

    frame = np.arange(12 * 10, dtype=np.uint16).reshape(12, 10) * 500
    cv2.imwrite(str(tmp_path / "f.png"), frame)
    tifffile.imwrite(tmp_path / "f.tif", frame)
    tifffile.imwrite(tmp_path / "s.tif", np.stack([frame, frame + 1]), photometric="minisblack")
    assert np.array_equal(read_image(tmp_path / "f.png"), frame)
    assert read_image(tmp_path / "f.png").dtype == np.uint16
    assert np.array_equal(read_image(tmp_path / "f.tif"), frame)
    stack = read_frames([tmp_path / "f.png", tmp_path / "s.tif"])
    assert stack.shape == (3, 12, 10)


def test_grey_saved_as_rgb_is_accepted_colour_is_not(tmp_path):
    import cv2

    grey = np.full((5, 6), 77, np.uint8)
    cv2.imwrite(str(tmp_path / "g.png"), np.dstack([grey] * 3))
    assert np.array_equal(read_image(tmp_path / "g.png"), grey)
    colour = np.dstack([grey, grey, grey + 1])
    cv2.imwrite(str(tmp_path / "c.png"), colour)
    with pytest.raises(InputError, match=r"c\.png: colour image"):
        read_image(tmp_path / "c.png")


def test_refused_inputs(tmp_path):
    (tmp_path / "bad.png").write_bytes(b"not a png")
    with pytest.raises(InputError, match=r"bad\.png: cannot read image"):
        read_image(tmp_path / "bad.png")
    with pytest.raises(InputError, match="not found"):
        read_image(tmp_path / "none.tif")
    (tmp_path / "x.gif").write_bytes(b"GIF89a")
    with pytest.raises(InputError, match="unknown image type"):
        read_image(tmp_path / "x.gif")


def test_mismatched_stack(tmp_path):
    import tifffile

    tifffile.imwrite(tmp_path / "a.tif", np.zeros((4, 4), np.uint16))
    tifffile.imwrite(tmp_path / "b.tif", np.zeros((4, 5), np.uint16))
    with pytest.raises(InputError, match=r"b.tif: frame is 5×4 uint16, but .*a.tif is 4×4"):
        read_frames([tmp_path / "a.tif", tmp_path / "b.tif"])
