"""Friction healing: the peak on re-sliding against the hold time, with the models' curves."""

from __future__ import annotations

from collections.abc import Mapping
from typing import TYPE_CHECKING, Any

import numpy as np

from granflow.errors import InvalidParameterError
from granflow.plotting._axes import check_axes, new_axes

if TYPE_CHECKING:
    from matplotlib.axes import Axes

__all__ = ["plot_healing"]

DELTA_MU = r"$\Delta\mu_\mathrm{peak}$"
T_HOLD = r"$t_\mathrm{h}$"
#: One colour per law, the same in every healing figure.
LAW_COLORS = {"aging": "C0", "slip": "C1"}
PAPER_COLOR = "C3"


def plot_healing(
    result: Any,
    ax: Axes | None = None,
    *,
    curves: Mapping[str, tuple[Any, Any]] | None = None,
    paper: bool = True,
) -> Axes:
    """Δμ_peak against the hold time on a log axis, the fitted healing line, each law's curve
    and the paper's time-clock prediction.

    Parameters
    ----------
    result : HealingResult
        A result of :func:`granflow.rsf.healing`.
    ax : matplotlib Axes, optional
    curves : mapping of str to (hold times [s], Δμ_peak [-]), optional
        A curve per model, by name (``"aging"``, ``"slip"``: e.g. from
        :func:`granflow.fitting.healing.model_healing` of each law's fit).
    paper : bool
        Draw the paper's prediction fitted to the peaks (:func:`granflow.rsf.paper_healing`,
        each hold at its own age).

    Returns
    -------
    matplotlib.axes.Axes
    """
    ax = new_axes(check_axes(ax, "ax"))
    hold = np.asarray(result.hold_times, dtype=float)
    delta = np.asarray(result.delta_mu_peak, dtype=float)
    if hold.size == 0:
        raise InvalidParameterError("result has no holds to draw")
    ax.semilogx(hold, delta, "o", color="black", label="measured", zorder=3)
    span = np.geomspace(hold.min() / 1.5, hold.max() * 1.5, 100)
    low, high = result.beta_ci95
    ax.semilogx(
        span,
        result.intercept + result.beta * np.log10(span),
        "--",
        color="0.5",
        label=rf"$\beta$ = {result.beta:.3g} per decade (95 %: {low:.3g} .. {high:.3g})",
    )
    for name, (times, values) in (curves or {}).items():
        ax.semilogx(
            np.asarray(times, dtype=float),
            np.asarray(values, dtype=float),
            "-",
            color=LAW_COLORS.get(name),
            label=f"rate-and-state, {name} law",
        )
    if paper and np.isfinite(result.paper_mu_a):
        ax.semilogx(
            hold,
            result.paper_prediction(),
            "s:",
            color=PAPER_COLOR,
            mfc="none",
            label=rf"paper (time clock): $\mu_\mathrm{{a}}$ = {result.paper_mu_a:.3g}",
        )
    ax.set_xlabel(f"hold time {T_HOLD} [s]")
    ax.set_ylabel(f"peak healing {DELTA_MU} [–]")
    ax.legend(fontsize="small", loc="upper left")
    return ax
