"""Figures of fits: data, fit and residuals; velocity collapse; Amontons; posterior corners."""

from granflow.plotting._axes import MICRO, MILLI, new_axes

__all__ = ["plot_amontons", "plot_collapse", "plot_corner", "plot_fit"]


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


def plot_collapse(result, ax=None):
    """Velocity collapse (Fig. 2b): every run against slip with the shared curve.

    Parameters
    ----------
    result : CollapseResult
        From :func:`granflow.velocity_collapse`.
    ax : matplotlib.axes.Axes, optional

    Returns
    -------
    matplotlib.axes.Axes
    """
    import numpy as np

    from granflow.model import friction_slip
    from granflow.params import Params

    ax = new_axes(ax)
    shared = result.shared
    for index, (run, params) in enumerate(zip(shared.individual, shared.run_params, strict=True)):
        color = f"C{index % 10}"
        ax.plot(run.x * MICRO, run.data * MILLI, ".", ms=1.5, alpha=0.4, color=color)
        model = Params(**dict(params))
        slip = np.geomspace(model.x0 * (1 + 1e-9), run.x[-1], 300)
        label = "shared a, α, F_d" if index == 0 else None
        ax.plot(slip * MICRO, friction_slip(slip, model) * MILLI, "-", color=color, label=label)
    ax.set_xlabel("slip x [µm]")
    ax.set_ylabel("force F [mN]")
    verdict = "collapse not rejected" if result.collapses else "collapse rejected"
    ax.set_title(f"{verdict} (p = {result.p_value:.3g})", fontsize="medium")
    ax.legend(frameon=False)
    return ax


def plot_amontons(result, axes=None):
    """Amontons' law (Fig. 2c): a, alpha (or alpha v) and Fd against the normal load.

    Per-load means with standard errors, and the lines through the origin for a and Fd.

    Parameters
    ----------
    result : AmontonsResult
        From :func:`granflow.fit_amontons`.
    axes : sequence of three matplotlib.axes.Axes, optional

    Returns
    -------
    list of matplotlib.axes.Axes
    """
    import numpy as np

    if axes is None:
        import matplotlib.pyplot as plt

        _, axes = plt.subplots(1, 3, figsize=(10.0, 3.4), layout="constrained")
    loads = np.array([row["normal_load"] for row in result.per_load])
    use_rate = all(row["alpha_v"] is not None for row in result.per_load)
    panels = (
        ("a", MILLI, "a [mN]"),
        ("alpha_v" if use_rate else "alpha", 1.0, "α v [1/s]" if use_rate else "α [1/m]"),
        ("Fd", MILLI, "F_d [mN]"),
    )
    span = np.linspace(0.0, loads.max() * 1.1, 50)
    for ax, (key, scale, label) in zip(axes, panels, strict=True):
        means = np.array([row[key][0] for row in result.per_load]) * scale
        errors = np.array([row[key][1] for row in result.per_load]) * scale
        ax.errorbar(loads * MILLI, means, yerr=errors, fmt="o", capsize=3)
        if key in result.lines:
            slope, error = result.lines[key]
            ax.plot(span * MILLI, slope * span * scale, "k-", lw=1)
            ax.fill_between(
                span * MILLI,
                (slope - error) * span * scale,
                (slope + error) * span * scale,
                color="0.8",
            )
        ax.set_xlabel("normal load F_N [mN]")
        ax.set_ylabel(label)
        ax.set_xlim(left=0)
    return list(axes)
