"""Posterior sampling of rate-and-state fits (``granflow.sample_posterior(rsf_fit)``).

The independent references: the truth the synthetic record was simulated from (by
:func:`granflow.rsf.simulate`, not the fit's forward model), and the fit's profile-likelihood
intervals, a different method that must agree with the posterior's on a well-determined
step.
"""

import json
import pickle
import warnings

import pytest
from test_rsf_fit import SETS, synthetic

import granflow as gf
from granflow import ConvergenceWarning, rsf
from granflow.errors import InvalidParameterError

pytest.importorskip("emcee")


@pytest.fixture(scope="module")
def fitted():
    t, mu, protocol = synthetic("weakening", 3)
    fit = rsf.fit(t, mu, protocol, law="aging")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ConvergenceWarning)  # short chains in a test
        post = gf.sample_posterior(fit, nwalkers=16, nsteps=700, seed=2, progress=False)
    return (t, mu, protocol), fit, post


def test_the_posterior_holds_the_truth_and_agrees_with_the_profiles(fitted):
    _, fit, post = fitted
    _, a, b, Dc, *_ = SETS["weakening"]
    truth = {"a": a, "b": b, "Dc": Dc}  # the parameters whose intervals are coverage-tested
    assert set(post.names) == {"a", "stiffness", "b", "Dc", "mu0"}  # slope held at 0
    for name, value in truth.items():
        low, high = post.ci95[name]
        assert low < value < high, name
    for name in ("a", "b", "Dc"):
        assert fit.ci_method[name] == "profile"
        (low, high), (plow, phigh) = post.ci95[name], fit.ci95[name]
        width = phigh - plow
        assert abs(low - plow) < 0.15 * width and abs(high - phigh) < 0.15 * width, name
        assert post.medians[name] == pytest.approx(fit.params[name], abs=0.1 * width)
    assert 0.2 < post.acceptance_fraction < 0.8


def test_the_same_seed_gives_the_same_chain(fitted):
    _, fit, post = fitted
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ConvergenceWarning)
        again = gf.sample_posterior(fit, nwalkers=16, nsteps=700, seed=2, progress=False)
    assert (again.chain == post.chain).all()


def test_a_held_parameter_is_not_sampled_and_priors_are_checked(fitted):
    (t, mu, protocol), fit, _ = fitted
    held = rsf.fit(t, mu, protocol, law="aging", fixed={"stiffness": 2000.0})
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ConvergenceWarning)
        post = gf.sample_posterior(held, nwalkers=12, nsteps=40, seed=1, progress=False)
    assert "stiffness" not in post.names and "a" in post.names
    with pytest.raises(InvalidParameterError, match="'alpha' is not a free parameter"):
        gf.sample_posterior(fit, priors={"alpha": ("uniform", 0, 1)}, nsteps=20, seed=1)
    with pytest.raises(InvalidParameterError, match="nwalkers must be an integer >= 10"):
        gf.sample_posterior(fit, nwalkers=4, nsteps=20, seed=1)


def test_a_result_read_back_is_sampled_like_the_fit(fitted):
    """The likelihood is rebuilt from the result itself: a result read back from JSON (or
    unpickled) gives the same chain as the fitted one, with the same seed."""
    _, fit, _ = fitted
    text = json.dumps(fit.to_dict())

    def short_chain(result):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", ConvergenceWarning)
            return gf.sample_posterior(result, nwalkers=12, nsteps=25, seed=3, progress=False)

    chain = short_chain(fit).chain
    for copy in (pickle.loads(pickle.dumps(fit)), type(fit).from_dict(json.loads(text))):
        assert copy == fit
        assert (short_chain(copy).chain == chain).all()


def test_the_rebuilt_likelihood_is_the_fits_chi_square(fitted):
    """At the fitted values, -2 variance x the rebuilt log-likelihood is the fit's chi-square
    (its own residuals), to 1e-9 relative."""
    _, fit, _ = fitted
    copy = type(fit).from_dict(json.loads(json.dumps(fit.to_dict())))
    likelihood = copy.log_likelihood()
    natural = [fit.params[name] for name in likelihood.names]
    chisqr = -2.0 * fit.redchi * likelihood(natural)
    assert chisqr == pytest.approx(float(fit.residuals @ fit.residuals), rel=1e-9)


def test_a_compact_result_says_why_it_cannot_be_sampled(fitted):
    _, fit, _ = fitted
    compact = type(fit).from_dict(fit.to_dict(include_arrays=False))
    with pytest.raises(InvalidParameterError, match="include_arrays=True"):
        gf.sample_posterior(compact, nsteps=20, seed=1)


def test_the_likelihood_is_rebuilt_window_by_window():
    """Three steps fitted jointly (one window each, a trend each, two states): the result read
    back rebuilds the fit's chi-square, to 1e-9 relative, from the residuals it stored."""
    import numpy as np

    v1, v2 = 1e-6, 1e-5
    truth = rsf.RateState(0.6, 0.01, v1, 2000.0, [rsf.State(0.012, 20e-6)])
    steps = gf.Protocol(
        [gf.Velocity(v1, 30.0), gf.Velocity(v2, 15.0), gf.Velocity(v1, 30.0), gf.Velocity(v2, 15.0)]
    )
    t = np.arange(0.0, 90.0 + 1e-9, 0.25)
    noise = np.random.default_rng(4).normal(0.0, 2e-4, t.size)
    mu = rsf.simulate(truth, steps, t_eval=t).friction + noise
    fit = rsf.fit(t, mu, steps, states=2, detrend=True, profile=False, fixed={"stiffness": 2000.0})
    assert len(fit.windows) == 3  # up, down, up
    copy = type(fit).from_dict(json.loads(json.dumps(fit.to_dict())))
    likelihood = copy.log_likelihood()
    assert "stiffness" not in likelihood.names and "slope_2" in likelihood.names
    natural = [fit.params[name] for name in likelihood.names]
    chisqr = -2.0 * fit.redchi * likelihood(natural)
    assert chisqr == pytest.approx(float(fit.residuals @ fit.residuals), rel=1e-9)
