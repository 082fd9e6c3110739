"""Figures of simulations: force and slip against time (Fig. 3), and stability maps."""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

from granflow.plotting._axes import (
    FORCE_SCALE,
    FORCE_UNIT,
    PEAK_COLOR,
    SLIP_SCALE,
    SLIP_UNIT,
    TIME_UNIT,
    new_axes,
)

if TYPE_CHECKING:
    from matplotlib.axes import Axes

    from granflow.simulation.results import SimulationResult
    from granflow.simulation.stability import StabilityMap

__all__ = [
    "plot_simulation",
    "plot_simulation_force",
    "plot_simulation_slip",
    "plot_stability_map",
]

_EVENT_STYLES = {
    "failure": ("X", "C3"),
    "stop": ("o", "C1"),
    "slide": (">", "C4"),
    "peak": ("^", "C5"),
    "reset": ("s", "C7"),
}


def _mark_events(ax, result, quantity):
    for kind, (marker, color) in _EVENT_STYLES.items():
        events = result.events_of(kind)
        if not events:
            continue
        times = [event.time for event in events]
        if quantity == "force":
            values = [event.force * FORCE_SCALE for event in events]
        else:
            values = np.interp(times, result.t, result.displacement) * SLIP_SCALE
        ax.plot(times, values, marker, color=color, linestyle="none", label=kind, zorder=3)


def plot_simulation_force(
    result: SimulationResult, ax: Axes | None = None, *, events: bool = True
) -> Axes:
    """Force exerted by the drive and the friction state against time [mN vs s].

    Parameters
    ----------
    result : SimulationResult
    ax : matplotlib.axes.Axes, optional
        Where to draw; a new figure when None.
    events : bool
        Mark failure, stop, slide, peak and reset events.

    Returns
    -------
    matplotlib.axes.Axes
    """
    ax = new_axes(ax)
    ax.plot(result.t, result.force * FORCE_SCALE, label="force")
    if np.any(result.state != result.force):
        ax.plot(result.t, result.state * FORCE_SCALE, "--", linewidth=1, label="strength F (state)")
    if events:
        _mark_events(ax, result, "force")
    ax.set_xlabel(f"time [{TIME_UNIT}]")
    ax.set_ylabel(f"force [{FORCE_UNIT}]")
    ax.legend(loc="best", fontsize="small")
    return ax


def plot_simulation_slip(
    result: SimulationResult, ax: Axes | None = None, *, events: bool = True
) -> Axes:
    """Displacement (total slip since the start) against time [µm vs s]."""
    ax = new_axes(ax)
    ax.plot(result.t, result.displacement * SLIP_SCALE, color="C2", label="slip")
    if events:
        _mark_events(ax, result, "slip")
    ax.set_xlabel(f"time [{TIME_UNIT}]")
    ax.set_ylabel(f"slip [{SLIP_UNIT}]")
    return ax


def plot_simulation(result: SimulationResult, axes: Sequence[Axes] | None = None) -> Any:
    """Force (top) and slip (bottom) against time, as in Fig. 3 of the paper.

    Parameters
    ----------
    result : SimulationResult
    axes : sequence of two Axes, optional
        Where to draw; a new two-panel figure when None.

    Returns
    -------
    numpy.ndarray of matplotlib.axes.Axes
        The force and slip axes.
    """
    if axes is None:
        import matplotlib.pyplot as plt

        _, axes = plt.subplots(2, 1, sharex=True, figsize=(6.0, 6.0), layout="constrained")
    force_ax, slip_ax = axes
    plot_simulation_force(result, force_ax)
    force_ax.set_xlabel("")
    plot_simulation_slip(result, slip_ax)
    opts = result.options
    force_ax.set_title(f"{opts['method']}, {opts['clock']} clock", fontsize="medium")
    return np.asarray(axes)


def plot_stability_map(stability: StabilityMap, ax: Axes | None = None) -> Axes:
    """Fail or stop over switch time and force ratio; colour is the stop slip [µm].

    Failing cells are grey; the method that made the map is in the title. The analytic
    boundary of the quasi-static model (stop below, failure above: F_peak / F(x) before the
    peak, 1 after it) is a dashed line, the switch time of the peak a red dotted one.

    Returns
    -------
    matplotlib.axes.Axes
    """
    ax = new_axes(ax)
    slip = np.where(stability.stopped, stability.stop_slip * SLIP_SCALE, np.nan).T
    mesh = ax.pcolormesh(
        stability.switch_points, stability.stress_ratios, slip, shading="nearest", cmap="viridis"
    )
    failed = np.where(stability.failed, 1.0, np.nan).T
    ax.pcolormesh(
        stability.switch_points,
        stability.stress_ratios,
        failed,
        shading="nearest",
        cmap="Greys",
        vmin=0.0,
        vmax=2.0,
    )
    ax.figure.colorbar(mesh, ax=ax, label=f"slip to stop [{SLIP_UNIT}]")
    ax.set_xlabel(f"switch time [{TIME_UNIT}]")
    ax.set_ylabel("imposed / current force [-]")
    ax.set_title(f"grey: failure ({stability.method}, {stability.clock} clock)", fontsize="medium")
    _analytic_boundary(ax, stability)
    return ax


def _analytic_boundary(ax, stability):
    """The quasi-static boundary between stop and failure, and the peak of the start-up.

    Switched at the aging coordinate x_s to r times the force F(x_s), the layer slides up the
    rising branch of F(x) and stops where F(x) = r F(x_s), unless r F(x_s) exceeds the peak:
    failure above r* = F_peak / F(x_s) before the peak, above r* = 1 after it (the friction
    ahead only falls). Drawn as a white line, the peak's switch time as a red dashed one.
    """
    from granflow.model.friction import NoPeakError, friction_slip, peak

    times = np.asarray(stability.switch_points, dtype=float)
    slips = np.asarray(stability.switch_slip, dtype=float)
    keep = np.isfinite(times) & np.isfinite(slips)
    if keep.sum() < 2 or getattr(stability, "params", None) is None:
        return
    times, slips = times[keep], slips[keep]
    try:
        top = peak(stability.params)
    except (NoPeakError, ValueError):
        return
    grid = np.linspace(times.min(), times.max(), 300)
    slip = np.interp(grid, times, slips)
    ratio = np.where(slip < top.slip, top.force / friction_slip(slip, stability.params), 1.0)
    ax.plot(grid, ratio, color="white", lw=2.2)
    ax.plot(grid, ratio, color="black", lw=1.0, ls="--", label="boundary (analytic)")
    if slips.min() <= top.slip <= slips.max():
        t_peak = float(np.interp(top.slip, slips, times))
        ax.axvline(t_peak, color=PEAK_COLOR, ls=":", lw=1.4, label=f"peak ({t_peak:.3g} s)")
    ratios = np.asarray(stability.stress_ratios, dtype=float)
    half = 0.5 * float(np.diff(ratios[:2]).sum()) if ratios.size > 1 else 0.01
    ax.set_ylim(ratios.min() - half, ratios.max() + half)
    # upper right: the failure side, after the peak, where no boundary runs
    ax.legend(loc="upper right", fontsize="small", framealpha=0.9)
