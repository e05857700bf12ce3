"""JSON number encoding shared by every report."""

import math

from inspect_validate.report.jsonfile import json_number


def test_json_numbers():
    assert json_number(1.5) == 1.5 and json_number(None) is None
    assert json_number(math.inf) == "inf" and json_number(-math.inf) == "-inf"
    assert json_number(math.nan) is None  # undefined, not "-inf"
