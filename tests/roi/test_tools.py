"""`rois propose`, `rois show` and `rois import`: regions found in frames the tests draw,
and annotations written to their formats' published layouts (COCO's RLE by pycocotools)."""

from __future__ import annotations

import json

import cv2
import numpy as np
import pytest
import tifffile

from inspect_validate.roi import class_masks, read_rois
from inspect_validate.roi.propose import coverage, find_regions

W, H = 320, 240


def scene_frame(seed=0):
    """Objects on a dim background, none of them touching the noise model's parts the
    detector was tuned on: a disc, a rectangle, an L, a 5 × 5 speck, and two objects of
    different grey that touch (no background between them)."""
    rng = np.random.default_rng(seed)
    truth = {}
    yy, xx = np.mgrid[0:H, 0:W]
    truth["disc"] = (xx + 0.5 - 60) ** 2 + (yy + 0.5 - 60) ** 2 <= 30**2
    truth["rect"] = (xx >= 120) & (xx < 200) & (yy >= 20) & (yy < 90)
    truth["L"] = ((xx >= 220) & (xx < 240) & (yy >= 20) & (yy < 120)) | (
        (xx >= 220) & (xx < 300) & (yy >= 100) & (yy < 120)
    )
    truth["left"] = (xx >= 30) & (xx < 130) & (yy >= 140) & (yy < 220)
    truth["right"] = (xx >= 130) & (xx < 230) & (yy >= 140) & (yy < 220)
    speck = (xx >= 280) & (xx < 285) & (yy >= 200) & (yy < 205)
    level = {"disc": 120, "rect": 200, "L": 80, "left": 150, "right": 110}
    frame = np.full((H, W), 20.0)
    for name, mask in truth.items():
        frame[mask] = level[name]
    frame[speck] = 180
    frame = cv2.GaussianBlur(frame, (0, 0), 0.8)  # the lens
    frame = rng.poisson(frame).astype(np.uint16)
    return frame, truth, level


def test_propose_finds_each_object_inside_its_edges():
    frame, truth, level = scene_frame()
    regions = find_regions(frame, margin=2)
    assert len(regions) == 5  # the speck is under the size floor, the background unlit
    for region in regions:
        (name,) = [n for n, m in truth.items() if (m & region.mask).sum() > 0.5 * region.pixels]
        inner = cv2.erode(truth[name].astype(np.uint8), np.ones((3, 3), np.uint8)).astype(bool)
        assert not (region.mask & ~inner).any(), name  # never across an edge
        # Nothing farther than 7 px from the object's edge is lost (the edge's blur, the
        # smoothing and the margin take the rest).
        core = cv2.erode(truth[name].astype(np.uint8), np.ones((15, 15), np.uint8)).astype(bool)
        assert (region.mask & core).sum() >= 0.98 * core.sum(), name
        assert abs(region.mean - level[name]) < 1.5, name
        assert coverage(region) > 0.97
    # Reading order: top to bottom, then left to right.
    corners = [tuple(int(v) for v in np.argwhere(r.mask).min(axis=0)) for r in regions]
    assert corners == sorted(corners)  # (top row, left column) of each region


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_propose_is_stable_under_fresh_noise(seed):
    frame, _, _ = scene_frame(seed)
    assert len(find_regions(frame)) == 5


def test_propose_and_show_from_the_command_line(cli, tmp_path):
    frame, _, _ = scene_frame()
    tifffile.imwrite(tmp_path / "f.tif", frame)
    out = tmp_path / "rois.yaml"
    code, text, err = cli(
        ["rois", "propose", tmp_path / "f.tif", "--out", out, "--names", "A,B,C,A,D"]
    )
    assert code == 0, err
    rois = read_rois(out)
    assert rois.frame == (W, H)
    assert [c.name for c in rois.classes] == ["A", "B", "C", "D"]  # 1 and 4 merged into A
    assert len(rois.classes[0].shapes) == 2
    assert (tmp_path / "rois.png").is_file() and "region" in text
    code, text, err = cli(
        ["rois", "show", tmp_path / "f.tif", "--rois", out, "--out", tmp_path / "s.png"]
    )
    assert code == 0, err
    masks = class_masks(rois, frame.shape)
    row = next(line for line in text.splitlines() if line.startswith("B "))
    values = frame[masks["B"]].astype(float)
    assert row.split()[1:] == [
        str(values.size),
        f"{values.mean():.2f}",
        f"{values.std(ddof=1):.2f}",
    ]
    picture = cv2.imread(str(tmp_path / "s.png"))
    assert picture.shape[0] >= 480 and picture.shape[1] == picture.shape[0] * W // H
    # A frame of another size is refused by show as by measure.
    tifffile.imwrite(tmp_path / "small.tif", frame[:120, :160])
    code, _, err = cli(["rois", "show", out, tmp_path / "small.tif", "--out", tmp_path / "t.png"])
    assert code == 2 and "drawn on a 320×240 frame" in err  # the ROI file first: still read
    assert "the ROI file as the first argument is deprecated" in err


@pytest.mark.parametrize(
    "args, message",
    [
        (["--names", "A,B"], "--names: 2 names for 5 regions"),
        (["--names", "A"], "--names: 1 name for 5 regions"),
        (["--names", "A,,B,C,D"], "an empty name"),
        (["--names", "1=A,1=B"], "region 1 is named twice"),
        (["--names", "1=A,B,C,D,E"], "not both"),
        (["--names", "1=,2=B"], "an empty number or name"),
        (["--names", "6=A"], "no region 6 (the regions are 1–5)"),
        (["--min-area", "100000"], "no uniform lit region found"),
        (["--out-of-range"], "No such option"),
    ],
)
def test_propose_refuses_what_it_cannot_do(cli, tmp_path, args, message):
    frame, _, _ = scene_frame()
    tifffile.imwrite(tmp_path / "f.tif", frame)
    code, _, err = cli(["rois", "propose", tmp_path / "f.tif", "--out", tmp_path / "r.yaml", *args])
    assert code == 2 and message in err
    assert not (tmp_path / "r.yaml").exists()


def rect_mask(x, y, w, h):
    m = np.zeros((H, W), bool)
    m[y : y + h, x : x + w] = True
    return m


def test_import_label_image_exactly(cli, tmp_path):
    labels = np.zeros((H, W), np.uint16)
    labels[10:50, 20:80] = 1
    labels[100:140, 200:300] = 7
    labels[150:160, 10:20] = 7  # a label in two places is one class
    tifffile.imwrite(tmp_path / "labels.tif", labels)
    out = tmp_path / "rois.yaml"
    code, _, err = cli(
        ["rois", "import", tmp_path / "labels.tif", "--out", out, "--names", "1=A,7=B"]
    )
    assert code == 0, err
    rois = read_rois(out)
    assert rois.frame == (W, H) and [c.name for c in rois.classes] == ["A", "B"]
    masks = class_masks(rois, (H, W))
    assert np.array_equal(masks["A"], labels == 1) and np.array_equal(masks["B"], labels == 7)
    assert "mask: rois.A.png" in out.read_text()  # beside the ROI file, relative


def test_import_labelme_json(cli, tmp_path):
    doc = {
        "version": "5.4.1",
        "flags": {},
        "shapes": [
            {
                "label": "A",
                "points": [[20, 10], [80, 50]],
                "shape_type": "rectangle",
                "group_id": None,
                "flags": {},
            },
            {
                "label": "B",
                "points": [[200, 100], [300, 100], [300, 140], [200, 140]],
                "shape_type": "polygon",
                "group_id": None,
                "flags": {},
            },
            {
                "label": "C",
                "points": [[160, 200], [170, 200]],
                "shape_type": "circle",
                "group_id": None,
                "flags": {},
            },
        ],
        "imagePath": "frame.png",
        "imageData": None,
        "imageHeight": H,
        "imageWidth": W,
    }
    (tmp_path / "frame.json").write_text(json.dumps(doc))
    code, _, err = cli(["rois", "import", tmp_path / "frame.json", "--out", tmp_path / "r.yaml"])
    assert code == 0, err
    rois = read_rois(tmp_path / "r.yaml")
    masks = class_masks(rois, (H, W))
    assert rois.frame == (W, H)
    assert np.array_equal(masks["A"], rect_mask(20, 10, 60, 40))
    assert np.array_equal(masks["B"], rect_mask(200, 100, 100, 40))
    assert abs(masks["C"].sum() - np.pi * 100) < 20
    doc["shapes"].append({"label": "D", "points": [[1, 1], [5, 5]], "shape_type": "line"})
    (tmp_path / "line.json").write_text(json.dumps(doc))
    code, _out, err = cli(["rois", "import", tmp_path / "line.json", "--out", tmp_path / "b.yaml"])
    assert code == 0 and "1 line shape: no area; left out" in err, err
    assert [c.name for c in read_rois(tmp_path / "b.yaml").classes] == ["A", "B", "C"]
    doc["shapes"][-1]["shape_type"] = "trapezoid"
    (tmp_path / "bad.json").write_text(json.dumps(doc))
    code, _, err = cli(["rois", "import", tmp_path / "bad.json", "--out", tmp_path / "c.yaml"])
    assert code == 2 and "shapes[3] 'D' (trapezoid)" in err and "unknown labelme shape" in err


def test_import_coco_polygons_and_rle(cli, tmp_path):
    from pycocotools import mask as coco_mask

    b = np.asfortranarray(rect_mask(200, 100, 100, 40).astype(np.uint8))
    rle = coco_mask.encode(b)
    rle["counts"] = rle["counts"].decode("ascii")
    doc = {
        "images": [
            {"id": 1, "file_name": "a.png", "width": W, "height": H},
            {"id": 2, "file_name": "b.png", "width": W, "height": H},
        ],
        "categories": [{"id": 1, "name": "A"}, {"id": 2, "name": "B"}],
        "annotations": [
            {
                "id": 1,
                "image_id": 1,
                "category_id": 1,
                "iscrowd": 0,
                "bbox": [20, 10, 60, 40],
                "segmentation": [[20, 10, 80, 10, 80, 50, 20, 50]],
            },
            {
                "id": 2,
                "image_id": 1,
                "category_id": 2,
                "iscrowd": 1,
                "bbox": [200, 100, 100, 40],
                "segmentation": rle,
            },
            {
                "id": 3,
                "image_id": 2,
                "category_id": 2,
                "iscrowd": 0,
                "bbox": [0, 0, 9, 9],
                "segmentation": [[0, 0, 9, 0, 9, 9]],
            },
        ],
    }
    (tmp_path / "coco.json").write_text(json.dumps(doc))
    code, _, err = cli(["rois", "import", tmp_path / "coco.json", "--out", tmp_path / "r.yaml"])
    assert code == 2 and "2 images in the file (a.png, b.png); give --image" in err
    code, _, err = cli(
        ["rois", "import", tmp_path / "coco.json", "--out", tmp_path / "r.yaml", "--image", "a.png"]
    )
    assert code == 0, err
    masks = class_masks(read_rois(tmp_path / "r.yaml"), (H, W))
    assert np.array_equal(masks["A"], rect_mask(20, 10, 60, 40))
    assert np.array_equal(masks["B"], rect_mask(200, 100, 100, 40))  # the RLE, exactly


def test_import_napari_shapes_csv(cli, tmp_path):
    # napari puts pixel centres on whole coordinates: a rectangle over pixels 20..79 × 10..49
    # has its corners at −0.5 of the first and +0.5 of the last.
    rows = ["index,shape-type,vertex-index,axis-0,axis-1"]
    for v, (r, c) in enumerate([(9.5, 19.5), (9.5, 79.5), (49.5, 79.5), (49.5, 19.5)]):
        rows.append(f"0,rectangle,{v},{r},{c}")
    for v, (r, c) in enumerate([(99.5, 199.5), (99.5, 299.5), (139.5, 299.5), (139.5, 199.5)]):
        rows.append(f"1,polygon,{v},{r},{c}")
    (tmp_path / "shapes.csv").write_text("\n".join(rows) + "\n")
    code, _, err = cli(
        [
            "rois",
            "import",
            tmp_path / "shapes.csv",
            "--out",
            tmp_path / "r.yaml",
            "--names",
            "1=A,2=B",
            "--size",
            f"{W}x{H}",
        ]
    )
    assert code == 0, err
    rois = read_rois(tmp_path / "r.yaml")
    masks = class_masks(rois, (H, W))
    assert rois.frame == (W, H)
    assert np.array_equal(masks["A"], rect_mask(20, 10, 60, 40))
    assert np.array_equal(masks["B"], rect_mask(200, 100, 100, 40))


@pytest.mark.parametrize(
    "name, content, args, message",
    [
        ("x.txt", "hello", [], "unknown annotation format '.txt'"),
        ("x.json", "{", [], "not valid JSON"),
        ("x.json", '{"a": 1}', [], "neither labelme"),
        ("x.csv", "a,b\n1,2\n", [], "napari shapes CSV has the columns"),
        ("x.json", '{"shapes": []}', [], "no annotation with an area"),
        (
            "x.json",
            '{"shapes": [{"label": "A", "points": [[0, 0], [4, 4]], "shape_type": "rectangle"}]}',
            ["--names", "9=B"],
            "--names gives 9",
        ),
        (
            "x.json",
            '{"shapes": [{"label": "A", "points": [[0, 0], [4, 4]], "shape_type": "rectangle"}], "imageWidth": 10, "imageHeight": 10}',
            ["--size", "20x20"],
            "its image is 10×10, --size says 20×20",
        ),
    ],
)
def test_import_refuses_what_it_cannot_read(cli, tmp_path, name, content, args, message):
    (tmp_path / name).write_text(content)
    code, _, err = cli(["rois", "import", tmp_path / name, "--out", tmp_path / "r.yaml", *args])
    assert code == 2 and message in err
    assert not (tmp_path / "r.yaml").exists()


def test_propose_warns_of_frames_no_brighter_than_dark_and_of_clipped_regions(cli, tmp_path):
    """Regions outlined in frames that are no brighter than their darks (a test pattern, a
    lens cap) and regions that clip were proposed with exit 0 and no word. With --dark,
    propose gives μ above dark as show does (131.7 against show's 127.75 before)."""
    frame, truth, _ = scene_frame()
    frame = np.clip(frame, 0, 255).astype(np.uint8)
    frame[truth["rect"]] = 255  # a saturated object
    cv2.imwrite(str(tmp_path / "f.png"), frame)
    code, out, err = cli(
        ["rois", "propose", tmp_path / "f.png", "--dark", tmp_path / "f.png", "--out",
         tmp_path / "r.yaml"]
    )  # fmt: skip
    assert code == 0, err
    assert "warning: the frames are no brighter than the dark frames" in err
    assert "% of its pixels saturated (255 DN)" in err
    assert "μ − dark [DN]" in out
    code, shown, err = cli(
        ["rois", "show", tmp_path / "f.png", "--rois", tmp_path / "r.yaml", "--dark", tmp_path / "f.png",
         "--out", tmp_path / "s.png"]
    )  # fmt: skip
    assert code == 0 and "μ − dark [DN]" in shown, err


def test_propose_on_a_saturated_frame_says_it_is_saturated(cli, tmp_path):
    """It suggested lowering --min-area."""
    cv2.imwrite(str(tmp_path / "f.png"), np.full((H, W), 255, np.uint8))
    code, _, err = cli(["rois", "propose", tmp_path / "f.png", "--out", tmp_path / "r.yaml"])
    assert code == 2 and "100 % of the frame's pixels are saturated (255 DN)" in err, err
    assert "--min-area" not in err and not (tmp_path / "r.yaml").exists()


def test_propose_outlines_no_mixture_of_objects_and_background(cli, tmp_path):
    """A frame of small lit squares gave one region over the whole frame (σ 78 DN here,
    87 in the fault round's 1200 squares): no region is uniform there."""
    frame = np.full((H, W), 20.0)
    for y in range(1, H - 2, 4):
        for x in range(1, W - 2, 4):
            frame[y : y + 2, x : x + 2] = 200  # 4800 squares finer than the smoothing
    frame = np.random.default_rng(0).poisson(frame).astype(np.uint8)
    cv2.imwrite(str(tmp_path / "f.png"), frame)
    code, out, err = cli(["rois", "propose", tmp_path / "f.png", "--out", tmp_path / "r.yaml"])
    if code == 0:  # any region proposed is uniform, not the whole frame
        for line in out.splitlines()[2:]:
            cells = line.split()
            if cells and cells[0].isdigit():
                assert float(cells[-2]) < 20 and int(cells[2]) < H * W // 4, out
    else:
        assert code == 2 and "no uniform lit region found" in err, err
