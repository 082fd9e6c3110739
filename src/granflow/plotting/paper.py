"""Figures in the manner of the paper: start-up curves (Fig. 2a), stress ramp (Fig. 3a) and
creep (Fig. 3b).

The switch from rate to force control (Fig. 3c) is in :mod:`granflow.plotting.switch`, the
velocity collapse (Fig. 2b) and Amontons' law (Fig. 2c) in :mod:`granflow.plotting.fits`,
:func:`save_figure` in :mod:`granflow.plotting.files`. Every function takes data as measured:
a fit may be missing or unsuccessful (the data are then drawn alone), columns may hold NaN, a
stress-controlled run may have no slip. Colours are the same in every figure: slip blue (left
axis), force black (right axis), model grey, F_peak and failure red, F_d green, the switch
orange.
"""

import numpy as np

from granflow.plotting._axes import (
    F_D,
    F_PEAK,
    FORCE_COLOR,
    FORCE_SCALE,
    FORCE_UNIT,
    MAX_LEGEND_RUNS,
    MODEL_COLOR,
    PEAK_COLOR,
    SLIP_COLOR,
    SLIP_SCALE,
    SLIP_UNIT,
    STEADY_COLOR,
    TIME_UNIT,
    check_axes,
    finite,
    legend_above,
    new_axes,
    run_colors,
    run_label,
)
from granflow.plotting._shared import (
    align_zeros,
    as_fits,
    as_params,
    as_run,
    as_runs,
    crossing_time,
    handles,
    no_slip_note,
    peak_or_none,
    quasistatic_slip,
    scale_to_creep,
    small_axes,
    twin_axes,
    usable,
)

__all__ = ["plot_creep", "plot_startup", "plot_stress_ramp"]

#: Up to this many start-up runs, the legend carries each fit's a, alpha v and t0.
FEW_RUNS = 4

#: A slip rate this many times its median marks the runaway (failure) of a stress ramp.
RUNAWAY_FACTOR = 50.0


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
    from granflow._format import format_number

    velocity = fit.velocity if fit.velocity is not None else run.nominal_velocity
    p = fit.params
    # the same digits on every line (3.30 beside 3.29, not 3.3), as the paper's caption
    a = f"a = {format_number(p['a'], FORCE_SCALE, 3)} {FORCE_UNIT}"
    if fit.domain == "time":
        k, t0 = p["k"], p["t0"]
    elif velocity:
        k, t0 = p["alpha"] * velocity, p["x0"] / velocity
    else:
        return f"{a}, α = {format_number(p['alpha'], significant=3)} 1/m"
    k, t0 = format_number(k, significant=2), format_number(t0, significant=2)
    return f"{a}, αv = {k} 1/s, t₀ = {t0} s"


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

    runs = as_runs(runs, "runs")
    fits = as_fits(fits, len(runs), "fits", FitResult)
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
        fitted = usable(fit)
        ax.plot(t, force * FORCE_SCALE, ".", ms=2.5, color=color, alpha=0.45 if fitted else 0.8)
        label = run_label(run)
        if fitted:
            t_model, model, t_points, residuals = _fit_in_time(run, fit)
            ax.plot(t_model, model * FORCE_SCALE, "-", color=color, lw=1.5)
            if detailed:
                label = f"{label}: {_fit_label(run, fit)}"
            if residual_ax is not None:
                residual_ax.plot(t_points, residuals * FORCE_SCALE, ".", ms=2, color=color)
        else:
            label += " (no fit)" if fit is None else " (fit failed)"
        if index < MAX_LEGEND_RUNS:
            handles.append(
                Line2D([], [], color=color, marker=".", ls="-" if fitted else "none", label=label)
            )
    if len(runs) > MAX_LEGEND_RUNS:
        handles.append(Line2D([], [], ls="none", label=f"+ {len(runs) - MAX_LEGEND_RUNS} more"))
    ax.set_ylabel(f"friction force F [{FORCE_UNIT}]")
    ax.set_ylim(bottom=0.0)
    legend_above(ax, handles, ncols=1 if detailed else 2)
    if residual_ax is not None:
        residual_ax.axhline(0.0, color="0.3", lw=0.8)
        residual_ax.set_ylabel(f"residual [{FORCE_UNIT}]")
        residual_ax.set_xlabel(f"time t [{TIME_UNIT}]")
    else:
        ax.set_xlabel(f"time t [{TIME_UNIT}]")
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


#: The inset of a stress ramp magnifies the creep up to this slip [m]: the sub-µm slip of the
#: paper's inset, far below the slip at failure.
CREEP_ZOOM = 1e-6


def _zoom_window(t, slip, end):
    """The time [s] and slip [m] the inset shows: from the start until the slip first
    reaches the smaller of :data:`CREEP_ZOOM` and a quarter of the slip at ``end``."""
    before = slip[t <= end]
    limit = min(CREEP_ZOOM, 0.25 * float(np.max(before)))
    reached = np.flatnonzero(before >= limit)
    stop = float(t[reached[0]]) if reached.size else float(end)
    return max(stop, float(t[0]) + 1e-9), limit


def _slip_inset(parent, t, slip, end, model=None):
    """An inset (upper left of ``parent``) magnifying the sub-µm creep long before the
    failure: time up to where the slip reaches about 1 µm, slip [µm] up to a little above."""
    stop, limit = _zoom_window(t, slip, end)
    inset = parent.inset_axes([0.07, 0.47, 0.32, 0.33])
    window = t <= stop * 1.02
    inset.plot(t[window], slip[window] * SLIP_SCALE, ".", ms=2.5, color=SLIP_COLOR)
    if model is not None:
        t_model, slip_model = model
        keep = t_model <= stop * 1.02
        inset.plot(t_model[keep], slip_model[keep] * SLIP_SCALE, "--", color=MODEL_COLOR, lw=1.2)
    inset.set_xlim(0.0, stop)
    inset.set_ylim(min(0.0, float(np.min(slip[window])) * SLIP_SCALE), 1.15 * limit * SLIP_SCALE)
    small_axes(inset, f"t [{TIME_UNIT}]", f"δ [{SLIP_UNIT}]")
    inset.text(
        0.04, 0.94, "creep below F_peak", transform=inset.transAxes, va="top", fontsize="x-small"
    )
    return inset


def _rate_controlled_force(force_ax, params, velocity, end):
    """The rate-controlled F(t) of Eq. 3 at ``velocity`` (grey, on the force axis), from t0
    to ``end`` [s], as the paper's grey curve."""
    from granflow.model.friction import friction_time

    start = params.t0(velocity)
    if not end > start:
        return
    grid = np.linspace(start, end, 400)
    force_ax.plot(
        grid,
        friction_time(grid, params, velocity) * FORCE_SCALE,
        "-",
        color=MODEL_COLOR,
        lw=2.5,
        alpha=0.55,
        zorder=1,
        label=f"F(t) under rate control, v = {velocity * 1e6:.3g} µm/s (model)",
    )


def plot_stress_ramp(run, params=None, ax=None, *, inset=True, clip_runaway=True, velocity=None):
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
        Magnify the sub-µm creep long before the failure in an inset (upper left): time up
        to where the slip reaches 1 µm (or a quarter of the slip before failure), as the
        paper's inset. The failure is the first of the predicted failure (with ``params``)
        and the first time the slip rate exceeds 50 times its median.
    clip_runaway : bool
        Scale the slip axis to the creep before that time (three times its largest slip),
        the runaway leaving through the top, marked "runaway ↑".
    velocity : float, optional
        With ``params``, also draws the rate-controlled F(t) of Eq. 3 at this velocity
        [m/s] on the force axis (grey), as the paper's grey curve: the imposed force meets
        its peak where the layer fails.

    Returns
    -------
    numpy.ndarray of matplotlib.axes.Axes
        ``[slip_axes, force_axes]``.

    Raises
    ------
    InvalidParameterError
        If ``run`` is not a Run, ``params`` not a Params, ``ax`` not an Axes.
    """
    run = as_run(run, "run")
    params = as_params(params)
    slip_ax, force_ax = twin_axes(ax)
    t_slip, slip = finite(run.t, run.slip)
    t_force, force = finite(run.t, run.force)
    if slip.size:
        slip_ax.plot(t_slip, slip * SLIP_SCALE, ".", ms=3, color=SLIP_COLOR, label="slip δ")
    else:
        no_slip_note(force_ax)
    force_ax.plot(
        t_force, force * FORCE_SCALE, "-", color=FORCE_COLOR, lw=1.5, label="imposed force"
    )
    failure = None
    model = None
    peak = None if params is None else peak_or_none(params)
    if peak is not None:
        force_ax.axhline(
            peak.force * FORCE_SCALE,
            color=PEAK_COLOR,
            ls="--",
            lw=1.2,
            label=f"{F_PEAK} = {peak.force * FORCE_SCALE:.3g} {FORCE_UNIT} (rate control)",
        )
        failure = crossing_time(t_force, force, peak.force)
        if failure is not None:
            force_ax.axvline(
                failure,
                color=PEAK_COLOR,
                ls=":",
                lw=1.2,
                label=f"failure predicted: {failure:.3g} s",
            )
        if force.size:
            model = (t_force, quasistatic_slip(force, params, peak))
            slip_ax.plot(
                model[0],
                model[1] * SLIP_SCALE,
                "--",
                color=MODEL_COLOR,
                lw=1.2,
                label="slip, quasi-static model",
            )
        if velocity is not None and t_force.size:
            _rate_controlled_force(force_ax, params, velocity, float(np.max(t_force)))
    align_zeros(slip_ax, force_ax, slip, force, peak)
    runaway = _runaway_time(t_slip, slip)
    ends = [value for value in (failure, runaway) if value is not None]
    end = min(ends) if ends else None  # the creep before failure ends at the first of them
    clipped = False
    if clip_runaway and slip.size and end is not None:
        clipped = scale_to_creep(slip_ax, t_slip, slip, end)
    if inset and slip.size and end is not None and end > t_slip[0]:
        before = slip[t_slip <= end]
        if before.size >= 3 and (clipped or np.ptp(before) < 0.25 * np.ptp(slip)):
            _slip_inset(force_ax, t_slip, slip, end, model)
    legend_above(slip_ax, handles(slip_ax, force_ax), ncols=2)
    return np.array([slip_ax, force_ax])


# --------------------------------------------------------------------------- Fig. 3b


def _imposed_force(run):
    """Median of the finite force column [N], or None."""
    force = run.force[np.isfinite(run.force)]
    return float(np.median(force)) if force.size else None


def _creep_inset(parent, params, levels):
    """The rate-controlled overshoot F(x) with the creep forces and F_d (upper left, where
    logarithmic creep leaves room; a legend inside the axes goes upper right)."""
    from granflow.model.friction import friction_slip

    peak = peak_or_none(params)
    top = 4.0 * peak.slip if peak is not None else 40.0 / params.alpha
    slip = np.linspace(params.x0, top, 400)
    inset = parent.inset_axes([0.1, 0.62, 0.36, 0.33])
    inset.plot(
        (slip - params.x0) * SLIP_SCALE,
        friction_slip(slip, params) * FORCE_SCALE,
        color=MODEL_COLOR,
    )
    inset.axhline(params.Fd * FORCE_SCALE, color=STEADY_COLOR, ls="--", lw=1.0)
    for color, level in levels:
        inset.axhline(level * FORCE_SCALE, color=color, lw=1.0)
    small_axes(inset, f"slip x [{SLIP_UNIT}]", f"F [{FORCE_UNIT}]")
    inset.text(
        0.97, 0.06, "rate control", transform=inset.transAxes, ha="right", fontsize="x-small"
    )
    inset.set_xlim(0.0, (top - params.x0) * SLIP_SCALE)
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
        Adds an inset (upper left) with the rate-controlled overshoot F(x), F_d (green
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

    runs = as_runs(runs, "runs")
    fits = as_fits(fits, len(runs), "fits", CurveFitResult)
    params = as_params(params)
    ax = new_axes(check_axes(ax, "ax"), figsize=(6.4, 4.2))
    from matplotlib import patheffects
    from matplotlib.lines import Line2D

    handles, levels = [], []
    colors = run_colors(len(runs))
    for index, (run, fit) in enumerate(zip(runs, fits, strict=True)):
        color = colors[index]
        t, slip = finite(run.t, run.slip)
        if log_time:
            t, slip = t[t > 0], slip[t > 0]
        fitted = usable(fit)
        # the points stay visible: drawn full size, the fit a thin line over them
        ax.plot(t, slip * SLIP_SCALE, ".", ms=4.0, color=color, alpha=0.55, zorder=2)
        if fitted:
            order = np.argsort(fit.x)
            x, y = fit.x[order], fit.best_fit[order]
            if log_time:
                x, y = x[x > 0], y[x > 0]
            outline = [patheffects.Stroke(linewidth=2.0, foreground="white"), patheffects.Normal()]
            ax.plot(x, y * SLIP_SCALE, "-", color=color, lw=0.9, zorder=3, path_effects=outline)
        level = _imposed_force(run)
        label = run_label(run) if level is None else f"F = {level * FORCE_SCALE:.3g} {FORCE_UNIT}"
        if fitted:
            label += (
                f", B = {fit.params['B'] * SLIP_SCALE:.2g} {SLIP_UNIT}" if "B" in fit.params else ""
            )
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
    if any(usable(fit) for fit in fits):
        handles.append(
            Line2D([], [], color="0.3", label=r"fit $\delta = B \ln(1 + t/\tau_\mathrm{c})$")
        )
    if log_time:
        ax.set_xscale("log")
    else:
        ax.set_xlim(left=0.0)
    ax.set_ylim(bottom=0.0)
    ax.set_xlabel(f"time t [{TIME_UNIT}]")
    ax.set_ylabel(f"creep slip δ [{SLIP_UNIT}]")
    if params is not None:
        # the inset takes the upper left: the curves keep the lower half
        ax.set_ylim(0.0, ax.get_ylim()[1] / 0.55)
        _creep_inset(ax, params, levels)
        handles.append(Line2D([], [], color=STEADY_COLOR, ls="--", label=f"{F_D} (inset)"))
    legend_above(ax, handles, ncols=2)
    return ax
