"""Forecasts that follow a record as it grows: :class:`RunningForecast` (live, one update per
batch of new samples) and :func:`running_forecast` (what an observer would have said at each
of a sequence of cut times, every method side by side)."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any

import numpy as np

from granflow.errors import InvalidDataError
from granflow.forecast import _inputs
from granflow.forecast._inputs import column
from granflow.forecast.baselines import inverse_velocity_forecast, voight_forecast
from granflow.forecast.failure import forecast_failure
from granflow.forecast.results import ForecastSeries

if TYPE_CHECKING:
    from granflow._typing import ArrayLike
    from granflow.forecast.results import FailureForecast, ForecastSeries, PeakForecast

__all__ = ["RunningForecast", "running_forecast"]

_KINDS = ("failure", "peak")


class RunningForecast:
    """A forecast that follows a record while it is written.

    Each :meth:`update` takes the samples that arrived since the last one, and re-forecasts
    the whole record so far from the previous forecast's optimum and profile ends (the fit
    converges in a few steps, each profile end in one or two), returning the same result as
    the one-shot call on the record so far (:func:`~granflow.forecast_failure`,
    :func:`~granflow.forecast_peak`): the optimum is polished to convergence and the
    profiles' ends are found to 1e-4 of their signed root whichever way they are reached.
    The likelihood's other minima within reach are followed too, and the lowest is the
    optimum; a minimum that first appears while the record grows, far from every one
    followed, is found by the one-shot call's starts and not by the update (early in a
    record two failures can fit nearly equally well: the intervals then hold both, but the
    point forecast may sit in the other one's valley).

    Parameters
    ----------
    kind : {"failure", "peak"}
        A force-controlled record's failure (updates take time, slip and force), or a
        rate-controlled start-up's peak (updates take time and force; ``velocity`` needed).
    level : float
        Level of the intervals [-]; default 0.9.
    velocity : float, optional
        The start-up's velocity [m/s] (``kind="peak"``).
    prior : Prior or mapping, optional
        Gaussian priors on a, alpha, Fd from the campaign.
    sigma : float, optional
        The noise standard deviation [m of slip, or N of force]; default estimated.
    direct_effect : optional
        As :func:`~granflow.forecast_failure` takes it (the creep forecast, re-fitted at each
        update).
    max_points : int, optional
        Hold the record pooled in at most this many points
        (:class:`~granflow.forecast.pooling.Pool`: equal runs of samples averaged, merged in
        pairs as it grows), so that an update costs the same however long the record (a
        watch that runs all day).
        Default None: every sample kept. The forecast is then the one-shot forecast of the
        pooled record (``t``, ``slip``, ``force``).
    warm_start : bool
        Start each quasi-static update from the previous optimum and profile ends (default).
        False: each update is the one-shot forecast of the record so far, from cold starts
        (as fast on records of a few thousand points; the live watch uses it).

    Examples
    --------
    >>> import numpy as np, granflow as gf
    >>> from granflow.forecast.synthetic import ramp_record
    >>> p = gf.Params(a=3.3e-3, alpha=5e4, Fd=11e-3, x0=0.3e-6)
    >>> t, slip, force, truth = ramp_record(p, rate=0.065e-3, noise=2e-9, seed=1)
    >>> rf = gf.RunningForecast(kind="failure", level=0.9)
    >>> for start in range(0, 180, 30):
    ...     batch = slice(start, start + 30)
    ...     ff = rf.update(t[batch], slip[batch], force[batch])
    >>> bool(ff.time_interval[0] <= truth <= ff.time_interval[1])
    True
    """

    def __init__(
        self,
        kind: str = "failure",
        *,
        level: float = 0.9,
        velocity: float | None = None,
        prior: Any = None,
        sigma: float | None = None,
        direct_effect: Any = None,
        max_points: int | None = None,
        warm_start: bool = True,
    ) -> None:
        from granflow import _validate as check
        from granflow.forecast.failure import check_level, check_prior

        if kind not in _KINDS:
            raise InvalidDataError(f"kind must be 'failure' or 'peak', got {kind!r}")
        if kind == "peak":
            if velocity is None:
                raise InvalidDataError("RunningForecast(kind='peak') needs the velocity [m/s]")
            velocity = check.positive(velocity, "velocity", "m/s")
        self.kind = kind
        self.level = check_level(level)
        self.velocity = velocity
        self.prior = check_prior(prior)
        self.sigma = sigma
        self.direct_effect = direct_effect
        self._columns = {"t": [], "slip": [], "force": []}
        self._pool = None
        if max_points is not None:
            from granflow.forecast.pooling import Pool

            names = ("t", "force") if kind == "peak" else ("t", "slip", "force")
            self._pool = Pool(names, max_points)
        self.warm_start = bool(warm_start)
        self._last = -math.inf
        self._size = 0
        self._warm = None
        self.forecast: FailureForecast | PeakForecast | None = None

    @property
    def t(self) -> np.ndarray:
        """The record's time so far [s]."""
        return self._joined("t")

    @property
    def slip(self) -> np.ndarray:
        """The record's slip so far [m] (``kind="failure"``)."""
        return self._joined("slip")

    @property
    def force(self) -> np.ndarray:
        """The record's force so far [N]."""
        return self._joined("force")

    def _joined(self, name):
        if self._pool is not None:
            return self._pool.column(name) if name in self._pool.names else np.empty(0)
        parts = self._columns[name]
        if len(parts) > 1:
            self._columns[name] = [np.concatenate(parts)]
        return self._columns[name][0] if parts else np.empty(0)

    def update(self, t: ArrayLike, slip: ArrayLike, force: ArrayLike | None = None) -> Any:
        """Take the samples that arrived and re-forecast.

        Parameters
        ----------
        t : array_like
            Times of the new samples [s], increasing, after the last one taken.
        slip : array_like
            Their slip [m] (``kind="failure"``); for ``kind="peak"`` the force [N] (the call
            is then ``update(t, force)``).
        force : array_like, optional
            Their imposed force [N] (``kind="failure"``).

        Returns
        -------
        FailureForecast or PeakForecast or None
            The forecast of the record so far; None while it holds fewer points than a
            forecast needs (12).
        """
        if self.kind == "peak":
            if force is not None:
                raise InvalidDataError("a peak forecast's update takes (t, force)")
            force, slip = slip, None
        elif force is None:
            raise InvalidDataError("a failure forecast's update takes (t, slip, force)")
        time = column(t, "t", "s")
        new = {"t": time, "force": column(force, "force", "N", time.size)}
        if slip is not None:
            new["slip"] = column(slip, "slip", "m", time.size)
        if time.size:
            last = self._last
            steps = np.diff(np.concatenate([[last], time]))
            if np.any(steps <= 0):
                where = int(np.flatnonzero(steps <= 0)[0])
                raise InvalidDataError(
                    f"t must increase strictly across updates: {time[where]:g} s follows "
                    f"{(last if where == 0 else time[where - 1]):g} s"
                )
            self._last = float(time[-1])
        if self._pool is not None:
            self._pool.add(new)
            self._size = self._pool.size
        else:
            for name, values in new.items():
                self._columns[name].append(values)
            self._size += time.size
        if self._size < _inputs.MIN_POINTS:
            return None
        if self.forecast is not None and getattr(self.forecast, "observed_failure", None):
            return self.forecast  # the record has failed: nothing more to forecast
        self.forecast = self._forecast()
        return self.forecast

    def _forecast(self):
        if self.kind == "peak":
            from granflow.forecast.peak import forecast_peak

            return forecast_peak(
                (self.t, self.force),
                velocity=self.velocity,
                prior=self.prior,
                level=self.level,
                sigma=self.sigma,
            )
        if self.direct_effect is not None:
            return forecast_failure(
                self.t,
                self.slip,
                self.force,
                prior=self.prior,
                level=self.level,
                sigma=self.sigma,
                direct_effect=self.direct_effect,
            )
        from granflow.forecast.failure import warm_forecast

        forecast, self._warm = warm_forecast(
            self.t,
            self.slip,
            self.force,
            prior=self.prior,
            level=self.level,
            sigma=self.sigma,
            warm=self._warm if self.warm_start else None,
        )
        return forecast


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
) -> ForecastSeries:
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
    ForecastSeries
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
    return ForecastSeries(
        cuts=np.array(kept),
        methods={
            name: {k: np.array(v) for k, v in values.items()} for name, values in methods.items()
        },
        observed=None if observed is None else float(observed),
        level=level,
    )
