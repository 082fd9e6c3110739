"""The league on a small fleet: what must hold at a few records a cell (the full league, with
at least 500 records a cell, is ``benchmarks/bench_forecast.py league``), and the residuals'
verdict on records that do and do not follow the model."""

import math

import numpy as np
import pytest

from granflow.forecast.discrepancy import SIGNIFICANT, assess, unreviewed
from granflow.forecast.failure import forecast_failure
from granflow.forecast.families import family_record, planted_drift
from granflow.forecast.league import METHODS, league, one_record, table
from granflow.forecast.loading import fit_loading
from granflow.forecast.results import BaselineForecast


def perfect(record, until):
    """A forecast that knows the truth: uniform over the 0.2 s about it."""
    truth = record.failure
    return BaselineForecast(
        method="perfect",
        time=truth,
        time_interval=(truth - 0.1, truth + 0.1),
        until=until,
        level=0.9,
        exponent=math.nan,
        n_points=record.t.size,
        approaching=True,
        cdf={"time": [truth - 0.1, truth + 0.1], "probability": [0.0, 1.0]},
    )


@pytest.fixture(scope="module")
def small_league():
    records = [family_record(seed, family) for family in ("model", "power law") for seed in (0, 1)]
    methods = [*METHODS, perfect]
    names = [*METHODS, "perfect"]
    return [e for r in records for e in one_record(r, (0.25,), methods, names)]


def test_every_score_of_the_small_league_is_finite(small_league):
    cells = table(small_league)
    assert {key[2] for key in cells} == {*METHODS, "perfect"}
    for key, s in cells.items():
        assert s.count == 2, key
        for value in (s.crps, s.log_score, s.interval_score, s.crps_se):
            assert math.isfinite(value), (key, value)


def test_the_perfect_forecast_scores_best(small_league):
    cells = table(small_league)
    for family in ("model", "power law"):
        best = cells[(family, 0.25, "perfect")]
        for method in METHODS:
            other = cells[(family, 0.25, method)]
            assert best.crps < other.crps, (family, method)
            assert best.log_score < other.log_score, (family, method)
            assert best.interval_score < other.interval_score, (family, method)
            assert best.skill(other)[0] > 0


def test_the_league_runs_its_seeds_and_families():
    entries = league([3], families=("gaps",), leads=(0.1,), methods=("inverse velocity",))
    assert [(e.family, e.seed, e.lead, e.method) for e in entries] == [
        ("gaps", 3, 0.1, "inverse velocity")
    ]
    assert entries[0].until == pytest.approx(0.9 * entries[0].truth)


def test_the_declining_rule_triggers_on_a_record_with_a_planted_drift():
    record = planted_drift(family_record(1, "model"), share=0.5)
    until = 0.75 * record.failure
    ff = forecast_failure(record.t, record.slip, record.force, until=until)
    assert ff.declined and ff.time is None and ff.cdf["time"] == []
    assert "does not follow the model" in ff.message
    with unreviewed():
        assert not forecast_failure(record.t, record.slip, record.force, until=until).declined
    clean = family_record(1, "model")
    kept = forecast_failure(clean.t, clean.slip, clean.force, until=until)
    assert not kept.declined and kept.time is not None
    entry = next(e for e in one_record(record, (0.25,), ("granflow",)) if e.method == "granflow")
    assert entry.declined and entry.would_cover is not None


def test_white_residuals_keep_their_noise_and_red_ones_widen_it():
    rng = np.random.default_rng(5)
    white = rng.standard_normal(2000)
    check = assess(white, 1.0, 1.0)
    assert check.inflation == 1.0 and check.verdict == ""
    red = np.empty(2000)
    red[0] = 0.0
    for k in range(1, red.size):  # AR(1), phi = 0.8: integrated time (1 + phi) / (1 - phi) = 9
        red[k] = 0.8 * red[k - 1] + rng.standard_normal()
    check = assess(red / red.std(), 1.0, 1.0)
    assert check.inflation > SIGNIFICANT and check.inflation == pytest.approx(9.0, rel=0.35)
    assert "scatter" in assess(white, 5.0, 1.0).verdict  # five times the record's own noise
    runaway = white.copy()
    runaway[-200:] += 1.0  # the last tenth off by a standard deviation: z ~ 14 / sqrt(tau)
    assert "runs away" in assess(runaway, 1.0, 1.0).verdict


def test_a_gap_in_a_ramp_is_no_step():
    t = np.concatenate([np.arange(0.0, 50.0), np.arange(80.0, 120.0)])
    force = 1e-4 * t + 1e-7 * np.random.default_rng(0).standard_normal(t.size)
    assert fit_loading(t, force).kind == "ramp"
    steps = np.where(t < 60.0, 1e-3, 2e-3)
    assert fit_loading(t, steps).kind == "steps"
