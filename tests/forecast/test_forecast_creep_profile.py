"""The creep forecast's profiles: the pieces that keep them from stalling (the ends of a
profile path, the history's integral on scalars) and two simulated records on which a
stalled profile used to miss the failure."""

import math

import mpmath
import numpy as np
import pytest

import granflow as gf
from granflow.forecast.calibration import PARAMETER_SETS, _creep_record
from granflow.forecast.creep import (
    History,
    _exp_times_relative_expm1,
    ramp_history,
)
from granflow.forecast.likelihood import Fit, params_from_peak
from granflow.model.friction import peak


@pytest.mark.parametrize("base", [-50.0, -3.0, 0.0, 2.5])
@pytest.mark.parametrize("k", [-40.0, -1e-3, -1e-12, 0.0, 1e-12, 1e-3, 0.7, 30.0])
def test_scalar_path_matches_mpmath(base, k):
    """exp(base) (exp(k) - 1) / k on plain scalars (the Newton iterations' path) against
    40-digit arithmetic, and against the array path."""
    mpmath.mp.dps = 40
    b, q = mpmath.mpf(base), mpmath.mpf(k)
    exact = mpmath.exp(b) * (mpmath.expm1(q) / q if k != 0 else 1)
    scalar = _exp_times_relative_expm1(np.float64(base), np.float64(k))
    array = _exp_times_relative_expm1(np.array([base]), np.array([k]))[0]
    assert isinstance(scalar, float)
    assert scalar == pytest.approx(float(exact), rel=1e-14)
    assert scalar == pytest.approx(array, rel=1e-14)


def test_history_integral_is_the_same_whatever_was_asked_before():
    """The history keeps the last amplitude's cumulative integral: asking for another
    amplitude and back gives a fresh history's values."""
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


def test_along_reads_the_quantity_at_the_interval_ends():
    """A profile path (q, delta): (1, 0), (2, 1), (3, 4) with the quantity 10 q and the
    interval (1, 2.5): the range is 10 to 25 (25 interpolated between q = 2 and 3)."""
    path = tuple((q, d, 10.0 * q, np.empty(0)) for q, d in ((1.0, 0.0), (2.0, 1.0), (3.0, 4.0)))
    fit = Fit(
        params=10.0,
        peak_force=1.0,
        chisqr=0.0,
        noise=1.0,
        path=path,
        interval=(1.0, 2.5),
        threshold=2.0,
    )
    assert fit.along(lambda value: value) == pytest.approx((10.0, 25.0), rel=1e-15)


def _strength(seed):
    return peak(gf.Params(*PARAMETER_SETS[seed % len(PARAMETER_SETS)])).force


def test_a_flat_profile_is_followed_down_to_the_failure():
    """Seed 5000's creeping ramp cut half-way to failure: the failure-time profile is flat
    over a wide range, and the fit's warm starts used to stall in it (the interval began
    40 s after the true failure)."""
    t, slip, force, truth = _creep_record(5000, "ramp")
    ff = gf.forecast_failure(t, slip, force, until=0.5 * truth, direct_effect=True)
    assert ff.time_interval[0] <= truth <= ff.time_interval[1]
    assert ff.force_interval[0] <= _strength(5000) <= ff.force_interval[1]


def test_a_fit_far_from_failure_still_bounds_it_from_below():
    """Seed 5014's ramp cut half-way: the fit sees no failure in sight and gives no date,
    but keeps the lower ends the record gives (it used to give none)."""
    t, slip, force, truth = _creep_record(5014, "ramp")
    ff = gf.forecast_failure(t, slip, force, until=0.5 * truth, direct_effect=True)
    assert ff.time is None
    assert "no sign" in ff.message
    low, high = ff.time_interval
    assert 0.5 * truth < low <= truth
    assert math.isinf(high)
    assert ff.force_interval[0] <= _strength(5014)


def test_a_peak_past_the_exponential_range_is_infeasible_not_an_error():
    """alpha x0 beyond exp's range (a fit's wandering start) is no curve, not an
    OverflowError (one stopped a calibration run)."""
    assert params_from_peak(1e-3, 1e9, 1e-5, 1e-2) is None
    assert params_from_peak(1e-3, 1e9, 6.5e-7, 1e-2) is None


def test_a_fit_on_the_family_edge_is_profiled_below_it():
    """Seed 7040's creeping staircase cut half-way: the best fit sits on the family's edge
    (Fd -> 0), where lowering F_peak at the fit's own a, alpha, x0 is infeasible; the
    profile's starts are repaired (a lowered) and F_peak's interval reaches down to the
    truth (it used to end at the best fit)."""
    t, slip, force, truth = _creep_record(7040, "steps")
    ff = gf.forecast_failure(t, slip, force, until=0.5 * truth, direct_effect=True)
    assert ff.params["Fd"] < 1e-3 * ff.params["a"]
    assert ff.force_interval[0] <= _strength(7040) <= ff.force_interval[1]
    assert ff.force_interval[0] < 0.99 * ff.force
    assert ff.time_interval[0] <= truth <= ff.time_interval[1]
