"""The per-run work of :func:`granflow.analyze` (rules in :mod:`granflow.analysis`).

What a run is, the fit window of a start-up, and the analysis of one start-up, creep test,
stress ramp or switch. A run's result is one of the frozen types of
:mod:`granflow.analysis.run_results`; everything here is deterministic and runs as well in a
worker process (local or Dask) as in the calling one.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from granflow.analysis.run_results import (
    CreepResult,
    FailedRun,
    ObservedPeak,
    RampFailure,
    RampResult,
    StartupResult,
    StartupWindow,
    SwitchEvent,
    SwitchResult,
)
from granflow.errors import ConvergenceWarning, FitError, GranflowError, InvalidDataError
from granflow.fitting.results import FrozenMap

if TYPE_CHECKING:
    from granflow.model.run import Run

__all__ = [
    "ANALYSES",
    "ELASTIC_RAMP_TOLERANCE",
    "RUNAWAY_FACTOR",
    "StartupData",
    "analyse_run",
    "classify",
    "increasing_time",
    "noise_level",
    "startup_data",
]

#: A slip velocity this many times the reference velocity is a runaway (failure): well above
#: any creep (slower than the drive), well below the flow after a failure.
RUNAWAY_FACTOR = 10.0
#: Noise standard deviations within which the elastic loading ramp is a straight line.
ELASTIC_RAMP_TOLERANCE = 5.0
_LEVEL_POINTS = 10  # points at one velocity that make a stress-controlled run a switch


# --------------------------------------------------------------------------- what a run is


def classify(run: Run) -> str:
    """The kind of test a run is: ``"startup"``, ``"ramp"``, ``"creep"`` or ``"switch"``.

    The metadata's ``test`` (from the manifest) wins; otherwise the rule documented in
    :mod:`granflow.analysis` decides from the control mode, the velocity and the force.

    Examples
    --------
    >>> import numpy as np, granflow
    >>> from granflow.analysis import classify
    >>> t = np.arange(50.0)
    >>> ramp = granflow.Run(t=t, slip=np.zeros(50), velocity=np.zeros(50),
    ...                     force=1e-4 * t, control="stress")
    >>> classify(ramp)
    'ramp'
    """
    from granflow.io.campaign import TEST_KINDS

    declared = run.meta.get("test")
    if isinstance(declared, str) and declared.strip().lower() in TEST_KINDS:
        return declared.strip().lower()
    if run.control == "rate":
        return "startup"
    velocity = run.velocity[np.isfinite(run.velocity)]
    if velocity.size >= _LEVEL_POINTS:
        lead = velocity[:_LEVEL_POINTS]
        level = float(np.median(lead))
        if level > 0 and np.all(np.abs(lead - level) <= 0.05 * level):
            return "switch"
    force = run.force[np.isfinite(run.force)]
    if force.size < 2:
        return "creep"
    tenth = max(1, force.size // 10)
    first, last = float(np.median(force[:tenth])), float(np.median(force[-tenth:]))
    return "ramp" if last - first > 0.05 * abs(last) else "creep"


# --------------------------------------------------------------------------- start-up window


@dataclass(frozen=True, eq=False)
class StartupData:
    """The points of a start-up run that are fitted, and how they were chosen.

    Attributes
    ----------
    slip : numpy.ndarray
        Abscissa of the fitted points [m].
    force : numpy.ndarray
        Friction force [N].
    abscissa : {"slip", "velocity*time"}
        Measured slip, or the nominal velocity times the time.
    elastic_points : int
        Leading points left out as the elastic loading ramp (0 if none was found).
    velocity : float or None
        Nominal velocity of the run [m/s].
    non_finite : int
        Rows left out because their time, slip or force is NaN or infinite.
    """

    slip: np.ndarray
    force: np.ndarray
    abscissa: str
    elastic_points: int
    velocity: float | None
    non_finite: int = 0

    def describe(self):
        """The window as a :class:`~granflow.analysis.run_results.StartupWindow`."""
        return StartupWindow(
            abscissa=self.abscissa,
            elastic_points=self.elastic_points,
            start=float(self.slip[0]),
            stop=float(self.slip[-1]),
            points=int(self.slip.size),
            non_finite=self.non_finite,
        )


def noise_level(values):
    """Robust point-to-point noise of ``values``: the median absolute deviation of the
    second differences, scaled to a standard deviation (0 with fewer than 4 points)."""
    values = np.asarray(values, dtype=float)
    if values.size < 4:
        return 0.0
    second = np.diff(values, 2)
    return float(1.4826 * np.median(np.abs(second - np.median(second))) / math.sqrt(6.0))


def _elastic_ramp_end(x, force):
    """Index of the last point of the leading straight line, or None (see the module doc)."""
    if x.size < 4:
        return None
    top = int(np.argmax(force))
    tolerance = ELASTIC_RAMP_TOLERANCE * noise_level(force) + 1e-6 * abs(float(force[top]))
    end = None
    for index in range(2, top):
        span = x[index] - x[0]
        chord = force[0] + (force[index] - force[0]) * (x[1:index] - x[0]) / span
        if np.max(np.abs(force[1:index] - chord)) > tolerance:
            break
        end = index
    return end


def startup_data(run: Run) -> StartupData:
    """The slip and force of a start-up run inside the fit window (rule: module doc).

    Parameters
    ----------
    run : granflow.Run

    Returns
    -------
    StartupData

    Raises
    ------
    InvalidDataError
        Without finite forces, or without a usable slip and a nominal velocity.
    """
    velocity = run.nominal_velocity
    keep = np.isfinite(run.t) & np.isfinite(run.force)
    with_slip = keep & np.isfinite(run.slip)
    slip = run.slip[with_slip]
    if slip.size >= 2 and np.all(np.diff(slip) > 0):
        x, force, abscissa = slip, run.force[with_slip], "slip"
        used = with_slip
    else:
        if velocity is None or not velocity > 0:
            raise InvalidDataError(
                f"{run.name}: the slip is missing or not strictly increasing, and there is no "
                "nominal velocity to compute it from the time"
            )
        t = run.t[keep]
        if t.size < 2 or np.any(np.diff(t) <= 0):
            raise InvalidDataError(f"{run.name}: the time is not strictly increasing")
        x, force, abscissa = velocity * (t - t[0]), run.force[keep], "velocity*time"
        used = keep
    end = _elastic_ramp_end(x, force)
    start = 0 if end is None else end
    x, force = x[start:], force[start:]
    return StartupData(
        slip=x,
        force=force,
        abscissa=abscissa,
        elastic_points=start,
        velocity=velocity,
        non_finite=int(used.size - np.count_nonzero(used)),
    )


# --------------------------------------------------------------------------- per-run work


class RunFailedError(GranflowError):
    """A run that cannot be analysed; ``found`` keeps what was found before the failure
    (JSON-safe, as :attr:`granflow.analysis.run_results.FailedRun.found`)."""

    def __init__(self, message, found=None):
        super().__init__(message)
        self.found = dict(found or {})


def _fit_startup(data, name):
    from granflow.fitting.single import fit
    from granflow.model.friction import NoPeakError, peak

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ConvergenceWarning)
        result = fit((data.slip, data.force), domain="slip", velocity=data.velocity)
    window = data.describe()
    if not result.success:
        found = {"fit": result.to_dict(include_arrays=False), "window": window.to_dict()}
        raise RunFailedError(f"the fit did not succeed: {result.message}", found)
    notes = []
    bounds = [n for n in result.names if result.at_bound[n]]
    if bounds:
        notes.append(f"{name}: fit at a bound of its search range: {', '.join(bounds)}")
    try:
        top = peak(result.to_params(), velocity=data.velocity)
    except NoPeakError:
        top = None
    smooth = (
        np.convolve(data.force, np.ones(5) / 5.0, mode="same")
        if data.force.size > 5
        else data.force
    )
    index = int(np.argmax(smooth))
    return StartupResult(
        fit=result,
        window=window,
        peak=top,
        observed_peak=ObservedPeak(force=float(smooth[index]), slip=float(data.slip[index])),
        warnings=tuple(notes),
    )


def _analyse_startup(run, options):
    data = startup_data(run)
    return _fit_startup(data, run.name)


def increasing_time(run, columns):
    """Finite rows (time and ``columns``), duplicate times reduced to their last row."""
    keep = np.isfinite(run.t)
    for name in columns:
        keep &= np.isfinite(getattr(run, name))
    rows = np.flatnonzero(keep)
    t = run.t[rows]
    if t.size and np.any(np.diff(t) < 0):
        raise InvalidDataError(f"{run.name}: the time decreases")
    last = np.r_[np.diff(t) > 0, True] if t.size else np.zeros(0, dtype=bool)
    return rows[last]


def _analyse_creep(run, options):
    from granflow.fitting.creep import fit_creep

    rows = increasing_time(run, ("slip", "force"))
    if rows.size < 4:
        raise InvalidDataError(f"{run.name}: fewer than 4 points with time, slip and force")
    force = run.force[rows]
    level = float(np.median(force[force.size // 2 :]))
    start = int(np.argmax(force >= 0.98 * level)) if level > 0 else 0
    rows = rows[start:]
    t = run.t[rows] - run.t[rows[0]]
    slip = run.slip[rows] - run.slip[rows[0]]
    result = CreepResult(
        fit=fit_creep(t, slip),
        stress=level,
        creep_start=float(run.t[rows[0]]),
        creep_slip=float(slip[-1]),
        duration=float(t[-1]),
    )
    if not result.fit.success:
        compact = result.to_dict(include_arrays=False)
        found = {k: v for k, v in compact.items() if k not in ("status", "reason")}
        raise RunFailedError(f"the creep fit did not succeed: {result.fit.message}", found)
    return result


def _slip_velocity(run):
    """The velocity column where it has finite values, else the slip's time derivative."""
    if np.isfinite(run.velocity).any():
        return np.array(run.velocity)
    velocity = np.full(run.t.shape, np.nan)
    rows = increasing_time(run, ("slip",))
    if rows.size >= 2:
        velocity[rows[1:]] = np.diff(run.slip[rows]) / np.diff(run.t[rows])
        velocity[rows[0]] = 0.0
    return velocity


def _missing_to_end(velocity):
    """Index from which the velocity is missing to the end (after a finite value), or None."""
    finite = np.flatnonzero(np.isfinite(velocity))
    if finite.size == 0 or finite[-1] == velocity.size - 1:
        return None
    return int(finite[-1] + 1)


def _force_carried_to(run, index, time):
    """The force [N] of the samples up to ``index`` carried on linearly to ``time`` [s]
    from the last two finite ones (the last one's where there is one only)."""
    finite = np.flatnonzero(np.isfinite(run.force[: index + 1]))
    if finite.size < 2:
        return float(run.force[finite[-1]]) if finite.size else math.nan
    i, j = finite[-2], finite[-1]
    slope = (run.force[j] - run.force[i]) / (run.t[j] - run.t[i])
    return float(run.force[j] + slope * (time - run.t[j]))


def _last_finite_force(run, index):
    finite = np.flatnonzero(np.isfinite(run.force[: index + 1]))
    return (float(run.force[finite[-1]]), int(finite[-1])) if finite.size else (math.nan, index)


def _runaway(velocity, threshold):
    """Index of the first runaway point and why, or None: a slip velocity at or above
    ``threshold``, or a velocity missing from some point to the end of the run."""
    candidates = []
    fast = np.flatnonzero(np.isfinite(velocity) & (velocity >= threshold))
    if fast.size:
        candidates.append((int(fast[0]), f"slip velocity above {threshold:.3g} m/s"))
    missing = _missing_to_end(velocity)
    if missing is not None:
        candidates.append((missing, "velocity missing to the end of the run"))
    return min(candidates) if candidates else None


def _analyse_ramp(run, options):
    threshold = RUNAWAY_FACTOR * options["reference_velocity"]
    runaway = _runaway(_slip_velocity(run), threshold)
    rows = increasing_time(run, ("force",))
    rate = None
    if rows.size >= 2:
        end = rows.size if runaway is None else max(2, int(np.searchsorted(rows, runaway[0])))
        rate = float(np.polyfit(run.t[rows[:end]], run.force[rows[:end]], 1)[0])
    if runaway is None:
        note = f"{run.name}: no failure observed in the stress ramp"
        return RampResult(failure=None, loading_rate=rate, warnings=(note,))
    index, criterion = runaway
    # the failure force is the largest the layer held: the last point before the runaway
    force, where = _last_finite_force(run, max(index - 1, 0))
    failure = RampFailure(
        criterion=criterion,
        index=where,
        time=float(run.t[where]),
        slip=float(run.slip[where]) if np.isfinite(run.slip[where]) else None,
        force=force,
        runaway_time=float(run.t[index]),
    )
    return RampResult(failure=failure, loading_rate=rate)


def _switch_index(run, nominal):
    """(index of the first point under stress control, how it was found)."""
    declared = run.meta.get("switch_time")
    if declared is not None:
        after = np.flatnonzero(run.t > float(declared))
        if after.size == 0:
            raise InvalidDataError(
                f"{run.name}: the run ends before the switch time {float(declared):g} s"
            )
        return int(after[0]), "manifest switch_time"
    velocity = run.velocity
    departs = ~np.isfinite(velocity) | (np.abs(velocity - nominal) > 0.5 * nominal)
    # the drive may need a few points to reach the velocity: look from the first point at it
    level = np.flatnonzero(~departs)
    after = np.flatnonzero(departs[level[0] :]) + level[0] if level.size else level
    if after.size == 0:
        raise InvalidDataError(
            f"{run.name}: no switch from rate to stress control found (the velocity never "
            "departs from the nominal one, and the manifest gives no switch_time)"
        )
    return int(after[0]), "velocity departs from the nominal one"


def _analyse_switch(run, options):
    velocity = np.array(run.velocity)
    nominal = run.meta.get("velocity")
    finite = np.flatnonzero(np.isfinite(velocity))
    if nominal is None and finite.size:
        nominal = float(np.median(velocity[finite[: max(1, finite.size // 10)]]))
    if nominal is None or not nominal > 0:
        raise InvalidDataError(f"{run.name}: no nominal velocity for the rate-controlled part")
    nominal = float(nominal)
    switch, found = _switch_index(run, nominal)
    if switch < 2:
        raise InvalidDataError(f"{run.name}: the switch comes before any rate-controlled data")
    force_before, where = _last_finite_force(run, switch - 1)
    imposed = run.force[switch:]
    imposed = imposed[np.isfinite(imposed)]
    level = float(np.median(imposed)) if imposed.size else force_before
    tail = velocity[switch:]
    # from the last sample under rate control: a velocity missing from the switch on (a
    # failure at the switch itself, its flow not recorded) is missing after a finite one
    if _runaway(velocity[switch - 1 :], RUNAWAY_FACTOR * nominal) is not None:
        outcome = "failure"
    elif np.isfinite(tail[-1]) and abs(tail[-1]) <= 0.01 * nominal:
        outcome = "stop"
    else:
        outcome = "creep"
    switch_time = float(run.meta.get("switch_time", run.t[where]))
    if "switch_time" not in run.meta:
        # found from the velocity: the switch came after the last sample under rate control
        # and at the first under stress control at the latest; taken there, with the
        # rate-controlled force carried on to it from its last two samples
        switch_time = float(run.t[switch])
        force_before = _force_carried_to(run, where, switch_time)
    event = SwitchEvent(
        switch_time=switch_time,
        found_by=found,
        index=switch,
        velocity=nominal,
        switch_force=force_before,
        imposed_force=level,
        factor=level / force_before if force_before > 0 else None,
        hold_time=float(np.nanmax(run.t[switch:]) - switch_time),
        outcome=outcome,
    )
    before = run.select(np.arange(len(run)) < switch)
    try:
        startup = _fit_startup(startup_data(before), run.name)
    except (RunFailedError, FitError, InvalidDataError) as exc:
        error = f"the start-up part could not be fitted: {exc}"
        return SwitchResult(
            switch=event, startup=None, fit_error=error, warnings=(f"{run.name}: {error}",)
        )
    return SwitchResult(switch=event, startup=startup, warnings=startup.warnings)


#: The analysis of each kind of test: ``function(run, options)`` -> its result.
ANALYSES = {
    "startup": _analyse_startup,
    "creep": _analyse_creep,
    "ramp": _analyse_ramp,
    "switch": _analyse_switch,
}


def analyse_run(task):
    """Analyse one run: ``task = (run, kind, options)`` -> its result.

    A top-level function, so that process pools and Dask workers can run it. Never raises for
    a problem of the run: it returns a :class:`~granflow.analysis.run_results.FailedRun`
    saying why.

    Returns
    -------
    StartupResult, CreepResult, RampResult, SwitchResult or FailedRun
    """
    run, kind, options = task
    try:
        with np.errstate(all="ignore"):
            return ANALYSES[kind](run, options)
    except RunFailedError as exc:
        return FailedRun(reason=str(exc), found=FrozenMap(exc.found))
    except GranflowError as exc:
        return FailedRun(reason=str(exc))
    except Exception as exc:  # a batch reports what failed and goes on with the rest
        return FailedRun(reason=f"{type(exc).__name__}: {exc}")
