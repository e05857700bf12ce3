"""``report.html`` of ``verify``: self-contained, every figure a decodable PNG, failures first,
and looked at as a page in headless Chromium (skipped where Debian's chromium is absent)."""

import base64
import io
import json
import re
from html.parser import HTMLParser

import pytest
from conftest import ROOT, chromium_probe, run_cli
from PIL import Image

STATION = ROOT / "sample_images" / "station"


class _Page(HTMLParser):
    def __init__(self):
        super().__init__()
        self.images, self.links, self.rows, self._row = [], [], [], None

    def handle_starttag(self, tag, attrs):
        a = dict(attrs)
        if tag == "img":
            self.images.append(a)
        for key in ("src", "href"):
            if key in a and tag != "img":
                self.links.append(a[key])
        if tag == "tr":
            self._row = []

    def handle_data(self, data):
        if self._row is not None and data.strip():
            self._row.append(data.strip())

    def handle_endtag(self, tag):
        if tag == "tr":
            self.rows.append(self._row)
            self._row = None


@pytest.fixture(scope="module")
def report(tmp_path_factory):
    """The report of the drifted-LED station (it fails: failures come first)."""
    out = tmp_path_factory.mktemp("report")
    assert run_cli(["verify", STATION / "amber_drift.yaml", "--report", out]) == 1
    return out / "report.html"


def test_every_figure_is_an_inline_picture_or_a_chart_with_its_data(report):
    text = report.read_text()
    page = _Page()
    page.feed(text)
    # Per illumination the frame (a picture) and the histograms (a chart); the agreement
    # (3 panels), the spectra (4) and ε per wavelength (1) are charts.
    assert len(page.images) == 2
    charts = re.findall(
        r'<div class="chart" role="img" aria-label="([^"]+)"><script type="application/json">(.*?)</script>',
        text,
    )
    assert len(charts) == 2 + 3 + 4 + 1
    for label, data in charts:
        spec = json.loads(data.replace("<\\/", "</"))
        assert label and spec["title"] and spec["series"]
        assert all(
            s.get("xref") is not None or len(s["x"]) == len(s["y"]) > 0 for s in spec["series"]
        )
    assert "uPlot 1.6.32, MIT licence" in text  # embedded, not loaded
    for img in page.images:
        assert img["alt"]
        head, data = img["src"].split(",", 1)
        assert head == "data:image/jpeg;base64"
        image = Image.open(io.BytesIO(base64.b64decode(data)))
        image.load()
        assert image.width > 300 and image.height > 200
    assert page.links == []  # nothing to load: the page opens offline


def test_checks_table_lists_failures_first(report):
    page = _Page()
    page.feed(report.read_text())
    checks = [r for r in page.rows if r and r[0] in ("pass", "FAIL")]
    verdicts = [r[0] for r in checks]
    assert "FAIL" in verdicts and verdicts == sorted(verdicts, key=lambda v: v != "FAIL")
    assert all("SNR_dB deviation" in r[1] for r in checks if r[0] == "FAIL")
    assert "<title>verify paperboard station, amber LED drifted: FAIL</title>" in report.read_text()


def test_skipped_work_is_rows_of_the_checks_table(report):
    """What was not computed sits in the checks table, after the checks, as rows marked
    skipped, each whole in the check column (split at a colon, "SNR_dB agreement of
    amber: C vs A,B, red: …" was cut into "SNR_dB agreement of amber" and the rest), not
    as loose paragraphs."""
    text = report.read_text()
    page = _Page()
    page.feed(text)
    skipped = [r for r in page.rows if r and r[0] == "skipped"]
    assert skipped and all(len(r) == 2 for r in skipped)  # verdict, what and why
    assert any(r[1].startswith("ε KDE: no check asks for it") for r in skipped)
    assert any(
        r[1].startswith("SNR_dB agreement of amber: C vs A,B, red:")
        and r[1].endswith(
            "below agreement.snr_floor_db (-20 dB), in every verification of this station"
        )
        for r in skipped
    )
    assert '<tr class="skipped">' in text and "<p>skipped:" not in text
    rows = [r[0] for r in page.rows if r and r[0] in ("pass", "FAIL", "skipped")]
    assert rows.index("skipped") > max(i for i, v in enumerate(rows) if v != "skipped")


def test_report_renders_in_headless_chromium(report, tmp_path):
    seen = chromium_probe(report, tmp_path)
    assert seen["images"] == 2 and seen["bad"] == 0  # every picture decoded
    assert seen["charts"] == seen["drawn"] == 10  # every chart drawn by the browser
    assert seen["console"] == [] and seen["dashes"] == 0  # legends print finished
