"""The residuals' verdict on the model: how far a record follows it, read from the fit's
residuals before any interval is drawn.

Real records are not the model plus white noise: their noise is red (the two velocity-step
records of ``../shared/data`` wander over tens of seconds), their apparatus drifts, their
physics may differ. A forecast that trusts white noise is then overconfident. Two answers,
at the cause (:func:`assess`, applied by :func:`granflow.forecast.inference.estimate` to
every forecast's first fit):

* **A model-discrepancy term.** The residuals' integrated correlation time tau (batch means
  over 20 blocks, :func:`granflow.fitting.rsf_fit.correlation_time`, as the rate-and-state
  fits' ``correlated_noise=True``): n correlated residuals carry the information of n / tau
  independent ones, so the noise's variance is multiplied by tau. Only where tau is
  significant: white residuals give tau = 1 within 2 sqrt(2 / 19) (the batch means'
  scatter), so below 1 + that (1.65) the variance stays as it is.
* **A goodness-of-fit check** that declines instead of dating (:func:`review`), where the
  record plainly does not follow the model: its residuals scatter more than the record's
  own noise allows (the residuals' RMS over the model-free noise of the second differences,
  ``lack_of_fit``, above :data:`LACK_OF_FIT`, beyond the red noise of the real records,
  whose total over white is at most 3.3), or they run away from the model at the cut (the
  last tenth's mean, in units of its own standard error with the correlation time,
  ``end_z``, beyond :data:`END_Z`), or the field's own law fits it plainly better: Voight's
  power law, fitted to the record's second half, lowers its chi-square (in units of the
  inflated noise) by more than :data:`POWER_LAW_GAIN` (a ramp's record; :func:`review`). A
  forecast then says "this record does not follow the model: no date" (``declined``), not a
  confident wrong date.

What no residual can see is a record that follows the model to the cut and parts from it
after: physics that differs only ahead (see the league, ``benchmarks/README.md``).
"""

from __future__ import annotations

import contextvars
import dataclasses
import math
from contextlib import contextmanager
from dataclasses import dataclass

import numpy as np

from granflow.fitting.rsf_fit import correlation_time
from granflow.forecast._inputs import rough_noise

__all__ = [
    "END_Z",
    "LACK_OF_FIT",
    "POWER_LAW_GAIN",
    "SIGNIFICANT",
    "Check",
    "assess",
    "check_fit",
    "power_law_gain",
    "review",
    "reviewed",
    "unreviewed",
]

#: tau above this inflates the variance (white residuals: 1 + 2 sqrt(2 / 19)).
SIGNIFICANT = 1.0 + 2.0 * math.sqrt(2.0 / 19.0)
#: A declined record whose first samples' median stands off zero by more than this many
#: times its noise is told that its slip should start at 0.
_OFFSET_NOISES = 5.0
_ZERO_SAMPLES = 5
#: The residuals' RMS over the record's own noise above which a forecast declines.
LACK_OF_FIT = 4.0
#: |end_z| above which a forecast declines.
END_Z = 4.0
#: The chi-square by which Voight's power law must fit a record's second half better than
#: the model for the forecast to decline.
POWER_LAW_GAIN = 25.0
#: A running forecast's review searches the power law in full where the gain its warm
#: search finds is within this of :data:`POWER_LAW_GAIN` (chi-square).
_NEAR_MARGIN = 5.0
_END = 0.1  # the share of the residuals at the cut that end_z reads
_BLOCKS = 20

_REVIEWED = contextvars.ContextVar("granflow_forecast_reviewed", default=True)


@dataclass(frozen=True)
class Check:
    """What the residuals say about the model.

    Attributes
    ----------
    correlation_time : float
        The residuals' integrated correlation time [points] (1 for white noise).
    inflation : float
        The factor applied to the noise's variance [-] (tau where significant, else 1).
    lack_of_fit : float
        The residuals' RMS over the model-free noise of the record [-] (about 1 where the
        model holds).
    end_z : float
        The mean of the last tenth of the residuals in units of its standard error [-].
    verdict : str
        Why the record does not follow the model; "" where it does.
    """

    correlation_time: float = 1.0
    inflation: float = 1.0
    lack_of_fit: float = math.nan
    end_z: float = 0.0
    verdict: str = ""


def assess(residuals, rms, rough):
    """The :class:`Check` of a fit's standardised ``residuals`` (in the record's order), its
    residual RMS ``rms`` and the record's model-free noise ``rough`` (the same unit)."""
    residuals = np.asarray(residuals, dtype=float)
    n = residuals.size
    if n < 2 * _BLOCKS:
        return Check(lack_of_fit=rms / rough if rough > 0 else math.nan)
    tau = float(correlation_time(residuals, blocks=_BLOCKS))
    inflation = tau if tau > SIGNIFICANT else 1.0
    scale = float(np.sqrt(np.mean(residuals**2))) or 1.0
    last = residuals[-max(int(_END * n), 5) :] / scale
    end_z = float(np.sum(last) / math.sqrt(last.size * max(tau, 1.0)))
    lack = rms / rough if rough > 0 else math.nan
    verdict = ""
    if lack > LACK_OF_FIT:
        verdict = (
            f"the record does not follow the model: its residuals scatter {lack:.3g} times "
            "its own noise (the second differences')"
        )
    elif abs(end_z) > END_Z:
        verdict = (
            f"the record does not follow the model: it runs away from the fit at the cut "
            f"(the last tenth's residuals {end_z:+.3g} standard errors)"
        )
    return Check(tau, inflation, lack, end_z, verdict)


def check_fit(problem, values, noise, size, within, rough):
    """The :class:`Check` of an engine ``problem``'s fit at ``values``, its data weighted at
    the noise level ``noise``, over ``size`` points (``within``: their squares about their
    groups' means [unit^2]); ``rough`` is the record's model-free noise [unit]."""
    curve = problem.curves[0]
    residuals = curve.w * (problem.model.function(curve.z, *values) - curve.y)
    squares = float(residuals @ residuals) * noise**2 + within
    rms = math.sqrt(squares / max(size - 4, 1))
    return assess(residuals, rms, rough)


def power_law_gain(fit, time, slip):
    """How much better Voight's power law (:func:`~granflow.forecast.references.ffm_forecast`'s
    model, 4 parameters) fits the second half of a record than the model's fit ``fit`` (an
    :class:`~granflow.forecast.inference.Estimate` with one residual per sample): the drop in
    the residual sum of squares over the fit's noise variance (its correlation inflation
    included) [-]; NaN where the fit's residuals are not one per sample (a staircase's)."""
    return _gain(fit, time, slip)[0]


def _gain(fit, time, slip, near=None):
    """(:func:`power_law_gain`, the power law's exponent at each of its leads, or None):
    ``near``, a previous call's exponents for the same record before it grew, starts the
    power law's search (:func:`~granflow.forecast.references.power_law_least`)."""
    from granflow.forecast.references import power_law_least

    curve = fit.problem.curves[0]
    residuals = curve.w * (fit.problem.model.function(curve.z, *fit.values) - curve.y)
    if residuals.size != time.size or time.size < 2 * _BLOCKS:
        return math.nan, None
    half = time >= 0.5 * (time[0] + time[-1])
    model = float(np.sum(residuals[half] ** 2))  # in units of fit.sigma^2 already
    least, exponents = power_law_least(time[half], slip[half], float(time[-1]), near=near)
    return model - least / fit.sigma**2, exponents


def review(forecast, fit, time, slip):
    """The forecast as the residuals allow: unchanged where the record follows the model,
    else declined (no date, no distribution, the verdict as its message: ``declined``).
    ``fit`` is the forecast's :class:`~granflow.forecast.inference.Estimate` (its
    :class:`Check`), ``time`` [s] and ``slip`` [m] the record up to the cut. Besides the
    check's verdict, a record whose second half Voight's power law fits better than the
    model by more than :data:`POWER_LAW_GAIN` (in chi-square) declines: its slip
    accelerates as a power law, not as the model's rising branch."""
    return reviewed(forecast, fit, time, slip)[0]


def reviewed(forecast, fit, time, slip, near=None):
    """(:func:`review`'s forecast, the power law's exponents at its leads or None): for a
    running forecast, whose next update passes the exponents back as ``near`` and so
    searches the power law about them (4 passes over the data, not 23). Where the gain
    found so comes within :data:`_NEAR_MARGIN` of :data:`POWER_LAW_GAIN`, the full search
    decides, so that an update declines exactly where the full search would on the same
    fit (a one-shot forecast of the same record declines alike where it reaches the same
    fit)."""
    if not _REVIEWED.get():
        return forecast, None
    verdict = fit.check.verdict
    exponents = None
    if not verdict:
        gain, exponents = _gain(fit, time, slip, near)
        if near is not None and gain > POWER_LAW_GAIN - _NEAR_MARGIN:
            gain, exponents = _gain(fit, time, slip)
        if gain > POWER_LAW_GAIN:
            verdict = (
                "the record does not follow the model: its slip accelerates as Voight's power "
                f"law (which fits its second half better by a chi-square of {gain:.3g})"
            )
    if not verdict:
        return forecast, exponents
    start = float(np.median(slip[:_ZERO_SAMPLES])) if len(slip) else 0.0
    if abs(start) > _OFFSET_NOISES * rough_noise(slip):
        # the likeliest cause: the slip clock counts from 0 where loading starts
        verdict += (
            f" (its slip starts at {start * 1e6:.4g} µm, not at 0: the forecast counts the "
            "slip from where the loading starts; subtract the slip there)"
        )
    check = dataclasses.replace(fit.check, verdict=verdict)
    nan = (math.nan, math.nan)
    return dataclasses.replace(
        forecast,
        time=None,
        time_interval=nan,
        force=None,
        force_interval=nan,
        slip=None,
        slip_interval=nan,
        approaching=False,
        steps=None,
        cdf={"time": [], "probability": []},
        message=check.verdict + ": no date",
        declined=True,
    ), exponents


@contextmanager
def unreviewed():
    """Forecasts made inside are not declined (the league asks what a declined forecast
    would have said)."""
    token = _REVIEWED.set(False)
    try:
        yield
    finally:
        _REVIEWED.reset(token)
