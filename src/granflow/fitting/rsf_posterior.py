"""The likelihood of a rate-and-state fit
(:meth:`granflow.fitting.rsf_result.RateStateFitResult.log_likelihood`), rebuilt from the
result itself, for :func:`granflow.sample_posterior`.

The likelihood is the fit's own: Gaussian with the fit's noise variance (the known sigma, or
the reduced chi-square), multiplied by the residuals' correlation time when the fit was made
with ``correlated_noise=True``, so that the posterior is as wide as the fit's intervals say
the data allow. Its model is built again from what the result stores (its points, the
protocol's load-point history, the windows, the laws, the held values, the ripple's
harmonics), so a result read back with ``from_dict`` (with its arrays) or unpickled gives
the chi-square of the fit itself.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from granflow.errors import InvalidParameterError
from granflow.families import Likelihood
from granflow.fitting.likelihoods import (
    fit_likelihood,
    require_points,
    scale_or_spread_prior,
)
from granflow.fitting.rsf_problem import Setup
from granflow.fitting.rsf_record import fit_record

if TYPE_CHECKING:
    from granflow.fitting.rsf_result import RateStateFitResult

__all__ = ["rate_state_likelihood"]

#: Search ranges the rebuilt problem declares (only evaluated, never searched).
_OPEN = (0.0, math.inf)
_POSITIVE = ("a", "stiffness", "wavelength", "Dc")


def _ranges(t, windows, shared):
    """(first, stop, start time) of each window in the result's concatenated points: a
    window runs from where the last one stopped to its last time; with ``shared``, each is
    simulated from the record's first time."""
    ranges, first = [], 0
    for start, end in windows:
        last = first + int(np.flatnonzero(t[first:] == end)[0])
        ranges.append((first, last + 1, float(t[0]) if shared else float(start)))
        first = last + 1
    return ranges


def rebuilt_problem(result):
    """(problem, values, names) of ``result``'s fit: the engine's problem over the result's
    points, and the fitted values of all its parameters (in the problem's order)."""
    require_points(result, ("t", "data", "load_point_history"))
    if result.sigma_known and result.sigma is None:
        raise InvalidParameterError(
            "this fit had a known sigma but does not store it: fit the record again"
        )
    t, data = np.asarray(result.t), np.asarray(result.data)
    ranges = _ranges(t, result.windows, result.shared_start)
    count = len(result.laws)
    record = fit_record(t, result.load_point_history, result.laws, ranges, result.shared_start)
    multi = len(ranges) > 1
    local_names = [
        (f"mu0_{i}", f"slope_{i}") if multi else ("mu0", "slope") for i in range(1, len(ranges) + 1)
    ]
    periodic = 1 + 2 * result.harmonics if result.harmonics else 0
    names = list(result.names[: len(result.names) - periodic])
    fixed = {n: result.params[n] for n in result.fixed}
    search = {n[:2]: _OPEN for n in _POSITIVE}
    setup = Setup((t, data), record, ranges, names, local_names, count, fixed, search, result.sigma)
    problem = setup.problem([result.params[n] for n in result.names], result.harmonics)
    return problem, np.array([result.params[n] for n in result.names]), list(result.names)


def rate_state_likelihood(result: RateStateFitResult) -> Likelihood:
    """The :class:`granflow.families.Likelihood` of rate-and-state fit ``result``.

    Default priors: log-uniform over a factor 1000 either way for a, the stiffness [1/m], Dc
    [m] and the ripple's wavelength [m]; uniform over 100 standard errors either side for b,
    mu0, the trend [1/m] and the ripple's amplitudes.

    Raises
    ------
    granflow.InvalidParameterError
        A result without its points or its protocol (written with
        ``to_dict(include_arrays=False)``, or before results stored their protocol).
    """
    problem, values, names = rebuilt_problem(result)
    inflation = max(result.correlation_time, 1.0) if result.correlated_noise else 1.0
    variance = (1.0 if result.sigma_known else result.redchi) * inflation
    free = [names[i] for i in problem.free]
    slots = list(problem.free)

    def log_likelihood(natural):
        trial = values.copy()
        trial[slots] = natural
        chisqr = problem.chisqr(trial)
        return -0.5 * chisqr / variance if math.isfinite(chisqr) else -math.inf

    priors = {
        n: scale_or_spread_prior(n, result.params[n], result.stderr[n], n.startswith(_POSITIVE))
        for n in free
    }
    return fit_likelihood(result, free, priors, log_likelihood)
