"""The log-likelihoods of fit results, rebuilt from what a result stores.

Gaussian likelihoods with the noise of the least-squares fit: the known sigma where the fit
had one, otherwise the residual variance (the reduced chi-square), so the posterior is as
wide as the fit's own uncertainties say. :func:`eq3_likelihood` serves
:meth:`granflow.FitResult.log_likelihood`, :func:`curve_likelihood`
:meth:`granflow.CurveFitResult.log_likelihood`; both need only the result's fields (its
points, weights, held values), so a result read back with ``from_dict`` gives the same
likelihood as the one fitted. See :class:`granflow.families.Likelihood`.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

from granflow.errors import InvalidParameterError
from granflow.families import Likelihood, resolve
from granflow.fitting.engine import model_only

if TYPE_CHECKING:
    from granflow.fitting.creep import CurveFitResult
    from granflow.fitting.single import FitResult

__all__ = ["curve_likelihood", "eq3_likelihood", "gaussian_likelihood", "require_points"]

#: Eq. 3's scale parameters: log-uniform priors by default.
_SCALE_PARAMETERS = {"a", "alpha", "x0", "k", "t0"}
_PRIOR_WIDTH = 1e3  # default log-uniform prior: [value / 1e3, value * 1e3]
_UNIFORM_ERRORS = 100.0  # default uniform prior: this many standard errors either side


def require_points(result: Any, names: tuple[str, ...] = ("data",)) -> None:
    """An error unless ``result`` holds its per-point arrays (a compact ``to_dict`` drops
    them)."""
    if any(np.asarray(getattr(result, name)).size == 0 for name in names):
        raise InvalidParameterError(
            f"this {type(result).__name__} holds no data points (it was written with "
            "to_dict(include_arrays=False)): its likelihood cannot be rebuilt; write it with "
            "include_arrays=True"
        )


def _eq3_prior(name, value):
    """Eq. 3's default prior of ``name`` about its least-squares ``value``."""
    if name in _SCALE_PARAMETERS and value > 0:
        return "log-uniform", value / _PRIOR_WIDTH, value * _PRIOR_WIDTH
    return "uniform", 0.0, max(10.0 * abs(value), 1e-12)


def scale_or_spread_prior(name, value, stderr, log):
    """Log-uniform over a factor 1000 either way for a positive parameter fitted in log
    coordinates (``log``), else uniform over 100 standard errors either side (``|value|``
    where the error is unknown)."""
    if log and value > 0:
        return "log-uniform", value / _PRIOR_WIDTH, value * _PRIOR_WIDTH
    width = _UNIFORM_ERRORS * stderr if stderr > 0 else max(abs(value), 1e-12)
    return "uniform", value - width, value + width


def gaussian_likelihood(result, free, priors, model, x, data, weights):
    """The :class:`Likelihood` of ``result``'s free parameters ``free``: ``-1/2 sum
    (weights (model(x, *values) - data) / noise)^2``, the noise 1 where sigma was known
    (the weights are then 1/sigma), else the square root of the reduced chi-square."""
    noise = 1.0 if result.sigma_known else math.sqrt(result.redchi)
    scaled = np.asarray(weights) / noise
    slots = [result.names.index(n) for n in free]
    base = np.array([result.params[n] for n in result.names])

    def log_likelihood(natural):
        values = base.copy()
        values[slots] = natural
        residual = scaled * (model(x, *values) - data)
        return -0.5 * float(residual @ residual)

    return fit_likelihood(result, free, priors, log_likelihood)


def fit_likelihood(result: Any, free: Sequence[str], priors: Any, function: Any) -> Likelihood:
    """The :class:`Likelihood` of ``result``'s free parameters ``free`` (their fitted values
    and standard errors from the result) with ``priors`` and ``function(natural) -> float``."""
    return Likelihood(
        names=tuple(free),
        values={n: result.params[n] for n in free},
        stderr={n: result.stderr[n] for n in free},
        priors=priors,
        function=function,
    )


def eq3_likelihood(result: FitResult) -> Likelihood:
    """The likelihood of an Eq. 3 fit: ``-1/2 sum (w (model - data) / noise)^2``, weights
    ``w`` as fitted; default priors log-uniform on [value/1000, value*1000] for a, alpha (k)
    and x0 (t0), uniform on [0, 10 value] for Fd."""
    require_points(result, ("x", "data", "weights"))
    free = [n for n in result.names if n not in result.fixed]
    x = np.ascontiguousarray(result.x)
    data = np.asarray(result.data)
    weights = np.asarray(result.weights)
    priors = {n: _eq3_prior(n, result.params[n]) for n in free}
    return gaussian_likelihood(result, free, priors, model_only, x, data, weights)


def curve_likelihood(result: CurveFitResult) -> Likelihood:
    """The likelihood of a closed-form curve fit: its engine model (``result.function``, a
    ``"module:NAME"`` reference) at its points, weights 1/sigma where sigma was known;
    default priors :func:`scale_or_spread_prior`."""
    require_points(result, ("x", "data"))
    if not result.function:
        raise InvalidParameterError(
            f"this {result.model} fit does not name its model function: its likelihood "
            "cannot be rebuilt"
        )
    model = resolve(result.function)
    x = np.ascontiguousarray(result.x)
    data = np.asarray(result.data)
    weight = 1.0 / np.asarray(1.0 if result.sigma is None else result.sigma, dtype=float)
    free = [n for n in result.names if n not in result.fixed]
    log = dict(zip(model.slots, model.log, strict=True))
    priors = {n: scale_or_spread_prior(n, result.params[n], result.stderr[n], log[n]) for n in free}
    return gaussian_likelihood(result, free, priors, model.function, x, data, weight)
