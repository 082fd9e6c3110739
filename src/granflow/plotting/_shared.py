"""What the paper's figures share: argument checks, twin axes, and the model curves they draw
(peak, rising branch, quasi-static slip, the outcome of a switch)."""

import numpy as np

from granflow.errors import InvalidParameterError
from granflow.plotting._axes import (
    FORCE_COLOR,
    FORCE_SCALE,
    FORCE_UNIT,
    SLIP_COLOR,
    SLIP_SCALE,
    SLIP_UNIT,
    TIME_UNIT,
    check_axes,
    new_axes,
)

__all__ = [
    "align_zeros",
    "as_fits",
    "as_params",
    "as_run",
    "as_runs",
    "crossing_time",
    "handles",
    "no_slip_note",
    "peak_or_none",
    "quasistatic_slip",
    "rising_branch",
    "scale_to_creep",
    "small_axes",
    "switch_outcome",
    "twin_axes",
    "usable",
]


# --------------------------------------------------------------------------- argument checks


def as_run(run, name):
    from granflow.model.run import Run

    if not isinstance(run, Run):
        raise InvalidParameterError(f"{name} must be a granflow.Run, got {type(run).__name__}")
    return run


def as_runs(runs, name):
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
        as_run(run, f"{name}[{index}]")
    return runs


def as_fits(fits, count, name, kind):
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


def as_params(params, name="params"):
    from granflow.model.params import Params

    if params is not None and not isinstance(params, Params):
        raise InvalidParameterError(
            f"{name} must be a granflow.Params or None, got {type(params).__name__}"
        )
    return params


def usable(fit):
    return fit is not None and bool(fit.success)


def twin_axes(ax):
    """(slip axes, force axes): ``ax`` (or a new one) and its twin on the right."""
    slip_ax = new_axes(check_axes(ax, "ax"), figsize=(6.4, 4.2))
    force_ax = slip_ax.twinx()
    slip_ax.set_xlabel(f"time t [{TIME_UNIT}]")
    slip_ax.set_ylabel(f"slip δ [{SLIP_UNIT}]", color=SLIP_COLOR)
    slip_ax.tick_params(axis="y", colors=SLIP_COLOR)
    force_ax.set_ylabel(f"force F [{FORCE_UNIT}]", color=FORCE_COLOR)
    return slip_ax, force_ax


def no_slip_note(ax):
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


def handles(*axes):
    handles = []
    for ax in axes:
        handles.extend(ax.get_legend_handles_labels()[0])
    return handles


def scale_to_creep(slip_ax, t, slip, end):
    """Scale the slip axis to the slip before ``end`` [s] (three times its largest value),
    so that the runaway after the failure does not squash the creep before it; the zero
    stays where align_zeros put it."""
    before = slip[t <= end]
    if before.size < 3 or np.max(before) <= 0:
        return False
    top = 3.0 * float(np.max(before)) * SLIP_SCALE
    low, high = slip_ax.get_ylim()
    if high <= top:
        return False
    slip_ax.set_ylim(low * top / high, top)
    slip_ax.annotate(
        "runaway ↑",
        xy=(1.0, 1.0),
        xycoords="axes fraction",
        xytext=(-4, -4),
        textcoords="offset points",
        ha="right",
        va="top",
        fontsize="small",
        color=SLIP_COLOR,
    )
    return True


def align_zeros(slip_ax, force_ax, slip, force, peak):
    """Both axes from zero (slip below zero only if measured so); force room above the top."""
    low = min(0.0, float(np.min(slip)) * SLIP_SCALE) if slip.size else 0.0
    slip_ax.set_ylim(bottom=low)
    top = max(float(np.max(force)) if force.size else 0.0, peak.force if peak else 0.0)
    if top > 0:
        force_ax.set_ylim(0.0, 1.12 * top * FORCE_SCALE)
    else:
        force_ax.set_ylim(bottom=0.0)
    slip_ax.set_xlim(left=0.0)


def small_axes(ax, xlabel, ylabel):
    """Small fonts for an inset."""
    ax.tick_params(labelsize="x-small", pad=1.5)
    ax.set_xlabel(xlabel, fontsize="x-small", labelpad=1.5)
    ax.set_ylabel(ylabel, fontsize="x-small", labelpad=1.5)


# --------------------------------------------------------------------------- the model


def peak_or_none(params):
    from granflow.model.friction import NoPeakError, peak

    try:
        return peak(params)
    except NoPeakError:
        return None


def rising_branch(params, top, points=2000):
    """Slip grid from x0 to ``top`` [m] and the friction on it (increasing up to the peak)."""
    from granflow.model.friction import friction_slip

    slip = np.geomspace(params.x0, max(top, params.x0 * (1 + 1e-9)), points)
    return slip, friction_slip(slip, params)


def quasistatic_slip(force, params, peak):
    """Slip [m] a fresh layer reaches under the imposed forces ``force`` [N], quasi-statically.

    The layer follows the rising branch of F(x): it sticks at x0 until the force exceeds the
    initial friction, then sits where F(x) equals the largest force imposed so far. NaN from
    the first force above F_peak (failure) on.
    """
    slip, strength = rising_branch(params, peak.slip)
    held = np.fmax.accumulate(np.where(np.isfinite(force), force, 0.0))
    aging = np.interp(held, strength, slip, left=params.x0)
    return np.where(held < peak.force, aging - params.x0, np.nan)


def crossing_time(t, values, level):
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


def switch_outcome(params, peak, slip_at_switch, force):
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
    slip, strength = rising_branch(params, peak.slip)
    keep = slip >= x_switch
    return "stops", float(np.interp(force, strength[keep], slip[keep]))
