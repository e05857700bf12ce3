"""The flat API, ``import inspect_validate as iv``: every verb's docstring example runs
(doctest, from the repository's root, on the shipped samples), the verbs load lazily,
and each gives what its command prints."""

import doctest
import json
import subprocess
import sys

import pytest
from conftest import ROOT, run_cli

import inspect_validate as iv


def test_every_example_in_the_api_runs(monkeypatch):
    import inspect_validate.api

    monkeypatch.chdir(ROOT)
    failed, attempted = doctest.testmod(inspect_validate.api, optionflags=doctest.ELLIPSIS)
    assert attempted >= 12 and failed == 0


def test_every_verb_documents_its_parameters_returns_and_an_example():
    """numpydoc's Parameters, Returns and Examples (a doctest, run above) on every verb."""
    missing = [
        f"{name}: {section}"
        for name in iv.__all__
        if callable(getattr(iv, name))
        for section in ("Parameters\n", "Returns\n", "Examples\n", ">>> ")
        if section not in (getattr(iv, name).__doc__ or "")
    ]
    assert missing == []


def test_import_is_cheap_and_the_verbs_are_listed():
    """``import inspect_validate`` loads no numpy, pydantic or scipy: the CLI's start."""
    code = (
        "import sys, inspect_validate as iv; "
        "print(sorted(m for m in ('numpy', 'pydantic', 'scipy') if m in sys.modules)); "
        "print(all(v in dir(iv) for v in iv.__all__))"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=True
    ).stdout.split("\n")
    assert out[:2] == ["[]", "True"]
    with pytest.raises(AttributeError, match="no attribute 'nothing'"):
        iv.nothing  # noqa: B018


def test_measure_from_python_is_measure_from_the_cli(tmp_path):
    """One import and one call give the numbers ``measure --json`` writes, and the
    module of the same concept does not shadow the verb."""
    import inspect_validate.measurement  # noqa: F401

    frames = ROOT / "sample_images" / "paperboard" / "optimized.png"
    rois = ROOT / "sample_images" / "paperboard" / "rois.yaml"
    m = iv.measure(frames, rois)
    assert run_cli(["measure", frames, "--rois", rois, "--json", tmp_path / "m.json"]) == 0
    doc = json.loads((tmp_path / "m.json").read_text())
    assert [c.mean for c in m.classes] == [c["mean"] for c in doc["classes"]]
    assert [c.snr_db for c in m.comparisons] == [c["snr_db"] for c in doc["comparisons"]]


def test_train_and_verify_against_it_from_python(tmp_path):
    station = ROOT / "sample_images" / "station" / "station.yaml"
    for k in (1, 2):
        iv.capture(station, tmp_path / f"c{k}")
    golden = iv.train(station, [tmp_path / "c1", tmp_path / "c2"])
    assert golden.repeats == 2 and set(golden.illuminations) == {"amber", "red"}
    assert iv.verify(station, tmp_path / "c1").passed


def test_the_running_line_from_python_is_the_cli(tmp_path):
    """iv.capture, iv.train and iv.verify with production=True give the verdict the CLI
    gives on the same frames and golden file; a list of folders, a missing folder of
    frames and a bench golden file are refused."""
    from inspect_validate.errors import InputError

    line = ROOT / "sample_images" / "line" / "station.yaml"
    good = iv.capture(line, tmp_path / "good", production=True, parts=20).folder / "amber"
    golden = iv.train(line, good, production=True)
    (tmp_path / "golden.json").write_text(json.dumps(golden.document()))
    batch = iv.capture(line, tmp_path / "batch", production=True, parts=8).folder / "amber"
    result = iv.verify(line, batch, production=True, golden=tmp_path / "golden.json")
    code = run_cli(["verify", line, "--production", "--frames", batch, "--golden",
                    tmp_path / "golden.json", "--report", tmp_path / "r"])  # fmt: skip
    report = json.loads((tmp_path / "r" / "production.json").read_text())
    assert (code == 0) == result.passed and report["verdict"] == ("pass" if code == 0 else "fail")
    assert [c["name"] for c in report["checks"]] == [c.name for c in result.checks]
    with pytest.raises(TypeError, match="one folder"):
        iv.train(line, [good], production=True)
    with pytest.raises(InputError, match="give frames"):
        iv.verify(line, production=True, golden=golden)


def test_a_scene_sweeps_with_its_own_ranking_and_prints_the_commands_table(cli):
    # Scene.sweep() needs no arguments (the scene's rank: and top 10), and the table the
    # command prints is one public call on its result.
    from conftest import ROOT

    from inspect_validate.report.prediction import format_prediction
    from inspect_validate.scene import read_scene

    path = ROOT / "sample_images" / "scenes" / "paperboard" / "scene.yaml"
    ranking = read_scene(path).sweep()
    assert ranking.lights[ranking.index[0][0]] == "amber LED"
    table = format_prediction(ranking)
    code, out, _ = cli(["predict", path, "--kde", "never"])
    assert code == 0
    ours = [line for line in table.splitlines() if line.startswith("1 ")]
    printed = [line for line in out.splitlines() if line.startswith("1 ")]
    assert ours and printed and ours[0].split()[:12] == printed[0].split()[:12]


def test_iv_verify_and_the_cli_skip_the_same_illuminations_by_default(tmp_path):
    """With the ranking off, red is predicted far behind amber on every comparison: both
    `verify` and iv.verify leave it out, saying so; all_illuminations (the CLI's
    --all-illuminations) captures it."""
    import yaml
    from conftest import copy_station

    path = copy_station(tmp_path)
    doc = yaml.safe_load(path.read_text())
    doc["acceptance"]["ranking"] = False
    path.write_text(yaml.safe_dump(doc, sort_keys=False))
    report = tmp_path / "r"
    assert run_cli(["verify", path, "--frames-out", tmp_path / "cli", "--report", report]) == 0
    cli_skipped = json.loads((report / "verification.json").read_text())["skipped"]
    result = iv.verify(path, out=tmp_path / "api")
    red = [s for s in result.skipped if s.startswith("illumination 'red'")]
    assert red and red == [s for s in cli_skipped if s.startswith("illumination 'red'")]
    assert set(result.measurements) == {"amber"}
    every = iv.verify(path, out=tmp_path / "all", all_illuminations=True)
    assert set(every.measurements) == {"amber", "red"}


def test_results_print_short_and_show_their_numbers_as_tables(paperboard, tmp_path):
    """repr of a prediction was 11 kB of arrays, of a measurement 4.9 kB: a line now, with
    the numbers as a text table (.table()) and in a notebook as HTML."""
    import inspect_validate as iv

    scene = iv.read_scene(ROOT / "sample_images" / "scenes" / "paperboard" / "scene.yaml")
    results = [
        iv.predict(scene),
        iv.sweep(scene),
        iv.measure(paperboard / "optimized.png", paperboard / "rois.yaml"),
        iv.verify(ROOT / "sample_images" / "station" / "station.yaml", out=tmp_path / "v"),
    ]
    for result in results:
        text = repr(result)
        assert len(text) < 300 and "\n" not in text and "array(" not in text, text
        table = result.table()
        assert "\n" in table and len(table) > 100
        assert result._repr_html_().startswith("<pre>")
    assert "amber LED" in results[0].table() and "A vs B,C" in results[0].table()
    assert "SNR_dB" in results[2].table() and "PASS" in repr(results[3])
