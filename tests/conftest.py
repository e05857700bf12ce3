from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PAPERBOARD = ROOT / "sample_images" / "paperboard"


@pytest.fixture
def paperboard():
    return PAPERBOARD
