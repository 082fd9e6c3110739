"""The fit engine with models that are not Eq. 3: a hand-solved line and scipy's curve_fit."""

import math

import numpy as np
import pytest
from scipy.optimize import curve_fit

from granflow.fitting.creep import fit_curve
from granflow.fitting.engine import Curve, GlobalParameter, Model, Problem
from granflow.fitting.multistart import multistart
from granflow.fitting.statistics import WALD_Z, fit_statistics


def _line(x, slope, intercept):
    return slope * x + intercept


def _line_jacobian(x, slope, intercept):
    return _line(x, slope, intercept), np.column_stack([x, np.ones_like(x)])


LINE = Model(("slope", "intercept"), _line, _line_jacobian, log=(False, False))


def _decay(x, amplitude, rate):
    return amplitude * np.exp(-rate * x)


def _decay_jacobian(x, amplitude, rate):
    e = np.exp(-rate * x)
    return amplitude * e, np.column_stack([e, -amplitude * x * e])


DECAY = Model(("amplitude", "rate"), _decay, _decay_jacobian, log=(False, True))


def test_line_matches_the_normal_equations_solved_by_hand():
    rng = np.random.default_rng(1)
    x = np.linspace(0.0, 10.0, 50)
    y = 2.5 * x - 1.0 + rng.normal(0, 0.3, x.size)
    result = fit_curve(
        LINE, name="line", formula="y = m x + c", units={}, start=(1.0, 0.0), x=x, y=y
    )
    design = np.column_stack([x, np.ones_like(x)])
    (slope, intercept), *_ = np.linalg.lstsq(design, y, rcond=None)
    residual = y - design @ (slope, intercept)
    variance = float(residual @ residual) / (x.size - 2)
    covar = variance * np.linalg.inv(design.T @ design)
    # the optimum to a millionth of a standard error
    assert abs(result.params["slope"] - slope) < 1e-6 * math.sqrt(covar[0, 0])
    assert abs(result.params["intercept"] - intercept) < 1e-6 * math.sqrt(covar[1, 1])
    assert result.covar["slope"]["intercept"] == pytest.approx(covar[0, 1], rel=1e-8)
    assert result.stderr["slope"] == pytest.approx(math.sqrt(covar[0, 0]), rel=1e-8)
    low, high = result.ci95["slope"]
    assert high - low == pytest.approx(2 * WALD_Z * math.sqrt(covar[0, 0]), rel=1e-8)
    n = x.size
    assert result.aic == pytest.approx(n * math.log(result.chisqr / n) + 4, rel=1e-12)
    assert result.success


def test_decay_matches_curve_fit_with_weights_and_known_sigma():
    rng = np.random.default_rng(2)
    x = np.linspace(0.0, 5.0, 80)
    sigma = np.linspace(0.01, 0.05, x.size)
    y = 3.0 * np.exp(-0.7 * x) + rng.normal(0, sigma)
    result = fit_curve(
        DECAY, name="decay", formula="A e^-rx", units={}, start=(1.0, 0.1), x=x, y=y, sigma=sigma
    )
    values, covar = curve_fit(_decay, x, y, p0=(2.0, 0.5), sigma=sigma, absolute_sigma=True)
    assert abs(result.params["amplitude"] - values[0]) < 1e-5 * math.sqrt(covar[0, 0])
    assert abs(result.params["rate"] - values[1]) < 1e-5 * math.sqrt(covar[1, 1])
    assert result.covar["rate"]["rate"] == pytest.approx(covar[1, 1], rel=1e-5)
    assert result.covar["amplitude"]["rate"] == pytest.approx(covar[0, 1], rel=1e-5)
    assert result.sigma_known
    back = type(result).from_dict(result.to_dict())  # the per-point noise is kept
    assert np.array_equal(back.sigma, sigma) and back == result


def test_tied_parameters_and_held_values_in_the_engine():
    """Two lines share a slope (tied by name), one intercept is held."""
    x = np.linspace(0.0, 4.0, 30)
    curves = [
        Curve(x, 1.5 * x + 0.5, np.ones_like(x), ((0, 1.0), (1, 1.0))),
        Curve(x, 1.5 * x - 2.0, np.ones_like(x), ((0, 1.0), (2, 1.0))),
    ]
    parameters = [
        GlobalParameter("slope", 1.0, log=False),
        GlobalParameter("intercept_0", 0.5, log=False, fixed=True),
        GlobalParameter("intercept_1", 0.0, log=False),
    ]
    problem = Problem(curves, parameters, LINE)
    solution = multistart(problem, [(1.0, 0.5, 0.0), (3.0, 0.5, 1.0)], noise=0.0)
    values = problem.values(solution.x)
    stats = fit_statistics(problem, values, [p.name for p in parameters], sigma_known=True)
    assert stats.params["slope"] == pytest.approx(1.5, rel=1e-10)
    assert stats.params["intercept_1"] == pytest.approx(-2.0, rel=1e-10)
    assert stats.params["intercept_0"] == 0.5 and stats.stderr["intercept_0"] == 0.0
    assert set(stats.covar) == {"slope", "intercept_1"}
    assert stats.ndata == 60 and stats.nfree == 2


@pytest.mark.parametrize(("size", "strided"), [(6, False), (100, False), (2000, True)])
def test_a_strided_chi_square_reads_every_point_of_a_small_problem(size, strided):
    """Starts are ranked by chi-square on every 8th point; a problem of a few points (a
    staircase's steps, one grouped point each) is ranked on all of them, by hand: 6 points
    strided by 8 would be ranked by the first alone."""
    x = np.linspace(0.0, 1.0, size)
    y = 2.0 * x + 0.1 * np.sin(37.0 * x)
    parameters = [
        GlobalParameter("slope", 1.0, log=False),
        GlobalParameter("intercept", 0.0, log=False),
    ]
    links = ((0, 1.0), (1, 1.0))
    problem = Problem([Curve(x, y, np.ones(size), links)], parameters, LINE)
    values = np.array([1.5, 0.2])
    everything = float(np.sum((1.5 * x + 0.2 - y) ** 2))
    every_eighth = float(np.sum((1.5 * x[::8] + 0.2 - y[::8]) ** 2))
    expected = every_eighth if strided else everything
    assert problem.chisqr(values, stride=8) == pytest.approx(expected, rel=1e-12)
    assert problem.chisqr(values) == pytest.approx(everything, rel=1e-12)
