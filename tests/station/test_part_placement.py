"""A station on its running line, on frames no one here drew: scikit-image's photograph of
a cameraman as the part (the reference frame), moved and rotated as on a belt. The part is
placed, its regions follow it and measure what they measured on the reference; a frame
without the part, a part cut by the frame's edge and a bad production block are each
said, naming the file and key."""

import re

import cv2
import numpy as np
import pytest
from conftest import PART_FRAME as SIZE
from conftest import moved_part as moved
from conftest import part_reference as reference
from conftest import production_station

from inspect_validate.comparisons import Comparisons
from inspect_validate.errors import InputError
from inspect_validate.station.production import (
    BLANK_RUN,
    blank_runs,
    focus_measure,
    measure_part,
    part_locator,
)


@pytest.mark.parametrize(("dx", "dy", "degrees"), [(0, 0, 0), (31.3, -22.7, 4.0), (-50, 40, -3)])
def test_the_regions_follow_the_part_and_measure_what_they_measured(tmp_path, dx, dy, degrees):
    station = production_station(tmp_path)
    locator = part_locator(station)
    placed = locator.place(moved(dx, dy, degrees))
    assert placed.reason is None and placed.pose.score > 0.99
    assert placed.pose.angle_deg == pytest.approx(degrees, abs=0.02)
    comparisons = Comparisons.of(list(locator.masks))
    part = measure_part(moved(dx, dy, degrees), placed, comparisons)
    still = moved(0, 0, 0, seed=9)  # the part where it was drawn, another noise draw
    golden = measure_part(still, locator.place(still), comparisons)
    for got, want in zip(part.classes, golden.classes, strict=True):
        # The same object's pixels: μ within 2 DN, σ² within 15 % (the region's edge
        # pixels are a rotated sampling of the same texture).
        assert got.mean == pytest.approx(want.mean, abs=2.0), got.name
        assert got.variance == pytest.approx(want.variance, rel=0.15), got.name


def test_a_regions_mean_does_not_jump_with_the_shifts_fraction(tmp_path):
    """The part moved by 10 + f px right and 7 + f/2 px up, f in tenths of a pixel, one
    noise draw: the face's μ, its pixels counted by their share of the moved region,
    stays within 0.1 DN (0.022 seen); counted by whole pixels (the placement's masks) it
    jumps by about 2 DN as the rounding of the shift flips at f = ½."""
    locator = part_locator(production_station(tmp_path))
    comparisons = Comparisons.of(list(locator.masks))
    shared, whole = [], []
    for f in np.arange(0.0, 1.0, 0.1):
        frame = moved(10 + f, -7 - f / 2, 0, seed=3)
        placed = locator.place(frame)
        part = measure_part(frame, placed, comparisons)
        shared.append(next(c.mean for c in part.classes if c.name == "face"))
        whole.append(frame[placed.masks["face"]].mean())
    assert np.ptp(shared) < 0.1
    assert np.ptp(whole) > 1.0


def test_a_region_thinner_than_a_pixel_is_measured_by_its_shares():
    """A line one pixel high moved by half a pixel down covers half of two rows and no
    pixel wholly: measured with every pixel by its share, as the weighted moments of
    those pixels."""
    from inspect_validate.roi.pose import Pose, moved_masks
    from inspect_validate.station.production import Placement
    from inspect_validate.stats import weighted_moments

    frame = moved(0, 0, 0, seed=4)
    line = np.zeros(SIZE, bool)
    line[300, 200:500] = True
    regions = moved_masks({"line": line}, Pose(np.array([[1.0, 0, 0], [0, 1, 0.5]]), 1.0))
    assert regions.weights["line"].max() == pytest.approx(0.5)
    part = measure_part(frame, Placement(Pose(np.eye(2, 3), 1.0), regions, {}),
                        Comparisons.of(["line"]))  # fmt: skip
    want = weighted_moments(frame, regions.weights["line"])
    assert part.classes[0].mean == pytest.approx(want.mean, rel=1e-12)
    assert part.classes[0].variance == pytest.approx(want.variance, rel=1e-12)
    assert part.classes[0].n_pixels == 300


def test_a_frame_without_the_part_and_a_cut_part_are_not_measured(tmp_path):
    locator = part_locator(production_station(tmp_path, min_pixels=4500))
    belt = np.clip(30 + np.random.default_rng(3).normal(0, 2, SIZE), 0, 255).astype(np.uint8)
    empty = locator.place(belt)
    assert empty.masks is None and "no part found: match score" in empty.reason
    # Moved 110 px up: the sky region (rows 90–150, 6000 px) loses 20 rows to the top edge
    # and keeps 4000 px; the face (4800 px) stays whole.
    cut = locator.place(moved(0, -110, 0))
    assert cut.masks is None and "class 'sky' keeps 4000 px" in cut.reason
    assert cut.outside == {"face": 0, "coat": 0, "sky": 20 * 100}


@pytest.mark.parametrize(
    ("rows", "cols", "fill", "share"),
    [
        (slice(150, 160), slice(None), 0, 0.125),  # a lost packet: 10 rows across the face
        (slice(None), slice(425, None), 0, 0.25),  # the right half: 15 of the face's 60 columns
        (slice(120, 124), slice(None), 255, 0.05),  # cut short with white: 4 of 80 rows
    ],
)
def test_a_blank_block_on_the_part_is_not_measured(tmp_path, rows, cols, fill, share):
    """Issue 62: a frame with a blank block on a class (one value over rows or columns, as a
    frame cut short or a lost packet leaves) is counted as unusable with the class, its
    share and the value, never measured; the same frame whole is measured."""
    locator = part_locator(production_station(tmp_path))
    frame = moved(0, 0, 0)
    assert locator.place(frame).reason is None
    frame[rows, cols] = fill
    placed = locator.place(frame)
    assert placed.masks is None, "the blank block was measured"
    # The share within 3 points: the blank block moves the part's located pose by ~2 px.
    got = re.match(r"a blank block: (\d+)% of class 'face' ", placed.reason)
    assert got and abs(int(got[1]) - 100 * share) <= 3, placed.reason
    assert f"at one value ({fill} DN), the reference's 0%" in placed.reason


def test_a_class_flat_to_the_dn_on_the_reference_is_measured_with_its_own_runs(tmp_path):
    """A quiet camera on a flat class (σ 0.3 DN about a whole DN): a third of the class lies
    in runs of one value on the reference and on every part, and no part is refused."""
    station = production_station(tmp_path)
    rng = np.random.default_rng(5)
    flat = np.s_[90:150, 170:270]  # the sky region

    def quiet(frame):
        frame[flat] = np.round(200 + rng.normal(0, 0.3, (60, 100)))
        return frame

    cv2.imwrite(str(tmp_path / "reference.png"), quiet(reference()))
    locator = part_locator(station)
    assert 0.15 < locator.blank_shares["sky"] < 0.45 and locator.blank_shares["face"] == 0
    for seed in range(20):
        placed = locator.place(quiet(moved(0, 0, 0, seed=seed)))
        assert placed.reason is None, placed.reason


def test_blank_runs_are_the_runs_of_their_length_or_more():
    """:func:`blank_runs` against a reading of every row and column in plain Python, on
    arrays of few values (long runs common); noise of 0.7 DN leaves none in 10⁶ pixels."""
    rng = np.random.default_rng(11)
    for _ in range(200):
        h, w = rng.integers(1, 40, 2)
        image = rng.choice(np.arange(rng.integers(1, 3)), size=(h, w), p=None).astype(np.uint8)
        length = int(rng.integers(2, 9))
        want = np.zeros((h, w), bool)
        for axis in (0, 1):
            view, mark = (image, want) if axis == 1 else (image.T, want.T)
            for line, out in zip(view, mark, strict=True):
                start = 0
                for j in range(1, len(line) + 1):
                    if j == len(line) or line[j] != line[start]:
                        if j - start >= length:
                            out[start:j] = True
                        start = j
        assert np.array_equal(blank_runs(image, length=length), want), (image, length)
    quiet = np.round(100 + np.random.default_rng(2).normal(0, 0.7, (1000, 1000))).astype(np.uint8)
    assert BLANK_RUN == 32 and not blank_runs(quiet).any()


def test_the_focus_measure_falls_as_the_lens_blurs(tmp_path):
    locator = part_locator(production_station(tmp_path))
    sharp, soft = moved(5, 5, 1), moved(5, 5, 1, blur=1.5)
    placed = locator.place(sharp)
    face = placed.masks["face"]
    assert focus_measure(soft, locator.place(soft).masks["face"]) < 0.5 * focus_measure(sharp, face)


def test_the_focus_measure_is_the_laplacians_variance_in_the_region():
    """Each moved region's focus measure, worked out in its box, is the variance of the
    whole frame's Laplacian over the region's pixels (to float32's 1e-5), for a region
    inside the frame and one cut by its top edge."""
    from inspect_validate.roi.pose import Pose, moved_masks
    from inspect_validate.station.production import part_focus

    frame = moved(3, -2, 2)
    masks = {"in": np.zeros(SIZE, bool), "cut": np.zeros(SIZE, bool)}
    masks["in"][200:300, 300:420] = True
    masks["cut"][0:40, 100:200] = True
    regions = moved_masks(masks, Pose(np.array([[1.0, 0, 0.3], [0, 1, -6.6]]), 1.0))
    lap = cv2.Laplacian(frame.astype(np.float32), cv2.CV_32F).astype(float)
    for name, got in part_focus(frame, regions).items():
        assert got == pytest.approx(lap[regions.masks[name]].var(), rel=1e-5), name


def test_bad_production_blocks_name_the_key(tmp_path):
    with pytest.raises(InputError, match=r"production\.illumination: no illumination 'uv'"):
        production_station(tmp_path, illumination="uv")
    with pytest.raises(InputError, match=r"production\.motion"):
        production_station(tmp_path, motion="rigid")
    station = production_station(tmp_path, template=[700, 0, 200, 200])
    with pytest.raises(InputError, match=r"production.template \[700, 0, 200, 200\] reaches"):
        part_locator(station)
    colour = np.dstack([reference()] * 3)
    colour[..., 0] //= 2
    cv2.imwrite(str(tmp_path / "colour.png"), colour)
    station = production_station(tmp_path, reference="colour.png")
    with pytest.raises(InputError, match="colour"):
        part_locator(station)
    cv2.imwrite(str(tmp_path / "belt.png"), np.full(SIZE, 30, np.uint8))
    with pytest.raises(InputError, match=r"is flat \(a frame without a part") as caught:
        part_locator(production_station(tmp_path, reference="belt.png"))
    assert caught.value.source.endswith("belt.png")
    locator = part_locator(production_station(tmp_path))
    with pytest.raises(InputError, match="reference's size"):
        locator.place(reference()[:-8])
