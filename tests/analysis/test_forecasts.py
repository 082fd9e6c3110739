"""The retrospective running forecast of the campaign's stress ramps: on the demo's ramp it
converges on the failure (the truth comes from the demo's generator, not from the forecast);
a run that cannot be forecast says why; results round-trip and reach the summary and the
report."""

import json
import math
import re
from dataclasses import replace

import numpy as np
import pytest

import granflow
from granflow.analysis.demo import TRUTH_FILE, make_demo_campaign
from granflow.analysis.forecasts import (
    CUT_FRACTIONS,
    ForecastCut,
    RunForecast,
    retrospective_forecasts,
)
from granflow.analysis.joint_results import Analyses, Estimate, Material
from granflow.analysis.prediction_results import Predictions
from granflow.analysis.report import render_html
from granflow.analysis.result import AnalysisResult, RunEntry
from granflow.analysis.runs import analyse_run
from granflow.fitting.results import FrozenMap


def entry_of(run, index=0, name="ramp"):
    """The RunEntry the engine makes for an analysed stress ramp."""
    result = analyse_run((run, "ramp", {"reference_velocity": 0.86e-6}))
    return RunEntry(
        index=index,
        name=name,
        source=None,
        interval=None,
        test="ramp",
        control="stress",
        normal_load=run.normal_load,
        velocity=None,
        preparation=None,
        points=len(run.t),
        result=result,
        run=run,
    )


def material_from(truth, relative_error):
    """Material constants at the demo's truth with a stated relative standard error."""
    estimates = {
        name: Estimate(truth[name], relative_error * truth[name], (None, None))
        for name in ("mu_a", "mu_d", "alpha")
    }
    return Material(**estimates, source="amontons joint fit", reason=None)


@pytest.fixture(scope="module")
def demo_ramp(tmp_path_factory):
    directory = tmp_path_factory.mktemp("demo")
    manifest = make_demo_campaign(directory, seed=0)
    truth = json.loads((directory / TRUTH_FILE).read_text(encoding="utf-8"))
    campaign = granflow.Campaign.from_manifest(manifest, errors="collect")
    pairs = zip(campaign, truth["runs"], strict=True)
    ((run, made),) = [(run, made) for run, made in pairs if made["test"] == "ramp"]
    return entry_of(run, name="fig3a"), truth, made["failure"]["time"]


@pytest.mark.parametrize("with_prior", [True, False], ids=["amontons prior", "no prior"])
def test_the_demo_ramp_forecast_converges_on_the_failure(demo_ramp, with_prior):
    entry, truth, failure_time = demo_ramp
    material = material_from(truth, 0.01) if with_prior else Material(reason="none")
    (forecast,) = retrospective_forecasts([entry], material)
    assert forecast.reason is None
    assert len(forecast.cuts) == len(CUT_FRACTIONS)
    observed = entry.result.failure
    assert forecast.observed_window == (observed.time, observed.runaway_time)
    np.testing.assert_allclose(
        [cut.cut for cut in forecast.cuts], np.array(CUT_FRACTIONS) * observed.time
    )
    first, last = forecast.dated[0], forecast.dated[-1]
    assert last.cut == forecast.cuts[-1].cut  # the last cut gives a date
    low, high = last.time_interval
    assert low <= failure_time <= high  # the generator's failure time
    assert forecast.holds(last)  # and the record's window [last point held, first runaway]
    assert last.width < first.width
    assert forecast.converged is True
    assert (forecast.prior is not None) is with_prior
    assert forecast.prior_from.startswith("amontons" if with_prior else "none")
    truth_peak = next(r for r in truth["runs"] if r["test"] == "ramp")["F_peak"]
    assert last.force_interval[0] <= truth_peak <= last.force_interval[1]


def test_round_trip_keeps_an_unbounded_interval():
    cut = ForecastCut(
        cut=80.0,
        time=190.0,
        time_interval=(90.0, math.inf),
        force=0.0125,
        force_interval=(0.012, math.inf),
        message="the record does not yet bound the failure from above",
    )
    forecast = RunForecast(
        run="r",
        normal_load=0.055,
        observed=204.0,
        observed_window=(204.0, 205.0),
        observed_force=0.0133,
        prior=None,
        prior_from="none: no material",
        cuts=(cut, ForecastCut(cut=100.0, time=None, message="too short")),
    )
    saved = json.loads(json.dumps(forecast.to_dict()))
    again = RunForecast.from_dict(saved)
    assert again == forecast
    assert again.cuts[0].time_interval[1] == math.inf
    assert again.converged is None  # a single dated cut says nothing about convergence
    assert again.holds(again.cuts[0]) is True
    assert again.holds(again.cuts[1]) is None


def test_a_run_too_short_to_forecast_says_so_and_the_rest_goes_on(demo_ramp):
    entry, truth, _ = demo_ramp
    t = np.arange(8.0)
    short = granflow.Run(
        t=t, slip=1e-9 * t, velocity=np.zeros(8), force=1e-3 * t, meta={"normal_load": 0.055}
    )
    bad = entry_of(short, index=1, name="short")
    assert bad.ok and bad.test == "ramp"
    no_slip = replace(entry, index=2, name="no slip", run=None)
    forecasts = retrospective_forecasts([bad, entry, no_slip], material_from(truth, 0.01))
    assert [f.run for f in forecasts] == ["short", "fig3a", "no slip"]
    short_forecast = forecasts[0]
    assert short_forecast.dated == ()
    assert all("too short" in cut.message for cut in short_forecast.cuts)
    assert "no date at any cut" in short_forecast.summary()
    assert forecasts[1].converged is True
    assert forecasts[2].reason == "its data are not at hand"
    assert "none (its data are not at hand)" in forecasts[2].summary()


def test_the_report_shows_the_forecast_table_and_the_failed_ones(demo_ramp):
    entry, truth, _ = demo_ramp
    (forecast,) = retrospective_forecasts([entry], material_from(truth, 0.01))
    failed = RunForecast(
        run="broken",
        normal_load=None,
        observed=None,
        observed_window=None,
        observed_force=None,
        prior=None,
        prior_from="none: the run has no normal load",
        cuts=(ForecastCut(cut=10.0, time=None, message="the layer has not slipped"),),
    )
    result = AnalysisResult(
        granflow_version="0",
        synthetic=False,
        campaign=FrozenMap(),
        runs=(),
        material=Material(reason="no loads"),
        analyses=Analyses(),
        predictions=Predictions(),
        forecasts=(forecast, failed),
    )
    html = render_html(result).replace("<wbr>", "")
    section = html[html.index('<section id="forecasting">') :]
    section = section[: section.index("</section>")]
    assert "Forecasting the failure" in section
    assert "fig3a" in section and "broken" in section
    assert section.count("<tr><td") == len(forecast.cuts) + 1
    assert "the layer has not slipped" in section
    last = forecast.cuts[-1]
    assert f"{last.force * 1e3:.4g}" in section  # F_peak in mN
    assert "converged</dt><dd>yes" in section
    # the intervals are written with digits enough that their two ends differ
    for low, high in re.findall(r"\[([-\d.]+), ([-\d.]+)\]", section):
        assert low != high
    assert "observed failure force F_f (the largest force held)" in section
