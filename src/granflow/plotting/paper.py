"""Figures in the manner of the paper: start-up curves (Fig. 2a), stress ramp (Fig. 3a), creep
(Fig. 3b), switch from rate to force control (Fig. 3c), and :func:`save_figure`.

The velocity collapse (Fig. 2b) and Amontons' law (Fig. 2c) are in
:mod:`granflow.plotting.fits`. Every function takes data as measured: a fit may be missing or
unsuccessful (the data are then drawn alone), columns may hold NaN, a stress-controlled run may
have no slip. Colours are the same in every figure: slip blue (left axis), force black (right
axis), model grey, F_peak and failure red, F_d green, the switch orange.
"""

import os
from pathlib import Path

import numpy as np

from granflow import _validate as check
from granflow.errors import InvalidParameterError
from granflow.plotting._axes import (
    FORCE_COLOR,
    MAX_LEGEND_RUNS,
    MICRO,
    MILLI,
    MODEL_COLOR,
    PEAK_COLOR,
    SLIP_COLOR,
    STEADY_COLOR,
    SWITCH_COLOR,
    check_axes,
    finite,
    legend_above,
    new_axes,
    run_colors,
    run_label,
)

__all__ = ["plot_creep", "plot_startup", "plot_stress_ramp", "plot_switch", "save_figure"]

#: Resolution of the PNG files written by :func:`save_figure` [dots per inch].
PNG_DPI = 150

#: Up to this many start-up runs, the legend carries each fit's a, alpha v and t0.
FEW_RUNS = 4

#: Relative change of the velocity that marks the end of the rate-controlled part of a switch.
SWITCH_TOLERANCE = 0.05

#: Fraction of a run's duration over which the slip rate is measured when there is no velocity.
SWITCH_LAG = 0.02

#: A slip rate this many times its median marks the runaway (failure) of a stress ramp.
RUNAWAY_FACTOR = 50.0


# --------------------------------------------------------------------------- argument checks


def _as_run(run, name):
    from granflow.model.run import Run

    if not isinstance(run, Run):
        raise InvalidParameterError(f"{name} must be a granflow.Run, got {type(run).__name__}")
    return run


def _as_runs(runs, name):
    """A list of Runs from one Run or a sequence of them."""
    from granflow.model.run import Run

    if isinstance(runs, Run):
        return [runs]
    if isinstance(runs, str | bytes | dict) or not hasattr(runs, "__iter__"):
        raise InvalidParameterError(
            f"{name} must be a granflow.Run or a sequence of Runs, got {type(runs).__name__}"
        )
    runs = list(runs)
    if not runs:
        raise InvalidParameterError(f"{name} is empty: give at least one Run")
    for index, run in enumerate(runs):
        _as_run(run, f"{name}[{index}]")
    return runs


def _as_fits(fits, count, name, kind):
    """``fits`` as a list of ``count`` entries, each None or an instance of ``kind``."""
    if fits is None:
        return [None] * count
    if isinstance(fits, kind):
        fits = [fits]
    elif isinstance(fits, str | bytes | dict) or not hasattr(fits, "__iter__"):
        raise InvalidParameterError(
            f"{name} must be a sequence of {kind.__name__} (or None), got {type(fits).__name__}"
        )
    fits = list(fits)
    if len(fits) != count:
        raise InvalidParameterError(
            f"{name} has {len(fits)} entries for {count} run{'s' if count != 1 else ''}: "
            "give one per run, None where there is no fit"
        )
    for index, fit in enumerate(fits):
        if fit is not None and not isinstance(fit, kind):
            raise InvalidParameterError(
                f"{name}[{index}] must be a {kind.__name__} or None, got {type(fit).__name__}"
            )
    return fits


def _as_params(params, name="params"):
    from granflow.model.params import Params

    if params is not None and not isinstance(params, Params):
        raise InvalidParameterError(
            f"{name} must be a granflow.Params or None, got {type(params).__name__}"
        )
    return params


def _usable(fit):
    return fit is not None and bool(fit.success)


def _twin_axes(ax):
    """(slip axes, force axes): ``ax`` (or a new one) and its twin on the right."""
    slip_ax = new_axes(check_axes(ax, "ax"), figsize=(6.4, 4.2))
    force_ax = slip_ax.twinx()
    slip_ax.set_xlabel("time t [s]")
    slip_ax.set_ylabel("slip δ [µm]", color=SLIP_COLOR)
    slip_ax.tick_params(axis="y", colors=SLIP_COLOR)
    force_ax.set_ylabel("force F [mN]", color=FORCE_COLOR)
    return slip_ax, force_ax


def _no_slip_note(ax):
    """Say on the (top-most) axes ``ax`` that the run has no slip data."""
    ax.text(
        0.5,
        0.5,
        "no slip recorded",
        transform=ax.transAxes,
        ha="center",
        va="center",
        color=SLIP_COLOR,
        fontsize="small",
        bbox={"facecolor": "white", "edgecolor": SLIP_COLOR, "boxstyle": "round"},
        zorder=5,
    )


def _handles(*axes):
    handles = []
    for ax in axes:
        handles.extend(ax.get_legend_handles_labels()[0])
    return handles


def _align_zeros(slip_ax, force_ax, slip, force, peak):
    """Both axes from zero (slip below zero only if measured so); force room above the top."""
    low = min(0.0, float(np.min(slip)) * MICRO) if slip.size else 0.0
    slip_ax.set_ylim(bottom=low)
    top = max(float(np.max(force)) if force.size else 0.0, peak.force if peak else 0.0)
    if top > 0:
        force_ax.set_ylim(0.0, 1.12 * top * MILLI)
    else:
        force_ax.set_ylim(bottom=0.0)
    slip_ax.set_xlim(left=0.0)


def _small_axes(ax, xlabel, ylabel):
    """Small fonts for an inset."""
    ax.tick_params(labelsize="x-small", pad=1.5)
    ax.set_xlabel(xlabel, fontsize="x-small", labelpad=1.5)
    ax.set_ylabel(ylabel, fontsize="x-small", labelpad=1.5)


# --------------------------------------------------------------------------- the model


def _peak_or_none(params):
    from granflow.model.friction import NoPeakError, peak

    try:
        return peak(params)
    except NoPeakError:
        return None


def _rising_branch(params, top, points=2000):
    """Slip grid from x0 to ``top`` [m] and the friction on it (increasing up to the peak)."""
    from granflow.model.friction import friction_slip

    slip = np.geomspace(params.x0, max(top, params.x0 * (1 + 1e-9)), points)
    return slip, friction_slip(slip, params)


def _quasistatic_slip(force, params, peak):
    """Slip [m] a fresh layer reaches under the imposed forces ``force`` [N], quasi-statically.

    The layer follows the rising branch of F(x): it sticks at x0 until the force exceeds the
    initial friction, then sits where F(x) equals the largest force imposed so far. NaN from
    the first force above F_peak (failure) on.
    """
    slip, strength = _rising_branch(params, peak.slip)
    held = np.fmax.accumulate(np.where(np.isfinite(force), force, 0.0))
    aging = np.interp(held, strength, slip, left=params.x0)
    return np.where(held < peak.force, aging - params.x0, np.nan)


def _crossing_time(t, values, level):
    """First time at which ``values`` reaches ``level`` (linear interpolation), or None."""
    above = np.flatnonzero(values >= level)
    if above.size == 0:
        return None
    i = int(above[0])
    if i == 0:
        return float(t[0])
    step = values[i] - values[i - 1]
    fraction = (level - values[i - 1]) / step if step > 0 else 1.0
    return float(t[i - 1] + fraction * (t[i] - t[i - 1]))


def _switch_outcome(params, peak, slip_at_switch, force):
    """What the quasi-static model predicts after a switch: ("fails", None) or ("stops", slip).

    The slip is the aging coordinate, as in the fits (x = v t under rate control; at least
    x0). The layer at x_s fails when the imposed force exceeds every friction ahead (F_peak
    before the peak, F(x_s) after it, where F only falls); otherwise it slides to the first
    x >= x_s where F(x) reaches the force and stops there.
    """
    from granflow.model.friction import friction_slip

    x_switch = max(slip_at_switch, params.x0)
    current = float(friction_slip(x_switch, params))
    ahead = peak.force if peak is not None and x_switch < peak.slip else current
    if force > ahead:
        return "fails", None
    if force <= current:
        return "stops", x_switch
    slip, strength = _rising_branch(params, peak.slip)
    keep = slip >= x_switch
    return "stops", float(np.interp(force, strength[keep], slip[keep]))


# --------------------------------------------------------------------------- Fig. 2a


def _time_of_slip(run):
    """A function slip [m] -> time [s] along a rate-controlled run (slip increasing)."""
    t, slip = finite(run.t, run.slip)
    order = np.argsort(slip, kind="stable")
    return lambda values: np.interp(values, slip[order], t[order])


def _fit_in_time(run, fit):
    """(t grid, model, t of fitted points, residuals) of a fit, against time [s]."""
    low, high = fit.window
    grid = np.unique(np.concatenate([np.geomspace(low, high, 200), np.linspace(low, high, 400)]))
    model = fit.model(grid)
    if fit.domain == "time":
        return grid, model, fit.x, fit.residuals
    to_time = _time_of_slip(run)
    return to_time(grid), model, to_time(fit.x), fit.residuals


def _fit_label(run, fit):
    """a, alpha v and t0 of a fit (the paper's Fig. 2a caption), or a and alpha."""
    velocity = fit.velocity if fit.velocity is not None else run.nominal_velocity
    p = fit.params
    a = f"a = {p['a'] * MILLI:.3g} mN"
    if fit.domain == "time":
        return f"{a}, αv = {p['k']:.2g} 1/s, t₀ = {p['t0']:.2g} s"
    if velocity:
        return f"{a}, αv = {p['alpha'] * velocity:.2g} 1/s, t₀ = {p['x0'] / velocity:.2g} s"
    return f"{a}, α = {p['alpha']:.3g} 1/m"


def plot_startup(runs, fits, ax=None, *, residual_ax=None):
    """Start-up curves under an imposed velocity with their fits (Fig. 2a).

    Friction force [mN] against time [s]: each run's data as points, its fit of Eq. 3 as a
    line in the same colour, the residuals in a panel below.

    Parameters
    ----------
    runs : Run or sequence of Run
        Rate-controlled start-up runs (``t`` [s], ``force`` [N]; rows with NaN are skipped).
    fits : FitResult, sequence of FitResult or None, or None
        One per run, in the same order (slip- or time-domain fits). A run whose fit is None
        or unsuccessful (``success=False``) is drawn as data only. None: no fits.
    ax : matplotlib.axes.Axes, optional
        Axes for data and fits. When neither ``ax`` nor ``residual_ax`` is given, a new figure
        with a residual panel below is made.
    residual_ax : matplotlib.axes.Axes, optional
        Axes for the residuals, data minus fit [mN] (none drawn when ``ax`` is given alone).

    Returns
    -------
    matplotlib.axes.Axes
        The axes with data and fits.

    Raises
    ------
    InvalidParameterError
        If ``runs`` holds something other than Runs, ``fits`` does not have one entry per
        run, or an axes argument is not an Axes.

    Examples
    --------
    >>> import numpy as np, granflow
    >>> from granflow.plotting import plot_startup
    >>> p = granflow.Params.from_time_domain(3.31e-3, 0.036, 0.23, 10e-3, 0.86e-6)
    >>> t = np.arange(1.0, 400.0)
    >>> run = granflow.Run(t, 0.86e-6 * t, np.full(t.size, 0.86e-6),
    ...                    granflow.friction_time(t, p, 0.86e-6))
    >>> ax = plot_startup([run], [granflow.fit(run, profile=False)])
    >>> ax.get_ylabel()
    'friction force F [mN]'
    """
    from granflow.fitting.single import FitResult

    runs = _as_runs(runs, "runs")
    fits = _as_fits(fits, len(runs), "fits", FitResult)
    check_axes(ax, "ax")
    check_axes(residual_ax, "residual_ax")
    if ax is None and residual_ax is None:
        import matplotlib.pyplot as plt

        _, (ax, residual_ax) = plt.subplots(
            2, 1, sharex=True, figsize=(6.4, 5.2), height_ratios=(3, 1), layout="constrained"
        )
    ax = new_axes(ax)
    from matplotlib.lines import Line2D

    handles = []
    colors = run_colors(len(runs))
    detailed = len(runs) <= FEW_RUNS  # fitted values in the legend, as in the paper's caption
    for index, (run, fit) in enumerate(zip(runs, fits, strict=True)):
        color = colors[index]
        t, force = finite(run.t, run.force)
        fitted = _usable(fit)
        ax.plot(t, force * MILLI, ".", ms=2.5, color=color, alpha=0.45 if fitted else 0.8)
        label = run_label(run)
        if fitted:
            t_model, model, t_points, residuals = _fit_in_time(run, fit)
            ax.plot(t_model, model * MILLI, "-", color=color, lw=1.5)
            if detailed:
                label = f"{label}: {_fit_label(run, fit)}"
            if residual_ax is not None:
                residual_ax.plot(t_points, residuals * MILLI, ".", ms=2, color=color)
        else:
            label += " (no fit)" if fit is None else " (fit failed)"
        if index < MAX_LEGEND_RUNS:
            handles.append(
                Line2D([], [], color=color, marker=".", ls="-" if fitted else "none", label=label)
            )
    if len(runs) > MAX_LEGEND_RUNS:
        handles.append(Line2D([], [], ls="none", label=f"+ {len(runs) - MAX_LEGEND_RUNS} more"))
    ax.set_ylabel("friction force F [mN]")
    ax.set_ylim(bottom=0.0)
    legend_above(ax, handles, ncols=1 if detailed else 2)
    if residual_ax is not None:
        residual_ax.axhline(0.0, color="0.3", lw=0.8)
        residual_ax.set_ylabel("residual [mN]")
        residual_ax.set_xlabel("time t [s]")
    else:
        ax.set_xlabel("time t [s]")
    return ax


# --------------------------------------------------------------------------- Fig. 3a


def _runaway_time(t, slip):
    """First time the slip rate exceeds RUNAWAY_FACTOR times its median, or None."""
    if slip.size < 3:
        return None
    dt = np.diff(t)
    rates = np.divide(np.diff(slip), dt, out=np.zeros_like(dt), where=dt > 0)
    moving = rates[rates > 0]
    if moving.size == 0:
        return None
    fast = np.flatnonzero(rates > RUNAWAY_FACTOR * np.median(moving))
    return float(t[fast[0]]) if fast.size else None


def _slip_inset(parent, t, slip, end, model=None):
    """An inset of the slip [µm] up to time ``end`` [s] in the upper left of ``parent``."""
    inset = parent.inset_axes([0.06, 0.48, 0.34, 0.34])
    window = t <= end
    inset.plot(t[window], slip[window] * MICRO, ".", ms=2, color=SLIP_COLOR)
    if model is not None:
        t_model, slip_model = model
        keep = t_model <= end
        inset.plot(t_model[keep], slip_model[keep] * MICRO, "--", color=MODEL_COLOR, lw=1.2)
    inset.set_xlim(0.0, end)
    _small_axes(inset, "t [s]", "δ [µm]")
    inset.text(
        0.04, 0.94, "before failure", transform=inset.transAxes, va="top", fontsize="x-small"
    )
    return inset


def plot_stress_ramp(run, params=None, ax=None, *, inset=True):
    """A stress ramp (Fig. 3a): slip (left axis) and imposed force (right axis) against time.

    Parameters
    ----------
    run : Run
        A force-controlled ramp: ``force`` is the imposed force [N], ``slip`` [m] the
        response (may be all NaN: the force is then drawn alone).
    params : Params, optional
        Parameters of the sample at this load. Overlays the peak of the rate-controlled
        overshoot F_peak (red dashed), the predicted failure (the time the imposed force
        reaches F_peak, red dotted) and the quasi-static slip along the rising branch of
        F(x) (grey dashed).
    ax : matplotlib.axes.Axes, optional
        Axes for the slip; the force goes on its twin. A new figure when None.
    inset : bool
        Magnify the slip before failure in an inset (upper left), when the runaway makes it
        small in the main axes. The end of that window is the predicted failure (with
        ``params``), else the first time the slip rate exceeds 50 times its median.

    Returns
    -------
    numpy.ndarray of matplotlib.axes.Axes
        ``[slip_axes, force_axes]``.

    Raises
    ------
    InvalidParameterError
        If ``run`` is not a Run, ``params`` not a Params, ``ax`` not an Axes.
    """
    run = _as_run(run, "run")
    params = _as_params(params)
    slip_ax, force_ax = _twin_axes(ax)
    t_slip, slip = finite(run.t, run.slip)
    t_force, force = finite(run.t, run.force)
    if slip.size:
        slip_ax.plot(t_slip, slip * MICRO, ".", ms=3, color=SLIP_COLOR, label="slip δ")
    else:
        _no_slip_note(force_ax)
    force_ax.plot(t_force, force * MILLI, "-", color=FORCE_COLOR, lw=1.5, label="imposed force")
    failure = None
    model = None
    peak = None if params is None else _peak_or_none(params)
    if peak is not None:
        force_ax.axhline(
            peak.force * MILLI,
            color=PEAK_COLOR,
            ls="--",
            lw=1.2,
            label=f"F_peak = {peak.force * MILLI:.3g} mN (rate control)",
        )
        failure = _crossing_time(t_force, force, peak.force)
        if failure is not None:
            force_ax.axvline(
                failure,
                color=PEAK_COLOR,
                ls=":",
                lw=1.2,
                label=f"failure predicted: {failure:.3g} s",
            )
        if force.size:
            model = (t_force, _quasistatic_slip(force, params, peak))
            slip_ax.plot(
                model[0],
                model[1] * MICRO,
                "--",
                color=MODEL_COLOR,
                lw=1.2,
                label="slip, quasi-static model",
            )
    _align_zeros(slip_ax, force_ax, slip, force, peak)
    end = failure if failure is not None else _runaway_time(t_slip, slip)
    if inset and slip.size and end is not None and end > t_slip[0]:
        before = slip[t_slip <= end]
        if before.size >= 3 and np.ptp(before) < 0.25 * np.ptp(slip):
            _slip_inset(force_ax, t_slip, slip, end, model)
    legend_above(slip_ax, _handles(slip_ax, force_ax), ncols=2)
    return np.array([slip_ax, force_ax])


# --------------------------------------------------------------------------- Fig. 3b


def _imposed_force(run):
    """Median of the finite force column [N], or None."""
    force = run.force[np.isfinite(run.force)]
    return float(np.median(force)) if force.size else None


def _creep_inset(parent, params, levels):
    """The rate-controlled overshoot F(x) with the creep forces and F_d (lower right)."""
    from granflow.model.friction import friction_slip

    peak = _peak_or_none(params)
    top = 4.0 * peak.slip if peak is not None else 40.0 / params.alpha
    slip = np.linspace(params.x0, top, 400)
    inset = parent.inset_axes([0.52, 0.64, 0.45, 0.32])
    inset.plot((slip - params.x0) * MICRO, friction_slip(slip, params) * MILLI, color=MODEL_COLOR)
    inset.axhline(params.Fd * MILLI, color=STEADY_COLOR, ls="--", lw=1.0)
    for color, level in levels:
        inset.axhline(level * MILLI, color=color, lw=1.0)
    _small_axes(inset, "slip x [µm]", "F [mN]")
    inset.text(
        0.97, 0.06, "rate control", transform=inset.transAxes, ha="right", fontsize="x-small"
    )
    inset.set_xlim(0.0, (top - params.x0) * MICRO)
    inset.set_ylim(bottom=0.0)
    return inset


def plot_creep(runs, fits=None, ax=None, *, params=None, log_time=False):
    """Creep under constant forces below the peak (Fig. 3b): slip [µm] against time [s].

    Parameters
    ----------
    runs : Run or sequence of Run
        Force-controlled creep runs; each is labelled by its imposed force (the median of
        its force column [mN]). A run without slip data is named in the legend only.
    fits : sequence of CurveFitResult or None, optional
        :func:`granflow.fit_creep` results, one per run (None or unsuccessful: data only),
        drawn as lines in the run's colour.
    ax : matplotlib.axes.Axes, optional
    params : Params, optional
        Adds an inset (lower right) with the rate-controlled overshoot F(x), F_d (green
        dashed) and the creep forces, as in the paper's inset.
    log_time : bool
        Logarithmic time axis (logarithmic creep is then a straight line).

    Returns
    -------
    matplotlib.axes.Axes

    Raises
    ------
    InvalidParameterError
        For runs that are not Runs, fits that are not CurveFitResults or not one per run,
        a params that is not a Params, an ax that is not an Axes.
    """
    from granflow.fitting.creep import CurveFitResult

    runs = _as_runs(runs, "runs")
    fits = _as_fits(fits, len(runs), "fits", CurveFitResult)
    params = _as_params(params)
    ax = new_axes(check_axes(ax, "ax"), figsize=(6.4, 4.2))
    from matplotlib.lines import Line2D

    handles, levels = [], []
    colors = run_colors(len(runs))
    for index, (run, fit) in enumerate(zip(runs, fits, strict=True)):
        color = colors[index]
        t, slip = finite(run.t, run.slip)
        if log_time:
            t, slip = t[t > 0], slip[t > 0]
        fitted = _usable(fit)
        ax.plot(t, slip * MICRO, ".", ms=2.5, color=color, alpha=0.45 if fitted else 0.8)
        if fitted:
            order = np.argsort(fit.x)
            x, y = fit.x[order], fit.best_fit[order]
            if log_time:
                x, y = x[x > 0], y[x > 0]
            ax.plot(x, y * MICRO, "-", color=color, lw=1.5)
        level = _imposed_force(run)
        label = run_label(run) if level is None else f"F = {level * MILLI:.3g} mN"
        if fitted:
            label += f", B = {fit.params['B'] * MICRO:.2g} µm" if "B" in fit.params else ""
        if not slip.size:
            label += " (no slip recorded)"
        elif fit is not None and not fitted:
            label += " (fit failed)"
        if level is not None:
            levels.append((color, level))
        if index < MAX_LEGEND_RUNS:
            handles.append(
                Line2D([], [], color=color, marker=".", ls="-" if fitted else "none", label=label)
            )
    if len(runs) > MAX_LEGEND_RUNS:
        handles.append(Line2D([], [], ls="none", label=f"+ {len(runs) - MAX_LEGEND_RUNS} more"))
    if any(_usable(fit) for fit in fits):
        handles.append(Line2D([], [], color="0.3", label="fit δ = B ln(1 + t/τ_c)"))
    if log_time:
        ax.set_xscale("log")
    else:
        ax.set_xlim(left=0.0)
    ax.set_ylim(bottom=0.0)
    ax.set_xlabel("time t [s]")
    ax.set_ylabel("creep slip δ [µm]")
    if params is not None:
        # the inset takes the upper right: the curves keep the lower half
        ax.set_ylim(0.0, ax.get_ylim()[1] / 0.55)
        _creep_inset(ax, params, levels)
        handles.append(Line2D([], [], color=STEADY_COLOR, ls="--", label="F_d (inset)"))
    legend_above(ax, handles, ncols=2)
    return ax


# --------------------------------------------------------------------------- Fig. 3c


def _slip_rates(run):
    """(time, slip rate) from secants over 2 % of the run's duration, stamped at their end."""
    t, slip = finite(run.t, run.slip)
    if slip.size < 3 or not t[-1] > t[0]:
        return t[:0], slip[:0]
    lag = SWITCH_LAG * (t[-1] - t[0])
    ends = np.searchsorted(t, t + lag)
    starts = np.flatnonzero(ends < t.size)
    ends = ends[starts]
    return t[starts] + lag, (slip[ends] - slip[starts]) / (t[ends] - t[starts])


def _detect_switch(run):
    """Time [s] of the last point still at the imposed velocity, or None.

    The reference velocity is the run's ``velocity`` metadata, else the median of its first
    ten finite velocities. The switch is the last point at which the velocity is within 5 %
    of it (so noise before the switch does not matter); None when that is the run's last
    point (no switch). Without a velocity column the slip rate stands in, measured over 2 %
    of the run's duration (so the switch is found to within that).
    """
    t, velocity = finite(run.t, run.velocity)
    if velocity.size < 3:
        t, velocity = _slip_rates(run)
        if velocity.size < 3:
            return None
    reference = run.meta.get("velocity")
    reference = float(reference) if reference else float(np.median(velocity[:10]))
    if not reference > 0:
        return None
    steady = np.flatnonzero(np.abs(velocity - reference) <= SWITCH_TOLERANCE * reference)
    if steady.size == 0 or steady[-1] == velocity.size - 1:
        return None
    return float(t[steady[-1]])


def _switch_time(run, switch_time):
    if switch_time is not None:
        return check.non_negative(switch_time, "switch_time", "s")
    if run.meta.get("switch_time") is not None:
        return check.non_negative(run.meta["switch_time"], "run.meta['switch_time']", "s")
    return _detect_switch(run)


def _rate_velocity(run, switch):
    """The imposed velocity [m/s] before the switch, or None."""
    value = run.meta.get("velocity")
    if value:
        return float(value)
    t, velocity = finite(run.t, run.velocity)
    before = velocity[(t <= switch) & (velocity > 0)] if switch is not None else velocity
    if before.size:
        return float(np.median(before))
    t, slip = finite(run.t, run.slip)
    keep = t <= switch if switch is not None else np.ones(t.size, dtype=bool)
    if np.count_nonzero(keep) >= 2 and np.ptp(t[keep]) > 0:
        slope = float(np.polyfit(t[keep], slip[keep], 1)[0])
        return slope if slope > 0 else None
    return None


def plot_switch(run, params=None, ax=None, *, switch_time=None):
    """Switch from rate to force control (Fig. 3c): slip and force against time.

    Slip [µm] on the left axis (blue), force [mN] on the right (black: the measured friction
    under rate control, then the imposed force), the switch marked by an orange dotted line.

    Parameters
    ----------
    run : Run
        One run: constant velocity up to the switch, constant force after it.
    params : Params, optional
        Overlays the rate-controlled curve F(t) of Eq. 3 from t0 (grey; slip x = v t, the
        fits' convention), v the run's ``velocity`` metadata or its measured velocity before
        the switch, and names the quasi-static outcome after the switch in the legend:
        failure, or a stop (its slip drawn as a grey dotted line).
    ax : matplotlib.axes.Axes, optional
        Axes for the slip; the force goes on its twin.
    switch_time : float, optional
        Time of the switch [s]. Default ``run.meta['switch_time']``, else the last point at
        which the velocity is within 5 % of the imposed one (the ``velocity`` metadata, else
        the median of the first ten velocities); none when the run ends at that velocity.
        Without a velocity column, the slip rate over 2 % of the run's duration stands in.

    Returns
    -------
    numpy.ndarray of matplotlib.axes.Axes
        ``[slip_axes, force_axes]``.

    Raises
    ------
    InvalidParameterError
        For a run that is not a Run, params not a Params, ax not an Axes, or a negative or
        non-numeric ``switch_time``.
    """
    run = _as_run(run, "run")
    params = _as_params(params)
    switch = _switch_time(run, switch_time)
    slip_ax, force_ax = _twin_axes(ax)
    t_slip, slip = finite(run.t, run.slip)
    t_force, force = finite(run.t, run.force)
    if slip.size:
        slip_ax.plot(t_slip, slip * MICRO, ".", ms=3, color=SLIP_COLOR, label="slip δ")
    else:
        _no_slip_note(force_ax)
    force_ax.plot(t_force, force * MILLI, "-", color=FORCE_COLOR, lw=1.5, zorder=3, label="force")
    velocity = _rate_velocity(run, switch)
    outcome = None
    if params is not None and velocity is not None:
        from granflow.model.friction import friction_time

        start = params.t0(velocity)
        end = max(float(np.nanmax(run.t)) if np.isfinite(run.t).any() else 0.0, 2 * start)
        grid = np.geomspace(start, end, 600)
        force_ax.plot(
            grid,
            friction_time(grid, params, velocity) * MILLI,
            "-",
            color=MODEL_COLOR,
            lw=3.0,
            alpha=0.6,
            zorder=1,
            label="rate control (model)",
        )
        after = force[t_force > switch] if switch is not None else force[:0]
        if after.size:
            slip_at = float(np.interp(switch, t_slip, slip)) if slip.size else velocity * switch
            outcome = _switch_outcome(params, _peak_or_none(params), slip_at, np.median(after))
            if outcome[0] == "stops":  # the slide, added to the measured slip at the switch
                outcome = ("stops", slip_at + outcome[1] - max(slip_at, params.x0))
    if switch is not None:
        label = f"switch at t = {switch:.3g} s"
        if outcome is not None:
            label += "; model: fails" if outcome[0] == "fails" else "; model: stops"
        force_ax.axvline(switch, color=SWITCH_COLOR, ls=":", lw=1.5, label=label)
    if outcome is not None and outcome[0] == "stops":
        slip_ax.axhline(
            outcome[1] * MICRO, color=MODEL_COLOR, ls=":", lw=1.2, label="stop slip (model)"
        )
    _align_zeros(slip_ax, force_ax, slip, force, None)
    legend_above(slip_ax, _handles(slip_ax, force_ax), ncols=2)
    return np.array([slip_ax, force_ax])


# --------------------------------------------------------------------------- saving


def _figure_of(figure):
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

    if isinstance(figure, Figure):
        return figure
    if isinstance(figure, Axes):
        return figure.figure
    if isinstance(figure, np.ndarray | list | tuple) and len(figure):
        first = np.ravel(np.asarray(figure, dtype=object))[0]
        if isinstance(first, Axes):
            return first.figure
    raise InvalidParameterError(
        f"figure must be a matplotlib Figure (or Axes), got {type(figure).__name__}"
    )


def _atomic_save(figure, path, **options):
    """Write to a temporary file beside ``path``, then rename it (no half-written figure)."""
    from granflow._files import write_atomic

    write_atomic(path, lambda temporary: figure.savefig(temporary, **options))


def save_figure(figure, directory, stem):
    """Save a figure as ``DIRECTORY/STEM.png`` (150 dpi) and ``DIRECTORY/STEM.svg``.

    The files are written atomically and carry no date, so saving the same figure twice
    gives the same files. The figure is not closed (the caller closes it).

    Parameters
    ----------
    figure : matplotlib.figure.Figure
        The figure (an Axes, or an array of Axes as the plot functions return, stands for
        its figure).
    directory : str or os.PathLike
        Output folder; made (with its parents) when missing.
    stem : str
        File name without extension; no path separators.

    Returns
    -------
    dict
        ``{"png": Path, "svg": Path}``.

    Raises
    ------
    InvalidParameterError
        If ``figure`` is not a Figure or Axes, ``directory`` not a path, or ``stem`` empty,
        not a string or holding a path separator.
    """
    import matplotlib

    figure = _figure_of(figure)
    if not isinstance(directory, str | os.PathLike):
        raise InvalidParameterError(
            f"directory must be a path (str or os.PathLike), got {type(directory).__name__}"
        )
    if not isinstance(stem, str) or not stem or stem in (".", ".."):
        raise InvalidParameterError(f"stem must be a non-empty file name, got {stem!r}")
    if any(sep in stem for sep in ("/", "\\", os.sep)):
        raise InvalidParameterError(f"stem must be a file name without a folder, got {stem!r}")
    directory = Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    paths = {"png": directory / f"{stem}.png", "svg": directory / f"{stem}.svg"}
    _atomic_save(figure, paths["png"], format="png", dpi=PNG_DPI, metadata={"Software": None})
    with matplotlib.rc_context({"svg.hashsalt": stem, "svg.fonttype": "path"}):
        _atomic_save(figure, paths["svg"], format="svg", metadata={"Date": None})
    return paths
