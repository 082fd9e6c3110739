"""The creep forecast on the fitting engine: the pieces of its model (the exponential
integrals of the history, the unit curve's analytic derivatives against forward
differences) and simulated records on which earlier versions' profiles stalled, reached the
wrong end or gave no bound."""

import math

import mpmath
import numpy as np
import pytest

import granflow as gf
from granflow.forecast.coordinates import natural
from granflow.forecast.creep import History, _exp_relative, ramp_history
from granflow.forecast.creep_model import CreepModel
from granflow.forecast.loading import fit_loading
from granflow.forecast.quasistatic import loading_error
from granflow.forecast.synthetic import creep_ramp_record, creep_staircase_record
from granflow.model.friction import peak

#: The creep study of issue 15: three tubes, slip noise 2 or 10 nm, force noise 30 uN, the
#: direct effect's A = 0.03 a and v_ref = 0.1 um/s.
SETS = (
    (3.3e-3, 5.0e4, 11.0e-3, 0.3e-6),
    (6.0e-3, 7.0e4, 20.0e-3, 0.5e-6),
    (1.5e-3, 3.5e4, 5.0e-3, 0.2e-6),
)


def creep_record(seed, protocol):
    """(t, slip, force, failure time) of the issue-15 creep study's seed (its records, drawn
    the way it drew them), simulated with granflow.simulate and the direct effect."""
    rng = np.random.default_rng(seed)
    params = gf.Params(*SETS[seed % 3])
    effect = gf.DirectEffect(amplitude=0.03 * params.a, velocity=1e-7)
    noise = (2e-9, 10e-9)[(seed // 3) % 2]
    strength = peak(params).force
    failure_time = float(rng.uniform(150.0, 300.0))
    if protocol == "ramp":
        return creep_ramp_record(
            params, strength / failure_time, effect, noise=noise, force_noise=3e-5, seed=seed
        )
    steps = int(rng.integers(10, 16))
    return creep_staircase_record(
        params,
        strength / (steps - 0.5),
        failure_time / steps,
        effect,
        noise=noise,
        force_noise=3e-5,
        seed=seed,
    )


def _strength(seed):
    return peak(gf.Params(*SETS[seed % 3])).force


@pytest.mark.parametrize("base", [-50.0, -3.0, 0.0, 2.5])
@pytest.mark.parametrize("k", [-40.0, -1e-3, -1e-12, 0.0, 1e-12, 1e-3, 0.7, 30.0])
def test_the_cells_exponential_integral_matches_mpmath(base, k):
    """exp(base) (exp(k) - 1) / k, the integral of a cell whose exponent is linear, against
    40-digit arithmetic."""
    mpmath.mp.dps = 40
    b, q = mpmath.mpf(base), mpmath.mpf(k)
    exact = mpmath.exp(b) * (mpmath.expm1(q) / q if k != 0 else 1)
    assert _exp_relative(base, k) == pytest.approx(float(exact), rel=1e-14)


def test_the_history_integral_is_the_same_whatever_was_asked_before():
    t = np.linspace(0.0, 300.0, 41)
    edges = np.array([50.0, 100.0, 150.0, 200.0])
    levels = np.array([1e-3, 2e-3, 3e-3, 4e-3, 5e-3])
    kept = History(np.concatenate([[0.0], edges]), levels, np.zeros(levels.size))
    for amplitude in (1e-4, 3e-4, 1e-4):
        fresh = History(np.concatenate([[0.0], edges]), levels, np.zeros(levels.size))
        np.testing.assert_array_equal(
            kept.integral(t, amplitude, 6e-3), fresh.integral(t, amplitude, 6e-3)
        )
        assert kept.time_of(1.0, amplitude, 6e-3) == fresh.time_of(1.0, amplitude, 6e-3)
    ramp = ramp_history(0.0, 2e-5)
    assert ramp.integral(np.array([10.0]), 1e-4, 1e-3)[0] > 0


@pytest.mark.parametrize("timed", [False, True])
def test_the_analytic_jacobian_agrees_with_central_differences(timed):
    """The model's Jacobian (the unit curve's shape derivatives in closed form over its
    grid, the targets' by forward differences) against central differences of the model
    itself, each column to 1e-2 of its scale (the grid's own discretisation, 2e-5 of the
    rise, bounds what the two can share)."""
    t, slip, force, failure = creep_record(5, "ramp")
    cut = t <= 0.75 * failure
    t, slip, force = t[cut], slip[cut], force[cut]
    loading = fit_loading(t, force)
    model = CreepModel(
        t, slip, loading, loading_error(loading, t)[0], None, t[-1], 1e-3, 2e-5, timed
    )
    params = gf.Params(*SETS[5 % 3])
    top = peak(params)
    named = {
        "peak_force": top.force,
        "ratio": params.Fd / top.force,
        "s0": params.alpha * params.x0,
        "amplitude": 0.03 * params.a,
        "lag": 1e-5,
        "gap": failure - t[-1],
        "z0": 0.1,
        "z1": -0.2,
    }
    values = np.array([named[name] for name in model.names])
    log = [name in ("peak_force", "s0", "amplitude", "gap") for name in model.names]
    _, jacobian = model.function_and_jacobian(values, log)
    for k in range(values.size):
        h = 1e-6 * (abs(values[k]) if log[k] else 1.0)
        up, down = values.copy(), values.copy()
        up[k] += h
        down[k] -= h
        central = (model.evaluate(up)[0] - model.evaluate(down)[0]) / (2 * h)
        scale = np.max(np.abs(central))
        assert np.max(np.abs(central - jacobian[:, k])) < 1e-2 * scale, model.names[k]


def test_a_peak_past_the_exponential_range_is_no_curve_not_an_error():
    """alpha x0 beyond exp's range (a fit's wandering start) is no curve (NaN), not an
    OverflowError (one stopped a calibration run)."""
    transform = np.empty((4, 4))
    assert math.isnan(natural(1e-2, 0.5, 700.0, 1e-5, transform)[0])
    assert math.isnan(natural(1e-2, 1.0, 0.01, 1e-5, transform)[0])


def test_a_flat_profile_is_followed_down_to_the_failure():
    """Seed 5000's creeping ramp cut half-way to failure: the failure-time profile is flat
    over a wide range, and the fit's warm starts used to stall in it (the interval began
    40 s after the true failure)."""
    t, slip, force, truth = creep_record(5000, "ramp")
    ff = gf.forecast_failure(t, slip, force, until=0.5 * truth, direct_effect=True)
    assert ff.time_interval[0] <= truth <= ff.time_interval[1]
    assert ff.force_interval[0] <= _strength(5000) <= ff.force_interval[1]


def test_a_fit_far_from_failure_still_bounds_it_from_below():
    """Seed 5014's ramp cut half-way: whether the fit dates the failure or not, it keeps the
    lower ends the record gives (an earlier version gave none): the time's is at or after the
    cut, the strength's below the truth, and where no date is given the strength's lower end
    is at least the largest force held (a creeping layer can fail before the force reaches
    F_peak, so then the time's lower end is the cut). Whether one seed's interval holds the
    time is a 90 % event, left to the calibration study."""
    t, slip, force, truth = creep_record(5014, "ramp")
    ff = gf.forecast_failure(t, slip, force, until=0.5 * truth, direct_effect=True)
    low, high = ff.time_interval
    assert 0.5 * truth <= low < high
    assert truth <= high
    assert ff.force_interval[0] <= _strength(5014)
    if ff.time is None:
        assert ff.force_interval[0] >= float(np.max(force[t <= 0.5 * truth])) - 1e-4


def test_a_fit_on_the_family_edge_is_profiled_below_it():
    """Seed 7040's creeping staircase cut half-way, where an earlier fit sat on the family's
    edge (Fd -> 0) and could not lower F_peak from there: in the peak coordinates every
    F_peak has a curve, and F_peak's interval reaches the truth."""
    t, slip, force, truth = creep_record(7040, "steps")
    ff = gf.forecast_failure(t, slip, force, until=0.5 * truth, direct_effect=True)
    assert ff.force_interval[0] <= _strength(7040) <= ff.force_interval[1]
    assert ff.time_interval[0] <= truth <= ff.time_interval[1]


@pytest.mark.parametrize("seed", [2063])
def test_a_profile_stranded_at_the_curves_box_finds_the_branch_beyond(seed):
    """Creeping ramps cut half-way to failure, where the record does not yet bound the
    strength from above: the profile is flat far above the best fit, on another branch of the
    creep curve. The conditional fits' warm starts left the curve's box just above the best
    fit (no Eq. 3 parameters give that shape: a flat penalty) and read it as a wall, so both
    intervals ended at the point forecast (seed 2063: t_f in (185.3, 186.4) s, truth 203.7 s;
    F_peak in (4.57, 6.22) mN, truth 6.63 mN). Restarted from the creep curve's shapes, the
    strength's profile goes on (its upper end well beyond the point) and both intervals hold
    the truth. The failure time's profile is restarted too, but its conditional fits can
    still miss the branch the strength's found and stop a little above the point (on one
    CPU this seed's ended at 193.6 s); it now also takes the strength's points that
    undercut it (the same curve, its failure time as the time's slot), so the two agree."""
    t, slip, force, truth = creep_record(seed, "ramp")
    ff = gf.forecast_failure(t, slip, force, until=0.5 * truth, direct_effect=True)
    assert ff.time is not None
    assert ff.time_interval[0] <= truth <= ff.time_interval[1]
    assert ff.force_interval[0] <= _strength(seed) <= ff.force_interval[1]
    assert ff.force_interval[1] > 1.2 * ff.force


def test_the_time_profile_finds_the_conditional_minimum_across_a_step_edge(monkeypatch):
    """Seed 330194's creeping staircase (the calibration study's draw) cut at 90 % of its
    failure time, which falls 0.07 s after a step's edge: the failure time's profile with
    t_f pinned at the truth lies on another branch than its warm starts (other edges' offset
    and stretch, another shape), and the interval missed the truth (it began 0.08 s after
    it; the profile's r there was -3.1). Checked against SciPy's least_squares within the
    engine's bounds, started from the profile's own points nearest the truth: the profile
    at the truth is no higher than that minimum, and the interval holds the truth."""
    from scipy.optimize import least_squares
    from scipy.special import ndtri, stdtrit

    import granflow.forecast.creeping as creeping
    from granflow.forecast.calibration import draw

    seen = {}

    def recorded(fit, index, level, **options):
        profile, distribution = creeping_scan(fit, index, level, **options)
        if "problem" in options:
            seen.update(fit=fit, problem=options["problem"], index=index, profile=profile)
        return profile, distribution

    def distribution(*arguments):
        seen["distribution"] = creeping_distribution(*arguments)
        return seen["distribution"]

    creeping_scan, creeping_distribution = creeping.scan, creeping.distribution_of
    monkeypatch.setattr(creeping, "scan", recorded)
    monkeypatch.setattr(creeping, "distribution_of", distribution)
    case = draw(330194, "creep steps")
    until = 0.9 * case.failure
    ff = gf.forecast_failure(case.t, case.slip, case.force, until=until, direct_effect=True)
    assert ff.time_interval[0] <= case.failure <= ff.time_interval[1]

    fit, problem, index, profile = (seen[k] for k in ("fit", "problem", "index", "profile"))
    parameters = problem.parameters
    others = [k for k in range(len(parameters)) if k != index]
    lower, upper = np.array([parameters[k].internal_bounds() for k in others]).T
    gap = case.failure - until

    def global_values(u_others, pinned):
        values = np.empty(len(parameters))
        values[index] = pinned
        for k, u in zip(others, u_others, strict=True):
            values[k] = parameters[k].from_internal(u)
        return values

    data = problem.curves[0]

    def residuals(u_others, pinned=gap):
        values = global_values(u_others, pinned)
        slip = problem.model.function(data.z, *values)
        return np.concatenate([(data.y - slip) * data.w, values[-2:]])

    optimum = profile.optimum.values
    u_optimum = np.array([parameters[k].to_internal(optimum[k]) for k in others])
    at_optimum = residuals(u_optimum, optimum[index])
    assert float(at_optimum @ at_optimum) == pytest.approx(fit.chisqr)
    nearest = sorted(profile.points, key=lambda p: abs(p.value - gap))[:6]
    lowest = math.inf
    for point in [profile.optimum, *nearest]:
        start = np.array([parameters[k].to_internal(point.values[k]) for k in others])
        start = np.clip(start, lower + 1e-9, upper - 1e-9)
        found = least_squares(residuals, start, bounds=(lower, upper), x_scale="jac")
        lowest = min(lowest, 2.0 * found.cost)
    independent = math.sqrt(max(lowest - fit.chisqr, 0.0))
    dist = seen["distribution"]
    probability = float(dist.cdf(case.failure))
    forecast = float(stdtrit(dist.dof, probability) if dist.dof else ndtri(probability))
    # the profile's signed root at the truth no farther out than SciPy's minimum puts it
    assert abs(forecast) <= independent + 0.1


@pytest.mark.parametrize("offset", [-3.0, -0.6, 0.0, 0.2, 5.0])
@pytest.mark.parametrize("stretch", [-0.05, 0.0, 0.04])
def test_the_record_edges_stay_between_their_samples(offset, stretch):
    """A staircase's step shows first at a sample and began after the one before: moved by
    any offset and stretch [s], each of the record's edges stays in that window (moved by
    hand where the window holds it, else on the window's nearer end), and the continued
    edges move freely."""
    from granflow.forecast.creep_model import history_with_error, staircase_edges

    t = np.arange(1, 601) * 0.37
    force = 2e-3 * (1.0 + np.floor(t / 21.3))
    loading = fit_loading(t, force)
    known, _ = staircase_edges(loading)
    lows, highs = np.array(loading.windows).T
    assert known.size == lows.size >= 10
    history = history_with_error(
        loading, np.zeros((2, 2)), np.zeros(0), 0.1, (offset, stretch), (known, 250.0)
    )
    edges = history.starts[1:]
    moved = known + offset + stretch * (np.arange(1, known.size + 1) - known.size)
    expected = np.where(moved < lows, lows, np.where(moved > highs, highs, moved))
    np.testing.assert_array_equal(edges[: known.size], expected)
    assert np.all((lows <= edges[: known.size]) & (edges[: known.size] <= highs))
    continued = 250.0 + loading.duration * np.arange(edges.size - known.size)
    shifted = continued + offset + stretch * np.arange(1, continued.size + 1)
    np.testing.assert_allclose(edges[known.size :], shifted, rtol=1e-15)


def test_a_creeping_staircase_fit_on_an_edge_cliff_is_profiled_across_it(monkeypatch):
    """Seed 370143's creeping staircase (the calibration study's draw) cut half-way: its
    last edge, moved early by half a sampling interval, crossed the sample before it, and
    that sample saw the creep burst that follows each edge: a cliff of 200 in chi-square.
    The fit stopped there, the strength's profile followed it up the cliff, and F_peak's
    interval (0.0151, 0.0166) N left out the truth 0.0223 N, though with F_peak pinned
    there SciPy's least_squares from the fit's other values finds chi-square below the
    fit's. Now the edges stay between their samples: the profile at the truth is no higher
    than SciPy's conditional minimum there, from the fit, from the grid of the edges' offset
    and stretch the forecast searches and from six drawn at random, and the interval holds
    the truth."""
    import granflow.forecast.creeping as creeping
    from granflow.forecast.calibration import draw

    seen = {}

    def recorded(fit, index, level, **options):
        profile, distribution = creeping_scan(fit, index, level, **options)
        if "problem" not in options:
            seen.update(fit=fit, profile=profile, distribution=distribution)
        return profile, distribution

    creeping_scan = creeping.scan
    monkeypatch.setattr(creeping, "scan", recorded)
    case = draw(370143, "creep steps")
    ff = gf.forecast_failure(
        case.t, case.slip, case.force, until=0.5 * case.failure, direct_effect=True
    )
    low, high = ff.force_interval
    assert low <= case.strength <= high

    fit = seen["fit"]
    problem = fit.problem
    names = [p.name for p in problem.parameters]
    others = [i for i in problem.free if i != 0]
    pinned = {0: problem.parameters[0].to_internal(case.strength)}
    lowest = math.inf
    grid = [(e, d) for e in (-5.0, 0.0, 5.0) for d in (-5.0, 0.0, 5.0)]
    # and starts the forecast's own search does not use: (e, d) drawn across their box
    drawn = [tuple(pair) for pair in np.random.default_rng(7).uniform(-10.0, 10.0, (6, 2))]
    for e, d in [(None, None), *grid, *drawn]:
        start = np.array(fit.values, dtype=float)
        if e is not None:
            start[names.index("e")], start[names.index("d")] = e, d
        u = np.array([problem.parameters[i].to_internal(start[i]) for i in others])
        found = problem.solve(u, order=others, pinned=pinned, max_nfev=2000)
        values = np.array(fit.values, dtype=float)
        values[0] = case.strength
        for i, ui in zip(others, found.x, strict=True):
            values[i] = problem.parameters[i].from_internal(ui)
        lowest = min(lowest, problem.chisqr(values))
    independent = math.sqrt(max(lowest - fit.chisqr, 0.0))
    distribution = seen["distribution"]
    probability = float(distribution.cdf(case.strength))
    from scipy.special import ndtri, stdtrit

    forecast = float(
        stdtrit(distribution.dof, probability) if distribution.dof else ndtri(probability)
    )
    assert independent < 1.0  # the truth well inside, by SciPy
    assert abs(forecast) <= independent + 0.1
