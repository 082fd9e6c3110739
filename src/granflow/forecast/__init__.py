"""Forecasts of failure from the slow slip before it, and of the static yield from the start
of a start-up.

``failure`` (:func:`forecast_failure`: force control, quasi-static, slip clock; or creeping
with the direct effect: ``creep``, the slip in closed form, and ``creeping``, its fit), ``peak``
(:func:`forecast_peak`: a rate-controlled start-up cut before its peak), ``likelihood`` (the
fit with F_peak as a parameter and its profile), ``branch`` (slip on the rising branch under
a force), ``loading`` (the force history and its continuation), ``prior`` (constraints from
the campaign), ``baselines`` (inverse velocity, Voight's law), ``running`` (the forecast at a
sequence of cut times), ``synthetic`` (records for the calibration study) and ``results``.
Stands on :mod:`granflow.model`, :mod:`granflow.fitting` and :mod:`granflow.simulation`.
"""

from granflow._lazy import attach

__getattr__, __dir__, __all__ = attach(
    __name__,
    {
        "failure": ["forecast_failure"],
        "peak": ["forecast_peak"],
        "prior": ["Prior"],
        "baselines": ["inverse_velocity_forecast", "voight_forecast"],
        "running": ["RunningForecast", "running_forecast"],
        "results": ["BaselineForecast", "FailureForecast", "ForecastSeries", "PeakForecast"],
    },
)
