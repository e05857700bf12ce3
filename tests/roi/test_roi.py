"""ROI files: shapes, ImageJ sets, erosion, and the errors that name file, class and shape."""

import numpy as np
import pytest

from inspect_validate.errors import InputError
from inspect_validate.roi import Ellipse, Polygon, Rect, class_masks, rasterise, read_rois


def write(tmp_path, text, name="rois.yaml"):
    p = tmp_path / name
    p.write_text(text)
    return p


def test_rect_and_polygon_give_the_same_pixels():
    rect = rasterise(Rect(3, 2, 5, 4), (10, 12), where="t")
    poly = rasterise(Polygon(((3, 2), (8, 2), (8, 6), (3, 6))), (10, 12), where="t")
    assert rect.sum() == 20 and np.array_equal(rect, poly)
    assert rect[2, 3] and rect[5, 7] and not rect[6, 7] and not rect[5, 8]


def test_ellipse_uses_pixel_centres():
    m = rasterise(Ellipse(5, 5, 2, 1), (10, 10), where="t")
    ys, xs = np.nonzero(m)
    assert np.all(((xs + 0.5 - 5) / 2) ** 2 + ((ys + 0.5 - 5) / 1) ** 2 <= 1)
    assert m.sum() == 4 * 2


def test_yaml_with_all_shapes(tmp_path):
    import cv2

    mask = np.zeros((40, 50), np.uint8)
    mask[30:35, 40:45] = 255
    cv2.imwrite(str(tmp_path / "m.png"), mask)
    p = write(
        tmp_path,
        """
erode: 0
classes:
  A:
    - rect: [0, 0, 10, 10]
    - ellipse: [25, 5, 4, 3]
  B:
    erode: 1
    shapes:
      - polygon: [[0, 20], [20, 20], [20, 30], [0, 30]]
  C:
    - mask: m.png
""",
    )
    masks = class_masks(read_rois(p), (40, 50))
    assert list(masks) == ["A", "B", "C"]
    assert masks["B"].sum() == 18 * 8  # 20×10 eroded by one pixel all round
    assert masks["C"].sum() == 25


def test_imagej_roiset(tmp_path):
    import roifile

    rect = roifile.ImagejRoi.frompoints(np.array([[2, 3], [12, 3], [12, 9], [2, 9]], float))
    rect.roitype = roifile.ROI_TYPE.RECT
    rect.name = "A:1"
    poly = roifile.ImagejRoi.frompoints(np.array([[20, 20], [30, 20], [30, 28]], float))
    poly.name = "B"
    path = tmp_path / "RoiSet.zip"
    roifile.roiwrite(path, [rect, poly])
    rois = read_rois(path)
    assert [c.name for c in rois.classes] == ["A", "B"]
    masks = class_masks(rois, (40, 40))
    assert masks["A"].any() and masks["B"].any()
    # Referenced from YAML, under a class its ROIs are not named for: refused, not merged.
    y = write(tmp_path, "classes:\n  X:\n    - imagej: RoiSet.zip\n")
    with pytest.raises(InputError, match=r"ROI 'A:1' is named for class 'A' \(not in this file\)"):
        read_rois(y)
    y = write(
        tmp_path, "classes:\n  A:\n    - imagej: RoiSet.zip\n  B:\n    - rect: [0, 30, 5, 5]\n"
    )
    with pytest.raises(
        InputError, match=r"ROI 'B' is named for class 'B' but listed under class 'A'"
    ):
        read_rois(y)
    # Named for the class it is listed under, or ImageJ's own names: taken.
    poly.name = "0020-0025"
    roifile.roiwrite(path, [rect, poly], mode="w")
    y = write(tmp_path, "classes:\n  A:\n    - imagej: RoiSet.zip\n")
    assert class_masks(read_rois(y), (40, 40))["A"].sum() == masks["A"].sum() + masks["B"].sum()


def test_a_recorded_frame_size_refuses_another(tmp_path):
    y = write(tmp_path, "frame: [320, 240]\nclasses:\n  A:\n    - rect: [10, 10, 20, 20]\n")
    rois = read_rois(y)
    assert rois.frame == (320, 240)
    assert class_masks(rois, (240, 320))["A"].sum() == 400
    with pytest.raises(InputError, match=r"drawn on a 320×240 frame.*this frame is 640×480"):
        class_masks(rois, (480, 640))
    with pytest.raises(InputError, match="frame"):
        read_rois(write(tmp_path, "frame: [0, 240]\nclasses:\n  A:\n    - rect: [1, 1, 2, 2]\n"))


@pytest.mark.parametrize(
    ("text", "frame", "message"),
    [
        (
            "classes:\n  A:\n    - rect: [30, 0, 30, 5]\n",
            (20, 50),
            r"classes\.A\[0\] \(rect\).*outside the 50×20 frame",
        ),
        ("classes:\n  A:\n    - circle: [1, 2, 3]\n", (20, 20), r"classes\.A\[0\].*unknown shape"),
        (
            "classes:\n  A:\n    erode: 3\n    shapes:\n      - rect: [0, 0, 5, 5]\n",
            (20, 20),
            "class 'A' has no pixel left after eroding 3",
        ),
        (
            "classes:\n  A:\n    - rect: [0, 0, 5, 5]\n  B:\n    - rect: [4, 4, 5, 5]\n",
            (20, 20),
            "'A' and 'B' share 1 pixels",
        ),
        ("classes:\n  A:\n    - rect: [0, 0, -5, 5]\n", (20, 20), r"classes\.A\[0\].*rect"),
        ("classes: [unclosed\n", (20, 20), "not valid YAML"),
        ("clases:\n  A: []\n", (20, 20), "classes"),
        ("classes:\n  A:\n    - polygon: [[0, 0], [1, 1]]\n", (20, 20), "at least 3 vertices"),
        ("classes:\n  A:\n    - mask: missing.png\n", (20, 20), "missing.png.*not found"),
    ],
)
def test_errors_name_file_class_and_shape(tmp_path, text, frame, message):
    p = write(tmp_path, text)
    with pytest.raises(InputError, match=message) as info:
        class_masks(read_rois(p), frame)
    assert str(p) in str(info.value) or "missing.png" in str(info.value)


def test_missing_file_and_line_roi(tmp_path):
    import roifile

    with pytest.raises(InputError, match="not found"):
        read_rois(tmp_path / "nope.yaml")
    line = roifile.ImagejRoi.frompoints(np.array([[0, 0], [5, 5]], float))
    line.roitype = roifile.ROI_TYPE.LINE
    line.tofile(tmp_path / "line.roi")
    with pytest.raises(InputError, match="no area"):
        read_rois(tmp_path / "line.roi")


def test_empty_imagej_set_is_refused(tmp_path):
    import zipfile

    from inspect_validate.errors import InputError
    from inspect_validate.roi import read_rois

    path = tmp_path / "RoiSet.zip"
    zipfile.ZipFile(path, "w").close()
    with pytest.raises(InputError, match=r"RoiSet\.zip: the ImageJ file holds no ROI"):
        read_rois(path)


@pytest.mark.parametrize("seed", range(6))
def test_ellipse_rasterised_in_its_box_equals_the_whole_frame_test(seed):
    # The ellipse is tested on its bounding box only; the reference tests every
    # pixel centre of the frame with the same formula. Fractional centres and
    # semi-axes, and ellipses touching the frame's edges.
    rng = np.random.default_rng(seed)
    height, width = 97, 131
    for _ in range(50):
        rx, ry = rng.uniform(0.3, 30, 2)
        cx = rng.uniform(rx, width - rx)
        cy = rng.uniform(ry, height - ry)
        if rng.random() < 0.3:
            cx, cy = rx, height - ry  # at the edges
        ys, xs = np.mgrid[:height, :width]
        want = ((xs + 0.5 - cx) / rx) ** 2 + ((ys + 0.5 - cy) / ry) ** 2 <= 1.0
        if not want.any():
            continue
        got = rasterise(Ellipse(cx, cy, rx, ry), (height, width), where="t")
        np.testing.assert_array_equal(got, want)


def test_shared_pixels_are_counted_only_where_boxes_meet(tmp_path):
    """The overlap check looks only inside the intersection of the classes' boxes: on
    random rectangles it reports exactly the pixels a whole-frame AND counts."""
    import re

    rng = np.random.default_rng(7)
    for trial in range(60):
        rects = [
            [
                int(rng.integers(0, 30)),
                int(rng.integers(0, 20)),
                int(rng.integers(1, 12)),
                int(rng.integers(1, 12)),
            ]
            for _ in range(3)
        ]
        text = "classes:\n" + "".join(
            f"  {k}:\n    - rect: {r}\n" for k, r in zip("ABC", rects, strict=True)
        )
        p = write(tmp_path, text)
        full = [np.zeros((32, 42), bool) for _ in rects]
        for m, (x, y, w, h) in zip(full, rects, strict=True):
            m[y : y + h, x : x + w] = True
        shared = [
            (a, b, int((full[i] & full[j]).sum()))
            for j, b in enumerate("ABC")
            for i, a in enumerate("ABC")
            if i < j
        ]
        first = next(((a, b, n) for a, b, n in shared if n), None)
        if first is None:
            class_masks(read_rois(p), (32, 42))
            continue
        with pytest.raises(InputError) as info:
            class_masks(read_rois(p), (32, 42))
        found = re.search(r"'(\w)' and '(\w)' share (\d+) pixels", str(info.value))
        assert (
            found and int(found[3]) == dict(((a, b), n) for a, b, n in shared)[found[1], found[2]]
        ), trial


@pytest.mark.parametrize(
    "text, message",
    [
        ("classes:\n  A:\n    - ellipse: [.nan, 40, 20, 20]\n", "finite number"),
        ("classes:\n  A:\n    - ellipse: [10, 10, .inf, 20]\n", "finite number"),
        (
            "classes:\n  A:\n    - polygon: [[0, 0], [1e308, 0], [5, 5]]\n",
            "less than or equal to 10000000",
        ),
        (
            "classes:\n  A:\n    - polygon: [" + ", ".join(["[1, 1]"] * 100_001) + "]\n",
            "at most 100000",
        ),
        (
            "classes:\n" + "".join(f"  c{i}:\n    - rect: [0, 0, 1, 1]\n" for i in range(1001)),
            "at most 1000",
        ),
        (
            "a: &a [1, 1, 1, 1, 1, 1, 1, 1, 1, 1]\n"
            + "".join(
                f"{c}: &{c} [{', '.join([f'*{p}'] * 10)}]\n"
                for p, c in zip("abcdefg", "bcdefgh", strict=True)
            )
            + "classes:\n  A:\n    - rect: [0, 0, 1, 1]\n",
            "expands to more than",
        ),
    ],
)
def test_hostile_roi_files_are_refused_quickly(tmp_path, text, message):
    import time

    p = write(tmp_path, text)
    start = time.perf_counter()
    with pytest.raises(InputError, match=message):
        class_masks(read_rois(p), (50, 50))
    assert time.perf_counter() - start < 30  # was minutes (a 10⁶-vertex polygon, an alias bomb)


def test_an_imagej_polygon_without_vertices_is_refused(tmp_path):
    import roifile

    empty = roifile.ImagejRoi(roitype=roifile.ROI_TYPE.POLYGON, name="A:1")
    path = tmp_path / "RoiSet.zip"
    roifile.roiwrite(path, [empty])
    with pytest.raises(InputError, match="a polygon of 0 vertices"):
        read_rois(path)


def _document():
    """ROI file mappings near the common form: rectangles whose numbers are ints, bools,
    floats, strings or out of range; extra, missing and misspelt keys; class names
    empty, long, with commas, or not strings; the per-class form; other shapes."""
    from hypothesis import strategies as st

    number = st.one_of(
        st.integers(-5, 5),
        st.integers(-(2**40), 2**40),
        st.booleans(),
        st.floats(allow_nan=True, allow_infinity=True),
        st.sampled_from([1.0, 3.0, 2.5, "3", None]),
    )
    plain = st.lists(st.integers(-3, 40), min_size=4, max_size=4)  # w, h ≤ 0 at times
    rect = st.one_of(plain, plain, plain, st.lists(number, min_size=3, max_size=5), number)
    shape = st.one_of(
        st.fixed_dictionaries({"rect": rect}),
        st.fixed_dictionaries({"rect": rect}),
        st.fixed_dictionaries({"rect": rect}),
        st.fixed_dictionaries({"rect": rect, "polygon": st.just([[0, 0], [1, 0], [0, 1]])}),
        st.fixed_dictionaries({"ellipse": st.just([5, 5, 2, 3])}),
        st.fixed_dictionaries({"polygon": st.just([[0, 0], [4, 0], [0, 4]])}),
        st.fixed_dictionaries({"rect ": rect}),
    )
    shapes = st.one_of(
        st.lists(shape, min_size=0, max_size=3),
        st.lists(shape, min_size=1, max_size=2),
        st.lists(shape, min_size=1, max_size=2),
        st.fixed_dictionaries({"shapes": st.lists(shape, min_size=1, max_size=2)}),
        st.fixed_dictionaries(
            {"shapes": st.lists(shape, min_size=1, max_size=2), "erode": st.integers(-1, 3)}
        ),
    )
    name = st.one_of(
        st.sampled_from(["A", "B", "C", "dark ink"]),
        st.sampled_from(["A", "B", "C", "dark ink"]),
        st.text(min_size=0, max_size=4),
        st.sampled_from(["A", "B,C", "x" * 100, "x" * 101, " ", "A\n"]),
        st.integers(0, 3),
        st.booleans(),
    )
    return (
        st.fixed_dictionaries(
            {
                "classes": st.one_of(
                    st.dictionaries(name, shapes, min_size=1, max_size=3),
                    st.dictionaries(name, shapes, min_size=0, max_size=3),
                )
            },
            optional={
                "version": st.one_of(st.just(1), number),
                "frame": st.one_of(
                    st.lists(st.integers(0, 99), min_size=2, max_size=2),
                    st.lists(number, min_size=1, max_size=3),
                    number,
                ),
                "erode": st.one_of(st.integers(-1, 3), number),
                "comment": st.just("x"),
            },
        )
        | st.fixed_dictionaries(  # the common form, one thing at a time off its edge
            {
                "classes": st.dictionaries(
                    st.sampled_from(["A", "B", "A,B", "", "x" * 100, "x" * 101, 7]),
                    st.lists(st.fixed_dictionaries({"rect": plain}), min_size=1, max_size=2),
                    min_size=1,
                    max_size=3,
                )
            },
            optional={
                "version": st.sampled_from([1, 2, 0, True, 1.0]),
                "frame": st.lists(
                    st.sampled_from([0, 1, 2, 640, True, 2.0]), min_size=2, max_size=2
                ),
                "erode": st.sampled_from([-1, 0, 1, True, 2.0]),
            },
        )
        | st.fixed_dictionaries(
            {"classes": number},
        )
    )


def test_the_common_form_reads_as_the_file_model_reads_it(tmp_path):
    """``read_rois`` reads rectangles-only files without pydantic (``measure``'s start): on
    every generated mapping that path accepts, the file model accepts the same ROI set;
    where the model refuses, that path has declined (the model's message is the one
    given). And the common form does take that path."""
    from hypothesis import HealthCheck, example, given, settings

    from inspect_validate.roi.roiset import _modelled_rois, _plain_rois

    source = tmp_path / "r.yaml"
    taken = []

    @settings(
        max_examples=600,
        deadline=None,
        derandomize=True,
        database=None,
        suppress_health_check=[HealthCheck.too_slow],
    )
    @given(_document())
    @example({"frame": [0, 48], "classes": {"A": [{"rect": [0, 0, 1, 1]}]}})
    @example({"frame": [64, 48, 1], "classes": {"A": [{"rect": [0, 0, 1, 1]}]}})
    @example({"erode": -1, "classes": {"A": [{"rect": [0, 0, 1, 1]}]}})
    @example({"version": 2, "classes": {"A": [{"rect": [0, 0, 1, 1]}]}})
    @example({"version": 0, "classes": {"A": [{"rect": [0, 0, 1, 1]}]}})
    @example({"classes": {"A": [{"rect": [-4, -4, 1, 1]}, {"rect": [0, 0, 1, 1]}]}})
    @example({"classes": {"A": [{"rect": [0, 0, 1, 1], "ellipse": [1, 1, 1, 1]}]}})
    def holds(doc):
        plain = _plain_rois(doc, str(source))
        try:
            modelled = _modelled_rois(doc, source)
        except InputError:
            assert plain is None, doc
            return
        if plain is not None:
            taken.append(doc)
            assert plain == modelled, doc

    holds()
    assert len(taken) >= 5  # the generator reaches the common form
    doc = {"frame": [64, 48], "erode": 1, "classes": {"A": [{"rect": [0, 0, 8, 8]}]}}
    assert _plain_rois(doc, str(source)) == _modelled_rois(doc, source)
    assert _plain_rois(doc, str(source)) is not None


def test_measure_starts_without_pydantic_on_a_file_of_rectangles(tmp_path):
    """What the fast path is for: a whole ``measure`` of a rectangles-only ROI file never
    imports pydantic (a file of another form does, as it must)."""
    import subprocess
    import sys

    import tifffile

    tifffile.imwrite(tmp_path / "f.tif", np.arange(64 * 48, dtype=np.uint16).reshape(48, 64))
    (tmp_path / "r.yaml").write_text(
        "classes:\n  A: [{rect: [0, 0, 32, 48]}]\n  B: [{rect: [32, 0, 32, 48]}]\n"
    )
    (tmp_path / "e.yaml").write_text(
        "classes:\n  A: [{rect: [0, 0, 32, 48]}]\n  B: [{ellipse: [48, 24, 10, 10]}]\n"
    )
    probe = (
        "import sys, runpy\n"
        "sys.argv = ['inspect_validate', 'measure', sys.argv[1], '--rois', sys.argv[2]]\n"
        "try:\n"
        "    runpy.run_module('inspect_validate', run_name='__main__', alter_sys=True)\n"
        "except SystemExit:\n"
        "    pass\n"
        "print('pydantic' in sys.modules, file=sys.stderr)\n"
    )
    for rois, loaded in (("r.yaml", "False"), ("e.yaml", "True")):
        proc = subprocess.run(
            [sys.executable, "-c", probe, str(tmp_path / "f.tif"), str(tmp_path / rois)],
            capture_output=True,
            text=True,
        )
        assert proc.stderr.strip().splitlines()[-1] == loaded, proc.stderr
