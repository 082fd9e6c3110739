"""Rate-and-state figures: a fit of velocity steps and a simulated run.

:func:`plot_rsf_fit` draws a :class:`~granflow.fitting.rsf_result.RateStateFitResult` (the data
with the fit, the residuals below); :func:`plot_rsf_simulation` a
:class:`~granflow.simulation.rsf.result.RateStateResult` (friction against time with the steady
state of the load-point velocity). The results' ``plot`` methods call them.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from granflow.plotting._axes import new_axes, plus_minus

if TYPE_CHECKING:
    from collections.abc import Sequence

    from matplotlib.axes import Axes

__all__ = ["plot_rsf_fit", "plot_rsf_simulation"]

#: The parameters a fit's figure names in its title: (mathtext symbol, factor, unit).
TITLE = {
    "a": ("$a$", 1.0, ""),
    "b": ("$b$", 1.0, ""),
    "Dc": (r"$D_\mathrm{c}$", 1e6, " µm"),
    "b1": ("$b_1$", 1.0, ""),
    "Dc1": (r"$D_\mathrm{c1}$", 1e6, " µm"),
    "b2": ("$b_2$", 1.0, ""),
    "Dc2": (r"$D_\mathrm{c2}$", 1e6, " µm"),
}


def plot_rsf_fit(result: Any, axes: Sequence[Axes] | None = None) -> tuple[Axes, Axes]:
    """The data with the fit (top) and the residuals (bottom) of a rate-and-state fit.

    With a fitted ripple (``result.harmonics``) the top also shows the fit without it
    (dashed).

    Parameters
    ----------
    result : RateStateFitResult
        A result of :func:`granflow.rsf.fit`.
    axes : pair of matplotlib Axes, optional
        Where to draw (default: a new figure).

    Returns
    -------
    (Axes, Axes)
        The top and bottom Axes.
    """
    import matplotlib.pyplot as plt

    if axes is None:
        _, axes = plt.subplots(
            2, 1, sharex=True, figsize=(7, 5), gridspec_kw={"height_ratios": [3, 1]}
        )
    top, bottom = axes
    top.plot(result.t, result.data, ".", ms=2, color="0.6", label="data")
    label = f"{'+'.join(result.laws)} fit"
    top.plot(result.t, result.best_fit, "-", color="C3", lw=1.5, label=label)
    if result.harmonics:
        top.plot(
            result.t,
            result.best_fit - result.ripple,
            "--",
            color="k",
            lw=1.0,
            label=f"without the ripple (λ = {result.params['wavelength'] * 1e6:.3g} µm)",
        )
    top.set_ylabel(r"friction coefficient $\mu$ [-]")
    text = ", ".join(
        f"{symbol} = "
        f"{plus_minus(result.params[n] * scale, result.stderr.get(n, np.nan) * scale)}{unit}"
        for n, (symbol, scale, unit) in TITLE.items()
        if n in result.names
    )
    top.set_title(text, fontsize=9)
    top.legend(loc="best", fontsize=8)
    bottom.plot(result.t, result.residuals, ".", ms=2, color="C0")
    bottom.axhline(0.0, color="k", lw=0.8)
    bottom.set_xlabel("time [s]")
    bottom.set_ylabel("residual [-]")
    return top, bottom


def plot_rsf_simulation(result: Any, ax: Axes | None = None) -> Axes:
    """Friction against time of a rate-and-state run, with the steady state of the
    load-point velocity (dashed; none where the load point is at rest).

    Parameters
    ----------
    result : RateStateResult
        A result of :func:`granflow.rsf.simulate`.
    ax : matplotlib Axes, optional
        Where to draw (default: a new figure).

    Returns
    -------
    matplotlib.axes.Axes
    """
    ax = new_axes(ax)
    ax.plot(result.t, result.friction, label="friction")
    moving = result.load_point_velocity > 0
    steady = np.full(result.t.shape, np.nan)
    steady[moving] = result.model.steady_state_friction(result.load_point_velocity[moving])
    ax.plot(result.t, steady, "--", label="steady state")
    ax.set_xlabel("time [s]")
    ax.set_ylabel("friction [-]")
    ax.legend()
    return ax
