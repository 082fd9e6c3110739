"""Forecast the static yield of a rate-controlled start-up from its beginning: fit Eq. 3 to
the record before the cut with F_peak as a parameter, and carry the profile likelihood of
F_peak to the peak's slip and time."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

import numpy as np

from granflow import _validate as check
from granflow.errors import InvalidDataError
from granflow.forecast import _inputs
from granflow.forecast.failure import _check_prior
from granflow.forecast.likelihood import Likelihood, fit_and_profile
from granflow.forecast.results import PeakForecast
from granflow.model.friction import friction_time, peak
from granflow.model.run import Run

if TYPE_CHECKING:
    from granflow._typing import ArrayLike
    from granflow.forecast.results import PeakForecast
    from granflow.model.run import Run

__all__ = ["forecast_peak"]


def _columns(run_or_t):
    if isinstance(run_or_t, Run):
        return run_or_t.t, run_or_t.force, run_or_t.nominal_velocity
    try:
        t, force = run_or_t
    except (TypeError, ValueError):
        raise InvalidDataError(
            "forecast_peak needs a granflow.Run or a (t, force) pair, "
            f"got {type(run_or_t).__name__}"
        ) from None
    return t, force, None


def _starts(force, scale, span):
    top = float(np.max(force))
    return tuple(
        (0.3 * top, alpha / span, x0 * span, top * factor)
        for x0 in (0.002, 0.02, 0.1)
        for alpha in (0.3, 1.0, 3.0)
        for factor in (1.02, 1.15, 1.5)
    )


def forecast_peak(
    run_or_t: Run | tuple[ArrayLike, ArrayLike],
    velocity: float | None = None,
    until: float | None = None,
    *,
    prior: Any = None,
    level: float = 0.9,
    noise: float | None = None,
) -> PeakForecast:
    """Forecast the peak (static yield) of a rate-controlled start-up from the record before
    ``until``.

    Parameters
    ----------
    run_or_t : Run or tuple of array_like
        A start-up :class:`~granflow.Run`, or ``(t, force)``: record time [s] (the model's t,
        0 when shearing starts) and friction force [N].
    velocity : float, optional
        The imposed velocity [m/s]; default the run's nominal velocity.
    until : float, optional
        The cut [s]; default the whole record.
    prior : Prior or mapping, optional
        Gaussian priors on a, alpha, Fd from other runs of the campaign.
    level : float
        Level of the predictive intervals [-]; default 0.9.
    noise : float, optional
        Force noise standard deviation [N]; default estimated from the fit.

    Returns
    -------
    PeakForecast
        ``force``, ``force_interval`` [N], ``slip`` [m], ``time`` [s] and their intervals.

    Raises
    ------
    granflow.InvalidDataError
        Non-finite values, time not increasing, fewer than 12 points, or no velocity.

    Examples
    --------
    >>> import numpy as np, granflow as gf
    >>> p = gf.Params(a=3.3e-3, alpha=5e4, Fd=11e-3, x0=0.3e-6)
    >>> v = 0.86e-6
    >>> t = np.arange(1.0, 18.0, 0.25)
    >>> force = gf.friction_time(t, p, v) + 3e-5 * np.random.default_rng(0).normal(size=t.size)
    >>> fc = gf.forecast_peak((t, force), velocity=v)
    >>> bool(fc.force_interval[0] <= gf.peak(p).force <= fc.force_interval[1])
    True
    """
    t, force, nominal = _columns(run_or_t)
    velocity = nominal if velocity is None else velocity
    if velocity is None:
        raise InvalidDataError("forecast_peak needs the start-up's velocity [m/s]")
    velocity = check.positive(velocity, "velocity", "m/s")
    level = check.real_scalar(level, "level")
    if not 0 < level < 1:
        raise InvalidDataError(f"level must lie between 0 and 1, got {level:g}")
    prior = _check_prior(prior)
    time, cut, until = _inputs.record(t, {"force": (force, "N")}, until)
    values = cut["force"]
    if noise is not None:
        noise = check.positive(noise, "noise", "N")
    span = velocity * float(time[-1])
    top = float(np.max(values))
    if not top > 0:
        raise InvalidDataError("the friction force never rises above zero before the cut")

    def residuals(params, s_peak):
        return values - friction_time(time, params, velocity, below="hold")

    likelihood = Likelihood(
        residuals=residuals,
        floor=0.0,
        starts=_starts(values, top, span),
        bounds=((1e-4 * top, 1e-3 / span, 1e-6 * span), (100 * top, 1e3 / span, 10 * span)),
        size=time.size,
        prior=None if prior is None else prior.residuals,
        prior_size=0 if prior is None else len(prior.names),
        noise=noise,
        scale=_inputs.rough_noise(values),
    )
    fit = fit_and_profile(likelihood, level)
    slip = peak(fit.params).slip
    slip_interval = fit.along(lambda p: peak(p).slip)
    message = "" if math.isfinite(fit.interval[1]) else "the record does not bound F_peak above"
    p = fit.params
    return PeakForecast(
        force=fit.peak_force,
        force_interval=fit.interval,
        slip=slip,
        slip_interval=slip_interval,
        time=slip / velocity,
        time_interval=(slip_interval[0] / velocity, slip_interval[1] / velocity),
        velocity=velocity,
        until=until,
        level=level,
        params={"a": p.a, "alpha": p.alpha, "Fd": p.Fd, "x0": p.x0},
        noise=fit.noise,
        n_points=time.size,
        prior=None if prior is None else prior.to_dict(),
        message=message,
    )
