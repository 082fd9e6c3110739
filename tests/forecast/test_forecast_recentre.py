"""A fit made again from a profile's point below it (:func:`granflow.forecast.inference.
lowest_point`, :func:`~granflow.forecast.inference.recentred`) and the creep forecast's
map from the failure time's slots to the strength's (``creeping._untimed``).

The references are independent of the code under test: SciPy's ``least_squares`` minimum of
the same residuals, and the two creep parametrisations' own slips, which must agree where
the map is right."""

import math

import numpy as np
import pytest
from scipy.optimize import least_squares

import granflow as gf
from granflow.fitting.engine import Curve, GlobalParameter, Model, Problem
from granflow.fitting.profile import ProfilePoint
from granflow.forecast.inference import Estimate, lowest_point, recentred

NOISE = 0.02


def _decay(x, amplitude, rate, offset):
    return amplitude * np.exp(-rate * x) + offset


def _decay_jacobian(x, amplitude, rate, offset):
    e = np.exp(-rate * x)
    return _decay(x, amplitude, rate, offset), np.column_stack(
        [e, -amplitude * x * e, np.ones_like(x)]
    )


DECAY = Model(("amplitude", "rate", "offset"), _decay, _decay_jacobian, log=(False, True, False))


def _record(seed):
    rng = np.random.default_rng(seed)
    x = np.linspace(0.0, 3.0, 60)
    return x, _decay(x, 2.0, 1.3, 0.4) + rng.normal(0.0, NOISE, x.size)


def _builder(x, y):
    def build(sigma, values):
        parameters = [
            GlobalParameter("amplitude", float(values[0]), log=False),
            GlobalParameter("rate", float(values[1]), log=True),
            GlobalParameter("offset", float(values[2]), log=False),
        ]
        curve = Curve(x, y, np.full(x.size, 1.0 / sigma), ((0, 1.0), (1, 1.0), (2, 1.0)))
        return Problem([curve], parameters, DECAY)

    return build


def _scipy_minimum(x, y):
    found = least_squares(
        lambda p: (_decay(x, *p) - y) / NOISE,
        (1.0, 1.0, 0.0),
        xtol=1e-15,
        ftol=1e-15,
        gtol=1e-15,
    )
    return found.x, 2.0 * found.cost


def _stopped_short(build, values):
    """An Estimate whose fit stands at ``values`` (not the minimum)."""
    problem = build(NOISE, values)
    chisqr, _, hessian = problem.state(problem.internal(values), problem.free)
    values = np.asarray(values, float)
    return Estimate(problem, values, float(chisqr), NOISE, None, hessian, 0, values)


@pytest.mark.parametrize("seed", [11, 12])
def test_a_fit_made_again_from_a_lower_point_reaches_the_minimum(seed):
    x, y = _record(seed)
    build = _builder(x, y)
    best, least = _scipy_minimum(x, y)
    short = _stopped_short(build, best * np.array([1.02, 0.97, 1.05]))
    assert short.chisqr > least + 1.0  # the fit stopped well short
    # a point between the two, below the short fit: where a profile would have found it
    below = 0.5 * (best + short.values)
    fit = recentred(short, build, below)
    assert fit is not short
    np.testing.assert_allclose(fit.values, best, rtol=1e-7)
    assert fit.chisqr == pytest.approx(least, rel=1e-9)
    assert fit.sigma == short.sigma and fit.dof == short.dof
    # made again from the minimum, a point above it gives nothing lower: the fit itself
    assert recentred(fit, build, short.values) is fit


def test_lowest_point_takes_only_a_point_clearly_below_the_fit():
    x, y = _record(13)
    build = _builder(x, y)
    best, least = _scipy_minimum(x, y)
    problem = build(NOISE, best)

    def point(values, delta):
        return ProfilePoint(0.0, float(values[1]), delta, np.asarray(values, float))

    above = best * np.array([1.0, 1.1, 1.0])
    points = [point(best, 0.0), point(above, 4.0)]
    # the fit 1.0 above the minimum: the point at the minimum lies clearly below it
    np.testing.assert_array_equal(lowest_point(problem, points, least + 1.0), best)
    # within 0.05 (the conditional minima's own imprecision): nothing
    assert lowest_point(problem, points, least + 0.03) is None
    # a point read above the fit is never taken, whatever its chi-square
    assert lowest_point(problem, [point(best, 0.5)], least + 1.0) is None


def test_the_failure_times_slots_map_to_the_strengths_with_the_same_slip(monkeypatch):
    """A creeping ramp cut half-way: each point of the failure time's profile (slots with
    the gap to failure) mapped to the strength's slots (the lag at the reference rate) gives
    the same slip at every sample, and so the same chi-square: the map keeps the curve and
    its rate."""
    import granflow.forecast.creeping as creeping
    from tests.forecast.test_forecast_creep_profile import creep_record

    seen = {}
    made = creeping.CreepModel

    def model(*arguments, **options):
        out = made(*arguments, **options)
        seen["timed" if out.timed else "model"] = out
        return out

    scanned = creeping.scan

    def recorded(fit, index, level, **options):
        profile, distribution = scanned(fit, index, level, **options)
        if "problem" in options:
            seen["points"] = profile.points
        return profile, distribution

    monkeypatch.setattr(creeping, "CreepModel", model)
    monkeypatch.setattr(creeping, "scan", recorded)
    t, slip, force, truth = creep_record(5003, "ramp")
    gf.forecast_failure(t, slip, force, until=0.75 * truth, direct_effect=True)
    strength, timed = seen["model"], seen["timed"]
    checked = 0
    for p in seen["points"]:
        timed_slip, timed_state = timed.evaluate(np.asarray(p.values, float))
        if timed_slip is None or not p.delta < 20.0:
            continue
        values = creeping._untimed(strength, timed, np.asarray(p.values, float))
        assert values is not None
        strength_slip, state = strength.evaluate(values)
        scale = float(np.ptp(timed_slip))
        np.testing.assert_allclose(strength_slip, timed_slip, rtol=0, atol=1e-9 * scale)
        assert state.velocity == pytest.approx(timed_state.velocity, rel=1e-9)
        if math.isfinite(state.failure_time):
            gap = state.failure_time - timed.until
            assert gap == pytest.approx(p.values[timed.profiled], rel=1e-4)
        checked += 1
    assert checked >= 4
