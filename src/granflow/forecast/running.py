"""The running forecast: what an observer would have said at each moment of a record."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

import numpy as np

from granflow.errors import InvalidDataError
from granflow.forecast._inputs import column
from granflow.forecast.baselines import inverse_velocity_forecast, voight_forecast
from granflow.forecast.failure import forecast_failure
from granflow.forecast.results import RunningForecast

if TYPE_CHECKING:
    from granflow._typing import ArrayLike
    from granflow.forecast.results import RunningForecast

__all__ = ["running_forecast"]


def _row(forecast):
    if forecast.time is None:
        return math.nan, math.nan, math.nan
    return forecast.time, *forecast.time_interval


def running_forecast(
    t: ArrayLike,
    slip: ArrayLike,
    force: ArrayLike,
    cuts: ArrayLike | None = None,
    *,
    observed: float | None = None,
    prior: Any = None,
    level: float = 0.9,
) -> RunningForecast:
    """Failure forecasts of every method at a sequence of cut times.

    Parameters
    ----------
    t, slip, force : array_like
        The force-controlled record (as :func:`~granflow.forecast_failure`): time [s], slip
        [m], imposed force [N].
    cuts : array_like, optional
        Cut times [s]; default ten from 40 % to 95 % of the observed failure time (or of the
        record).
    observed : float, optional
        The observed failure time [s], shown against the forecasts.
    prior : Prior, optional
        Prior of the model-based forecast.
    level : float
        Level of the intervals [-].

    Returns
    -------
    RunningForecast
        Per method ("model", "inverse velocity", "voight") the forecast time and interval
        [s] at each cut; NaN where a method gives no date.
    """
    time = column(t, "t", "s")
    end = float(observed) if observed is not None else float(time[-1])
    cuts = np.linspace(0.4 * end, 0.95 * end, 10) if cuts is None else column(cuts, "cuts", "s")
    methods = {
        name: {"time": [], "low": [], "high": []}
        for name in ("model", "inverse velocity", "voight")
    }
    kept = []
    for cut in cuts:
        try:
            forecasts = {
                "model": forecast_failure(t, slip, force, until=cut, prior=prior, level=level),
                "inverse velocity": inverse_velocity_forecast(t, slip, until=cut, level=level),
                "voight": voight_forecast(t, slip, until=cut, level=level),
            }
        except InvalidDataError:
            continue  # too early: too few points before this cut
        kept.append(float(cut))
        for name, forecast in forecasts.items():
            for key, value in zip(("time", "low", "high"), _row(forecast), strict=True):
                methods[name][key].append(value)
    if not kept:
        raise InvalidDataError("no cut time leaves enough points for a forecast")
    return RunningForecast(
        cuts=np.array(kept),
        methods={
            name: {k: np.array(v) for k, v in values.items()} for name, values in methods.items()
        },
        observed=None if observed is None else float(observed),
        level=level,
    )
