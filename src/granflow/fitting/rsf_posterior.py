"""The posterior of a rate-and-state fit (:func:`granflow.sample_posterior` on a result of
:func:`granflow.rsf.fit`), with emcee: the optional extra ``granflow[mcmc]``.

The likelihood is the fit's own: Gaussian with the fit's noise variance (the known sigma, or
the reduced chi-square), multiplied by the residuals' correlation time when the fit was made
with ``correlated_noise=True``, so that the posterior is as wide as the fit's intervals say
the data allow. The fit keeps its model for this (the result's ``_likelihood``): a result
read back from a file or unpickled has none and must be fitted again.
"""

from __future__ import annotations

import math

import numpy as np

from granflow.errors import InvalidParameterError
from granflow.fitting.mcmc import priors_for, sample

__all__ = ["attach_likelihood", "rate_state_posterior"]

_PRIOR_WIDTH = 1e3  # log-uniform: [value / 1e3, value * 1e3]
_UNIFORM_ERRORS = 100.0  # uniform: this many standard errors either side


class _Likelihood:
    """The chi-square of a fit's problem at its free parameters' natural values."""

    def __init__(self, problem, values, names, variance):
        self.problem = problem
        self.values = np.array(values, dtype=float)
        self.names = tuple(names)
        self.free = tuple(problem.free)
        self.variance = float(variance)

    def __call__(self, natural):
        values = self.values.copy()
        values[list(self.free)] = natural
        chisqr = self.problem.chisqr(values)
        return -0.5 * chisqr / self.variance if math.isfinite(chisqr) else -math.inf


def attach_likelihood(result, problem, values, variance):
    """Keep the fit's problem on ``result`` for :func:`rate_state_posterior` (not saved, not
    pickled, not compared)."""
    likelihood = _Likelihood(problem, values, result.names, variance)
    object.__setattr__(result, "_likelihood", likelihood)
    return result


def _default(stderr):
    def prior(name, value):
        if name.startswith(("a", "stiffness", "Dc", "wavelength")) and value > 0:
            return "log-uniform", value / _PRIOR_WIDTH, value * _PRIOR_WIDTH
        error = stderr.get(name, 0.0)
        width = _UNIFORM_ERRORS * error if error > 0 else max(abs(value), 1e-12)
        return "uniform", value - width, value + width

    return prior


def rate_state_posterior(fit, priors, sampling):
    """The posterior of the free parameters of rate-and-state fit ``fit``.

    Parameters
    ----------
    fit : RateStateFitResult
        A result of :func:`granflow.rsf.fit` made in this session.
    priors : mapping of str to (kind, low, high) or None
        As :func:`granflow.sample_posterior` takes them; by default log-uniform over a factor
        1000 either way for a, the stiffness [1/m], Dc [m] and the wavelength [m], uniform over
        100 standard errors either side for b, mu0, the trend [1/m] and the ripple's
        amplitudes.
    sampling : tuple
        ``(nwalkers, nsteps, burn, seed, progress)``.

    Returns
    -------
    PosteriorResult

    Raises
    ------
    granflow.InvalidParameterError
        A result without its model (read from a file or unpickled).
    """
    likelihood = getattr(fit, "_likelihood", None)
    if likelihood is None:
        raise InvalidParameterError(
            "this rate-and-state result has no model to sample (it was read from a file or "
            "unpickled): fit the record again with granflow.rsf.fit, then sample"
        )
    free = [likelihood.names[i] for i in likelihood.free]
    least_squares = {n: fit.params[n] for n in free}
    spread = {n: fit.stderr[n] for n in free}
    chosen = priors_for(least_squares, priors, _default(spread))
    return sample(likelihood, chosen, least_squares, spread, sampling)
