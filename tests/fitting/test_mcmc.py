"""Posterior sampling with emcee: agreement with the truth and least squares, reproducibility."""

import json
import warnings

import matplotlib
import numpy as np
import pytest

import granflow
from granflow import ConvergenceWarning, Params, friction_slip

matplotlib.use("Agg")

TRUTH = Params(a=3.1e-3, alpha=5e4, Fd=10e-3, x0=2.5e-7)


@pytest.fixture(scope="module")
def least_squares():
    x = np.linspace(TRUTH.x0, 4e-4, 600)
    y = friction_slip(x, TRUTH) + np.random.default_rng(21).normal(0, 5e-5, x.size)
    return granflow.fit((x, y))


@pytest.fixture(scope="module")
def posterior(least_squares):
    return granflow.sample_posterior(least_squares, nwalkers=24, nsteps=4000, seed=7)


def test_posterior_agrees_with_truth_and_least_squares(posterior, least_squares):
    assert posterior.names == ("a", "alpha", "Fd", "x0")
    for name, value in TRUTH.to_dict().items():
        median, std = posterior.medians[name], posterior.std[name]
        assert abs(median - value) < 2 * std, name
        assert abs(median - least_squares.params[name]) < 0.5 * std, name
        # posterior width and least-squares standard error agree for this well-posed fit
        assert std == pytest.approx(least_squares.stderr[name], rel=0.5), name
        low, high = posterior.ci68[name]
        assert posterior.ci95[name][0] < low < median < high < posterior.ci95[name][1]
    assert 0.15 < posterior.acceptance_fraction < 0.8
    assert posterior.chain.shape == (4000 - 1000, 24, 4)
    assert posterior.converged
    json.dumps(posterior.to_dict())
    assert "tau" in posterior.report()


def test_seeded_run_is_reproducible(least_squares):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ConvergenceWarning)
        first = granflow.sample_posterior(least_squares, nwalkers=12, nsteps=60, seed=3)
        second = granflow.sample_posterior(least_squares, nwalkers=12, nsteps=60, seed=3)
        other = granflow.sample_posterior(least_squares, nwalkers=12, nsteps=60, seed=4)
    np.testing.assert_array_equal(first.chain, second.chain)
    assert not np.array_equal(first.chain, other.chain)


def test_short_chains_warn(least_squares):
    with pytest.warns(ConvergenceWarning, match="autocorrelation"):
        result = granflow.sample_posterior(least_squares, nwalkers=12, nsteps=40, seed=1)
    assert not result.converged


def test_fixed_parameters_and_priors(least_squares):
    x, y = least_squares.x, least_squares.data
    fixed = granflow.fit((x, y), fixed={"Fd": 10e-3})
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ConvergenceWarning)
        result = granflow.sample_posterior(
            fixed, nwalkers=12, nsteps=50, seed=2, priors={"a": ("uniform", 0.0, 0.01)}
        )
    assert result.names == ("a", "alpha", "x0")
    assert result.priors["a"] == ("uniform", 0.0, 0.01)
    assert result.priors["alpha"][0] == "log-uniform"
    with pytest.raises(granflow.InvalidParameterError, match="not a free parameter"):
        granflow.sample_posterior(fixed, priors={"Fd": ("uniform", 0, 1)})
    with pytest.raises(granflow.InvalidParameterError, match="nwalkers"):
        granflow.sample_posterior(fixed, nwalkers=3)


def test_corner_and_fit_plots(posterior, least_squares):
    figure = posterior.plot_corner()
    assert len(figure.axes) == 16
    # the parameters in display units, their symbols in mathtext ("Fd" once had no unit)
    bottom = [ax.get_xlabel() for ax in figure.axes[-4:]]
    assert bottom == ["$a$ [mN]", r"$\alpha$ [1/m]", r"$F_\mathrm{d}$ [mN]", "$x_0$ [µm]"]
    low, high = figure.axes[-1].get_xlim()  # x0 in µm, about the least-squares value
    x0 = posterior.least_squares["x0"] * 1e6
    assert low < x0 < high and high - low < x0
    figure.canvas.draw()
    offsets = [ax.xaxis.get_offset_text().get_text() for ax in figure.axes]
    assert not any(offsets), offsets  # no "+1.099e1" beside the ticks
    ax = least_squares.plot()
    assert ax.get_ylabel() == "force F [mN]"
    assert len(ax.figure.axes) == 2
    lines = ax.get_lines()
    np.testing.assert_allclose(lines[1].get_ydata(), least_squares.best_fit * 1e3)
    matplotlib.pyplot.close("all")
