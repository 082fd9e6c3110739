"""forecast_failure against ramps generated directly from the model: the quasi-static slip
x(t) = F^-1(sigma(t)) found by brentq on friction_slip (not the forecast's own inversion),
slip = x - x0, failure when sigma reaches F_peak."""

import math

import numpy as np
import pytest
from rising_branch import branch_slip
from scipy.optimize import brentq

import granflow as gf
from granflow.errors import InvalidDataError
from granflow.forecast import Prior

PARAMS = gf.Params(a=3.3e-3, alpha=5.0e4, Fd=11.0e-3, x0=0.3e-6)
RATE = 0.065e-3  # N/s


def ramp(params=PARAMS, rate=RATE, noise=5e-9, seed=0):
    """(t, slip, force, failure time) of a ramp from zero, sampled once a second."""
    failure = gf.peak(params).force / rate
    t = np.arange(0.0, failure, 1.0)
    sigma = rate * t
    rng = np.random.default_rng(seed)
    return t, branch_slip(sigma, params) + noise * rng.standard_normal(t.size), sigma, failure


@pytest.fixture(scope="module")
def record():
    return ramp()


def test_a_late_cut_dates_the_failure_within_its_interval(record):
    t, slip, force, failure = record
    ff = gf.forecast_failure(t, slip, force, until=0.9 * failure)
    low, high = ff.time_interval
    assert low <= failure <= high
    assert math.isfinite(high)
    assert abs(ff.time - failure) < 0.05 * failure
    assert ff.force_interval[0] <= gf.peak(PARAMS).force <= ff.force_interval[1]
    assert ff.time_interval[0] >= ff.until  # it has not failed yet at the cut
    assert ff.loading.kind == "ramp"


def test_the_forecast_tightens_as_the_cut_nears_the_failure(record):
    t, slip, force, failure = record
    early = gf.forecast_failure(t, slip, force, until=0.75 * failure)
    late = gf.forecast_failure(t, slip, force, until=0.9 * failure)
    width = late.time_interval[1] - late.time_interval[0]
    assert width < early.time_interval[1] - early.time_interval[0]


def test_a_prior_from_the_campaign_narrows_the_interval(record):
    t, slip, force, failure = record
    alone = gf.forecast_failure(t, slip, force, until=0.75 * failure)
    prior = Prior(a=(3.3e-3, 0.1e-3), alpha=(5.0e4, 2e3), Fd=(11e-3, 0.2e-3))
    helped = gf.forecast_failure(t, slip, force, until=0.75 * failure, prior=prior)
    assert helped.time_interval[0] <= failure <= helped.time_interval[1]
    assert math.isfinite(helped.time_interval[1])
    assert helped.time_interval[1] - helped.time_interval[0] < (
        alone.time_interval[1] - alone.time_interval[0]
    )


def test_small_calibration_at_a_quarter_lead():
    """Twelve seeds over three parameter sets, cut at 75 % of the time to failure: the 90 %
    intervals cover the truth in at least 10 of 12 (binomial: P(<= 9 | 0.9) = 11 %)."""
    sets = [PARAMS, gf.Params(a=6e-3, alpha=7e4, Fd=20e-3, x0=0.5e-6)]
    covered = 0
    for seed in range(12):
        params = sets[seed % 2]
        t, slip, force, failure = ramp(params, rate=gf.peak(params).force / 200.0, seed=seed)
        ff = gf.forecast_failure(t, slip, force, until=0.75 * failure)
        covered += ff.time_interval[0] <= failure <= ff.time_interval[1]
    assert covered >= 10


def test_a_staircase_fails_at_the_first_step_above_the_peak():
    strength = gf.peak(PARAMS).force
    step, duration = strength / 11.5, 15.0
    failure = 11 * duration  # the 12th step, the first above F_peak, starts here
    t = np.arange(0.0, failure, 1.0)
    sigma = step * (1 + np.floor(t / duration))
    slip = branch_slip(sigma, PARAMS) + 5e-9 * np.random.default_rng(3).standard_normal(t.size)
    ff = gf.forecast_failure(t, slip, sigma, until=0.9 * failure)
    assert ff.loading.kind == "steps"
    assert ff.time_interval[0] <= failure <= ff.time_interval[1]


def test_the_slip_noise_is_estimated_at_its_true_level(record):
    """The profile's scale is the residual noise: a noise estimate 50x too large (as a fit
    stopped at its start gives) makes every interval far too wide."""
    t, slip, force, failure = record
    for cut in (0.5, 0.9):
        ff = gf.forecast_failure(t, slip, force, until=cut * failure)
        assert 0.75 * 5e-9 < ff.sigma < 1.25 * 5e-9


def test_a_staircase_between_samples_is_dated_within_the_sampling():
    """Steps of 17.3 s sampled once a second: each step shows at the first sample after it
    began, so the failure (the start of the first step above F_peak, 11 x 17.3 s) is known only
    to within the sampling; the interval must hold it and stay that tight near failure."""
    strength = gf.peak(PARAMS).force
    step, duration = strength / 11.5, 17.3
    failure = 11 * duration
    t = np.arange(0.0, failure, 1.0)
    sigma = step * (1 + np.floor(t / duration))
    slip = branch_slip(sigma, PARAMS) + 2e-9 * np.random.default_rng(4).standard_normal(t.size)
    ff = gf.forecast_failure(t, slip, sigma, until=0.95 * failure)
    for k, (low, high) in enumerate(ff.loading.windows, start=1):
        assert low < k * duration <= high
    low, high = ff.time_interval
    assert low <= failure <= high
    assert high - low < 3.0
    assert ff.force_interval[0] <= strength <= ff.force_interval[1]


def test_a_record_without_approaching_failure_says_so():
    t = np.arange(0.0, 100.0)
    constant = np.full(t.size, 5e-3)
    creep = 1e-7 * np.log1p(t) + 1e-9 * np.random.default_rng(0).standard_normal(t.size)
    ff = gf.forecast_failure(t, creep, constant)
    assert ff.time is None and not ff.approaching
    assert "does not rise" in ff.message
    still = gf.forecast_failure(
        t, 1e-9 * np.random.default_rng(1).standard_normal(t.size), t * 1e-5
    )
    assert still.time is None and "not slipped" in still.message
    assert "no failure forecast" in still.report()


@pytest.mark.parametrize(
    ("change", "words"),
    [
        (lambda t, s, f: (t, np.where(t == 5, np.nan, s), f), "slip must be finite"),
        (lambda t, s, f: (t[::-1], s, f), "t must increase"),
        (lambda t, s, f: (t[:8], s[:8], f[:8]), "too short"),
        (lambda t, s, f: (t, s[:-1], f), "slip has"),
    ],
)
def test_bad_input_gets_a_clear_error(record, change, words):
    t, slip, force, _ = record
    with pytest.raises(InvalidDataError, match=words):
        gf.forecast_failure(*change(t, slip, force))


def test_the_input_is_not_modified(record):
    t, slip, force, failure = record
    copies = [a.copy() for a in (t, slip, force)]
    gf.forecast_failure(t, slip, force, until=0.9 * failure)
    for before, after in zip(copies, (t, slip, force), strict=True):
        np.testing.assert_array_equal(before, after)


def test_the_result_round_trips_through_a_dict(record):
    t, slip, force, failure = record
    ff = gf.forecast_failure(t, slip, force, until=0.6 * failure)
    back = gf.FailureForecast.from_dict(ff.to_dict())
    assert back.time == ff.time and back.time_interval == ff.time_interval
    assert back.loading == ff.loading and back.params == ff.params
    assert "Failure forecast" in back.report()


@pytest.mark.parametrize("kind", ["ramp", "steps"])
def test_the_failure_time_under_an_erroneous_history(kind):
    """Where the true history is the fitted one plus an error c0 + c1 u (u: time for a ramp,
    step index for a staircase, about the regression's origin), the failure comes when the
    *true* history reaches F_peak; the forecast dates it by the fitted history's force at
    that moment (and maps it back to F_peak for the time profile). Checked against brentq
    on the true history."""
    from granflow.forecast.loading import fit_loading
    from granflow.forecast.models import Continuation
    from granflow.forecast.quasistatic import loading_error

    t = np.arange(0.0, 150.0, 1.0)
    ramp_force, staircase = 1e-3 + 0.065e-3 * t, 1e-3 * (1.0 + np.floor(t / 12.5))
    force = ramp_force if kind == "ramp" else staircase
    loading = fit_loading(t, force + 3e-5 * np.random.default_rng(4).standard_normal(t.size))
    root, _, anchor, slope = loading_error(loading, t)
    continuation = Continuation(anchor, slope, root[-2], root[-1])
    z = np.array([1.3, -0.8])
    c0, c1 = root @ z
    assert c0 != 0 and c1 != 0
    peak_force = float(np.max(force)) + 2.5e-3
    level = continuation.level(peak_force, z)
    if kind == "ramp":
        # the true line start + c0 + (rate + c1) t reaches peak_force at t_f
        t_f = brentq(lambda s: loading.start + c0 + (loading.rate + c1) * s - peak_force, 0, 1e4)
        assert loading.force(t_f) == pytest.approx(level, rel=1e-12)
    else:
        # the first continued step whose true level reaches peak_force
        origin = len(loading.levels) - 1
        k = origin
        while loading.levels[-1] + (k - origin) * loading.step + c0 + c1 * (k - origin) < (
            peak_force
        ):
            k += 1
        index = loading._index(level)
        assert index == k
    assert level != peak_force
    assert continuation.peak_force(level, z)[0] == pytest.approx(peak_force, rel=1e-12)


def test_an_irregular_staircase_keeps_the_history_error_off_its_early_steps():
    """Steps 2 and 4 of 0.7 and 1.3 times the step height, then equal steps: the levels are
    not on a line, so each is its own step's mean. The two-coordinate history error (the
    creep forecast's) then applies to the last level (offset) and the continuation (slope)
    only, not as a tilt c0 + c1 u over the early steps (the quasi-static forecast gives every
    level its own coordinate: tests/forecast/test_forecast_steps.py), and the failure (the
    start of the 12th step, the first above F_peak) lies in the interval."""
    from granflow.forecast.quasistatic import loading_error

    strength = gf.peak(PARAMS).force
    step, duration = strength / 11.5, 15.0
    failure = 11 * duration
    t = np.arange(0.0, failure, 1.0)
    k = np.floor(t / duration)
    sigma = step * (1 + k) - 0.3 * step * ((k == 1) | (k == 3))
    rng = np.random.default_rng(0)
    slip = branch_slip(sigma, PARAMS) + 5e-9 * rng.standard_normal(t.size)
    column = sigma + 1e-2 * step * rng.standard_normal(t.size)
    until = 0.9 * failure
    ff = gf.forecast_failure(t, slip, column, until=until)
    loading = ff.loading
    assert loading.kind == "steps" and not loading.on_line
    assert loading.levels[1] == pytest.approx(1.7 * step, rel=0.01)
    assert loading.step == pytest.approx(step, rel=0.01)
    root, basis, _, _ = loading_error(loading, t[t <= until])
    last = t[t <= until] >= loading.edges[-1]
    np.testing.assert_array_equal(basis[:, 1], 0.0)  # no tilt inside the record
    np.testing.assert_array_equal(basis[:, 0], last.astype(float))  # the last level only
    assert root[0, 0] > 0 and root[1, 1] > 0  # the offset and the continuing step do vary
    assert ff.time_interval[0] <= failure <= ff.time_interval[1]
    assert ff.force_interval[0] <= strength <= ff.force_interval[1]


def test_a_noise_free_force_column_gives_the_forecast_without_the_history_error(
    record, monkeypatch
):
    """An exact ramp column has a history error of ~1e-19 N: the forecast with the two
    nuisance coordinates must be the one without them (intervals to 1e-9; the best fit,
    re-solved once more with them, to the optimiser's tolerance)."""
    from granflow.forecast import quasistatic

    t, slip, force, failure_time = record
    inner = quasistatic.loading_error

    def without_error(loading, time, each_level=False):
        root, basis, anchor, slope = inner(loading, time, each_level)
        return np.zeros_like(root), basis, anchor, slope

    for cut in (0.75, 0.9):
        with_error = gf.forecast_failure(t, slip, force, until=cut * failure_time)
        with monkeypatch.context() as patch:
            patch.setattr(quasistatic, "loading_error", without_error)
            without = gf.forecast_failure(t, slip, force, until=cut * failure_time)
        assert with_error.sigma == pytest.approx(without.sigma, rel=1e-9)
        for name in ("time_interval", "force_interval"):
            np.testing.assert_allclose(getattr(with_error, name), getattr(without, name), rtol=1e-9)
        assert with_error.time == pytest.approx(without.time, rel=1e-7)
        assert with_error.force == pytest.approx(without.force, rel=1e-7)


def test_a_ramp_read_with_an_offset_and_slope_error_is_still_dated():
    """The force column is the true ramp plus a deliberate error (-1 standard error of the
    regression's offset, +1.5 of its slope, for 30 uN of column noise) plus that noise; the
    slip follows the true ramp. The failure time, where the true history reaches the model's
    F_peak (brentq), lies in the interval."""
    strength = gf.peak(PARAMS).force
    truth = brentq(lambda s: RATE * s - strength, 0.0, 1e4)
    t = np.arange(0.0, strength / RATE, 1.0)
    sigma = RATE * t
    rng = np.random.default_rng(0)
    slip = branch_slip(sigma, PARAMS) + 2e-9 * rng.standard_normal(t.size)
    until, force_noise = 0.9 * truth, 3e-5
    cut = t <= until
    cov = np.polyfit(t[cut], sigma[cut], 1, cov="unscaled")[1] * force_noise**2
    offset, slope = -1.0 * math.sqrt(cov[1, 1]), 1.5 * math.sqrt(cov[0, 0])
    column = sigma + offset + slope * t + force_noise * rng.standard_normal(t.size)
    ff = gf.forecast_failure(t, slip, column, until=until)
    assert ff.loading.kind == "ramp"
    assert ff.time_interval[0] <= truth <= ff.time_interval[1]
    assert math.isfinite(ff.time_interval[1])
    assert ff.time_interval[0] >= until
