"""The landslide practice's baselines: the inverse-velocity method (Fukuzono 1985: 1/v falls
linearly to zero at failure) and Voight's rate law (1988: dv/dt = A v^alpha, alpha fitted).

Both start from the slip rate, smoothed as Carlà et al. (2017) recommend: the velocity at
each point is the slope of a straight line through a moving window of slip (a moving average
of the point-to-point rate), and the fit uses the second half of the record, where the
acceleration shows.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np
from scipy.optimize import least_squares
from scipy.stats import norm

from granflow.forecast import _inputs
from granflow.forecast.results import BaselineForecast

if TYPE_CHECKING:
    from granflow._typing import ArrayLike
    from granflow.forecast.results import BaselineForecast

__all__ = ["inverse_velocity_forecast", "smoothed_velocity", "voight_forecast"]

_DRAWS = 4000


def smoothed_velocity(t, slip, window):
    """Slip rate [m/s] at the centre of each window of ``window`` points: the least-squares
    slope of slip against time there. Returns ``(t_centre, velocity)``."""
    width = int(window)
    centres, rates = [], []
    for start in range(0, t.size - width + 1):
        tw, sw = t[start : start + width], slip[start : start + width]
        dt = tw - tw.mean()
        rates.append(float(dt @ (sw - sw.mean()) / (dt @ dt)))
        centres.append(float(tw.mean()))
    return np.array(centres), np.array(rates)


def _prepared(t, slip, until, window):
    time, cut, until = _inputs.record(t, {"slip": (slip, "m")}, until)
    width = window or max(5, time.size // 10)
    centres, rates = smoothed_velocity(time, cut["slip"], width)
    late = (centres >= centres[0] + 0.5 * (centres[-1] - centres[0])) & (rates > 0)
    return centres[late], rates[late], until


def _none(method, until, level, exponent, count, message):
    return BaselineForecast(
        method=method,
        time=None,
        time_interval=(math.nan, math.nan),
        until=until,
        level=level,
        exponent=exponent,
        n_points=count,
        approaching=False,
        message=message,
    )


def inverse_velocity_forecast(
    t: ArrayLike,
    slip: ArrayLike,
    until: float | None = None,
    *,
    level: float = 0.9,
    window: int | None = None,
) -> BaselineForecast:
    """Fukuzono's inverse-velocity method: the time where a straight line through 1/v
    reaches zero.

    Parameters
    ----------
    t : array_like
        Record time [s], strictly increasing.
    slip : array_like
        Record slip [m].
    until : float, optional
        The cut [s]; default the whole record.
    level : float
        Level of the interval [-]: from the line's parameter uncertainty (seeded draws).
    window : int, optional
        Points per velocity window; default a tenth of the record (at least 5).

    Returns
    -------
    BaselineForecast
        ``time`` None when 1/v does not fall.
    """
    method = "inverse velocity"
    centres, rates, until = _prepared(t, slip, until, window)
    if centres.size < 3:
        return _none(method, until, level, 2.0, centres.size, "too few moving points")
    inverse = 1.0 / rates
    design = np.column_stack([np.ones_like(centres), centres])
    coef, *_ = np.linalg.lstsq(design, inverse, rcond=None)
    intercept, slope = coef
    if not slope < 0:
        return _none(method, until, level, 2.0, centres.size, "1/v does not fall")
    residual = inverse - design @ coef
    variance = float(residual @ residual) / max(centres.size - 2, 1)
    cov = variance * np.linalg.inv(design.T @ design)
    draws = np.random.default_rng(0).multivariate_normal(coef, cov, _DRAWS)
    roots = np.where(
        draws[:, 1] < 0, -draws[:, 0] / np.where(draws[:, 1] < 0, draws[:, 1], -1.0), np.inf
    )
    roots = np.maximum(roots, until)
    tail = 0.5 * (1 - level)
    # Order statistics, not interpolation: the draws include roots at infinity.
    interval = (
        float(np.quantile(roots, tail, method="lower")),
        float(np.quantile(roots, 1 - tail, method="higher")),
    )
    return BaselineForecast(
        method=method,
        time=max(float(-intercept / slope), until),
        time_interval=interval,
        until=until,
        level=level,
        exponent=2.0,
        n_points=centres.size,
        approaching=True,
    )


def voight_forecast(
    t: ArrayLike,
    slip: ArrayLike,
    until: float | None = None,
    *,
    level: float = 0.9,
    window: int | None = None,
) -> BaselineForecast:
    """Voight's rate law with alpha fitted: ``v = C (t_f - t)^(-1/(alpha - 1))``, fitted in
    log v over the second half of the record; the interval from the fit's covariance of
    ln(t_f - until).

    Parameters and returns as :func:`inverse_velocity_forecast`; ``exponent`` is the fitted
    alpha [-].
    """
    method = "voight"
    centres, rates, until = _prepared(t, slip, until, window)
    if centres.size < 4:
        return _none(method, until, level, math.nan, centres.size, "too few moving points")
    log_rate = np.log(rates)
    span = centres[-1] - centres[0] + 1e-300

    def residual(u):
        log_c, log_p, log_lead = u
        return log_rate - (log_c - math.exp(log_p) * np.log(until + math.exp(log_lead) - centres))

    slope = np.polyfit(centres, log_rate, 1)[0]
    if not slope > 0:
        return _none(method, until, level, math.nan, centres.size, "the slip rate does not grow")
    start = np.array([log_rate[-1] + math.log(span), 0.0, math.log(span)])
    fit = least_squares(
        residual,
        start,
        bounds=([-np.inf, -5.0, math.log(span) - 12], [np.inf, 5.0, math.log(span) + 8]),
    )
    u = fit.x
    dof = max(centres.size - 3, 1)
    variance = 2 * fit.cost / dof
    try:
        cov = variance * np.linalg.inv(fit.jac.T @ fit.jac)
        se = math.sqrt(max(cov[2, 2], 0.0))
    except np.linalg.LinAlgError:
        se = math.inf
    z = float(norm.ppf(0.5 + 0.5 * level))
    low = until + math.exp(max(u[2] - z * se, -700.0))
    upper = u[2] + z * se
    high = until + math.exp(upper) if upper < 700.0 else math.inf
    return BaselineForecast(
        method=method,
        time=until + math.exp(u[2]),
        time_interval=(float(low), float(high)),
        until=until,
        level=level,
        exponent=1.0 + 1.0 / math.exp(u[1]),
        n_points=centres.size,
        approaching=True,
    )
