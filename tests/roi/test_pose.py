"""Locating a part and moving the regions with it, on frames no one here drew: scikit-image's
photograph of a cameraman (512 × 512, 8-bit) placed in a larger frame, moved and rotated as
parts on a line are, with sensor noise. The pose is recovered to a fraction of a pixel and
of a degree; the moved regions are the reference's regions under the true pose."""

import math

import cv2
import numpy as np
import pytest
from conftest import rendered_part
from skimage import data

from inspect_validate.errors import InputError
from inspect_validate.roi.pose import Pose, locate_part, moved_masks

SIZE = (640, 800)  # frame rows, columns


def reference() -> np.ndarray:
    """The photograph in the middle of a darker frame (the part on a belt)."""
    frame = np.full(SIZE, 30, np.uint8)
    frame[64:576, 144:656] = data.camera()
    return frame


def true_pose(dx, dy, degrees, scale=1.0) -> np.ndarray:
    """A pose (pixel corners) rotating about the frame's centre, then shifting."""
    cx, cy = SIZE[1] / 2, SIZE[0] / 2
    t = math.radians(degrees)
    a = scale * np.array([[math.cos(t), -math.sin(t)], [math.sin(t), math.cos(t)]])
    b = np.array([cx + dx, cy + dy]) - a @ np.array([cx, cy])
    return np.column_stack([a, b])


def moved_frame(matrix, *, seed=0, noise=2.0) -> np.ndarray:
    """The reference under ``matrix`` (what the camera sees of a moved part), with noise."""
    a, b = matrix[:, :2], matrix[:, 2]
    centres = np.column_stack([a, b + a @ np.array([0.5, 0.5]) - 0.5])
    moved = cv2.warpAffine(reference().astype(np.float32), centres, SIZE[::-1],
                           flags=cv2.INTER_CUBIC, borderValue=30)  # fmt: skip
    rng = np.random.default_rng(seed)
    return np.clip(moved + rng.normal(0, noise, moved.shape), 0, 255).astype(np.uint8)


TEMPLATE = (144, 64, 512, 512)


@pytest.mark.parametrize(
    ("dx", "dy", "degrees"),
    [(0, 0, 0), (23.4, -17.8, 0), (-40.2, 31.5, 3.0), (55.0, 12.3, -5.0), (-8.6, -60.1, 1.5)],
)
def test_the_pose_of_a_moved_and_rotated_photograph_is_recovered(dx, dy, degrees):
    """Shifts up to a tenth of the frame, rotations up to 5°: within 0.1 px at the
    template's corners (the regions move by whole pixels) and 0.01°, score above 0.99
    (the noise is 2 DN)."""
    want = true_pose(dx, dy, degrees)
    pose = locate_part(moved_frame(want), reference(), TEMPLATE)
    corners = np.array([[144, 64], [656, 64], [144, 576], [656, 576]], float)
    assert np.max(np.abs(pose.apply(corners) - Pose(want, 1.0).apply(corners))) < 0.1
    assert pose.angle_deg == pytest.approx(degrees, abs=0.01)
    assert pose.score > 0.99


@pytest.mark.parametrize(("dx", "dy"), [(200.0, 160.0), (0.0, 220.0), (-130.0, -90.0)])
def test_a_part_cut_by_any_edge_of_the_frame_is_still_placed(dx, dy):
    """A part pushed past the bottom-right corner (39 % and 31 % of the template beyond
    the edges), the bottom edge (43 %) or the top-left corner: the coarse search runs on
    the frame widened by a quarter of the template on every side, filled with its
    median; the pose within 0.1 px (0.04–0.06 seen; not widened at the bottom, 400 px
    off)."""
    want = true_pose(dx, dy, 2.0)
    pose = locate_part(moved_frame(want), reference(), TEMPLATE)
    corners = np.array([[144, 64], [656, 64], [144, 576], [656, 576]], float)
    assert np.max(np.abs(pose.apply(corners) - Pose(want, 1.0).apply(corners))) < 0.1


def test_a_frame_ecc_cannot_refine_on_gives_a_pose_of_score_0():
    """A flat frame: ECC finds no gradient and stops; the pose is where the coarse search
    put the template (a finite matrix), its score 0."""
    pose = locate_part(np.full(SIZE, 30, np.uint8), reference(), TEMPLATE)
    assert pose.score == 0.0 and np.all(np.isfinite(pose.matrix)) and pose.matrix.shape == (2, 3)


@pytest.mark.parametrize(("size", "degrees"), [(600, 10.0), (1280, 6.0), (2000, -5.0)])
def test_a_large_part_turned_is_placed_to_five_hundredths_of_a_pixel(size, degrees):
    """Templates over :data:`~inspect_validate.roi.pose.FINE_SIZE` px are refined on a
    coarser level of the pyramid and the pose carried up to full resolution: within
    0.05 px of the truth at the template's corners (cv2.pyrDown's pixel c sits on 2c of
    the level above; taken as 2c + ½, or the template's levels cut from its window
    alone, the corners were off by 0.3–1.2 px)."""
    identity = np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
    ref, template = rendered_part(size, identity, seed=1)
    n = ref.shape[0]
    t = math.radians(degrees)
    a = np.array([[math.cos(t), -math.sin(t)], [math.sin(t), math.cos(t)]])
    want = np.column_stack([a, np.array([n / 2 + 7.3, n / 2 - 4.6]) - a @ np.full(2, n / 2)])
    frame, _ = rendered_part(size, want, seed=2)
    pose = locate_part(frame, ref, template)
    x, y, w, h = template
    corners = np.array([[x, y], [x + w, y], [x, y + h], [x + w, y + h]], float)
    assert np.max(np.abs(pose.apply(corners) - Pose(want, 1.0).apply(corners))) < 0.05
    assert pose.angle_deg == pytest.approx(degrees, abs=0.002)


def test_translation_only_and_affine_motions():
    want = true_pose(12.25, -7.5, 0)
    pose = locate_part(moved_frame(want), reference(), TEMPLATE, motion="translation")
    assert pose.shift == pytest.approx((12.25, -7.5), abs=0.05) and pose.angle_deg == 0
    scaled = true_pose(5.0, 3.0, 2.0, scale=1.02)
    pose = locate_part(moved_frame(scaled), reference(), TEMPLATE, motion="affine")
    assert pose.scale == pytest.approx(1.02, abs=1e-3)
    assert pose.angle_deg == pytest.approx(2.0, abs=0.02)


def test_a_frame_without_the_part_scores_low():
    """An empty belt (the background and noise) is no part: its score stays far below a
    part's."""
    empty = np.clip(30 + np.random.default_rng(1).normal(0, 2, SIZE), 0, 255).astype(np.uint8)
    assert locate_part(empty, reference(), TEMPLATE).score < 0.5


@pytest.mark.parametrize(
    ("template", "fits"),
    [
        ((0, 0, 8, 8), True),  # the smallest window, at the corner
        ((792, 632, 8, 8), True),  # reaching the frame's far edges exactly
        ((0, 0, 7, 8), False),
        ((0, 0, 8, 7), False),
        ((-1, 0, 8, 8), False),
        ((0, -1, 8, 8), False),
        ((793, 0, 8, 8), False),
        ((0, 633, 8, 8), False),
    ],
)
def test_a_template_is_a_window_of_8_px_or_more_inside_the_reference(template, fits):
    """The template's bounds, to the pixel; a window of faint contrast (σ 0.5 DN) is a
    template, a flat one is not."""
    from inspect_validate.roi.pose import TemplateSearch

    ref = np.random.default_rng(4).normal(100, 20, SIZE).astype(np.float32)
    if fits:
        TemplateSearch.of(ref, template)
    else:
        with pytest.raises(InputError, match=r"at least 8 × 8 px inside the 800×640 reference"):
            TemplateSearch.of(ref, template)
    faint = np.full(SIZE, 100, np.float32)
    faint[::2] += 1.0  # σ 0.5 DN
    TemplateSearch.of(faint, (0, 0, 16, 16))


def test_a_warp_of_a_coarse_level_is_carried_up_by_its_power_of_two():
    """Level k's shift is 2**k of the full resolution's (k = 3: 8, not 6), its linear
    part unchanged."""
    from inspect_validate.roi.pose import _at_full

    warp = np.array([[0.99, -0.1, 1.5], [0.1, 0.99, -2.25]], np.float32)
    for level in (0, 1, 2, 3, 4):
        got = _at_full(warp, level)
        assert np.allclose(got[:, :2], warp[:, :2])
        assert np.allclose(got[:, 2], warp[:, 2] * 2**level)


def test_bad_input_is_refused_naming_what_to_give():
    ref = reference()
    with pytest.raises(InputError, match="the frame is 800×639, the reference 800×640"):
        locate_part(ref[:-1], ref, TEMPLATE)
    with pytest.raises(InputError, match="the frame is 799×640, the reference 800×640"):
        locate_part(ref[:, :-1], ref, TEMPLATE)
    with pytest.raises(InputError, match="monochrome"):
        locate_part(np.dstack([ref] * 3), ref, TEMPLATE)
    with pytest.raises(InputError, match="inside the"):
        locate_part(ref, ref, (700, 0, 200, 200))
    with pytest.raises(InputError, match="no contrast"):
        locate_part(ref, ref, (0, 0, 100, 60))
    with pytest.raises(InputError, match="motion 'rigid': one of translation, euclidean, affine"):
        locate_part(ref, ref, TEMPLATE, motion="rigid")
    from inspect_validate.roi.pose import TemplateSearch

    with pytest.raises(
        InputError, match=r"^locating a part needs monochrome frames \(one channel\)$"
    ):
        TemplateSearch.of(np.dstack([ref] * 3), TEMPLATE)


def test_regions_follow_the_part_and_count_what_leaves_the_frame():
    """A region moved by the pose holds the pixels of the same object: the mean of the
    moved region in the moved frame equals the region's mean in the reference within
    the noise; a region pushed past the frame's edge loses exactly the pixels that
    leave, and two classes never share a pixel."""
    ref = reference()
    masks = {"face": np.zeros(SIZE, bool), "coat": np.zeros(SIZE, bool)}
    masks["face"][120:200, 380:440] = True
    masks["coat"][300:420, 300:420] = True
    want = true_pose(-20.0, 15.0, 4.0)
    frame = moved_frame(want)
    regions = moved_masks(masks, Pose(want, 1.0))
    for name, mask in masks.items():
        assert regions.outside[name] == 0
        assert abs(int(regions.masks[name].sum()) - int(mask.sum())) <= 0.03 * mask.sum()
        assert frame[regions.masks[name]].mean() == pytest.approx(ref[mask].mean(), abs=2.0)
    assert not (regions.masks["face"] & regions.masks["coat"]).any()
    # 120 px up: the face region (rows 120–200) is pushed 40 rows past the top edge.
    gone = moved_masks(masks, Pose(true_pose(0.0, -160.0, 0.0), 1.0))
    assert gone.outside["face"] == 40 * 60 and gone.masks["face"].sum() == 40 * 60
    assert gone.outside["coat"] == 0
    # 400 px left: the face (columns 380–440) loses 20 columns past the left edge. A
    # pixel counts by its centre: one landing on 0 is inside, one landing on the frame's
    # width or height (800, 640) is not.
    left = moved_masks(masks, Pose(true_pose(-400.0, 0.0, 0.0), 1.0))
    assert left.outside["face"] == 20 * 80
    edge = moved_masks(masks, Pose(true_pose(-380.5, 0.0, 0.0), 1.0))
    assert edge.outside["face"] == 0
    right = moved_masks(masks, Pose(true_pose(360.5, 0.0, 0.0), 1.0))  # last centre on 800
    assert right.outside["face"] == 1 * 80
    up = moved_masks(masks, Pose(true_pose(0.0, -120.5, 0.0), 1.0))
    assert up.outside["face"] == 0
    down = moved_masks(masks, Pose(true_pose(0.0, 440.5, 0.0), 1.0))  # last centre on 640
    assert down.outside["face"] == 1 * 60


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_moving_each_regions_box_is_moving_the_whole_mask(seed):
    """The regions are warped box by box (a 5 MP frame's masks in full cost 3 ms a class):
    pixel for pixel the bilinear warp of the whole mask, for random poses, regions of
    random shapes, and a region pushed partly off the frame."""
    rng = np.random.default_rng(seed)
    masks = {}
    for k in range(3):
        mask = np.zeros(SIZE, bool)
        y, x = rng.integers(0, SIZE[0] - 150), rng.integers(0, SIZE[1] - 150)
        mask[y : y + rng.integers(20, 150), x : x + rng.integers(20, 150)] = True
        mask[y : y + 10, x : x + 200] = True  # not a rectangle
        masks[f"c{k}"] = mask
    matrix = true_pose(rng.uniform(-120, 120), rng.uniform(-120, 120), rng.uniform(-8, 8),
                       rng.uniform(0.95, 1.05))  # fmt: skip
    a, b = matrix[:, :2], matrix[:, 2]
    centres = np.column_stack([a, b + a @ np.array([0.5, 0.5]) - 0.5])
    got = moved_masks(masks, Pose(matrix, 1.0))
    for name, mask in masks.items():
        whole = cv2.warpAffine(mask.astype(np.float32), centres, SIZE[::-1],
                               flags=cv2.INTER_LINEAR, borderMode=cv2.BORDER_CONSTANT)  # fmt: skip
        # To 1e-4: the box's origin shifts OpenCV's fixed-point coordinates (3e-5 seen).
        np.testing.assert_allclose(got.weights[name], whole, atol=1e-4, err_msg=name)
        clear = np.abs(whole - 0.5) > 1e-4
        assert np.array_equal(got.masks[name][clear], (whole > 0.5)[clear]), name


def test_an_edge_moved_by_a_fraction_of_a_pixel_covers_that_fraction():
    """The weights are the pixels' covered shares: a 40 × 30 px rectangle moved by
    (0.25, 0.5) px covers a quarter of its new right column's pixels and three quarters
    of its old left column's, half of its top and bottom rows', and its area stays
    40 × 30 px (OpenCV's bilinear warp resolves a 32nd of a pixel: exact here)."""
    mask = np.zeros(SIZE, bool)
    mask[100:130, 200:240] = True
    got = moved_masks({"r": mask}, Pose(true_pose(0.25, 0.5, 0.0), 1.0)).weights["r"]
    assert got.sum() == pytest.approx(40 * 30, abs=1e-3)
    assert got[110, 240] == pytest.approx(0.25) and got[110, 200] == pytest.approx(0.75)
    assert got[100, 220] == pytest.approx(0.5) and got[130, 220] == pytest.approx(0.5)
    assert got[110, 220] == 1.0 and got[110, 241] == 0.0


@pytest.mark.parametrize("degrees", [10.0, -30.0])
def test_a_texture_without_an_outline_turned_is_found_by_sweeping_the_rotation(degrees):
    """A template inside a textured part (no outline to find at the coarse level): turned
    by 10° it no longer correlates with its unturned self, and without the sweep it is not
    found; with ``max_rotation_deg`` 30 it is, within 0.05 px at its corners."""
    identity = np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
    ref, (x0, y0, _, _) = rendered_part(700, identity, seed=1)
    template = (x0 + 150, y0 + 150, 400, 400)
    n = ref.shape[0]
    t = math.radians(degrees)
    a = np.array([[math.cos(t), -math.sin(t)], [math.sin(t), math.cos(t)]])
    want = np.column_stack([a, np.array([n / 2 + 5.3, n / 2 - 3.1]) - a @ np.full(2, n / 2)])
    frame, _ = rendered_part(700, want, seed=2)
    x, y, w, h = template
    corners = np.array([[x, y], [x + w, y], [x, y + h], [x + w, y + h]], float)
    pose = locate_part(frame, ref, template, max_rotation_deg=30.0)
    assert np.max(np.abs(pose.apply(corners) - Pose(want, 1.0).apply(corners))) < 0.05
    assert pose.score > 0.99
    assert locate_part(frame, ref, template).score < 0.5  # the coarse search shifts only
