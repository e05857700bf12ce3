"""SNR (35)-(36), CNR and Fisher ratio: closed forms, the chapter's Tables 3-4, degenerate cases."""

import numpy as np
import pytest

from inspect_validate.stats import cnr_db, fisher_db, snr, snr_db

TABLE4 = {  # chapter Table 4
    "optimized": {"A": (127.0, 42.3), "B": (111.4, 41.0), "C": (119.3, 47.6)},
    "non_optimized": {"A": (113.2, 37.2), "B": (115.3, 34.8), "C": (120.5, 44.9)},
}


@pytest.mark.parametrize(
    ("setting", "pair", "expected"),
    [  # (36) applied to the chapter's Table 4, to the printed two decimals
        ("optimized", "AB", -14.55),
        ("non_optimized", "AB", -30.70),
        ("optimized", "AC", -21.35),
        ("non_optimized", "AC", -21.02),
    ],
)
def test_table3_from_table4(setting, pair, expected):
    (m1, v1), (m2, v2) = (TABLE4[setting][c] for c in pair)
    assert snr_db(m1, v1, m2, v2) == pytest.approx(expected, abs=0.006)


def test_closed_forms():
    assert snr(10, 1, 14, 3) == pytest.approx(1.0)
    assert snr_db(10, 1, 30, 3) == pytest.approx(20 * np.log10(5))
    assert cnr_db(10, 1, 14, 3) == pytest.approx(20 * np.log10(2))
    assert fisher_db(10, 1, 14, 3) == pytest.approx(10 * np.log10(4))
    # Vectorised and symmetric.
    a = snr_db([1, 2], [1, 1], [3, 5], [1, 2])
    assert np.allclose(a, snr_db([3, 5], [1, 2], [1, 2], [1, 1]))


def test_degenerate_cases():
    assert snr_db(5, 1, 5, 2) == -np.inf  # equal means
    assert snr_db(5, 0, 6, 0) == np.inf  # zero variance
    assert cnr_db(5, 0, 6, 0) == np.inf
    assert snr_db(5, 0, 5, 0) == -np.inf  # identical constants cannot be told apart
    with pytest.raises(ValueError, match="non-negative"):
        snr(1, -1, 2, 1)
