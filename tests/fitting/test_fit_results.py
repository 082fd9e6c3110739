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


# --------------------------------------------------------------------------- the compact form

#: Keys of the per-point arrays (and of a posterior's chain).
ARRAY_KEYS = {"x", "data", "best_fit", "residuals", "weights", "chain"}


def _keys(value):
    """Every mapping key inside a ``to_dict()`` output."""
    if isinstance(value, dict):
        return set(value).union(*(_keys(item) for item in value.values()))
    if isinstance(value, list):
        return set().union(*(_keys(item) for item in value))
    return set()


def _arrays(result):
    """The per-point arrays of ``result`` and of every result it holds."""
    if isinstance(result, dict | FrozenMap):
        return [a for item in result.values() for a in _arrays(item)]
    if isinstance(result, tuple):
        return [a for item in result for a in _arrays(item)]
    if not hasattr(result, "__dataclass_fields__"):
        return []
    found = [getattr(result, key) for key in getattr(type(result), "ARRAYS", ())]
    for name in result.__dataclass_fields__:
        found += _arrays(getattr(result, name))
    return found


def _curves(count, seed=0, **values):
    return [_curve(seed=seed + i, **values) for i in range(count)]


def _posterior():
    pytest.importorskip("emcee")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", granflow.ConvergenceWarning)
        return granflow.sample_posterior(granflow.fit(_curve()), nwalkers=8, nsteps=40, seed=2)


COMPACT_CASES = {
    "FitResult": lambda: granflow.fit(_curve(), weights=np.linspace(1, 2, 400), velocity=1e-6),
    "FitResult-time": lambda: granflow.fit(
        (_curve()[0] / 1e-6, _curve()[1]), domain="time", velocity=1e-6, fixed={"Fd": 10e-3}
    ),
    "CurveFitResult": lambda: granflow.fit_creep(
        np.linspace(0, 300, 301), 2e-6 * np.log1p(np.linspace(0, 300, 301) / 5.0)
    ),
    "JointFitResult": lambda: granflow.fit_joint(_curves(2)),
    "CollapseResult": lambda: granflow.velocity_collapse(_curves(4), [1e-6, 1e-6, 2e-6, 2e-6]),
    "AmontonsResult": lambda: granflow.fit_amontons(
        [_curve(Fd=0.2 * load, seed=10 + i) for i, load in enumerate((0.05, 0.05, 0.1, 0.1))],
        [0.05, 0.05, 0.1, 0.1],
        velocities=[1e-6] * 4,
    ),
    "PreparationSpread": lambda: granflow.preparation_spread(
        [granflow.fit(_curve(x0=x0, seed=i)) for i, x0 in enumerate((1e-7, 2e-7, 3e-7))]
    ),
    "ModelComparison": lambda: granflow.compare_models(_curve()),
    "PosteriorResult": _posterior,
}


@pytest.mark.parametrize("case", list(COMPACT_CASES))
def test_compact_form_round_trips(case):
    result = COMPACT_CASES[case]()
    assert type(result).__name__ == case.split("-")[0]
    assert result.to_dict() == result.to_dict(include_arrays=True)  # complete by default
    compact = result.to_dict(include_arrays=False)
    assert _keys(compact) & ARRAY_KEYS == set()
    assert _keys(compact) == _keys(result.to_dict()) - ARRAY_KEYS
    rebuilt = type(result).from_dict(json.loads(json.dumps(compact)))
    assert type(result).from_dict(compact) == rebuilt
    assert rebuilt.to_dict(include_arrays=False) == compact
    # the compact result is the original with its arrays emptied: its report is the same
    assert all(array.size == 0 for array in _arrays(rebuilt))
    assert len(_arrays(rebuilt)) == len(_arrays(result))
    assert rebuilt.report() == result.report()
    assert (rebuilt == result) == (not any(array.size for array in _arrays(result)))


def test_compact_posterior_keeps_the_shape_of_its_chain():
    posterior = _posterior()
    rebuilt = granflow.PosteriorResult.from_dict(posterior.to_dict(include_arrays=False))
    steps = posterior.chain.shape[0]  # after burn-in
    assert 0 < steps < 40
    assert rebuilt.shape == posterior.shape == posterior.chain.shape == (steps, 8, 4)
    assert rebuilt.chain.shape == (0, 8, 4) and rebuilt.samples.shape == (0, 4)
    assert repr(rebuilt) == repr(posterior)


def test_from_dict_refuses_what_is_not_a_mapping():
    with pytest.raises(granflow.InvalidParameterError, match=r"FitResult\.from_dict"):
        granflow.FitResult.from_dict([1, 2])


def test_same_compares_by_value():
    assert same(np.array([1.0, math.nan]), np.array([1.0, math.nan]))
    assert not same(np.array([1.0]), np.array([1.0, 2.0]))
    assert same(FrozenMap({"a": (1.0, math.nan)}), {"a": [1.0, math.nan]})
    assert not same({"a": 1.0}, {"b": 1.0})
    assert same(math.nan, math.nan) and not same(1.0, 2.0)
