"""The HTML cards of the results are built from their fields, with their units (issue 28,
points 6 and 7): no title twice, no "um", no value split at " = ", no SI beside display
units, intervals whose two ends differ, and a rate-and-state fit with its own card."""

import re
import sys
from pathlib import Path

import numpy as np
import pytest
from rising_branch import branch_slip

import granflow as gf
from granflow import rsf

sys.path.insert(0, str(Path(__file__).parent))
from test_html import parsed

PARAMS = gf.Params(a=3.3e-3, alpha=5.0e4, Fd=11.0e-3, x0=0.3e-6)
RECORDS = Path(__file__).resolve().parents[2] / "shared" / "data" / "rate-state-velocity-steps"


def _words(markup):
    """The page's text, tags removed and entities decoded."""
    import html

    return html.unescape(re.sub(r"<[^>]+>", " ", re.sub(r"<style>.*?</style>", "", markup)))


def _shown_well(markup):
    page = parsed(markup)  # balanced
    words = _words(markup)
    assert not re.search(r"\bum\b", words), "µm written as um"
    assert not re.search(r"\d\s+,|\[\s*\d[^\]]*\s\]", words), "a space inside an interval"
    split = [c for c in page.cells if c.rstrip().endswith("=") or c.lstrip().startswith("= ")]
    assert not split, f"a value split at ' = ' into two cells: {split}"
    return page, words


def _intervals_differ(words):
    for low, high in re.findall(r"\[([-\d.]+), ([-\d.]+)\]", words):
        assert low != high, f"an interval whose ends read the same: [{low}, {high}]"


@pytest.fixture(scope="module")
def forecast():
    failure = gf.peak(PARAMS).force / 0.065e-3
    t = np.arange(0.0, failure, 1.0)
    force = 0.065e-3 * t
    slip = branch_slip(force, PARAMS) + 5e-9 * np.random.default_rng(0).standard_normal(t.size)
    return gf.forecast_failure(t, slip, force, until=0.9 * failure)


def test_the_failure_forecast_card_is_built_from_its_fields(forecast):
    markup = forecast._repr_html_()
    page, words = _shown_well(markup)
    assert markup.count("<h4>") == 1 and "FailureForecast" in words
    assert words.count("Failure forecast") == 0  # the text report's title is not repeated
    cells = page.cells
    row = cells[cells.index("failure time t_f") :][:4]
    assert float(row[1]) == pytest.approx(forecast.time, rel=1e-3)
    assert row[3] == "s"
    row = cells[cells.index("failure force F_f") :][:4]
    assert float(row[1]) == pytest.approx(forecast.force * 1e3, rel=1e-3) and row[3] == "mN"
    row = cells[cells.index("slip at failure") :][:4]
    assert float(row[1]) == pytest.approx(forecast.slip * 1e6, rel=1e-3) and row[3] == "µm"
    _intervals_differ(words)


def test_the_failure_forecast_report_writes_its_intervals_whole(forecast):
    text = forecast.report()
    assert "um" not in text.replace("µm", "") and " ]" not in text and " ," not in text
    _intervals_differ(text)


def test_the_simulation_card_says_what_the_layer_did_in_display_units():
    p = gf.Params.from_time_domain(a=3.31e-3, k=0.036, t0=0.23, Fd=10e-3, velocity=0.86e-6)
    result = gf.simulate(p, gf.Protocol([gf.ForceRamp(rate=0.05e-3, duration=400.0)]))
    markup = result._repr_html_()
    page, words = _shown_well(markup)
    title = re.search(r"<h4>(.*?)</h4>", markup).group(1)
    assert "fails at t = 275.7 s" in title and "13.78 mN" in title
    cells = page.cells
    assert cells[cells.index("simulation") + 1].startswith("completed")
    assert "success" not in cells  # not "failed" above "success True"
    assert not re.search(r"\d e-\d\d m\b|0\.0\d{5,} N\b", words), "SI beside display units"
    decimals = re.findall(r"\d+\.\d+", words)
    long = [n for n in decimals if len(n.replace(".", "").lstrip("0")) > 5]
    assert not long, f"more digits than a reader needs: {long}"


@pytest.mark.skipif(not RECORDS.is_dir(), reason="../shared/data not beside the repository")
def test_the_rate_and_state_fit_has_its_own_card_with_units():
    record = rsf.read_velocity_steps(RECORDS / "velstep4_BRAVA_expb819_basalt.txt")
    fit = rsf.fit(record, law="slip", correlated_noise=True)
    page, _ = _shown_well(fit._repr_html_())
    cells = page.cells
    row = cells[cells.index("Dc") :][:6]
    assert row[4] == "µm"
    value = float(row[1].split(" ± ")[0])
    assert value == pytest.approx(fit.params["Dc"] * 1e6, rel=0.05)
    report = fit.report()
    a_line = next(line for line in report.splitlines() if line.strip().startswith("a  "))
    # the value to the digit its error justifies: a = 0.0099 +/- 0.0011, not 0.0098596575
    assert re.search(r"= 0\.00\d\d \+/- 0\.00\d\d \(", a_line), a_line
    assert "µm" in next(line for line in report.splitlines() if line.strip().startswith("Dc"))
