"""Forecast the failure of a force-controlled layer from its slow slip (quasi-static, slip
clock): the slip record before the cut constrains the rising branch of F(x), and the layer
fails when the continued force history reaches F_peak.

The likelihood is the engine's (:func:`granflow.forecast.models.branch_problem`), in the
peak coordinates (:mod:`granflow.forecast.coordinates`); F_peak's distribution is its
profile's, and the failure time's is the profile of P, the force at which the fitted history
stands when the true one reaches F_peak (:class:`~granflow.forecast.models.Continuation`).
"""

from __future__ import annotations

import warnings
from typing import TYPE_CHECKING, Any

from granflow import _validate as check
from granflow.errors import InvalidDataError
from granflow.forecast import _inputs
from granflow.forecast.creeping import forecast_creep
from granflow.forecast.loading import fit_loading
from granflow.forecast.observed import find_failure
from granflow.forecast.prior import Prior
from granflow.forecast.quasistatic import no_date, quasi_static
from granflow.forecast.results import FailureForecast

if TYPE_CHECKING:
    from granflow._typing import ArrayLike
    from granflow.forecast.results import FailureForecast

__all__ = [
    "check_level",
    "check_prior",
    "forecast_failure",
    "sigma_argument",
    "warm_forecast",
]


def check_prior(prior):
    """A :class:`Prior` from a Prior, a mapping or None."""
    if prior is None or isinstance(prior, Prior):
        return prior
    if isinstance(prior, dict):
        return Prior(**prior)
    raise InvalidDataError(f"prior must be a granflow.forecast.Prior or a mapping, got {prior!r}")


def check_level(level):
    """The confidence level, checked: a number strictly between 0 and 1."""
    level = check.real_scalar(level, "level")
    if not 0 < level < 1:
        raise InvalidDataError(f"level must lie between 0 and 1, got {level:g}")
    return level


def sigma_argument(sigma, noise, unit):
    """The noise level from ``sigma=`` or from the deprecated ``noise=`` (with a warning that
    names ``sigma``); None where neither is given."""
    if noise is not None:
        warnings.warn(
            "the forecasts' noise= is deprecated: pass sigma= (the same standard deviation, "
            "as the fits take it)",
            DeprecationWarning,
            stacklevel=3,
        )
        if sigma is not None:
            raise InvalidDataError("give sigma= or its old name noise=, not both")
        sigma = noise
    return None if sigma is None else check.positive(sigma, "sigma", unit)


def forecast_failure(
    t: ArrayLike,
    slip: ArrayLike,
    force: ArrayLike,
    until: float | None = None,
    *,
    prior: Any = None,
    level: float = 0.9,
    sigma: float | None = None,
    direct_effect: Any = None,
    noise: float | None = None,
) -> FailureForecast:
    """Forecast when a layer under a rising imposed force fails, from its slip before ``until``.

    Quasi-static with the slip clock (SPEC §2): the layer creeps up the rising branch of F(x),
    ``x0 + slip(t) = F^-1(sigma(t))``, and fails when the imposed force sigma reaches F_peak.
    The force history is read from ``force`` (a ramp's line, or a staircase's levels) and
    continued beyond the cut. F_peak's distribution is its profile likelihood's (the other
    parameters re-fitted at each F_peak, the slip noise estimated from the residuals: Student's
    t), and every interval, probability and step probability of the forecast comes from it.

    The fitted history is itself uncertain (the force column is noisy), and the slip is very
    sensitive to it near the peak. So the history's error, a line ``c0 + c1 u`` on the
    regression's abscissa (time, or step index) with the regression's covariance, enters the
    likelihood as standard-normal nuisance coordinates, fitted and profiled with the others
    (errors in variables). (An irregular staircase, whose levels are each their own step's
    mean, has no such line: each level then has its own coordinate, and the slope is the
    continuing step's, as uncertain as the record's step heights differ.) The failure time
    has its own profile, over the force at which the fitted history stands when the true
    history reaches F_peak.

    Under a staircase the layer fails at the start of the first step that reaches F_peak,
    each start bounded by the samples between which the record's steps began (their regular
    spacing continued beyond the record): the forecast gives each step beyond the record its
    probability (``steps``), and the time interval is the smallest run of whole steps about
    the most likely ones whose probability reaches ``level``.

    A record that already shows its failure (the slip running away: see
    :mod:`granflow.forecast.observed`) says so: ``observed_failure`` is its time, and the
    forecast uses the samples before it only (``until`` is cut there).

    Parameters
    ----------
    t : array_like
        Record time [s], 0 when loading starts, strictly increasing.
    slip : array_like
        Record slip (displacement) [m], 0 at the start (the model's x = x0 + slip); a
        record whose start stands off zero (more than five times its noise) does not
        follow the model, and its forecast says so.
    force : array_like
        Imposed force at ``t`` [N].
    until : float, optional
        The cut [s]: only points with ``t <= until`` are used; default the whole record (or,
        where it shows its failure, up to the last sample before it).
    prior : Prior or mapping, optional
        Gaussian priors on a, alpha, Fd from other runs (:class:`~granflow.forecast.Prior`).
    level : float
        Level of the predictive intervals [-]; default 0.9.
    sigma : float, optional
        Slip noise standard deviation [m]; default estimated from the fit's residuals.
    direct_effect : bool, float or DirectEffect, optional
        None (default): the quasi-static model above. Otherwise the layer creeps with the
        direct effect of :class:`granflow.DirectEffect` (:mod:`granflow.forecast.creeping`):
        ``True`` fits the amplitude A [N], a float or ``DirectEffect(amplitude=A)`` holds it.
    noise : float, optional
        Deprecated name of ``sigma``.

    Returns
    -------
    FailureForecast
        ``time``, ``time_interval`` [s], ``force``, ``force_interval`` [N], ``slip`` [m],
        ``probability_within(seconds)``; ``time`` is None with a ``message`` when the record
        shows no approaching failure.

    Raises
    ------
    granflow.InvalidDataError
        Non-finite values, time not increasing, or fewer than 12 points up to the cut.

    Examples
    --------
    >>> import numpy as np, granflow as gf
    >>> from granflow.forecast.synthetic import ramp_record
    >>> p = gf.Params(a=3.3e-3, alpha=5e4, Fd=11e-3, x0=0.3e-6)
    >>> t, slip, force, truth = ramp_record(p, rate=0.065e-3, noise=2e-9, seed=1)
    >>> ff = gf.forecast_failure(t, slip, force, until=0.9 * truth)
    >>> bool(ff.time_interval[0] <= truth <= ff.time_interval[1])
    True
    """
    from granflow.forecast._inputs import creep_amplitude

    amplitude = None if direct_effect is None else creep_amplitude(direct_effect)
    level = check_level(level)
    prior = check_prior(prior)
    sigma = sigma_argument(sigma, noise, "m")
    record = _prepared(t, slip, force, until)
    time, slip_cut, loading, until, observed, message = record
    if loading.rate <= 0:
        text = "the imposed force does not rise, so it never reaches the peak"
        return no_date(until, level, loading, time.size, text, prior, observed)
    if direct_effect is not None:
        return forecast_creep(
            time, slip_cut, loading, until, level, amplitude, prior, sigma, observed, message
        )
    return quasi_static(time, slip_cut, loading, until, level, prior, sigma, observed, message)[0]


def _prepared(t, slip, force, until):
    """(time, slip, loading, until, observed failure, message) of a record: checked, cut at
    ``until``, and where it shows its failure cut before it."""
    whole, columns, _ = _inputs.record(t, {"slip": (slip, "m"), "force": (force, "N")}, None)
    observed = find_failure(whole, columns["slip"], columns["force"])
    message = ""
    if observed is not None:
        last = float(whole[observed.index])
        if until is None or check.real_scalar(until, "until", "s") > last:
            if until is not None:
                message = (
                    f"the record fails at {observed.time:.4g} s: forecast from the samples "
                    f"before it (up to {last:.4g} s), not up to until = {float(until):.4g} s"
                )
            until = last
    time, cut, until = _inputs.record(
        whole, {"slip": (columns["slip"], "m"), "force": (columns["force"], "N")}, until
    )
    return time, cut["slip"], fit_loading(time, cut["force"]), until, observed, message


def warm_forecast(t, slip, force, *, prior=None, level=0.9, sigma=None, warm=None):
    """The quasi-static :func:`forecast_failure` of a whole record, warm-started from the
    :class:`~granflow.forecast.quasistatic.Warm` state of its forecast before it grew;
    ``(forecast, warm state)`` (the state None where there was no fit)."""
    level = check_level(level)
    prior = check_prior(prior)
    sigma = sigma_argument(sigma, None, "m")
    time, slip_cut, loading, until, observed, message = _prepared(t, slip, force, None)
    if loading.rate <= 0:
        text = "the imposed force does not rise, so it never reaches the peak"
        return no_date(until, level, loading, time.size, text, prior, observed), None
    return quasi_static(
        time, slip_cut, loading, until, level, prior, sigma, observed, message, warm
    )
