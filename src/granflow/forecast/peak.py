"""Forecast the static yield of a rate-controlled start-up from its beginning: fit Eq. 3 to
the record before the cut in the peak coordinates (:mod:`granflow.forecast.coordinates`),
in which F_peak and the peak's slip x_peak are parameters, and read the distributions of
both from their profiles (the peak's time is x_peak / v)."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

import numpy as np

from granflow import _validate as check
from granflow.errors import InvalidDataError
from granflow.fitting.results import FrozenMap
from granflow.forecast import _inputs
from granflow.forecast.coordinates import natural
from granflow.forecast.failure import check_level, check_prior, sigma_argument
from granflow.forecast.inference import estimate, scan
from granflow.forecast.models import startup_problem, startup_values
from granflow.forecast.results import PeakForecast
from granflow.model.run import Run

if TYPE_CHECKING:
    from granflow._typing import ArrayLike
    from granflow.forecast.results import PeakForecast
    from granflow.model.run import Run

__all__ = ["forecast_peak"]

_RATIOS = (0.3, 0.6, 0.85)
_INITIAL_STATES = (1e-3, 1e-2, 1e-1)
_SLIP_FACTORS = (0.5, 1.0, 2.0, 4.0)  # x_peak over the record's slip
_RANKED = 256  # points used to scale the starts


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


def _starts(time, force, velocity):
    """Starting values (F_peak, r, s0, x_peak) over a grid of the curve's shape and x_peak
    (over the record's slip), each with the F_peak that fits best: at fixed r, s0 and
    x_peak the force scales with F_peak (a linear least-squares scale)."""
    stride = max(time.size // _RANKED, 1)
    t = np.ascontiguousarray(time[::stride])
    data = force[::stride]
    span = velocity * float(time[-1])
    unit = np.empty(t.size)
    jacobian = np.empty((t.size, 4))
    starts = []
    for ratio in _RATIOS:
        for s0 in _INITIAL_STATES:
            for factor in _SLIP_FACTORS:
                peak_slip = factor * span
                if startup_values(t, velocity, 1.0, ratio, s0, peak_slip, unit, jacobian):
                    continue
                norm = float(unit @ unit)
                peak_force = float(unit @ data) / norm if norm > 0 else 0.0
                if math.isfinite(peak_force) and peak_force > 0:
                    starts.append([peak_force, ratio, s0, peak_slip])
    if not starts:
        raise InvalidDataError("the friction force never rises above zero before the cut")
    return starts


def forecast_peak(
    run_or_t: Run | tuple[ArrayLike, ArrayLike],
    velocity: float | None = None,
    until: float | None = None,
    *,
    prior: Any = None,
    level: float = 0.9,
    sigma: float | None = None,
    noise: float | None = None,
) -> PeakForecast:
    """Forecast the peak (static yield) of a rate-controlled start-up from the record before
    ``until``.

    Eq. 3 (paper initial condition, the force held at F(x0) before the model takes over) is
    fitted in its peak coordinates ``(F_peak, Fd / F_peak, alpha x0, x_peak)``; F_peak's and
    x_peak's distributions are their profile likelihoods' (the force noise estimated from
    the residuals: Student's t), and the peak's time is x_peak / v on the record's clock.

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
    sigma : float, optional
        Force noise standard deviation [N]; default estimated from the fit.
    noise : float, optional
        Deprecated name of ``sigma``.

    Returns
    -------
    PeakForecast
        ``force``, ``force_interval`` [N], ``slip`` [m], ``time`` [s] and their intervals;
        ``probability_within(seconds)``.

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
    level = check_level(level)
    prior = check_prior(prior)
    sigma = sigma_argument(sigma, noise, "N")
    time, cut, until = _inputs.record(t, {"force": (force, "N")}, until)
    values = cut["force"]
    if not float(np.max(values)) > 0:
        raise InvalidDataError("the friction force never rises above zero before the cut")

    def build(noise_level, start):
        return startup_problem(time, values, velocity, noise_level, start, prior=prior)

    fit = estimate(
        build,
        _starts(time, values, velocity),
        size=time.size,
        within=0.0,
        sigma=sigma,
        rough=_inputs.rough_noise(values),
    )
    _, strength = scan(fit, 0, level)
    _, reach = scan(fit, 3, level)
    best = fit.values
    transform = np.empty((4, 4))
    a, alpha, fd, x0, _ = natural(best[0], best[1], best[2], best[3], transform)
    force_interval = strength.interval(level)
    slip_interval = reach.interval(level)
    message = ""
    if math.isinf(force_interval[1]) or math.isinf(slip_interval[1]):
        message = "the record does not bound the peak from above"
    nodes, probabilities = reach.table()
    return PeakForecast(
        force=float(best[0]),
        force_interval=force_interval,
        slip=float(best[3]),
        slip_interval=slip_interval,
        time=float(best[3]) / velocity,
        time_interval=(slip_interval[0] / velocity, slip_interval[1] / velocity),
        velocity=velocity,
        until=until,
        level=level,
        params=FrozenMap({"a": a, "alpha": alpha, "Fd": fd, "x0": x0}),
        sigma=fit.sigma,
        n_points=time.size,
        prior=None if prior is None else prior.to_dict(),
        message=message,
        cdf={
            "time": [float(q) / velocity for q in nodes],
            "probability": [float(p) for p in probabilities],
        },
    )
