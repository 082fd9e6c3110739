"""The retrospective running forecast of each force-controlled run that fails under a rising
force (a stress ramp, a staircase): what an observer would have said at a handful of cut times
before the observed failure.

A pure function of the campaign's runs and its material constants
(:func:`retrospective_forecasts`); each run's forecasts are one frozen
:class:`RunForecast`. Times are on the record's clock (force control from rest: 0 when loading
starts), forces in N; the model's slip coordinate is x = x0 + slip (slip clock).
"""

import math
from dataclasses import dataclass, replace

import numpy as np

from granflow.analysis.values import FieldValue, Value
from granflow.errors import GranflowError
from granflow.fitting.results import decode, encode, number
from granflow.forecast.results import FAILURE_CLOCK
from granflow.model.units import to_display

__all__ = ["CUT_FRACTIONS", "LEVEL", "ForecastCut", "RunForecast", "retrospective_forecasts"]

#: The cut times, as fractions of the observed failure time (of the record's end when the run
#: did not fail): a handful, so that the analysis stays fast.
CUT_FRACTIONS = (0.4, 0.51, 0.62, 0.73, 0.84, 0.95)
#: Level of the forecast intervals [-].
LEVEL = 0.9

_NAN_PAIR = (math.nan, math.nan)


def _pair(values):
    return tuple(number(v) for v in values)


@dataclass(frozen=True, eq=False)
class ForecastCut(FieldValue):
    """The model's failure forecast at one cut time.

    Attributes
    ----------
    cut : float
        The cut: the last record time used [s].
    time, time_interval : float or None, tuple
        Forecast failure time and its interval [s] (None and NaN: no date).
    force, force_interval : float or None, tuple
        Forecast failure strength F_peak and its interval [N].
    message : str
        Why there is no date, or what limits the forecast; "" otherwise.
    """

    cut: float
    time: float | None
    time_interval: tuple[float, float] = _NAN_PAIR
    force: float | None = None
    force_interval: tuple[float, float] = _NAN_PAIR
    message: str = ""

    KEEP_INFINITIES = True  # an unbounded end is kept (see granflow._codec.encode)

    @property
    def width(self):
        """Width of the time interval [s] (inf when unbounded, NaN without a date)."""
        low, high = self.time_interval
        return high - low if self.time is not None else math.nan


@dataclass(frozen=True, eq=False)
class RunForecast(Value):
    """The retrospective running forecast of one run.

    Attributes
    ----------
    run : str
        The run's name.
    normal_load : float or None
        [N]
    observed : float or None
        The observed failure time: the last point the layer held [s] (None: no failure).
    observed_window : tuple or None
        Where the failure lies in the record: from that point to the first runaway point [s].
    observed_force : float or None
        The largest force the layer held [N].
    prior : dict or None
        The prior on a, alpha, Fd (:meth:`granflow.forecast.Prior.to_dict`), if any.
    prior_from : str
        Where the prior comes from, or why there is none.
    level : float
        Level of the intervals [-].
    cuts : tuple of ForecastCut
        In increasing cut time (empty with a ``reason``).
    reason : str or None
        Why the run has no forecast at all.
    clock : str
        The clock of the times.
    """

    run: str
    normal_load: float | None
    observed: float | None
    observed_window: tuple | None
    observed_force: float | None
    prior: dict | None
    prior_from: str
    level: float = LEVEL
    cuts: tuple = ()
    reason: str | None = None
    clock: str = FAILURE_CLOCK

    @property
    def dated(self):
        """The cuts with a forecast date."""
        return tuple(cut for cut in self.cuts if cut.time is not None)

    def holds(self, cut):
        """Whether the cut's interval meets the observed failure window (None: no failure or
        no date)."""
        if self.observed_window is None or cut.time is None:
            return None
        low, high = cut.time_interval
        return bool(low <= self.observed_window[1] and high >= self.observed_window[0])

    @property
    def converged(self):
        """Whether the last dated forecast holds the observed failure and its interval is
        narrower than the first's (None when that cannot be said)."""
        dated = self.dated
        if len(dated) < 2 or self.observed_window is None:
            return None
        return bool(self.holds(dated[-1]) and dated[-1].width < dated[0].width)

    def running(self):
        """The forecasts as a :class:`granflow.forecast.ForecastSeries` (for
        :func:`granflow.plotting.plot_forecast`)."""
        from granflow.forecast.results import ForecastSeries

        def column(values):
            return np.array([math.nan if v is None else v for v in values], dtype=float)

        return ForecastSeries(
            cuts=column(cut.cut for cut in self.cuts),
            methods={
                "model": {
                    "time": column(cut.time for cut in self.cuts),
                    "low": column(cut.time_interval[0] for cut in self.cuts),
                    "high": column(cut.time_interval[1] for cut in self.cuts),
                }
            },
            observed=self.observed,
            level=self.level,
        )

    def summary(self) -> str:
        """One line: the first and last forecasts against the observed failure (s)."""
        if self.reason is not None:
            return f"forecast {self.run}: none ({self.reason})"
        dated = self.dated
        if not dated:
            return f"forecast {self.run}: no date at any cut ({self.cuts[-1].message})"
        observed = (
            "no failure observed" if self.observed is None else f"observed {self.observed:.4g} s"
        )
        from granflow._format import format_interval, format_number

        text = " -> ".join(
            f"at {format_number(cut.cut)} s: {format_number(cut.time, significant=5)} s "
            f"{format_interval(list(cut.time_interval))} ({self.level:.0%})"
            for cut in ((dated[0], dated[-1]) if len(dated) > 1 else dated)
        )
        verdict = {True: " (converged)", False: " (NOT converged)", None: ""}[self.converged]
        return f"forecast {self.run}: t_f {text}; {observed}{verdict}"

    def to_dict(self):
        """JSON-safe mapping (SI units)."""
        window = None if self.observed_window is None else list(self.observed_window)
        return encode(
            {
                "run": self.run,
                "normal_load": self.normal_load,
                "observed": self.observed,
                "observed_window": window,
                "observed_force": self.observed_force,
                "prior": self.prior,
                "prior_from": self.prior_from,
                "level": self.level,
                "cuts": [cut.to_dict() for cut in self.cuts],
                "converged": self.converged,
                "reason": self.reason,
                "clock": self.clock,
            }
        )

    @classmethod
    def from_dict(cls, saved):
        """The forecast of :meth:`to_dict`."""
        saved = decode(saved, cls)
        window = saved.get("observed_window")
        prior = saved.get("prior")
        return cls(
            run=saved["run"],
            normal_load=None if saved["normal_load"] is None else number(saved["normal_load"]),
            observed=None if saved["observed"] is None else number(saved["observed"]),
            observed_window=None if window is None else _pair(window),
            observed_force=(
                None if saved["observed_force"] is None else number(saved["observed_force"])
            ),
            prior=None if prior is None else {k: list(v) for k, v in prior.items()},
            prior_from=saved["prior_from"],
            level=number(saved["level"]),
            cuts=tuple(ForecastCut.from_dict(cut) for cut in saved["cuts"]),
            reason=saved.get("reason"),
            clock=saved.get("clock", FAILURE_CLOCK),
        )


def forecast_at(task):
    """The :class:`ForecastCut` of one ``(t, slip, force, cut, prior, level)`` task; a forecast
    that fails is returned as a cut without a date, its message saying why."""
    from granflow.forecast import forecast_failure

    t, slip, force, cut, prior, level = task
    try:
        result = forecast_failure(t, slip, force, until=cut, prior=prior, level=level)
    except (GranflowError, ArithmeticError, ValueError, RuntimeError, np.linalg.LinAlgError) as exc:
        return ForecastCut(cut=cut, time=None, message=f"{type(exc).__name__}: {exc}")
    return ForecastCut(
        cut=cut,
        time=result.time,
        time_interval=result.time_interval,
        force=result.force,
        force_interval=result.force_interval,
        message=result.message,
    )


def _prior(material, load):
    """(Prior or None, where it comes from or why there is none) at ``load`` [N]."""
    from granflow.forecast import Prior

    if material.source is None or material.mu_a.value is None:
        return None, f"none: material constants not determined ({material.reason})"
    if load is None or not load > 0:
        return None, "none: the run has no normal load"
    try:
        prior = Prior.from_material(
            *((e.value, e.stderr) for e in (material.mu_a, material.mu_d, material.alpha)), load
        )
    except GranflowError as exc:
        return None, f"none: {exc}"
    where = f"{material.source} at F_N = {to_display('normal_load', load):.4g} mN"
    return prior, where


def _eligible(entry):
    """Why a ramp run cannot be forecast, or None."""
    run = entry.run
    if run is None:
        return "its data are not at hand"
    if run.slip is None or run.force is None:
        return "the record has no slip or no force"
    return None


def retrospective_forecasts(entries, material, executor=None):
    """The running forecast of every force-controlled run with a rising force.

    Parameters
    ----------
    entries : sequence of granflow.analysis.result.RunEntry
        The campaign's runs with their data and results; the analysed ramps are forecast.
    material : granflow.analysis.joint_results.Material
        The material constants: their prior at each run's load constrains a, alpha, Fd.
    executor : granflow._parallel.Executor, optional
        Runs the cuts (default: in this process).

    Returns
    -------
    tuple of RunForecast
        In manifest order; a run or a cut whose forecast fails says why.
    """
    plans, out = [], []
    for entry in entries:
        if entry.test != "ramp" or not entry.ok:
            continue
        failure = entry.result.failure
        load = entry.run.normal_load if entry.run is not None else entry.normal_load
        prior, prior_from = _prior(material, load)
        common = {
            "run": entry.name,
            "normal_load": load,
            "observed": None if failure is None else failure.time,
            "observed_window": None if failure is None else (failure.time, failure.runaway_time),
            "observed_force": None if failure is None else failure.force,
            "prior": None if prior is None else prior.to_dict(),
            "prior_from": prior_from,
        }
        reason = _eligible(entry)
        if reason is not None:
            out.append(RunForecast(**common, reason=reason))
            continue
        run = entry.run
        start = float(run.t[0])
        end = float(run.t[-1]) if failure is None else failure.time
        cuts = [start + fraction * (end - start) for fraction in CUT_FRACTIONS]
        tasks = [(run.t, run.slip, run.force, cut, prior, LEVEL) for cut in cuts]
        plans.append((len(out), tasks))
        out.append(RunForecast(**common))
    tasks = [task for _, run_tasks in plans for task in run_tasks]
    if executor is None:
        results = [forecast_at(task) for task in tasks]
    else:
        results = executor.map(forecast_at, tasks)
    for position, run_tasks in plans:
        done, results = results[: len(run_tasks)], results[len(run_tasks) :]
        out[position] = replace(out[position], cuts=tuple(done))
    return tuple(out)
