"""The running forecast figure: each method's failure time and band against the cut time,
with the observed failure, on an axis that shows the bands."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    from matplotlib.axes import Axes

__all__ = ["plot_forecast"]

_COLOURS = {"model": "C0", "inverse velocity": "C1", "voight": "C2"}
#: How each method is named in the legend.
_NAMES = {
    "model": "model (Eq. 2)",
    "inverse velocity": "inverse velocity (Fukuzono)",
    "voight": "Voight's law",
}


def _span(result: Any) -> tuple[float, float] | None:
    """The forecast times' range that the axis shows: every finite time and band end of the
    methods and the observed failure, each band at least visible."""
    values = []
    for series in result.methods.values():
        for key in ("time", "low", "high"):
            values += [v for v in np.asarray(series[key], dtype=float) if np.isfinite(v)]
    if result.observed is not None:
        values.append(float(result.observed))
    if not values:
        return None
    low, high = min(values), max(values)
    if result.observed is not None:  # far-off baselines do not squash the model's band
        low = max(low, 0.5 * result.observed)
        high = min(high, 1.5 * result.observed)
    pad = 0.08 * (high - low) if high > low else max(abs(high) * 1e-3, 1e-3)
    return low - pad, high + pad


def plot_forecast(result: Any, ax: Axes | None = None) -> Axes:
    """Plot a :class:`~granflow.forecast.ForecastSeries`: each method's forecast failure
    time against the cut time, with its band, and the observed failure (dashed).

    The forecast-time axis spans the forecasts and their bands (within half the observed
    time either side), not the whole record, so a narrow band stays visible; when the model's
    band is still narrower than a twentieth of that axis, an inset shows the model's
    forecast minus the observed failure time [s] with its band.

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
        _, ax = plt.subplots(figsize=(6.4, 4.2), layout="constrained")
    cuts = np.asarray(result.cuts, dtype=float)
    level = f"{result.level:.0%}"
    for name, values in result.methods.items():
        colour = _COLOURS.get(name)
        label = f"{_NAMES.get(name, name)}, {level} band"
        ax.plot(cuts, values["time"], "o-", color=colour, label=label, markersize=3.5)
        high = np.where(np.isfinite(values["high"]), values["high"], np.nan)
        ax.fill_between(cuts, values["low"], high, color=colour, alpha=0.25, linewidth=0)
    if result.observed is not None:
        ax.axhline(result.observed, color="k", linestyle="--", label="observed failure")
    span = _span(result)
    if span is not None:
        ax.set_ylim(*span)
        beyond = _beyond(result, span)
        if beyond:
            ax.text(0.01, 0.99, "\n".join(beyond), transform=ax.transAxes, va="top", ha="left",
                    fontsize="x-small", color="0.3")  # fmt: skip
    ax.set_xlabel("cut time (the last record time used) [s]")
    ax.set_ylabel(r"forecast failure time $t_\mathrm{f}$ [s]")
    ax.legend(fontsize="small", loc="upper right")
    model = result.methods.get("model")
    if model is not None and result.observed is not None and span is not None:
        widths = np.asarray(model["high"], float) - np.asarray(model["low"], float)
        widths = widths[np.isfinite(widths)]
        if widths.size and np.max(widths) < (span[1] - span[0]) / 20:
            _deviation_inset(ax, cuts, model, float(result.observed), level)
    return ax


def _beyond(result: Any, span: tuple[float, float]) -> list[str]:
    """A line for each method whose forecasts or band leave the axis (its span keeps far-off
    baselines from squashing the model's band): which way, and how far they reach [s]."""
    lines = []
    for name, series in result.methods.items():
        values = np.concatenate(
            [np.asarray(series[k], dtype=float) for k in ("time", "low", "high")]
        )
        values = values[np.isfinite(values)]
        shown = _NAMES.get(name, name)
        if values.size and values.max() > span[1]:
            lines.append(f"↑ {shown} above the axis (up to {values.max():.4g} s)")
        if values.size and values.min() < span[0]:
            lines.append(f"↓ {shown} below the axis (down to {values.min():.4g} s)")
    return lines


def _deviation_inset(ax: Axes, cuts: Any, model: Any, observed: float, level: str) -> None:
    """The model's forecast minus the observed failure [s], with its band (lower right)."""
    inset = ax.inset_axes((0.52, 0.1, 0.44, 0.36))
    low = np.asarray(model["low"], float) - observed
    high = np.asarray(model["high"], float) - observed
    inset.fill_between(cuts, low, high, color="C0", alpha=0.3, linewidth=0)
    inset.plot(cuts, np.asarray(model["time"], float) - observed, "o-", color="C0", ms=2.5)
    inset.axhline(0.0, color="k", ls="--", lw=0.8)
    inset.set_xlabel("cut [s]", fontsize="x-small", labelpad=1)
    inset.set_ylabel(r"$t_\mathrm{f}$ − observed [s]", fontsize="x-small", labelpad=1)
    inset.tick_params(labelsize="x-small")
    inset.set_title(f"model, {level} band, magnified", fontsize="x-small", pad=2)
