"""The forecast core on the fitting engine: what an independent check found failing on
records the calibration study never saw (issue 27), each reproduced on records of the same
kind made here (the quasi-static slip found by brentq on friction_slip, not the forecast's
own inversion), and what the core adds: one confidence distribution behind every
interval and ``probability_within``, the live ``RunningForecast``, a record that shows its
own failure, the fits' vocabulary."""

import math
import re

import numpy as np
import pytest
from rising_branch import branch_slip
from scipy.special import expi

import granflow as gf
from granflow.errors import InvalidDataError
from granflow.forecast.calibration import step_pit

#: Parameter sets unlike the calibration study's: a light tube, a heavy one, a fine grain.
SETS = (
    gf.Params(a=1.2e-3, alpha=1.5e5, Fd=4e-3, x0=0.1e-6),
    gf.Params(a=8e-3, alpha=2.0e4, Fd=25e-3, x0=1.0e-6),
    gf.Params(a=2.5e-3, alpha=9e4, Fd=6e-3, x0=0.05e-6),
)


def ramp(params, seed, samples=600, noise=0.01):
    """(t, slip, force, failure time): a ramp from zero that reaches F_peak at 300 s,
    ``samples`` points to failure, slip noise ``noise`` of x_peak - x0, force noise 0.2 %
    of F_peak."""
    rng = np.random.default_rng(seed)
    top = gf.peak(params)
    t = np.linspace(0.0, 300.0, samples, endpoint=False)
    sigma = top.force / 300.0 * t
    slip = branch_slip(sigma, params) + noise * (top.slip - params.x0) * rng.standard_normal(t.size)
    return t, slip, sigma + 2e-3 * top.force * rng.standard_normal(t.size), 300.0


def staircase(params, seed, samples=600, noise=0.01, steps=12):
    """(t, slip, force, failure time): steps of 25 s, F_peak anywhere in its step (a
    uniform draw); the layer fails at the start of the first step whose level reaches
    F_peak."""
    rng = np.random.default_rng(seed)
    top = gf.peak(params)
    step = top.force / (steps - 1 + rng.uniform())
    failure = (steps - 1) * 25.0
    t = np.linspace(0.0, failure, samples, endpoint=False)
    sigma = step * (1.0 + np.floor(t / 25.0))
    slip = branch_slip(sigma, params) + noise * (top.slip - params.x0) * rng.standard_normal(t.size)
    return t, slip, sigma + 2e-3 * top.force * rng.standard_normal(t.size), failure


def test_a_fit_on_the_family_edge_reaches_below_it():
    """The check's misses at a quarter lead had the truth below the interval, whose lower end
    equalled the best fit: fits with Fd -> 0, where a lower F_peak at the fit's own a, alpha,
    x0 has no curve. In the peak coordinates every F_peak has one; this record (the light
    tube, 1 % noise) is one the earlier code dated "not before 337.6 s", truth 300 s."""
    params = SETS[0]
    t, slip, force, failure = ramp(params, 2)
    ff = gf.forecast_failure(t, slip, force, until=0.75 * failure)
    low, high = ff.time_interval
    assert low <= failure <= high
    assert ff.force_interval[0] <= gf.peak(params).force <= ff.force_interval[1]
    if ff.time is not None:
        assert low < ff.time  # the interval reaches below the point forecast


def test_a_quarter_lead_is_calibrated_on_records_unlike_the_study():
    """30 ramps of the three sets at a quarter lead, 1 % noise (the check: 57-73 %): the
    90 % interval holds the failure in at least 24 (binomial at 0.9: P(<= 23) = 2.6 %)."""
    covered = 0
    for seed in range(10):
        for params in SETS:
            t, slip, force, failure = ramp(params, 100 + seed)
            low, high = gf.forecast_failure(t, slip, force, until=0.75 * failure).time_interval
            covered += low <= failure <= high
    assert covered >= 24


def test_half_way_up_a_noisy_ramp_there_is_a_forecast():
    """At half lead the earlier code gave no forecast ("the layer has not slipped beyond the
    noise") while the slip had reached 5.8 times its noise. The record carries information
    (the trend against a slip that does not move is overwhelming): a forecast with a
    distribution comes (whether its interval holds the failure is the calibration study's
    question, not one record's)."""
    params = SETS[1]
    t, slip, force, failure = ramp(params, 7, noise=0.015)
    cut = t <= 0.5 * failure
    noise = 0.015 * (gf.peak(params).slip - params.x0)
    assert 4.0 * noise < float(np.ptp(branch_slip(force[cut], params))) < 8.0 * noise
    ff = gf.forecast_failure(t, slip, force, until=0.5 * failure)
    assert "not slipped" not in ff.message
    assert ff.until < ff.time_interval[0] < failure + 300.0
    assert ff.cdf["time"]
    assert 0.0 < ff.probability_within(failure) <= 1.0


def test_a_record_of_noise_alone_is_declined():
    """A slip that does not move (noise alone) says nothing of the failure: no date, and no
    probability of one."""
    rng = np.random.default_rng(3)
    t = np.arange(0.0, 200.0)
    ff = gf.forecast_failure(t, 1e-8 * rng.standard_normal(t.size), 1e-5 * t)
    assert ff.time is None and not ff.approaching
    assert "not slipped beyond the noise" in ff.message
    assert ff.probability_within(1e4) == 0.0


@pytest.fixture(scope="module")
def anywhere():
    """Staircases with F_peak anywhere in its step, cut at 60 % of the time to failure."""
    out = []
    for seed in range(8):
        for params in SETS:
            t, slip, force, failure = staircase(params, 200 + seed)
            out.append((gf.forecast_failure(t, slip, force, until=0.6 * failure), failure))
    return out


def test_every_staircase_forecast_lists_its_steps(anywhere):
    """The check: 35 of 80 such records got no forecast, and several a time and an open
    interval with an empty step table."""
    for ff, _ in anywhere:
        assert ff.steps is not None and ff.steps["step"]
        total = sum(ff.steps["probability"]) + ff.steps["below"] + ff.steps["beyond"]
        assert total == pytest.approx(1.0, abs=1e-9)


def test_the_step_probabilities_are_calibrated(anywhere):
    """The randomised PIT of the true step (Czado et al. 2009), uniform where the step
    probabilities are calibrated: its central 90 % holds at least 19 of the 24 (binomial at
    0.9: P(<= 18) = 3.7 %), and the PITs' mean is near 1/2 (the check found the true step at
    0.02-0.05 on average while the most probable claimed 0.40-0.53)."""
    pits = np.array(
        [step_pit(ff, truth, np.random.default_rng(k)) for k, (ff, truth) in enumerate(anywhere)]
    )
    assert np.all(np.isfinite(pits))
    assert np.sum((pits > 0.05) & (pits < 0.95)) >= 19
    assert 0.3 < pits.mean() < 0.7


def test_near_failure_the_steps_claim_what_they_hold():
    """At 85 % of the time to failure the check found the steps' intervals held the failure
    in 83-89 % while claiming 62-71 %: the interval of whole steps now holds it about as
    often as its steps' probabilities say (24 records: within 0.2)."""
    held, claimed = [], []
    for seed in range(8):
        for params in SETS:
            t, slip, force, failure = staircase(params, 300 + seed, noise=0.005)
            ff = gf.forecast_failure(t, slip, force, until=0.85 * failure)
            low, high = ff.time_interval
            held.append(low <= failure <= high)
            claimed.append(ff.time_probability)
    assert abs(np.mean(held) - np.mean(claimed)) < 0.2


def _startup(params, velocity, seed, fraction):
    """(t, force, peak): a start-up sampled four times a second up to ``fraction`` of its
    peak time, force noise 0.03 mN; Eq. 3 evaluated here with scipy's expi."""
    top = gf.peak(params, velocity=velocity)
    t = np.arange(0.25, fraction * top.time, 0.25)
    t = t[velocity * t > params.x0]
    k, t0 = params.alpha * velocity, params.x0 / velocity
    force = params.a * np.exp(-k * t) * (expi(k * t) - expi(k * t0)) + params.Fd * (
        1.0 - np.exp(-k * t)
    )
    noise = 3e-5 * np.random.default_rng(seed).standard_normal(t.size)
    return t, force + noise, top


def test_the_peak_time_is_covered_as_often_as_its_force():
    """The check: F_peak held in 89 %, the peak's time in 84 %. The time is now the profile
    of the peak's slip itself (a coordinate of the fit): over 30 start-ups of three sets cut
    at 70 % of the peak time, both hold in at least 24 (P(<= 23 | 0.9) = 2.6 %)."""
    force_held = time_held = 0
    for seed in range(10):
        for params in SETS:
            velocity = 0.86e-6
            t, force, top = _startup(params, velocity, seed, 0.7)
            fc = gf.forecast_peak((t, force), velocity=velocity)
            force_held += fc.force_interval[0] <= top.force <= fc.force_interval[1]
            time_held += fc.time_interval[0] <= top.time <= fc.time_interval[1]
    assert force_held >= 24
    assert time_held >= 24


@pytest.mark.parametrize("cut", [32.5, 44.5])
def test_an_early_interval_reaches_every_valley_of_the_likelihood(cut):
    """Early on a slow ramp (a sixth to a fifth of the way to failure, the slip 100 times its
    noise) the record is fitted nearly as well by a failure at 90 s as at 170 s: two minima
    of the likelihood 0.3 apart in chi-square. The profile followed the first valley alone
    and closed the interval at its wall ([86.8, 94.6] s at 44.5 s; the layer fails at
    210.8 s); each minimum within reach now gets its own scan, and the interval holds both."""
    params = gf.Params(a=3.3e-3, alpha=5e4, Fd=11e-3, x0=0.3e-6)
    top = gf.peak(params)
    rate = 0.065e-3  # N/s
    failure = top.force / rate
    t = np.arange(0.0, failure, 0.5)
    force = rate * t + 2e-6 * np.random.default_rng(2).standard_normal(t.size)
    slip = branch_slip(rate * t, params) + 2e-9 * np.random.default_rng(1).standard_normal(t.size)
    ff = gf.forecast_failure(t, slip, force, until=cut)
    low, high = ff.time_interval
    assert low <= failure <= high


def test_probability_within_is_the_distribution_behind_the_interval():
    """``probability_within`` reads the failure time's CDF: 0 at the cut, rising, and the
    probability between the interval's ends is the level (a central interval of a
    continuous outcome)."""
    t, slip, force, failure = ramp(SETS[2], 11, noise=0.003)
    ff = gf.forecast_failure(t, slip, force, until=0.8 * failure)
    low, high = ff.time_interval
    assert math.isfinite(high)
    assert ff.probability_within(0.0) < 1e-3
    within = [ff.probability_within(s) for s in np.linspace(0.0, 3 * (high - ff.until), 30)]
    assert np.all(np.diff(within) >= -1e-12)
    inside = ff.probability_within(high - ff.until) - ff.probability_within(low - ff.until)
    assert inside == pytest.approx(ff.level, abs=0.02)
    with pytest.raises(InvalidDataError, match="seconds"):
        ff.probability_within(-1.0)


def test_the_running_forecast_ends_where_the_one_shot_does():
    """Fed a record, its last 300 samples ten at a time, the running forecast's last answer is
    the one-shot forecast of the whole record: its noise to 1e-6, its intervals to 1e-5 (their
    ends are found to 1e-4 of the signed root, whichever way they are reached), its best fit
    where the optimiser leaves it (chi-square equal to 1e-8: its flattest direction moves
    the point forecast by a few 1e-6 and the curve's parameters by 1e-5 at that)."""
    params = SETS[0]
    t, slip, force, failure = ramp(params, 5, samples=2400, noise=0.003)
    cut = t <= 0.8 * failure
    t, slip, force = t[cut], slip[cut], force[cut]
    running = gf.RunningForecast(kind="failure", level=0.9)
    assert running.update(t[:5], slip[:5], force[:5]) is None  # too few points yet
    # the first part at once, then ten samples at a time: each warm update starts
    # from the previous optima, which is what the equality is about
    first = t.size - 300
    running.update(t[5:first], slip[5:first], force[5:first])
    for start in range(first, t.size, 10):
        last = running.update(
            t[start : start + 10], slip[start : start + 10], force[start : start + 10]
        )
    whole = gf.forecast_failure(t, slip, force)
    assert type(last) is type(whole)
    for name in ("a", "alpha", "Fd", "x0"):
        assert last.params[name] == pytest.approx(whole.params[name], rel=1e-4)
    assert last.time == pytest.approx(whole.time, rel=1e-5)
    assert last.sigma == pytest.approx(whole.sigma, rel=1e-6)
    np.testing.assert_allclose(last.time_interval, whole.time_interval, rtol=1e-5)
    np.testing.assert_allclose(last.force_interval, whole.force_interval, rtol=1e-5)
    np.testing.assert_array_equal(running.t, t)


@pytest.mark.parametrize("index", [0, 1, 2])
def test_each_update_of_a_running_forecast_is_the_one_shot_forecast_so_far(index):
    """Not only the last: each update answers as the one-shot forecast of the record it has
    seen, though it reaches the fit from the previous optima and the profiles' ends by
    Newton's steps from the previous ends (one conditional fit an end where the one-shot's
    secant search makes two or three): the point forecast to 1e-5, the noise to 1e-6, the
    intervals to 1e-4 (each end is found to 1e-4 of the signed root, and read between the
    profile's points; the one-shot's were seen 1e-4 off a scan made ten times finer, the
    running forecast's nearer it). Where the likelihood holds two minima nearly as deep,
    an update can follow the one it held before for a few updates (not on these records)."""
    t, slip, force, failure = ramp(SETS[index], 4, samples=2000, noise=0.003)
    cut = t <= 0.85 * failure
    t, slip, force = t[cut], slip[cut], force[cut]
    running = gf.RunningForecast(kind="failure", level=0.9)
    first = t.size - 200
    running.update(t[:first], slip[:first], force[:first])
    checked = 0
    for start in range(first, t.size, 10):
        stop = start + 10
        answer = running.update(t[start:stop], slip[start:stop], force[start:stop])
        if (stop - first) % 50:
            continue
        whole = gf.forecast_failure(t[:stop], slip[:stop], force[:stop])
        assert answer.time == pytest.approx(whole.time, rel=1e-5)
        assert answer.sigma == pytest.approx(whole.sigma, rel=1e-6)
        np.testing.assert_allclose(answer.time_interval, whole.time_interval, rtol=1e-4)
        np.testing.assert_allclose(answer.force_interval, whole.force_interval, rtol=1e-4)
        checked += 1
    assert checked == 4


def test_a_running_peak_forecast_follows_a_start_up():
    params, velocity = SETS[2], 0.86e-6
    t, force, top = _startup(params, velocity, 1, 0.8)
    running = gf.RunningForecast(kind="peak", velocity=velocity)
    for start in range(0, t.size, 20):
        last = running.update(t[start : start + 20], force[start : start + 20])
    whole = gf.forecast_peak((t, force), velocity=velocity)
    assert last.force == pytest.approx(whole.force, rel=1e-6)
    assert last.force_interval[0] <= top.force <= last.force_interval[1]


@pytest.mark.parametrize(
    ("arguments", "words"),
    [
        ({"kind": "creep"}, "kind must be"),
        ({"kind": "peak"}, "needs the velocity"),
        ({"level": 1.5}, "level must lie between"),
    ],
)
def test_a_running_forecast_checks_its_arguments(arguments, words):
    with pytest.raises(InvalidDataError, match=words):
        gf.RunningForecast(**arguments)


def test_a_running_forecast_refuses_time_going_back():
    running = gf.RunningForecast()
    running.update(np.arange(5.0), np.zeros(5), np.arange(5.0))
    with pytest.raises(InvalidDataError, match="increase strictly across updates"):
        running.update(np.array([3.0]), np.zeros(1), np.ones(1))
    with pytest.raises(InvalidDataError, match="takes"):
        running.update(np.array([6.0]), np.zeros(1))


def _failed_ramp(dt=1.0):
    """A simulated ramp to failure (the blue set at 0.05 mN/s fails at 275.60 s), then the
    layer flowing at 100 um/s, sampled every ``dt`` seconds to 290 s."""
    params = gf.Params(a=3.31e-3, alpha=4.19e4, Fd=10e-3, x0=0.198e-6)
    result = gf.simulate(params, gf.Protocol([gf.ForceRamp(rate=0.05e-3, duration=400.0)]))
    t = np.arange(0.0, 290.0, dt)
    slip = np.interp(t, result.t, result.displacement)
    after = t > result.failure.time
    slip[after] = slip[~after][-1] + 1e-4 * (t[after] - result.failure.time)
    slip = slip + 2e-9 * np.random.default_rng(0).standard_normal(t.size)
    return t, slip, 0.05e-3 * t, result.failure.time


@pytest.mark.parametrize("dt", [1.0, 0.01])
def test_a_record_that_shows_its_failure_says_so(dt):
    """The earlier code forecast a later failure from a ramp that already contained its
    own (on the demo's ramp t_f = 295 s while the record fails at 204 s)."""
    t, slip, force, failure = _failed_ramp(dt)
    ff = gf.forecast_failure(t, slip, force)
    assert ff.observed_failure == pytest.approx(failure, abs=dt)
    window = ff.observed["window"]
    assert window[0] < failure <= window[1] + 1e-9
    assert ff.until == window[0]  # the forecast from the samples before it
    assert ff.time_interval[0] <= failure <= ff.time_interval[1] + dt
    assert ff.probability_within(failure + 1.0 - ff.until) == 1.0
    assert "observed failure" in ff.report()
    # a cut past the failure is moved back before it, and says so
    later = gf.forecast_failure(t, slip, force, until=285.0)
    assert later.until == window[0] and "fails at" in later.message


def test_a_record_that_has_not_failed_has_no_observed_failure():
    params = SETS[2]
    t, slip, force, failure = ramp(params, 3, noise=0.003)
    assert gf.forecast_failure(t, slip, force, until=0.9 * failure).observed_failure is None


def test_the_forecast_command_prints_the_observed_failure(tmp_path, capsys):
    from granflow.cli import main
    from granflow.io.writer import write_trios

    t, slip, force, failure = _failed_ramp()
    run = gf.Run(t=t, slip=slip, velocity=np.gradient(slip, t), force=force, control="stress")
    path = tmp_path / "ramp.txt"
    write_trios(path, [run])
    assert main(["forecast", str(path), "--within", "10s"]) == 0
    out = capsys.readouterr().out
    observed = gf.forecast_failure(
        *[getattr(r, n) for r in gf.read_runs(path) for n in ("t", "slip", "force")]
    )
    assert f"observed failure: t = {observed.observed_failure:.4g} s" in out
    assert abs(observed.observed_failure - failure) <= 1.0
    assert "P(failure within 10 s" in out


def test_a_plain_csv_start_up_is_forecast_with_its_velocity(tmp_path, capsys):
    from granflow.cli import main

    params, velocity = SETS[2], 0.86e-6
    t, force, _ = _startup(params, velocity, 2, 0.7)
    path = tmp_path / "startup.csv"
    slip = velocity * t
    np.savetxt(
        path,
        np.column_stack([t, slip, force]),
        delimiter=",",
        header="time [s],slip [m],force [N]",
        comments="",
    )
    assert main(["forecast", str(path), "--velocity", "0.86um/s"]) == 0
    out = capsys.readouterr().out
    assert "Peak forecast" in out
    assert main(["forecast", str(path), "--velocity", "0.86"]) == 2  # no unit


def test_the_forecast_help_reads_as_written(capsys):
    from granflow.cli import main

    assert main(["forecast", "--help"]) == 0
    out = capsys.readouterr().out
    assert "90 % intervals" in out and "%%" not in out


def test_the_old_names_warn_and_name_the_new_ones():
    t, slip, force, failure = ramp(SETS[2], 4, noise=0.003)
    with pytest.warns(DeprecationWarning, match="sigma="):
        ff = gf.forecast_failure(t, slip, force, until=0.9 * failure, noise=2e-9)
    assert ff.sigma == 2e-9
    with pytest.warns(DeprecationWarning, match=r"\.sigma"):
        assert ff.noise == ff.sigma
    params = ff.to_params()
    assert isinstance(params, gf.Params)
    assert params.a == ff.params["a"]
    with (
        pytest.warns(DeprecationWarning, match="sigma="),
        pytest.raises(InvalidDataError, match="not both"),
    ):
        gf.forecast_failure(t, slip, force, noise=1e-9, sigma=1e-9)


def test_an_empty_record_is_an_error_not_a_crash():
    with pytest.raises(InvalidDataError, match="too short: 0 points"):
        gf.forecast_failure([], [], [])


@pytest.mark.parametrize("offset", [2e-6, 20e-6])
def test_a_slip_that_does_not_start_at_zero_is_told_so(offset):
    """A record whose slip column starts off zero (an export that does not reset the
    deflection) does not follow the model, whose slip clock starts at 0 with the loading: the
    code before issue 27 dated such a ramp at 162 s with the truth at 211 s and an interval
    open above from 161.8 s. It is declined, and the message says where the slip starts and
    what to do."""
    t, slip, force, failure = ramp(SETS[1], 3, noise=0.001)
    shifted = gf.forecast_failure(t, slip + offset, force, until=0.75 * failure)
    assert shifted.declined and shifted.time is None
    start = re.search(r"its slip starts at ([\d.]+) µm, not at 0", shifted.message)
    assert start and float(start.group(1)) == pytest.approx(offset * 1e6, abs=0.1)
    assert "subtract the slip there" in shifted.message


def test_a_profile_end_far_beyond_the_range_is_no_crash():
    """A study ramp (seed 200177 of the calibration design) whose force profile ran so far
    out that its end's exponential overflowed: ``OverflowError: math range error`` on the
    way to the running forecast's hints. It is forecast, and its interval holds the truth."""
    from granflow.forecast.calibration import draw

    case = draw(200177, "ramp")
    ff = gf.forecast_failure(case.t, case.slip, case.force, until=0.9 * case.failure)
    assert ff.time_interval[0] <= case.failure <= ff.time_interval[1]


def test_a_profile_takes_only_the_lent_points_that_undercut_it():
    """with_points: of the points another profile of the same likelihood lends, a profile
    takes those lower than its own there (by more than 0.01 in chi-square) and not next to
    a point it has; beyond its last point, lower than that point."""
    import dataclasses

    from granflow.fitting.engine import GlobalParameter
    from granflow.fitting.profile import Profile, ProfilePoint
    from granflow.forecast.inference import with_points

    parameter = GlobalParameter("gap", 1.0, log=False)
    parameter.scale = 1.0
    u = np.array([-2.0, -1.0, 1.0, 2.0])
    own = tuple(ProfilePoint(float(v), float(v), float(v * v), np.array([v])) for v in u)
    optimum = ProfilePoint(0.0, 0.0, 0.0, np.array([0.0]))
    profile = Profile(0, optimum, own, {-1: [-2.0], 1: [2.0]}, {-1: [True], 1: [True]})
    lent = [
        (np.array([1.5]), 0.5),  # under the profile's 2.25 there (r interpolated): taken
        (np.array([-1.5]), 2.6),  # above its 2.25 there: left out
        (np.array([3.0]), 1.0),  # beyond its end, under its last point's 4: taken
        (np.array([2.0005]), 0.1),  # next to its point at 2: left out
    ]
    joined = with_points(profile, parameter, 0, lent)
    taken = sorted(p.u for p in joined.points if p not in own)
    assert taken == [1.5, 3.0]
    assert dataclasses.replace(joined, points=own) == profile
