"""`rois import` of annotations as people draw them: touching objects that share a pixel
or two, clicks past the border, labelme's __ignore__, lines and points, labelme masks —
laid out as labelme's and COCO's own example files are (their 2011_000003, 2011_000025
and primitives examples have each of these) — imported into ROI files every command
accepts; and a corpus of malformed files, each refused naming the file and the field,
with nothing written and every existing file left as it was."""

from __future__ import annotations

import base64
import json

import cv2
import numpy as np
import pytest

from inspect_validate.roi import class_masks, read_rois

W, H = 500, 338  # the size of labelme's 2011_000003 example


def _polygon(points, label, kind="polygon", **extra):
    return {"label": label, "points": points, "group_id": None, "shape_type": kind,
            "flags": {}, **extra}  # fmt: skip


def _png64(mask: np.ndarray) -> str:
    ok, png = cv2.imencode(".png", mask.astype(np.uint8) * 255)
    assert ok
    return base64.b64encode(png.tobytes()).decode()


def labelme_doc():
    patch = np.zeros((20, 30), bool)
    patch[5:15, 5:25] = True
    return {
        "version": "5.0.1",
        "flags": {},
        "imagePath": "2011_000003.jpg",
        "imageData": None,
        "imageWidth": W,
        "imageHeight": H,
        "shapes": [
            # Two objects drawn along one edge: they share the pixels of that edge.
            _polygon([[100, 100], [200, 100], [201.5, 200], [100, 200]], "person"),
            _polygon([[200, 100], [260, 100], [260, 200], [198.5, 200]], "bottle"),
            # A click past the border (by 0.38 px, as in COCO's image 2).
            _polygon([[300, 300], [400, 300], [400, H + 0.38], [300, H + 0.38]], "person"),
            _polygon([[10, 10], [40, 10], [40, 40]], "__ignore__"),
            _polygon([[50, 50], [90, 90]], "line", "line"),
            _polygon([[60, 60]], "point", "point"),
            _polygon([[10, 300], [50, 310], [90, 300]], "line_strip", "linestrip"),
            _polygon([[400, 20], [429, 39]], "octagon", "mask", mask=_png64(patch)),
        ],
    }


def test_a_labelme_file_as_people_draw_imports_into_a_file_every_command_accepts(cli, tmp_path):
    (tmp_path / "a.json").write_text(json.dumps(labelme_doc()))
    out = tmp_path / "rois.yaml"
    code, _said, err = cli(["rois", "import", tmp_path / "a.json", "--out", out])
    assert code == 0, err
    assert "label '__ignore__': left out" in err
    assert "1 line shape: no area" in err and "1 point shape" in err and "1 linestrip" in err
    assert "clipped to the 500×338 frame" in err
    assert "'person': " in err and "shares with 'bottle' left out" in err
    rois = read_rois(out)
    assert [c.name for c in rois.classes] == ["person", "bottle", "octagon"]
    masks = class_masks(rois, (H, W))  # every command's check: no overlap, inside
    assert not (masks["person"] & masks["bottle"]).any()
    assert masks["person"][330:338, 300:400].all()  # the overshoot kept up to the border
    expected = np.zeros((H, W), bool)
    expected[25:35, 405:425] = True  # the mask patch placed at its box's corner
    assert np.array_equal(masks["octagon"], expected)
    frame = np.random.default_rng(0).integers(20, 200, (H, W)).astype(np.uint8)
    cv2.imwrite(str(tmp_path / "f.png"), frame)
    code, _, err = cli(["measure", tmp_path / "f.png", "--rois", out])
    assert code == 0, err
    code, _, err = cli(
        ["rois", "show", tmp_path / "f.png", "--rois", out, "--out", tmp_path / "s.png"]
    )
    assert code == 0, err
    # --drop leaves a label out; --names can keep an ignored one.
    code, _, err = cli(
        ["rois", "import", tmp_path / "a.json", "--out", tmp_path / "d.yaml", "--drop", "octagon",
         "--names", "__ignore__=I"]
    )  # fmt: skip
    assert code == 0, err
    assert [c.name for c in read_rois(tmp_path / "d.yaml").classes] == ["person", "bottle", "I"]


def coco_doc():
    return {
        "images": [{"id": 1, "file_name": "a.jpg", "width": W, "height": H}],
        "categories": [{"id": 1, "name": "bus"}, {"id": 2, "name": "car"}],
        "annotations": [
            {"id": 1, "image_id": 1, "category_id": 1,
             "segmentation": [[100, 100, 200, 100, 200, 200, 100, 200]]},
            {"id": 2, "image_id": 1, "category_id": 2,
             "segmentation": [[199, 150, 260, 150, 260, H + 1, 199, H + 1]]},
            {"id": 3, "image_id": 1, "category_id": 2, "bbox": [0, 0, 5, 5]},
        ],
    }  # fmt: skip


def test_a_coco_file_with_touching_objects_imports(cli, tmp_path):
    (tmp_path / "c.json").write_text(json.dumps(coco_doc()))
    code, _, err = cli(["rois", "import", tmp_path / "c.json", "--out", tmp_path / "r.yaml"])
    assert code == 0, err
    assert "50 pixels it shares with 'car'" in err and "no segmentation" in err
    masks = class_masks(read_rois(tmp_path / "r.yaml"), (H, W))
    assert masks["bus"].sum() == 100 * 100 - 50 and not (masks["bus"] & masks["car"]).any()


def test_a_refused_import_leaves_every_existing_file_as_it_was(cli, tmp_path):
    """--force over a good ROI file with a bad import: the good file is untouched (it was
    replaced, then the import refused on reading it back). An import to roi.yml never
    writes over roi.1.png, a mask roi.yaml uses."""
    labels = np.zeros((H, W), np.uint8)
    labels[10:50, 20:80] = 1
    cv2.imwrite(str(tmp_path / "labels.png"), labels)
    good = tmp_path / "roi.yaml"
    assert cli(["rois", "import", tmp_path / "labels.png", "--out", good])[0] == 0
    (tmp_path / "bad.json").write_text('{"shapes": [{"label": "A", "points": "x"}]}')
    before = {p.name: p.read_bytes() for p in tmp_path.iterdir()}
    code, _, err = cli(["rois", "import", tmp_path / "bad.json", "--out", good, "--force"])
    assert code == 2 and "shapes[0].points" in err, err
    labels[100:120, 100:300] = 1
    cv2.imwrite(str(tmp_path / "labels2.png"), labels)
    code, _, err = cli(["rois", "import", tmp_path / "labels2.png", "--out", tmp_path / "roi.yml"])
    assert code == 2 and "roi.1.png exists and roi.yml does not name it" in err, err
    after = {p.name: p.read_bytes() for p in tmp_path.iterdir() if p.name != "labels2.png"}
    assert after == before  # nothing written, nothing left behind
    # Over its own file with --force, the masks it names are its own to replace.
    code, _, err = cli(["rois", "import", tmp_path / "labels2.png", "--out", good, "--force"])
    assert code == 0, err
    assert class_masks(read_rois(good), (H, W))["1"].sum() == 40 * 60 + 20 * 200


def _labelme_with(**changes):
    doc = {"shapes": [_polygon([[1, 1], [9, 1], [9, 9]], "A")], "imageWidth": 20,
           "imageHeight": 20}  # fmt: skip
    doc.update(changes)
    return json.dumps(doc)


def _coco_with(images=None, categories=None, annotations=None):
    doc = {
        "images": [{"id": 1, "width": 20, "height": 20}] if images is None else images,
        "categories": [{"id": 1, "name": "A"}] if categories is None else categories,
        "annotations": [{"image_id": 1, "category_id": 1, "segmentation": [[1, 1, 9, 1, 9, 9]]}]
        if annotations is None
        else annotations,
    }
    return json.dumps(doc)


def _rle(counts, size=(20, 20)):
    return _coco_with(annotations=[{"image_id": 1, "category_id": 1,
                                    "segmentation": {"counts": counts, "size": list(size)}}])  # fmt: skip


MALFORMED = {
    # labelme: structure
    "shapes a dict": ("x.json", '{"shapes": {"a": 1}}', "shapes"),
    "shapes a string": ("x.json", '{"shapes": "abc"}', "shapes"),
    "a shape an int": ("x.json", '{"shapes": [3]}', "shapes[0]"),
    "a shape a list": ("x.json", '{"shapes": [[1, 2]]}', "shapes[0]"),
    "a label a dict": ("x.json", _labelme_with(shapes=[_polygon([[1, 1], [9, 1], [9, 9]], {})]), "label"),
    "points of three numbers": ("x.json", _labelme_with(shapes=[_polygon([[1, 1, 1], [9, 1, 1], [9, 9, 9]], "A")]), "points"),
    "booleans as points": ("x.json", _labelme_with(shapes=[_polygon([[True, 1], [9, 1], [9, 9]], "A")]), "points"),
    "a size as text": ("x.json", _labelme_with(imageWidth="320"), "imageWidth"),
    "a size as a float": ("x.json", _labelme_with(imageWidth=320.0), "imageWidth"),
    "a size of a boolean": ("x.json", _labelme_with(imageWidth=True), "imageWidth"),
    "a huge frame": ("x.json", _labelme_with(imageWidth=10**12, imageHeight=10**12), "imageWidth"),
    "a shape covering no pixel": ("x.json", _labelme_with(shapes=[_polygon([[1, 1], [1.0000001, 1], [1, 1.0000001]], "A")]), "no class keeps a pixel of the"),
    "a 100000-pixel side": ("x.json", _labelme_with(imageWidth=100_000, imageHeight=100_000), "larger than any camera's frame"),
    "a NaN coordinate": ("x.json", _labelme_with(shapes=[_polygon([[1, 1], [9, 1], [9, 9]], "A")]).replace("[9, 1]", "[NaN, 1]"), "finite"),
    "an unknown shape": ("x.json", _labelme_with(shapes=[_polygon([[1, 1], [9, 1], [9, 9], [1, 9]], "A", "trapezoid")]), "unknown labelme shape type 'trapezoid'"),
    "a mask without its bitmap": ("x.json", _labelme_with(shapes=[_polygon([[1, 1], [9, 9]], "A", "mask")]), "no mask"),
    "a mask of garbage": ("x.json", _labelme_with(shapes=[_polygon([[1, 1], [9, 9]], "A", "mask", mask="bm90IGEgcG5n")]), "not a base64 PNG"),
    # COCO: structure
    "annotations not objects": ("x.json", _coco_with(annotations=[1, 2]), "annotations[0]"),
    "images not objects": ("x.json", _coco_with(images=["a"]), "images[0]"),
    "categories a string": ("x.json", '{"images": [], "annotations": [], "categories": "A"}', "categories"),
    "a category without id": ("x.json", _coco_with(categories=[{"name": "A"}]), "categories[0].id"),
    "an image without width": ("x.json", _coco_with(images=[{"id": 1, "height": 20}]), "width"),
    "a width as text": ("x.json", _coco_with(images=[{"id": 1, "width": "20", "height": 20}]), "width"),
    "a width of 320.7": ("x.json", _coco_with(images=[{"id": 1, "width": 320.7, "height": 20}]), "width"),
    "duplicate category ids": ("x.json", _coco_with(categories=[{"id": 1, "name": "A"}, {"id": 1, "name": "B"}]), "listed twice"),
    "an image id that matches nothing": ("x.json", _coco_with(annotations=[{"image_id": 9, "category_id": 1, "segmentation": [[1, 1, 9, 1, 9, 9]]}]), "image 1 has no annotation with a segmentation"),
    "RLE counts as strings": ("x.json", _rle(["1", "2"]), "counts"),
    "RLE counts negative": ("x.json", _rle([-5, 405]), "counts"),
    "RLE counts as floats": ("x.json", _rle([10.0, 390.0]), "counts"),
    "RLE counts not summing": ("x.json", _rle([10, 20]), "sum to 30, not the image's 20×20 = 400"),
    "RLE counts huge": ("x.json", _rle([10**30, 1]), "sum to"),
    "RLE text not ascii": ("x.json", _rle("ü∂ø"), "not COCO's compressed RLE"),
    "RLE of a 200000-pixel side": ("x.json", _coco_with(images=[{"id": 1, "width": 200000, "height": 200000}]), "width"),
    "a NaN in a COCO polygon": ("x.json", _coco_with(annotations=[{"image_id": 1, "category_id": 1, "segmentation": [[1, 1, 9, 1, 9, 9]]}]).replace("9, 1, 9", "NaN, 1, 9"), "finite"),
    "a polygon of odd length": ("x.json", _coco_with(annotations=[{"image_id": 1, "category_id": 1, "segmentation": [[1, 1, 9, 1, 9]]}]), "x, y pairs"),
    # JSON itself
    "nested 100000 deep": ("x.json", "[" * 100_000 + "]" * 100_000, "nested too deeply"),
    "a 5000-digit number": ("x.json", _labelme_with(imageWidth=0).replace('"imageWidth": 0', '"imageWidth": ' + "9" * 5000), "not valid JSON"),
    # napari CSV
    "a short row": ("x.csv", "index,shape-type,vertex-index,axis-0,axis-1\n0,polygon,0,1\n", "missing or extra values"),
    "an index of text": ("x.csv", "index,shape-type,vertex-index,axis-0,axis-1\na,polygon,0,1,1\n", "not a shape number"),
    "an index as a float": ("x.csv", "index,shape-type,vertex-index,axis-0,axis-1\n1.0,polygon,0,1,1\n", "not a shape number"),
    "an index 01": ("x.csv", "index,shape-type,vertex-index,axis-0,axis-1\n01,polygon,0,1,1\n", "not a shape number"),
    "a blank axis": ("x.csv", "index,shape-type,vertex-index,axis-0,axis-1,axis-2\n0,polygon,0,1,1,\n", "missing or extra values"),
    "a polygon of 100001 vertices": ("x.csv", "index,shape-type,vertex-index,axis-0,axis-1\n" + "".join(f"0,polygon,{i},{i % 97},{i % 89}\n" for i in range(100_001)), "more than 100000 vertices"),
    "binary content": ("x.csv", b"\xff\xfe\x00\x01index", "not a text CSV"),
}  # fmt: skip


@pytest.mark.parametrize("case", MALFORMED, ids=list(MALFORMED))
def test_a_malformed_annotation_file_is_refused_naming_the_field(cli, tmp_path, case):
    name, content, says = MALFORMED[case]
    path = tmp_path / name
    if isinstance(content, bytes):
        path.write_bytes(content)
    else:
        path.write_text(content)
    code, _, err = cli(["rois", "import", path, "--out", tmp_path / "r.yaml"])
    assert code == 2 and "Traceback" not in err, err
    assert says in err and name in err and ".rois-import" not in err, err
    assert sorted(p.name for p in tmp_path.iterdir()) == [name]  # nothing written
