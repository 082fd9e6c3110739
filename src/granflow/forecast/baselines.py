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
from scipy.stats import norm

from granflow.fitting.engine import Curve, GlobalParameter, Model, Problem
from granflow.fitting.multistart import multistart
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


def _voight_problem(centres, log_rate, until, span):
    """The engine's problem of Voight's rate law in log v: ``ln v = ln C - p ln(t_f - t)``
    with t_f = until + lead; slots (ln C, p [-], lead [s]), p and the lead positive."""

    def function(z, log_c, power, lead):
        return log_c - power * np.log(until + lead - z)

    def jacobian(z, log_c, power, lead):
        remaining = until + lead - z
        columns = np.column_stack([np.ones_like(z), -np.log(remaining), -power / remaining])
        return log_c - power * np.log(remaining), columns

    model = Model(("log_c", "power", "lead"), function, jacobian, log=(False, True, True))
    parameters = [
        GlobalParameter("log_c", float(log_rate[-1] + math.log(span)), log=False),
        GlobalParameter("power", 1.0, log=True, lower=math.exp(-5.0), upper=math.exp(5.0)),
        GlobalParameter(
            "lead", span, log=True, lower=span * math.exp(-12.0), upper=span * math.exp(8.0)
        ),
    ]
    curve = Curve(centres, log_rate, np.ones_like(centres), ((0, 1.0), (1, 1.0), (2, 1.0)))
    return Problem([curve], parameters, model=model)


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
    slope = np.polyfit(centres, log_rate, 1)[0]
    if not slope > 0:
        return _none(method, until, level, math.nan, centres.size, "the slip rate does not grow")
    problem = _voight_problem(centres, log_rate, until, span)
    start = [log_rate[-1] + math.log(span), 1.0, span]
    solution = multistart(problem, [start], 0.0)
    values = problem.values(solution.x)
    dof = max(centres.size - 3, 1)
    chisqr, _, hessian = problem.state(solution.x, problem.free)
    variance = chisqr / dof
    try:
        se = math.sqrt(max(variance * np.linalg.inv(hessian)[2, 2], 0.0))
    except np.linalg.LinAlgError:
        se = math.inf
    u = (values[0], math.log(values[1]), math.log(values[2]))
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
        exponent=1.0 + 1.0 / values[1],
        n_points=centres.size,
        approaching=True,
    )
