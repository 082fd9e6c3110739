"""Forecasts of failure from the slow slip before it, and of the static yield from the start
of a start-up.

``failure`` (:func:`forecast_failure`: force control, quasi-static, slip clock; or creeping
with the direct effect: ``creep``, the slip in closed form, and ``creeping``, its fit), ``peak``
(:func:`forecast_peak`: a rate-controlled start-up cut before its peak), ``likelihood`` (the
fit with F_peak as a parameter and its profile), ``branch`` (slip on the rising branch under
a force), ``loading`` (the force history and its continuation), ``prior`` (constraints from
the campaign), ``baselines`` (inverse velocity, Voight's law), ``running`` (the forecast at a
sequence of cut times), ``synthetic`` (records for the calibration study) and ``results``.
Judged as forecasts are judged: ``scoring`` (:func:`score`: CRPS, logarithmic and interval
scores, coverage, PIT, reliability, skill), ``references`` (the field's methods as
distributions), ``families`` (records the model did not make), ``discrepancy`` (the
residuals' verdict on the model: wider intervals, or a declined forecast) and ``league``
(every method on every family).
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
        "references": ["current_rate_forecast", "ffm_forecast", "fukuzono_forecast"],
        "scoring": ["Scores", "score", "skill"],
        "running": ["RunningForecast", "running_forecast"],
        "results": ["BaselineForecast", "FailureForecast", "ForecastSeries", "PeakForecast"],
    },
)
