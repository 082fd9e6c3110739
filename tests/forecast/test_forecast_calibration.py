"""A small calibration of the failure forecasts (the >= 200-seed study is
benchmarks/bench_forecast.py): ramps and staircases generated here with brentq on
friction_slip (not the forecast's own inversion of the rising branch), cut at 50 %, 25 % and
10 % of the time to failure; the truth is the model's peak (gf.peak, tested against 40-digit
values in tests/model)."""

import math

import numpy as np
import pytest
from rising_branch import branch_slip

import granflow as gf
from granflow.forecast import inverse_velocity_forecast

SETS = (
    gf.Params(a=3.3e-3, alpha=5.0e4, Fd=11.0e-3, x0=0.3e-6),
    gf.Params(a=1.5e-3, alpha=3.5e4, Fd=5.0e-3, x0=0.2e-6),
)
LEADS = (0.5, 0.25, 0.1)
SEEDS = range(700, 708)


def record(seed, protocol):
    """(t, slip, force, failure time, F_peak): quasi-static slip x = F^-1(max force so far)."""
    rng = np.random.default_rng(seed)
    params = SETS[seed % 2]
    pk = gf.peak(params)
    failure = float(rng.uniform(150.0, 300.0))
    if protocol == "ramp":
        rate = pk.force / failure

        def sigma(t):
            return rate * t

    else:
        steps = int(rng.integers(10, 16))
        step, duration = pk.force / (steps - 0.5), failure / steps
        failure = (steps - 1) * duration  # the first step above F_peak starts here

        def sigma(t):
            return step * (1.0 + np.floor(t / duration))

    t = np.arange(0.0, failure, 1.0)
    noise = (2e-9, 10e-9)[seed % 2]
    slip = branch_slip(sigma(t), params) + noise * rng.standard_normal(t.size)
    force = sigma(t) + 3e-5 * rng.standard_normal(t.size)
    return t, slip, force, failure, pk.force


@pytest.fixture(scope="module")
def outcomes():
    rows = []
    for seed in SEEDS:
        for protocol in ("ramp", "steps"):
            t, slip, force, failure, strength = record(seed, protocol)
            for lead in LEADS:
                cut = (1.0 - lead) * failure
                ff = gf.forecast_failure(t, slip, force, until=cut)
                iv = inverse_velocity_forecast(t, slip, until=cut)
                rows.append(
                    {
                        "protocol": protocol,
                        "lead": lead,
                        "time": ff.time_interval[0] <= failure <= ff.time_interval[1],
                        "force": ff.force_interval[0] <= strength <= ff.force_interval[1],
                        "error": math.inf if ff.time is None else abs(ff.time - failure),
                        "baseline": math.inf if iv.time is None else abs(iv.time - failure),
                    }
                )
    return rows


def test_the_90_percent_intervals_cover_about_90_percent(outcomes):
    """48 forecasts: F_peak covered in 39 to 47 (binomial at 0.9: P(<= 38) = 1.9 %,
    P(48) = 0.6 %; the noise level 50x too large of an earlier version covered all 48), and
    the time at least 39 times (a staircase's time may cover more: its failure can only come
    at a step start, and a forecast that knows the step covers it nearly always)."""
    force = sum(row["force"] for row in outcomes)
    time = sum(row["time"] for row in outcomes)
    assert 39 <= force <= 47
    assert time >= 39
    ramps = [row["time"] for row in outcomes if row["protocol"] == "ramp"]
    assert 18 <= sum(ramps) <= 23  # 24 ramp forecasts: P(<= 17 | 0.9) = 0.7 %, P(24) = 8 %


@pytest.mark.parametrize("protocol", ["ramp", "steps"])
def test_the_model_beats_the_inverse_velocity_method_three_times_at_half_lead(outcomes, protocol):
    rows = [r for r in outcomes if r["protocol"] == protocol and r["lead"] == 0.5]
    model = np.median([r["error"] for r in rows])
    baseline = np.median([r["baseline"] for r in rows])
    assert model <= baseline / 3.0
