"""The quasi-static staircase's forecast step by step: the layer fails at the start of a step,
so the forecast gives each step a probability (the confidence distribution of the failure's
force, from its profile likelihood) and the time interval is a run of whole steps. Records
are generated here with brentq on friction_slip (not the forecast's own inversion)."""

import math
import types

import numpy as np
import pytest
from scipy.optimize import brentq
from scipy.stats import chi2, kstest, norm

import granflow as gf
from granflow.forecast.calibration import step_pit
from granflow.forecast.failure import _confidence
from granflow.forecast.likelihood import Fit
from granflow.forecast.results import FailureForecast

PARAMS = gf.Params(a=3.3e-3, alpha=5.0e4, Fd=11.0e-3, x0=0.3e-6)


def staircase(offset, steps=12, duration=15.0, noise=3e-9, seed=0):
    """(t, slip, force, failure time): steps of F_peak / (steps - offset) every ``duration``
    seconds, so that F_peak lies ``offset`` of a step above the last level it holds; the
    layer fails at the start of step ``steps`` (the first above F_peak)."""
    pk = gf.peak(PARAMS)
    step = pk.force / (steps - offset)
    failure = (steps - 1) * duration
    t = np.arange(0.0, failure, 1.0)
    sigma = step * (1.0 + np.floor(t / duration))
    start = gf.friction_slip(PARAMS.x0, PARAMS)
    x = np.array(
        [
            PARAMS.x0
            if s <= start
            else brentq(lambda z, s=s: gf.friction_slip(z, PARAMS) - s, PARAMS.x0, pk.slip)
            for s in sigma
        ]
    )
    rng = np.random.default_rng(seed)
    return t, x - PARAMS.x0 + noise * rng.standard_normal(t.size), sigma, failure


def _fit(best, sigma, forces, interval, threshold):
    """A Fit whose profile is exactly quadratic: delta chi-square ((P - best) / sigma)^2."""
    path = tuple((p, ((p - best) / sigma) ** 2, None, np.empty(0)) for p in forces)
    return Fit(
        params=None,
        peak_force=best,
        chisqr=0.0,
        noise=1.0,
        path=path,
        interval=interval,
        threshold=threshold,
    )


def test_a_quadratic_profile_gives_the_normal_distribution():
    """Known noise: the signed root of a quadratic profile is (P - best) / sigma, so the
    confidence distribution is the normal CDF, inside the path, at the interval's ends and
    extrapolated beyond them."""
    best, sigma = 20e-3, 0.4e-3
    threshold = float(chi2.ppf(0.9, 1))
    half = math.sqrt(threshold) * sigma
    forces = best + sigma * np.array([-2.0, -1.0, -0.3, 0.5, 1.2, 2.1])
    fit = _fit(best, sigma, forces, (best - half, best + half), threshold)
    known = types.SimpleNamespace(floor=0.0, noise=1.0, size=200)
    confidence = _confidence(fit, known)
    for z in (-3.0, -1.645, -1.0, -0.1, 0.0, 0.7, 1.645, 2.5, 3.5):
        assert confidence(best + z * sigma) == pytest.approx(norm.cdf(z), abs=1e-9)


def test_an_estimated_noise_gives_students_t_and_an_open_profile_no_upper_tail():
    best, sigma = 20e-3, 0.4e-3
    threshold = 3.0
    forces = best + sigma * np.array([-2.5, -1.0, 0.5, 1.0, 1.5])
    fit = _fit(best, sigma, forces, (best - math.sqrt(threshold) * sigma, math.inf), threshold)
    estimated = types.SimpleNamespace(floor=0.0, noise=None, size=14)
    confidence = _confidence(fit, estimated)
    from scipy.stats import t as student

    assert confidence(best - 1.0 * sigma) == pytest.approx(student.cdf(-1.0, 10), abs=1e-9)
    assert confidence(best + 1.2 * sigma) == pytest.approx(student.cdf(1.2, 10), abs=1e-9)
    assert math.isnan(confidence(best + 2.0 * sigma))  # above the path, open above


@pytest.fixture(scope="module")
def mid_step():
    t, slip, force, failure = staircase(offset=0.5)
    return gf.forecast_failure(t, slip, force, until=0.9 * failure), failure


@pytest.fixture(scope="module")
def near_a_level():
    """F_peak 0.005 of a step (about 10 uN, the size of its late interval) above the last
    level it holds: the forecast cannot tell that level's step from the next."""
    t, slip, force, failure = staircase(offset=0.995)
    return gf.forecast_failure(t, slip, force, until=0.9 * failure), failure


def test_the_steps_hold_all_the_probability(mid_step, near_a_level):
    for ff, _ in (mid_step, near_a_level):
        steps = ff.steps
        probability = np.array(steps["probability"])
        assert np.all(probability >= 0.0)
        assert probability.sum() + steps["below"] + steps["beyond"] == pytest.approx(1.0, abs=1e-9)
        assert np.all(np.diff(steps["step"]) == 1)
        assert np.all(np.diff(steps["level"]) > 0)
        assert np.all(np.array(steps["earliest"]) <= np.array(steps["latest"]))
        assert steps["earliest"][0] >= ff.until  # not failed at the cut
        assert ff.time_probability >= ff.level


def test_a_peak_mid_step_is_one_certain_step(mid_step):
    ff, failure = mid_step
    table = ff.step_table()
    likely = table[table.probability > 1e-3]
    assert len(likely) == 1
    (row,) = likely.itertuples()
    assert row.step == 12
    assert row.earliest <= failure <= row.latest
    assert ff.time_interval == (row.earliest, row.latest)
    assert ff.time_probability > 0.999


def test_a_peak_at_a_level_splits_between_two_steps(near_a_level):
    """The interval holds both steps and the failure, each step at least 5 % likely."""
    ff, failure = near_a_level
    table = ff.step_table()
    likely = table[table.probability > 0.05]
    assert list(likely.step) == [11, 12]
    assert ff.time_interval[0] <= likely.earliest.iloc[0]
    assert ff.time_interval[1] >= likely.latest.iloc[1]
    assert ff.time_interval[0] <= failure <= ff.time_interval[1]
    assert "fails at the start of step 11" in ff.report()


def test_the_steps_survive_the_round_trip(near_a_level):
    ff, _ = near_a_level
    back = FailureForecast.from_dict(ff.to_dict())
    assert back.steps["step"] == ff.steps["step"]
    assert back.steps["probability"] == ff.steps["probability"]
    assert back.time_probability == ff.time_probability
    assert isinstance(back.n_points, int) and back.n_points == ff.n_points
    assert back.steps["beyond"] == ff.steps["beyond"] or math.isnan(ff.steps["beyond"])


def test_a_ramp_has_no_steps():
    pk = gf.peak(PARAMS)
    t = np.arange(0.0, 200.0, 1.0)
    rate = pk.force / 200.0
    x = np.array(
        [
            brentq(lambda z, s=s: gf.friction_slip(z, PARAMS) - s, PARAMS.x0, pk.slip)
            if s > gf.friction_slip(PARAMS.x0, PARAMS)
            else PARAMS.x0
            for s in rate * t
        ]
    )
    slip = x - PARAMS.x0 + 3e-9 * np.random.default_rng(1).standard_normal(t.size)
    ff = gf.forecast_failure(t, slip, rate * t, until=170.0)
    assert ff.steps is None
    assert ff.time_probability == ff.level
    assert ff.step_table().empty


def test_the_pit_of_a_certain_step_is_the_uniform_draw():
    steps = {
        "step": [5, 6, 7],
        "level": [1.0, 2.0, 3.0],
        "earliest": [10.0, 20.0, 30.0],
        "latest": [11.0, 21.0, 31.0],
        "probability": [0.2, 0.5, 0.25],
        "below": 0.03,
        "beyond": 0.02,
    }
    forecast = types.SimpleNamespace(steps=steps)
    draw = np.random.default_rng(4).uniform()
    assert step_pit(forecast, 20.5, np.random.default_rng(4)) == pytest.approx(0.23 + 0.5 * draw)
    assert step_pit(forecast, 5.0, np.random.default_rng(4)) == pytest.approx(0.03 * draw)
    assert step_pit(forecast, 40.0, np.random.default_rng(4)) == pytest.approx(0.98 + 0.02 * draw)
    open_above = types.SimpleNamespace(steps={**steps, "beyond": math.nan})
    assert math.isnan(step_pit(open_above, 40.0, np.random.default_rng(4)))


def test_the_step_probabilities_are_calibrated_over_seeds():
    """Twelve staircases with F_peak anywhere in its step, cut at half the time to failure
    (where the steps are uncertain): the randomised PITs of the true step are uniform (a
    forecast that put its mass on the wrong steps gives PITs near 0 or 1)."""
    pits = []
    for seed in range(12):
        rng = np.random.default_rng(100 + seed)
        offset = float(rng.uniform(0.05, 0.95))
        t, slip, force, failure = staircase(offset=offset, noise=1e-8, seed=seed)
        ff = gf.forecast_failure(t, slip, force, until=0.5 * failure)
        pits.append(step_pit(ff, failure, rng))
    pits = np.array(pits)
    assert np.all(np.isfinite(pits))
    assert kstest(pits, "uniform").pvalue > 1e-3


def test_the_calibration_runs_the_protocols_and_leads_it_is_given():
    from granflow.forecast.calibration import calibrate

    outcomes = calibrate([9001], protocols=("steps anywhere",), leads=(0.1,))
    assert {(o.protocol, o.lead) for o in outcomes} == {("steps anywhere", 0.1)}
    (model,) = [o for o in outcomes if o.method == "model"]
    assert model.claimed >= 0.9
    assert 0.0 <= model.pit <= 1.0
