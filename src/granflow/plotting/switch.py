"""The switch from rate to force control (Fig. 3c): slip and force against time, with what
the model predicts after the switch."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from granflow import _validate as check
from granflow.plotting._axes import (
    FORCE_COLOR,
    FORCE_SCALE,
    MODEL_COLOR,
    SLIP_COLOR,
    SLIP_SCALE,
    SWITCH_COLOR,
    finite,
    legend_above,
)
from granflow.plotting._shared import (
    align_zeros,
    as_params,
    as_run,
    handles,
    no_slip_note,
    peak_or_none,
    scale_to_creep,
    switch_outcome,
    twin_axes,
)

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from numpy.typing import NDArray

    from granflow.model.params import Params
    from granflow.model.run import Run

__all__ = ["plot_switch"]

#: Relative change of the velocity that marks the end of the rate-controlled part of a switch.
SWITCH_TOLERANCE = 0.05

#: Fraction of a run's duration over which the slip rate is measured when there is no velocity.
SWITCH_LAG = 0.02


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


def plot_switch(
    run: Run,
    params: Params | None = None,
    ax: Axes | None = None,
    *,
    switch_time: float | None = None,
    clip: bool = False,
) -> NDArray[Any]:
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

    clip : bool
        Scale the slip axis to the slip before the switch (three times its largest value),
        the runaway leaving through the top. Off by default: the runaway after the switch is
        what the figure shows (Fig. 3c).

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
    run = as_run(run, "run")
    params = as_params(params)
    switch = _switch_time(run, switch_time)
    slip_ax, force_ax = twin_axes(ax)
    t_slip, slip = finite(run.t, run.slip)
    t_force, force = finite(run.t, run.force)
    if slip.size:
        slip_ax.plot(t_slip, slip * SLIP_SCALE, ".", ms=3, color=SLIP_COLOR, label="slip δ")
    else:
        no_slip_note(force_ax)
    force_ax.plot(
        t_force, force * FORCE_SCALE, "-", color=FORCE_COLOR, lw=1.5, zorder=3, label="force"
    )
    velocity = _rate_velocity(run, switch)
    outcome = None
    if params is not None and velocity is not None:
        from granflow.model.friction import friction_time

        start = params.t0(velocity)
        end = max(float(np.nanmax(run.t)) if np.isfinite(run.t).any() else 0.0, 2 * start)
        grid = np.geomspace(start, end, 600)
        force_ax.plot(
            grid,
            friction_time(grid, params, velocity) * FORCE_SCALE,
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
            outcome = switch_outcome(params, peak_or_none(params), slip_at, np.median(after))
            if outcome[0] == "stops":  # the slide, added to the measured slip at the switch
                outcome = ("stops", slip_at + outcome[1] - max(slip_at, params.x0))
    if switch is not None:
        label = f"switch at t = {switch:.3g} s"
        if outcome is not None:
            label += "; model: fails" if outcome[0] == "fails" else "; model: stops"
        force_ax.axvline(switch, color=SWITCH_COLOR, ls=":", lw=1.5, label=label)
    if outcome is not None and outcome[0] == "stops":
        slip_ax.axhline(
            outcome[1] * SLIP_SCALE, color=MODEL_COLOR, ls=":", lw=1.2, label="stop slip (model)"
        )
    # the force axis holds the model's whole overshoot too, not only the measured force
    align_zeros(slip_ax, force_ax, slip, force, None if params is None else peak_or_none(params))
    if clip and switch is not None and slip.size:
        # a failure's runaway would squash the slip before the switch: scale to it
        scale_to_creep(slip_ax, t_slip, slip, switch)
    legend_above(slip_ax, handles(slip_ax, force_ax), ncols=2)
    return np.array([slip_ax, force_ax])
