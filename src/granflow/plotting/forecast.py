"""The running forecast figure: each method's failure time and band against the cut time,
with the observed failure."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    from matplotlib.axes import Axes

__all__ = ["plot_forecast"]

_COLOURS = {"model": "C0", "inverse velocity": "C1", "voight": "C2"}


def plot_forecast(result: Any, ax: Axes | None = None) -> Axes:
    """Plot a :class:`~granflow.forecast.ForecastSeries`.

    Parameters
    ----------
    result : ForecastSeries
        Forecasts at a sequence of cut times.
    ax : matplotlib.axes.Axes, optional
        Axes to draw on; default a new figure's.

    Returns
    -------
    matplotlib.axes.Axes
    """
    import matplotlib.pyplot as plt

    if ax is None:
        _, ax = plt.subplots(figsize=(6, 4))
    cuts = np.asarray(result.cuts)
    for name, values in result.methods.items():
        colour = _COLOURS.get(name)
        ax.plot(cuts, values["time"], "o-", color=colour, label=name, markersize=3)
        high = np.where(np.isfinite(values["high"]), values["high"], np.nan)
        ax.fill_between(cuts, values["low"], high, color=colour, alpha=0.2, linewidth=0)
    if result.observed is not None:
        ax.axhline(result.observed, color="k", linestyle="--", label="observed failure")
        ax.set_ylim(0, 2.0 * result.observed)
    ax.plot(cuts, cuts, color="0.6", linewidth=0.8, label="cut time")
    ax.set_xlabel("cut time [s]")
    ax.set_ylabel(f"forecast failure time [s] ({result.level:.0%} band)")
    ax.legend(fontsize="small")
    return ax
