"""Named parameters (granflow.fitting.Parameter) and the one report of every fit result."""

import json
import math
import pickle
import re

import numpy as np
import pytest
from scipy.optimize import curve_fit

import granflow
from granflow import InvalidParameterError, Params, friction_slip, friction_time
from granflow.fitting import Parameter, Parameters, fit_report
from granflow.fitting.parameters import unit_of

NOISE = 3e-5


def _curve(x0=2e-7, seed=1, points=800):
    x = np.linspace(1e-6, 5e-4, points)
    force = friction_slip(x, Params(3e-3, 4e4, 10e-3, x0))
    return x, force + np.random.default_rng(seed).normal(0, NOISE, points)


def _creep(seed=0):
    t = np.linspace(0.0, 300.0, 301)
    return t, 2e-6 * np.log1p(t / 5.0) + np.random.default_rng(seed).normal(0, 1e-8, t.size)


# --------------------------------------------------------------------------- Parameter


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"name": "x0", "value": math.nan}, r"value of parameter 'x0' must be finite"),
        ({"name": "alpha", "value": math.inf}, r"value of parameter 'alpha' must be finite"),
        ({"name": "a", "value": "3e-3"}, r"value of parameter 'a' must be a real number"),
        ({"name": "a", "value": True}, r"value of parameter 'a' must be a real number"),
        ({"name": "Fd", "value": 1.0, "min": 2.0, "max": 1.0}, r"'Fd' must have min < max"),
        ({"name": "Fd", "value": 1.0, "min": 1.0, "max": 1.0}, r"'Fd' must have min < max"),
        ({"name": "x0", "value": 1.0, "min": 2.0}, r"value of parameter 'x0' must lie inside"),
        ({"name": "x0", "value": 3.0, "max": 2.0}, r"value of parameter 'x0' must lie inside"),
        ({"name": "k", "value": 1.0, "max": math.nan}, r"max of parameter 'k' must be a number"),
        ({"name": "k", "value": 1.0, "min": "0"}, r"min of parameter 'k' must be a real number"),
        ({"name": "x0", "value": 1e-7, "unit": "um"}, r"unit of parameter 'x0' must be .*'m'"),
        ({"name": "x0_3", "value": 1e-7, "unit": "mm"}, r"unit of parameter 'x0_3'"),
        ({"name": "F1", "value": 1e-3, "unit": 3}, r"unit of parameter 'F1' must be a string"),
        ({"name": "Fd", "value": 1e-2, "vary": "no"}, r"vary of parameter 'Fd' must be True"),
        ({"name": "1st", "value": 1.0}, r"parameter name must be an identifier.*'1st'"),
        ({"name": "", "value": 1.0}, r"parameter name must be an identifier"),
    ],
)
def test_parameter_errors_name_the_parameter_and_the_reason(kwargs, match):
    with pytest.raises(InvalidParameterError, match=match):
        Parameter(**kwargs)


def test_parameter_holds_si_floats_and_the_unit_of_its_quantity():
    alpha = Parameter("alpha", np.int64(40000), min=1e3, max=np.float32(1e6))
    assert type(alpha.value) is float and alpha.value == 4e4 and alpha.max == 1e6
    assert alpha.unit == "1/m" and alpha.vary is True
    assert Parameter("x0_3", 1e-7).unit == "m"  # per-run names take their quantity's unit
    assert Parameter("alpha_v1", 1.0).unit == "1/m"
    assert Parameter("mu_a", 0.3).unit == ""
    assert Parameter("F1", 1e-3, unit="N").unit == "N"  # a name with no quantity keeps its unit
    assert Parameter("Fd", 1e-2, min=1e-2).value == 1e-2  # the bounds are closed
    assert unit_of("t0") == "s" and unit_of("tau_c") == "s" and unit_of("nothing_1") == ""
    with pytest.raises(AttributeError):
        alpha.value = 1.0  # frozen


def test_parameters_is_an_ordered_read_only_mapping():
    params = Parameters([Parameter("Fd", 1e-2, vary=False), Parameter("alpha", 4e4)])
    assert list(params) == ["Fd", "alpha"] and len(params) == 2
    assert params["alpha"].value == 4e4
    assert params.valuesdict() == {"Fd": 1e-2, "alpha": 4e4}
    assert pickle.loads(pickle.dumps(params)) == params  # travels to worker processes
    assert "Parameter(name='Fd'" in repr(params)
    with pytest.raises(InvalidParameterError, match="'Fd' is given twice"):
        Parameters([Parameter("Fd", 1e-2), Parameter("Fd", 2e-2)])
    with pytest.raises(InvalidParameterError, match=r"must hold granflow\.fitting\.Parameter"):
        Parameters([("Fd", 1e-2)])
    with pytest.raises(InvalidParameterError, match="iterable of Parameter"):
        Parameters(Parameter("Fd", 1e-2))


def test_the_new_names_resolve_from_granflow_fitting():
    for name in ("Parameter", "Parameters", "fit_report"):
        assert name in granflow.fitting.__all__


# --------------------------------------------------------------------------- fit(params=)


def _same_fit(first, second, rel=1e-7):
    assert first.fixed == second.fixed and first.ci_method == second.ci_method
    assert first.at_bound == second.at_bound
    for name in first.names:
        assert second.params[name] == pytest.approx(first.params[name], rel=rel)
        assert second.stderr[name] == pytest.approx(first.stderr[name], rel=1e-4, abs=0.0)
        assert second.ci95[name] == pytest.approx(first.ci95[name], rel=1e-4)
    assert second.chisqr == pytest.approx(first.chisqr, rel=1e-9)


def test_params_give_the_fit_of_fixed_and_bounds():
    data = _curve()
    with_dicts = granflow.fit(data, fixed={"Fd": 10e-3}, bounds={"alpha": (1e3, 1e6)})
    params = [Parameter("Fd", 10e-3, vary=False), Parameter("alpha", 2e4, min=1e3, max=1e6)]
    with_params = granflow.fit(data, params=params)
    _same_fit(with_dicts, with_params)
    assert with_params.fixed == ("Fd",) and with_params.params["Fd"] == 10e-3
    # a mapping of name to Parameter and a Parameters collection are taken too
    by_name = granflow.fit(data, params={p.name: p for p in params})
    _same_fit(with_params, by_name, rel=1e-12)


def test_an_infinite_side_keeps_the_default_search_range():
    data = _curve()
    x = data[0]
    with pytest.warns(granflow.ConvergenceWarning, match="at a bound"):
        with_dicts = granflow.fit(data, bounds={"alpha": (1e3, 3e4), "a": (0.0, 1.0)})
    with pytest.warns(granflow.ConvergenceWarning, match="at a bound"):
        with_params = granflow.fit(
            data, params=Parameters([Parameter("alpha", 2e4, max=3e4), Parameter("a", 1e-3)])
        )
    _same_fit(with_dicts, with_params)
    assert with_params.at_bound["alpha"] and with_params.params["alpha"] == pytest.approx(3e4)
    # the default lower bound of alpha is 1e-4 / x_last: a start below it is moved inside
    low = granflow.fit(data, params=[Parameter("alpha", 1e-9 / x[-1])])
    _same_fit(granflow.fit(data), low)


def test_params_in_the_time_domain():
    velocity = 1e-6
    t = np.linspace(0.5, 500.0, 800)
    p = Params(3e-3, 4e4, 10e-3, 2e-7)
    force = friction_time(t, p, velocity) + np.random.default_rng(5).normal(0, NOISE, t.size)
    with_dicts = granflow.fit((t, force), domain="time", fixed={"k": 4e4 * velocity})
    with_params = granflow.fit(
        (t, force), domain="time", params=[Parameter("k", 4e4 * velocity, vary=False)]
    )
    _same_fit(with_dicts, with_params)


@pytest.mark.parametrize(
    ("params", "extra", "match"),
    [
        ([Parameter("k", 1.0)], {}, r"unknown parameter 'k' for the slip domain"),
        ([Parameter("x0", -1e-7, vary=False)], {}, r"held parameter 'x0' must be positive"),
        ([Parameter("Fd", -1e-3, vary=False)], {}, r"held parameter 'Fd' must be non-negative"),
        ([Parameter("alpha", -1.0, max=0.0)], {}, r"parameter 'alpha' must have lower < upper"),
        ([Parameter("x0", 1e-21, min=-1.0, max=1e-20)], {}, r"of parameter 'x0' must be positive"),
        ([Parameter("Fd", 1e-2)], {"fixed": {"a": 1e-3}}, r"give params, or fixed and bounds"),
        ([Parameter("Fd", 1e-2)], {"bounds": {}}, r"give params, or fixed and bounds"),
        ([3.0], {}, r"must hold granflow.fitting.Parameter"),
        ({"Fd": Parameter("a", 1e-3)}, {}, r"key 'Fd' holds the parameter named 'a'"),
    ],
)
def test_fit_checks_params_against_the_model(params, extra, match):
    with pytest.raises(InvalidParameterError, match=match):
        granflow.fit(_curve(), params=params, **extra)


def test_fit_many_passes_params_to_every_fit():
    curves = [_curve(seed=seed) for seed in (1, 2)]
    params = Parameters([Parameter("Fd", 10e-3, vary=False)])
    batch = granflow.fit_many(curves, jobs=1, params=params)
    for data, result in zip(curves, batch, strict=True):
        _same_fit(granflow.fit(data, fixed={"Fd": 10e-3}), result, rel=1e-12)


# --------------------------------------------------------------------------- fit_joint(params=)


def _runs():
    return [_curve(x0=x0, seed=seed) for seed, x0 in enumerate((1e-7, 1.5e-7), start=7)]


def test_joint_params_give_the_fit_of_fixed_and_honour_bounds():
    runs = _runs()
    with_dicts = granflow.fit_joint(runs, fixed={"Fd": 10e-3})
    with_params = granflow.fit_joint(runs, params=[Parameter("Fd", 10e-3, vary=False)])
    assert with_params == with_dicts  # held values only: the very same problem
    started = granflow.fit_joint(runs, params=[Parameter("alpha", 3e4), Parameter("x0_1", 1e-7)])
    free = granflow.fit_joint(runs)
    for name in free.names:
        assert started.params[name] == pytest.approx(free.params[name], rel=1e-6)
    capped = granflow.fit_joint(runs, params=[Parameter("alpha", 2e4, min=1e3, max=3e4)])
    assert capped.params["alpha"] == pytest.approx(3e4, rel=1e-9)  # the truth 4e4 is above
    with pytest.raises(InvalidParameterError, match="unknown parameter 'x0_5' for this joint"):
        granflow.fit_joint(runs, params=[Parameter("x0_5", 1e-7)])
    with pytest.raises(InvalidParameterError, match="'alpha' must be positive"):
        granflow.fit_joint(runs, params=[Parameter("alpha", -1.0, max=0.0)])
    with pytest.raises(InvalidParameterError, match="give params or fixed"):
        granflow.fit_joint(runs, params=[], fixed={})


# --------------------------------------------------------------------------- fit_creep(params=)


def test_creep_with_tau_held_is_the_linear_least_squares_solution():
    t, slip = _creep()
    result = granflow.fit_creep(t, slip, params=[Parameter("tau_c", 5.0, vary=False)])
    # by hand: slip = B s(t) with s = ln(1 + t / 5) is linear in B
    shape = np.log1p(t / 5.0)
    B = float(shape @ slip / (shape @ shape))
    redchi = float(np.sum((slip - B * shape) ** 2)) / (t.size - 1)
    assert result.params["B"] == pytest.approx(B, rel=1e-9)
    assert result.stderr["B"] == pytest.approx(math.sqrt(redchi / (shape @ shape)), rel=1e-6)
    assert result.fixed == ("tau_c",) and result.nfree == 1 and result.stderr["tau_c"] == 0.0
    assert type(result).from_dict(json.loads(json.dumps(result.to_dict()))) == result


def test_creep_with_b_held_matches_curve_fit_and_bounds_hold():
    t, slip = _creep(seed=1)
    result = granflow.fit_creep(t, slip, params=Parameters([Parameter("B", 2e-6, vary=False)]))
    (tau,), pcov = curve_fit(lambda t_, tau_: 2e-6 * np.log1p(t_ / tau_), t, slip, p0=(4.0,))
    assert result.params["tau_c"] == pytest.approx(tau, rel=1e-6)
    assert result.stderr["tau_c"] == pytest.approx(math.sqrt(pcov[0, 0]), rel=1e-3)
    capped = granflow.fit_creep(t, slip, params=[Parameter("tau_c", 3.0, min=1.0, max=4.0)])
    assert capped.params["tau_c"] == pytest.approx(4.0, rel=1e-9)  # the truth 5 s is above
    free = granflow.fit_creep(t, slip)
    started = granflow.fit_creep(t, slip, params=[Parameter("tau_c", 6.0)])
    assert started.params["tau_c"] == pytest.approx(free.params["tau_c"], rel=1e-7)
    assert "fixed" not in free.to_dict()  # the record of a plain fit is unchanged
    with pytest.raises(InvalidParameterError, match="unknown parameter 'x0' for the creep law"):
        granflow.fit_creep(t, slip, params=[Parameter("x0", 1e-7)])
    with pytest.raises(InvalidParameterError, match="'tau_c' must be positive"):
        granflow.fit_creep(t, slip, params=[Parameter("tau_c", -1.0, vary=False)])


# --------------------------------------------------------------------------- the one report


#: The display unit of each SI unit in a report (granflow.model.units.display_of_si).
_SHOWN = {
    "N": (1e3, "mN"),
    "m": (1e6, "µm"),
    "1/m": (1.0, "1/m"),
    "1/s": (1.0, "1/s"),
    "s": (1.0, "s"),
    "": (1.0, ""),
}


def _variable(text, name):
    """(value, stderr, unit, low, high) of the [[Variables]] line of ``name``, as shown."""
    pattern = (
        rf"^    {re.escape(name)} += (\S+) \+/- (\S+)(?: (\S+))? \(\S+ %\)  "
        r"95%: \[(\S+), (\S+)\]"
    )
    match = re.search(pattern, text, flags=re.MULTILINE)
    assert match, f"no line for {name} in\n{text}"
    value, err, unit, low, high = match.groups()
    return float(value), float(err), unit or "", float(low), float(high)


def _check_variables(result, units):
    """Each variable in its display unit, the value rounded at the last digit of its error
    (two digits), the interval with digits enough that its ends differ."""
    text = result.report()
    assert text.index("[[Variables]]") < text.index("[[Correlations]]")
    for name in result.names:
        scale, shown = _SHOWN[units[name]]
        if name in getattr(result, "fixed", ()):
            assert re.search(rf"^    {re.escape(name)} += \S+ {shown} \(fixed\)", text, re.M)
            continue
        value, err, unit, low, high = _variable(text, name)
        assert unit == shown
        place = 10.0 ** (math.floor(math.log10(err)) - 1)  # the error's second digit
        assert value == pytest.approx(scale * result.params[name], abs=0.51 * place)
        assert err == pytest.approx(scale * result.stderr[name], abs=0.51 * place)
        assert (low, high) == pytest.approx(tuple(scale * v for v in result.ci95[name]), rel=1e-3)
    return text


def test_report_of_a_single_fit_has_units_intervals_and_methods():
    result = granflow.fit(_curve(), fixed={"Fd": 10e-3})
    text = _check_variables(result, {"a": "N", "alpha": "1/m", "Fd": "N", "x0": "m"})
    assert "(profile)" in text and "(wald)" in text and "window" in text
    assert "R-squared" in text and "# function evals" in text
    assert text == fit_report(
        result,
        title="Fit Statistics",
        extra=(("domain", "slip"), ("# function evals", result.nfev)),
        after=(("window", f"[{result.window[0]:.6g}, {result.window[1]:.6g}] m"),),
    )


def test_report_of_a_joint_fit_has_units_and_intervals():
    joint = granflow.fit_joint(_runs(), fixed={"Fd": 10e-3})
    units = {"a": "N", "alpha": "1/m", "Fd": "N", "x0_0": "m", "x0_1": "m"}
    assert dict(joint.units) == units
    text = _check_variables(joint, units)
    assert text.startswith("[[Joint Fit Statistics]]") and "runs               = 2" in text


def test_report_of_a_time_domain_joint_fit_and_of_amontons():
    velocity = 1e-6
    t = np.linspace(0.5, 500.0, 600)
    noise = np.random.default_rng(3).normal(0, NOISE, (2, t.size))
    runs = [
        (t, friction_time(t, Params(3e-3, 4e4, 10e-3, x0), velocity) + noise[i])
        for i, x0 in enumerate((1e-7, 1.5e-7))
    ]
    joint = granflow.fit_joint(runs, domain="time")
    _check_variables(joint, {"a": "N", "k": "1/s", "Fd": "N", "t0_0": "s", "t0_1": "s"})
    x = np.linspace(1e-6, 5e-4, 600)
    loads = (0.5, 1.0)
    noise = np.random.default_rng(4).normal(0, NOISE, (2, x.size))
    curves = [
        (x, friction_slip(x, Params(6e-3 * load, 4e4, 20e-3 * load, 2e-7)) + noise[i])
        for i, load in enumerate(loads)
    ]
    amontons = granflow.fit_amontons(curves, loads)
    units = {"mu_a": "", "alpha": "1/m", "mu_d": "", "x0_0": "m", "x0_1": "m"}
    text = _check_variables(amontons.joint, units)
    assert text in amontons.report()


def test_report_of_a_curve_fit_has_units_intervals_and_correlations():
    t, slip = _creep()
    result = granflow.fit_creep(t, slip)
    text = _check_variables(result, {"B": "m", "tau_c": "s"})
    assert text.startswith("[[Fit of delta(t) = B ln(1 + t/tau_c)]]")
    correlation = result.covar["B"]["tau_c"] / (result.stderr["B"] * result.stderr["tau_c"])
    assert result.correl["B"]["tau_c"] == pytest.approx(correlation, rel=1e-12)
    assert f"C(B, tau_c) = {correlation:+.4f}" in text
    held = granflow.fit_creep(t, slip, params=[Parameter("tau_c", 5.0, vary=False)])
    _check_variables(held, {"B": "m", "tau_c": "s"})
