"""The production verdict's own pieces: why frames held no part, counted by kind."""

from inspect_validate.verification.production import counted_reasons


def test_reasons_are_counted_by_kind_the_commonest_first():
    """Each kind once, counted: a score below the limit whatever its value, a class short
    of pixels by its name, a copy of any frame as one kind, an unreadable file by what
    precedes its colon; ties in the order first met."""
    reasons = {
        "a.tif": "no part found: match score 0.210 below production.min_score 0.5",
        "b.tif": "no part found: match score 0.300 below production.min_score 0.5",
        "c.tif": "class 'A' keeps 12 px on this part, below production.min_pixels 50 (3 px "
        "of its region fall outside the frame)",
        "d.tif": "the same frame as a.tif (a copy or a link): a part is one frame",
        "e.tif": "the same frame as b.tif (a copy or a link): a part is one frame",
        "f.tif": "the same frame as c.tif (a copy or a link): a part is one frame",
        "g.tif": "unreadable: not a TIFF file",
    }
    assert counted_reasons(reasons) == (
        "the same frame as another (3); no part found (2); class 'A' (1); unreadable (1)"
    )
    assert counted_reasons({}) == ""
