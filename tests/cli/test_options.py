"""The command line's options as one vocabulary: a concept is spelled one way in every
command. Here: ``--json`` writes the command's document, and ``--json -`` puts it on
standard output in place of the table (``predict --json -`` wrote a file named ``-``)."""

import json
import re

import click
import pytest
from conftest import ROOT

from inspect_validate.cli import cli as group

SCENE = ROOT / "sample_images" / "scenes" / "paperboard" / "scene.yaml"
STATION = ROOT / "sample_images" / "station" / "station.yaml"


def _commands():
    for name in group.list_commands(click.Context(group)):
        command = group.get_command(click.Context(group), name)
        subs = getattr(command, "commands", None)
        yield from ((f"{name} {s}", c) for s, c in subs.items()) if subs else [(name, command)]


def test_every_json_option_takes_a_dash_for_standard_output():
    with_json = {n: c for n, c in _commands() if any("--json" in p.opts for p in c.params)}
    assert set(with_json) >= {"predict", "measure", "analyze-spectra", "design", "devices"}
    for name, command in with_json.items():
        (option,) = [p for p in command.params if "--json" in p.opts]
        assert "'-': to stdout only" in option.help, name


@pytest.mark.parametrize(
    ("args", "schema"),
    [
        (["predict", SCENE], "inspect-validate/prediction"),
        (["analyze-spectra", SCENE], "inspect-validate/spectral-analysis"),
        (["design", STATION], "inspect-validate/design"),
        (
            ["measure", ROOT / "sample_images/paperboard/optimized.png", "--rois",
             ROOT / "sample_images/paperboard/rois.yaml"],
            "inspect-validate/measurement",
        ),
    ],
)  # fmt: skip
def test_json_dash_is_the_document_alone_on_standard_output(cli, tmp_path, args, schema):
    code, out, err = cli([*args, "--json", "-"])
    assert code in (0, 1), err
    assert json.loads(out)["schema"] == schema  # nothing but the document
    assert not (tmp_path / "-").exists()


def test_no_help_shows_a_range_of_none():
    """measure --saturation-level's help read '[x<=None]'."""
    from click.testing import CliRunner

    for name, _ in _commands():
        result = CliRunner().invoke(group, [*name.split(), "--help"])
        assert result.exit_code == 0 and "None]" not in result.output, name


@pytest.mark.parametrize(
    ("args", "says"),
    [
        (["measure", "f.png", "--rois", "r.yaml", "--saturation-level", "-3"], "x>0"),
        (["init", "s.yaml", "--exposure-us", "0"], "--exposure-us"),
    ],
)
def test_an_impossible_number_is_refused_naming_the_option(cli, args, says):
    """--saturation-level -3 called every class 100 % saturated; init --exposure-us 0
    named the file's key camera.exposure_us instead of the option."""
    code, _, err = cli(args)
    assert code == 2 and says in err and "camera.exposure_us" not in err, err


#: Retired spellings and the one that replaces them (kept a release, hidden, deprecated),
#: in every command or in the one that gave the spelling another meaning.
RETIRED = {"--no-kde": "--kde", "--frame": "--size"}
RETIRED_IN = {
    ("init", "--camera"): "--camera-backend",
    ("verify", "--out"): "--frames-out",
    ("predict", "--comparison"): "--rank-comparison",
    ("history", "--recent"): "--list",
}

#: What an option spelled in several commands means in each: a phrase its help holds.
MEANINGS = {
    "--camera": "of a station of several cameras",
    "--golden": "golden file",
    "--comparison": "compare only these",
    "--frames-out": "frames",
    "--rois": "roi file",
}


def test_one_spelling_per_concept():
    """A frame size is --size WxH (rois import had --frame), the nonparametric error is
    --kde auto|always|never (predict and analyze-spectra had --no-kde), the ROI file is
    --rois (rois show took it as its first argument), a JSON document --json, plots go
    into a folder given by --plot (analyze-spectra took a PNG file). A retired spelling is
    hidden and deprecated."""
    from inspect_validate.cli.common import KDE_MODES, SIZE

    seen = {}
    for name, command in _commands():
        for p in command.params:
            if not isinstance(p, click.Option):
                continue
            (spelling,) = [o for o in p.opts if o.startswith("--")]
            if spelling in RETIRED or (name, spelling) in RETIRED_IN:
                assert p.hidden and p.deprecated, f"{name} {spelling}: not retired"
                continue
            if p.type is SIZE:
                assert spelling == "--size", f"{name} {spelling}: a frame size is --size"
            if spelling == "--kde":
                assert tuple(p.type.choices) == KDE_MODES, name
            if re.match(r"(the )?roi file\b", (p.help or "").lower()) and spelling != "--out":
                assert spelling == "--rois", f"{name} {spelling}: the ROI file is --rois"
            if spelling == "--plot":
                assert "folder" in (p.help or "") or "into" in (p.help or ""), name
            seen.setdefault(spelling, []).append(name)
    assert {"--size", "--kde", "--rois", "--json", "--plot"} <= set(seen)
    assert not {"--frame", "--no-kde"} & set(seen)


def test_retired_spellings_still_work_saying_what_to_write(cli, tmp_path):
    code, out, err = cli(["analyze-spectra", SCENE, "--no-kde", "--json", "-"])
    assert code == 0 and "write --kde never" in err and json.loads(out)["comparisons"]
    code, _, err = cli(["analyze-spectra", SCENE, "--plot", tmp_path / "old.png"])
    assert code == 0 and "--plot takes a folder now" in err and (tmp_path / "old.png").is_file()


def test_a_fraction_is_taken_in_per_cent_too(cli):
    """--max-saturated took only a fraction (0.001) that verify and measure show as
    '≤ 0.1 %': 0.1% is the same."""
    from inspect_validate.cli.common import Share

    assert Share().convert("0.1%", None, None) == pytest.approx(0.001)
    assert Share().convert("0.001", None, None) == pytest.approx(0.001)
    code, _, err = cli(["measure", "f.png", "--rois", "r.yaml", "--max-saturated", "200%"])
    assert code == 2 and "0<=x<=1" in err


def test_one_meaning_per_option():
    """An option spelled in several commands means one thing in each: --camera is a
    camera of several (init took a backend), --golden a golden file (bench verify
    refused it), --comparison filters what is compared (predict picked the ranking's),
    --kde defaults to auto (predict and analyze-spectra: always), --out is no longer the
    frames of verify; a retired spelling names itself, not an identifier of the code."""
    from inspect_validate.cli.common import Retired

    for name, command in _commands():
        for p in command.params:
            if not isinstance(p, click.Option) or isinstance(p, Retired):
                continue
            spelling = max(p.opts, key=len)
            if spelling in MEANINGS:
                assert MEANINGS[spelling] in (p.help or "").lower(), (name, spelling, p.help)
            if spelling == "--kde":
                assert p.default == "auto", name
    for (name, spelling), instead in RETIRED_IN.items():
        command = dict(_commands())[name]
        (p,) = [p for p in command.params if spelling in p.opts]
        assert isinstance(p, Retired) and p.human_readable_name == spelling
        assert instead in p.deprecated, (name, spelling)


def test_a_retired_spelling_says_itself_and_what_to_write(cli, tmp_path):
    code, out, err = cli(["history", tmp_path / "none.sqlite", "--recent", 3])
    assert "The option '--recent' is deprecated. write --list N" in err, err
    code, out, err = cli(["predict", SCENE, "--comparison", "A vs B", "--json", "-"])
    assert code == 0 and "'--comparison' is deprecated" in err
    assert json.loads(out)["rank_comparison"] == "A vs B"
