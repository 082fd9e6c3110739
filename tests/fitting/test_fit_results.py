"""Every fit result rebuilds from its to_dict(), directly and through JSON; equality by value."""

import json
import math
import warnings

import numpy as np
import pytest

import granflow
from granflow import Params, friction_slip
from granflow.fitting.results import FrozenMap, same

NOISE = 5e-5


def _curve(x0=2e-7, Fd=10e-3, seed=0, points=400):
    x = np.linspace(1e-6, 5e-4, points)
    params = Params(3e-3, 4e4, Fd, x0)
    return x, friction_slip(x, params) + np.random.default_rng(seed).normal(0, NOISE, points)


def _both_ways(result):
    """The result rebuilt from to_dict() and from its JSON text; both equal the original."""
    direct = type(result).from_dict(result.to_dict())
    through_json = type(result).from_dict(json.loads(json.dumps(result.to_dict())))
    assert direct == result
    assert through_json == result
    assert through_json.to_dict() == result.to_dict()
    return through_json


def test_fit_result_round_trip_keeps_arrays_and_weights():
    x, y = _curve()
    weights = np.linspace(1.0, 2.0, x.size)
    result = granflow.fit((x, y), weights=weights, velocity=1e-6)
    rebuilt = _both_ways(result)
    np.testing.assert_array_equal(rebuilt.weights, result.weights)
    assert rebuilt.units == result.units and rebuilt.names == result.names
    assert rebuilt.report() == result.report()
    with pytest.raises(ValueError):
        rebuilt.x[0] = 1.0


def test_fit_result_time_domain_and_fixed_round_trip():
    x, y = _curve(seed=3)
    result = granflow.fit((x / 1e-6, y), domain="time", velocity=1e-6, fixed={"Fd": 10e-3})
    rebuilt = _both_ways(result)
    assert rebuilt.fixed == ("Fd",)
    assert rebuilt.to_params() == result.to_params()


def test_fit_result_summary_without_arrays():
    result = granflow.fit(_curve())
    summary = result.to_dict(include_arrays=False)
    assert "x" not in summary
    rebuilt = granflow.FitResult.from_dict(summary)
    assert dict(rebuilt.params) == dict(result.params) and rebuilt.x.size == 0


def test_infinities_and_nan_survive_json():
    result = granflow.fit(_curve())
    changed = granflow.FitResult(
        **{
            **{f: getattr(result, f) for f in result.__dataclass_fields__},
            "aic": -math.inf,
            "rsquared": math.nan,
            "ci95": FrozenMap({**result.ci95, "a": (-math.inf, math.inf)}),
        }
    )
    payload = json.loads(json.dumps(changed.to_dict(), allow_nan=False))
    assert payload["aic"] is None and payload["rsquared"] is None
    rebuilt = granflow.FitResult.from_dict(payload)
    assert rebuilt.aic == -math.inf and math.isnan(rebuilt.rsquared)
    assert rebuilt.ci95["a"] == (-math.inf, math.inf)
    assert rebuilt == changed
    assert rebuilt != result


def test_joint_collapse_amontons_round_trip():
    runs = [_curve(x0=x0, seed=i) for i, x0 in enumerate((1.5e-7, 2.5e-7))]
    joint = granflow.fit_joint(runs)
    rebuilt = _both_ways(joint)
    assert rebuilt.individual == joint.individual
    collapse = granflow.velocity_collapse(
        [_curve(x0=2e-7, seed=i) for i in range(4)], [1e-6, 1e-6, 2e-6, 2e-6]
    )
    _both_ways(collapse)
    loads = [0.05, 0.05, 0.1, 0.1]
    amontons = granflow.fit_amontons(
        [_curve(Fd=0.2 * load, seed=10 + i) for i, load in enumerate(loads)],
        loads,
        velocities=[1e-6] * 4,
    )
    _both_ways(amontons)
    without_velocity = granflow.fit_amontons(
        [_curve(Fd=0.2 * load, seed=10 + i) for i, load in enumerate(loads)], loads
    )
    assert _both_ways(without_velocity).per_load[0]["alpha_v"] is None


def test_preparation_spread_round_trip():
    fits = [granflow.fit(_curve(x0=x0, seed=i)) for i, x0 in enumerate((1e-7, 2e-7, 3e-7))]
    _both_ways(granflow.preparation_spread(fits))
    _both_ways(granflow.preparation_spread(fits[:2]))  # nan correlation


def test_curve_fit_and_comparison_round_trip():
    t = np.linspace(0, 300, 301)
    creep = granflow.fit_creep(t, 2e-6 * np.log1p(t / 5.0) + 1e-9 * np.sin(t))
    rebuilt = _both_ways(creep)
    assert rebuilt.report() == creep.report()
    comparison = granflow.compare_models(_curve())
    rebuilt = _both_ways(comparison)
    assert isinstance(rebuilt.fits["eq3"], granflow.FitResult)
    assert isinstance(rebuilt.fits["exponential"], granflow.CurveFitResult)
    x = np.linspace(1e-6, 5e-4, 300)
    flat = x, 10e-3 * (1 - np.exp(-x / 1e-5))  # no overshoot: Eq. 3 is not fitted
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        comparison = granflow.compare_models(flat)
    assert comparison.fits["eq3"] is None
    _both_ways(comparison)


def test_posterior_round_trip():
    pytest.importorskip("emcee")
    result = granflow.fit(_curve())
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", granflow.ConvergenceWarning)
        posterior = granflow.sample_posterior(result, nwalkers=8, nsteps=40, seed=2)
    rebuilt = _both_ways(posterior)
    assert rebuilt.chain.shape == posterior.chain.shape


def test_from_dict_refuses_what_is_not_a_mapping():
    with pytest.raises(granflow.InvalidParameterError, match=r"FitResult\.from_dict"):
        granflow.FitResult.from_dict([1, 2])


def test_same_compares_by_value():
    assert same(np.array([1.0, math.nan]), np.array([1.0, math.nan]))
    assert not same(np.array([1.0]), np.array([1.0, 2.0]))
    assert same(FrozenMap({"a": (1.0, math.nan)}), {"a": [1.0, math.nan]})
    assert not same({"a": 1.0}, {"b": 1.0})
    assert same(math.nan, math.nan) and not same(1.0, 2.0)
