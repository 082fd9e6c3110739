"""Figures of fits: data with the fitted curve and residuals; corner plots of posteriors."""

from granflow.plotting._axes import MICRO, MILLI, new_axes

__all__ = ["plot_corner", "plot_fit"]


def plot_fit(result, ax=None, *, residual_ax=None):
    """Data, fitted curve and residuals of a fit, in mN against µm (slip) or s (time).

    Parameters
    ----------
    result : FitResult or CurveFitResult
        A single-curve fit (``x``, ``data``, ``best_fit``, ``residuals``).
    ax : matplotlib.axes.Axes, optional
        Axes for data and fit. When neither ``ax`` nor ``residual_ax`` is given, a new figure
        with a residual panel below the main one is made.
    residual_ax : matplotlib.axes.Axes, optional
        Axes for the residuals (none drawn when ``ax`` is given without it).

    Returns
    -------
    matplotlib.axes.Axes
        The axes with data and fit.

    Examples
    --------
    >>> import numpy as np, granflow
    >>> x = np.linspace(3e-7, 4e-4, 300)
    >>> y = granflow.friction_slip(x, granflow.Params(3e-3, 4e4, 10e-3, 2e-7))
    >>> ax = granflow.fit((x, y)).plot()
    """
    if ax is None and residual_ax is None:
        import matplotlib.pyplot as plt

        _, (ax, residual_ax) = plt.subplots(
            2, 1, sharex=True, figsize=(6.0, 5.0), height_ratios=(3, 1), layout="constrained"
        )
    ax = new_axes(ax)
    domain = getattr(result, "domain", "time")
    scale, label = (MICRO, "slip x [µm]") if domain == "slip" else (1.0, "time t [s]")
    force_scale = MILLI if getattr(result, "model", "eq3") != "creep" else MICRO
    unit = "mN" if force_scale == MILLI else "µm"
    ax.plot(result.x * scale, result.data * force_scale, ".", ms=2, color="0.55", label="data")
    ax.plot(result.x * scale, result.best_fit * force_scale, "-", color="C3", label="fit")
    ax.set_ylabel(f"force F [{unit}]" if unit == "mN" else f"slip δ [{unit}]")
    ax.legend(frameon=False)
    if residual_ax is not None:
        residual_ax.plot(result.x * scale, result.residuals * force_scale, ".", ms=2, color="C0")
        residual_ax.axhline(0.0, color="0.3", lw=0.8)
        residual_ax.set_ylabel(f"residual [{unit}]")
        residual_ax.set_xlabel(label)
    else:
        ax.set_xlabel(label)
    return ax


def plot_corner(posterior, **kwargs):
    """Corner plot of a :class:`granflow.mcmc.PosteriorResult` (needs ``corner``).

    Parameters
    ----------
    posterior : PosteriorResult
    **kwargs
        Passed to ``corner.corner`` (e.g. ``fig``, ``bins``).

    Returns
    -------
    matplotlib.figure.Figure
    """
    try:
        import corner
    except ImportError as exc:  # pragma: no cover - depends on the environment
        raise ImportError(
            "plot_corner needs corner: install the extra with `pip install granflow[mcmc]`"
        ) from exc
    options = {
        "labels": list(posterior.names),
        "truths": [posterior.least_squares[n] for n in posterior.names],
        "quantiles": (0.16, 0.5, 0.84),
    }
    options.update(kwargs)
    return corner.corner(posterior.samples, **options)
