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


def test_tiff_stack_written_page_by_page_is_every_page(tmp_path):
    import tifffile

    path = tmp_path / "stack.tif"
    for i in range(3):  # three separate writes: three series to tifffile
        tifffile.imwrite(path, np.full((4, 5), i, np.uint16), append=True, photometric="minisblack")
    stack = read_frames([path])
    assert stack.shape == (3, 4, 5) and stack[:, 0, 0].tolist() == [0, 1, 2]


def test_tiff_pages_of_mixed_size_or_type_are_refused(tmp_path):
    import tifffile

    path = tmp_path / "mixed.tif"
    tifffile.imwrite(path, np.zeros((4, 5), np.uint16), photometric="minisblack")
    tifffile.imwrite(path, np.zeros((4, 5), np.uint8), append=True, photometric="minisblack")
    with pytest.raises(
        InputError, match=r"mixed\.tif: page 2 is \(4, 5\) uint8, page 1 is \(4, 5\) uint16"
    ):
        read_frames([path])


def test_lzw_tiff_as_opencv_writes_it(tmp_path):
    import cv2

    path = tmp_path / "lzw.tif"
    frame = np.arange(64 * 48, dtype=np.uint16).reshape(48, 64)
    assert cv2.imwrite(str(path), frame)  # OpenCV's default TIFF compression is LZW
    assert np.array_equal(read_frames([path])[0], frame)


def test_uint64_beyond_signed_range_is_refused_not_wrapped(tmp_path):
    path = tmp_path / "big.npy"
    np.save(path, np.full((4, 4), 2**63 + 5, np.uint64))
    with pytest.raises(InputError, match=r"big\.npy: grey values up to 9223372036854775813 DN"):
        read_frames([path])
    ok = tmp_path / "ok.npy"
    np.save(ok, np.full((4, 4), 7, np.uint64))
    assert read_frames([ok]).dtype == np.int64


def test_nan_pixel_is_named_with_its_file_and_position(tmp_path):
    path = tmp_path / "f.npy"
    frame = np.ones((4, 6), np.float32)
    frame[2, 5] = np.nan
    np.save(path, frame)
    with pytest.raises(InputError, match=r"f\.npy: pixel \(5, 2\) \(x, y\[, frame\]\) is NaN"):
        read_frames([path])


def test_integer_frame_spanning_2_to_the_40_does_not_allocate_by_span():
    from inspect_validate.measurement import measure_classes
    from inspect_validate.stats import as_sample

    frame = np.zeros((1, 40, 40), np.int64)
    frame[0, 20:] = 2**40
    frame[0, ::2] += 3
    sample = as_sample(frame)
    assert isinstance(sample, np.ndarray) and sample.size == 1600  # values, not a 2⁴⁰ histogram
    mask = np.ones((40, 40), bool)
    (cls,) = measure_classes(frame, {"all": mask})
    assert cls.mean == pytest.approx(2**39 + 1.5)


def test_frames_of_several_files_are_read_into_one_stack_without_a_second_copy(tmp_path):
    """Files of 1, 3 and 2 frames (the second outgrows the first's estimate), then a
    single file: the same stack as concatenating them, and a peak (numpy's buffers, as
    tracemalloc sees them) of the stack plus about one file, not twice the stack."""
    import tracemalloc

    import tifffile

    rng = np.random.default_rng(0)
    parts = [rng.integers(0, 4096, (k, 300, 400), dtype=np.uint16) for k in (1, 3, 2)]
    for i, part in enumerate(parts):
        tifffile.imwrite(
            tmp_path / f"f{i}.tif", part if len(part) > 1 else part[0], photometric="minisblack"
        )
    expected = np.concatenate(parts)
    got = read_frames(sorted(tmp_path.glob("f*.tif")))
    assert got.dtype == np.uint16 and np.array_equal(got, expected)

    big = rng.integers(0, 4096, (8, 500, 500), dtype=np.uint16)
    for i, frame in enumerate(big):
        tifffile.imwrite(tmp_path / f"g{i}.tif", frame)
    tifffile.imwrite(tmp_path / "stack.tif", big)
    for frames in (sorted(tmp_path.glob("g*.tif")), [tmp_path / "stack.tif"]):
        tracemalloc.start()
        got = read_frames(frames)
        peak = tracemalloc.get_traced_memory()[1]
        tracemalloc.stop()
        assert np.array_equal(got, big)
        assert peak < 1.3 * big.nbytes  # the stack, one frame in flight, the reader's buffers


@pytest.mark.parametrize("identical_columns", [False, True])
def test_a_stack_of_narrow_frames_is_a_stack_not_colour(tmp_path, identical_columns):
    """Frames 3 or 4 pixels wide: a stack's trailing axis looks like RGB(A), but the
    TIFF says one sample per pixel. Identical columns once made it read as one frame."""
    import tifffile

    rng = np.random.default_rng(5)
    for width in (3, 4):
        stack = rng.integers(100, 200, (5, 10, width)).astype(np.uint16)
        if identical_columns:
            stack[:] = stack[..., :1]
        path = tmp_path / f"narrow{width}.tif"
        tifffile.imwrite(path, stack, photometric="minisblack")
        assert np.array_equal(read_image(path), stack)
    rgb = tmp_path / "rgb.tif"
    tifffile.imwrite(rgb, rng.integers(0, 255, (10, 4, 3)).astype(np.uint8), photometric="rgb")
    with pytest.raises(InputError, match="colour image"):
        read_image(rgb)


@pytest.mark.filterwarnings("ignore:.*stored as RGB with separate component planes")
def test_a_stack_written_as_one_array_of_three_is_a_stack(tmp_path):
    """tifffile.imwrite of a (3, H, W) array tags it planar RGB; the shape it records
    says it was three frames (it was refused as colour). A planar colour image from
    elsewhere is colour, its planes compared as planes (grey when they are equal)."""
    import tifffile

    rng = np.random.default_rng(3)
    stack = rng.integers(0, 255, (3, 12, 16)).astype(np.uint8)
    tifffile.imwrite(tmp_path / "s.tif", stack)
    assert np.array_equal(read_image(tmp_path / "s.tif"), stack)
    grey = np.broadcast_to(stack[0], (3, 12, 16))
    for planes, grey_ok in ((grey, True), (stack, False)):
        path = tmp_path / f"planar{grey_ok}.tif"
        tifffile.imwrite(path, planes, photometric="rgb", planarconfig="separate", metadata=None)
        if grey_ok:
            assert np.array_equal(read_image(path), stack[0])
        else:
            with pytest.raises(InputError, match="colour image"):
                read_image(path)


def test_nan_outside_every_region_is_measured_inside_is_named(tmp_path):
    """Only the regions' pixels must be numbers: a NaN border (a masked frame) is
    measured, a NaN inside a region is refused naming the file, class and pixel."""
    from inspect_validate.measurement import measure_files

    rng = np.random.default_rng(1)
    frame = rng.normal(500, 10, (40, 60)).astype(np.float32)
    frame[0, :] = np.nan
    frame[:, -1] = np.inf
    np.save(tmp_path / "f.npy", frame)
    (tmp_path / "r.yaml").write_text(
        "classes:\n  A: [{rect: [2, 2, 20, 30]}]\n  B: [{rect: [30, 2, 20, 30]}]\n"
    )
    result = measure_files(tmp_path / "f.npy", tmp_path / "r.yaml")
    assert np.isfinite([c.mean for c in result.classes]).all()
    frame[10, 35] = np.nan
    np.save(tmp_path / "f.npy", frame)
    with pytest.raises(InputError, match=r"f\.npy: class B: pixel \(35, 10\) of frame 1"):
        measure_files(tmp_path / "f.npy", tmp_path / "r.yaml")
    frame = frame.astype(np.float64)
    frame[10, 35] = 1e300  # beside the inf border: still a value no camera gives
    np.save(tmp_path / "f.npy", frame)
    with pytest.raises(InputError, match=r"f\.npy: grey values up to 1e\+300"):
        measure_files(tmp_path / "f.npy", tmp_path / "r.yaml")


def test_an_empty_array_is_called_empty(tmp_path):
    """An empty NPY of uint8 read 'not a grey-value image (dtype uint8)'."""
    import numpy as np
    import pytest

    from inspect_validate.errors import InputError
    from inspect_validate.images import read_image

    np.save(tmp_path / "e.npy", np.zeros((0, 32), np.uint8))
    with pytest.raises(InputError, match=r"an empty image \(shape \(0, 32\)\)"):
        read_image(tmp_path / "e.npy")


def test_integers_beyond_2_53_are_no_camera_s(tmp_path):
    """int64 frames of 1.2e17 were taken by rois propose and measure (only floats were
    held to 2⁵³)."""
    import numpy as np
    import pytest

    from inspect_validate.errors import InputError
    from inspect_validate.images import read_image

    np.save(tmp_path / "big.npy", np.full((4, 4), 120_000_000_000_000_000, np.int64))
    with pytest.raises(InputError, match="beyond ±2⁵³"):
        read_image(tmp_path / "big.npy")
    np.save(tmp_path / "ok.npy", np.full((4, 4), 2**40, np.int64))
    assert read_image(tmp_path / "ok.npy").max() == 2**40
