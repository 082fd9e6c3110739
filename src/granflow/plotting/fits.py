"""Figures of fits: data, fit and residuals; velocity collapse; Amontons; posterior corners."""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

from granflow.errors import InvalidParameterError
from granflow.plotting._axes import (
    F_D,
    F_N,
    FORCE_SCALE,
    FORCE_UNIT,
    MU_A,
    MU_D,
    SLIP_SCALE,
    SLIP_UNIT,
    TIME_UNIT,
    VELOCITY_SCALE,
    VELOCITY_UNIT,
    check_axes,
    finite,
    legend_above,
    new_axes,
    plus_minus,
    run_colors,
    velocity_colors,
)

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

    from granflow.fitting.joint import AmontonsResult, CollapseResult
    from granflow.fitting.mcmc import PosteriorResult
    from granflow.fitting.single import FitResult

__all__ = ["plot_amontons", "plot_collapse", "plot_corner", "plot_fit", "plot_fit_grid"]


def plot_fit(result: FitResult, ax: Axes | None = None, *, residual_ax: Axes | None = None) -> Axes:
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
    scale, label = (
        (SLIP_SCALE, f"slip x [{SLIP_UNIT}]")
        if domain == "slip"
        else (1.0, f"time t [{TIME_UNIT}]")
    )
    force_scale = FORCE_SCALE if getattr(result, "model", "eq3") != "creep" else SLIP_SCALE
    unit = FORCE_UNIT if force_scale == FORCE_SCALE else SLIP_UNIT
    ax.plot(result.x * scale, result.data * force_scale, ".", ms=2, color="0.55", label="data")
    ax.plot(result.x * scale, result.best_fit * force_scale, "-", color="C3", label="fit")
    ax.set_ylabel(f"force F [{unit}]" if unit == FORCE_UNIT else f"slip δ [{unit}]")
    ax.legend(frameon=False)
    if residual_ax is not None:
        residual_ax.plot(result.x * scale, result.residuals * force_scale, ".", ms=2, color="C0")
        residual_ax.axhline(0.0, color="0.3", lw=0.8)
        residual_ax.set_ylabel(f"residual [{unit}]")
        residual_ax.set_xlabel(label)
    else:
        ax.set_xlabel(label)
    return ax


def plot_corner(posterior: PosteriorResult, **kwargs: Any) -> Figure:
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
    factors, labels = [], []
    for name in posterior.names:
        scale, unit = _display_of_parameter(name)
        factors.append(scale)
        symbol = _SYMBOLS.get(name, name)
        labels.append(f"{symbol} [{unit}]" if unit not in ("", "1") else symbol)
    scales = np.asarray(factors, dtype=float)
    options = {
        "labels": labels,
        "truths": [
            posterior.least_squares[n] * k for n, k in zip(posterior.names, scales, strict=True)
        ],
        "quantiles": (0.16, 0.5, 0.84),
        "max_n_ticks": 3,  # tick labels of neighbouring panels never run into each other
        "labelpad": 0.12,
    }
    options.update(kwargs)
    figure = corner.corner(np.asarray(posterior.samples) * scales, **options)
    from matplotlib.ticker import ScalarFormatter

    for axis in (axis for ax in figure.axes for axis in (ax.xaxis, ax.yaxis)):
        formatter = axis.get_major_formatter()
        if isinstance(formatter, ScalarFormatter):  # whole values, no "+1.099e1" beside them
            formatter.set_useOffset(False)
            formatter.set_scientific(False)
    return figure


#: Each fitted parameter's symbol in mathtext (the others are shown by name).
_SYMBOLS = {
    "a": r"$a$",
    "alpha": r"$\alpha$",
    "Fd": F_D,
    "x0": r"$x_0$",
    "k": r"$\alpha v$",
    "t0": r"$t_0$",
    "sigma": r"$\sigma$",
}


def _display_of_parameter(name):
    """(factor from SI, display unit) of a fitted parameter; (1, "") where it has none."""
    from granflow.model.units import quantity

    try:
        shown = quantity(name)
    except (KeyError, ValueError, InvalidParameterError):
        return 1.0, ""
    return float(shown.scale), shown.display


def _velocity_groups(result):
    """Index into ``result.velocities`` of each run of a CollapseResult, or None if unknown.

    The per-velocity fit gives every run of a group the same a: a run belongs to the
    velocity whose ``a_v<i>`` it carries; failing that, to its own fit's velocity.
    """
    per_velocity = result.per_velocity
    groups = []
    for run_params, individual in zip(
        per_velocity.run_params, result.shared.individual, strict=True
    ):
        found = None
        for index in range(len(result.velocities)):
            value = per_velocity.params.get(f"a_v{index}")
            if value is not None and math.isclose(run_params["a"], value, rel_tol=1e-12):
                found = index
                break
        if found is None and individual.velocity is not None:
            matches = [
                i
                for i, v in enumerate(result.velocities)
                if math.isclose(v, individual.velocity, rel_tol=1e-9)
            ]
            found = matches[0] if matches else None
        groups.append(found)
    return groups


def _short_slip_window(run_params, fallback):
    """Upper end [m] of the short-slip inset: 1.5 times the largest peak slip."""
    from granflow.model.friction import NoPeakError, peak
    from granflow.model.params import Params

    slips = []
    for values in run_params:
        try:
            slips.append(peak(Params(**dict(values))).slip)
        except (NoPeakError, ValueError):
            continue
    return 1.5 * max(slips) if slips else fallback


def plot_collapse(result: CollapseResult, ax: Axes | None = None, *, inset: bool = True) -> Axes:
    """Velocity collapse (Fig. 2b): every run against slip with the shared curve.

    Points are the data, coloured by sliding velocity; lines are the joint fit (a, α and F_d
    shared, x0 per run) in the same colour. The verdict of the likelihood-ratio test is the
    legend's title.

    Parameters
    ----------
    result : CollapseResult
        From :func:`granflow.velocity_collapse`.
    ax : matplotlib.axes.Axes, optional
        Where to draw; a new figure when None.
    inset : bool
        Add an inset (lower right) magnifying the short slips, up to 1.5 times the slip of
        the largest peak, where the runs differ by their initial state x0.

    Returns
    -------
    matplotlib.axes.Axes
        The main axes (the inset is in ``ax.child_axes``).

    Raises
    ------
    InvalidParameterError
        If ``result`` is not a CollapseResult or ``ax`` not an Axes.
    """
    from matplotlib.lines import Line2D

    from granflow.fitting.joint import CollapseResult
    from granflow.model.friction import friction_slip
    from granflow.model.params import Params

    if not isinstance(result, CollapseResult):
        raise InvalidParameterError(
            f"result must be a granflow.CollapseResult, got {type(result).__name__}"
        )
    ax = new_axes(check_axes(ax, "ax"), figsize=(6.4, 4.4))
    shared = result.shared
    groups = _velocity_groups(result)
    palette = velocity_colors(len(result.velocities))
    fallback = run_colors(len(groups))
    curves = []
    for index, (run, params, group) in enumerate(
        zip(shared.individual, shared.run_params, groups, strict=True)
    ):
        color = palette[group] if group is not None else fallback[index]
        x, force = finite(run.x, run.data)
        ax.plot(x * SLIP_SCALE, force * FORCE_SCALE, ".", ms=1.5, alpha=0.4, color=color)
        model = Params(**dict(params))
        slip = np.geomspace(model.x0 * (1 + 1e-9), max(x[-1], model.x0 * 2), 400)
        curve = friction_slip(slip, model)
        ax.plot(slip * SLIP_SCALE, curve * FORCE_SCALE, "-", color=color, lw=1.2)
        curves.append((color, x, force, slip, curve))
    handles = [
        Line2D(
            [],
            [],
            color=color,
            marker="o",
            ms=4,
            ls="none",
            label=f"{v * VELOCITY_SCALE:.3g} {VELOCITY_UNIT}",
        )
        for color, v in zip(palette, result.velocities, strict=True)
    ]
    handles.append(
        Line2D([], [], color="0.3", lw=1.2, label=rf"joint fit: shared $a$, $\alpha$, {F_D}")
    )
    ax.set_xlabel(f"slip x [{SLIP_UNIT}]")
    ax.set_ylabel(f"friction force F [{FORCE_UNIT}]")
    ax.set_xlim(left=0.0)
    ax.set_ylim(bottom=0.0)
    verdict = "collapse not rejected" if result.collapses else "collapse rejected"
    legend_above(
        ax,
        handles,
        ncols=4 if len(handles) <= 4 else 3,
        title=f"{verdict} (p = {result.p_value:.3g})",
    )
    if inset and curves:
        top = _short_slip_window(shared.run_params, 0.05 * max(c[1][-1] for c in curves))
        _collapse_inset(ax, curves, top)
    return ax


def _collapse_inset(ax, curves, top):
    """Inset of the short slips ``0 <= x <= top`` [m] in the lower right of ``ax``."""
    inset = ax.inset_axes([0.47, 0.2, 0.5, 0.4])
    highest = 0.0
    for color, x, force, slip, curve in curves:
        near = x <= top
        inset.plot(
            x[near] * SLIP_SCALE, force[near] * FORCE_SCALE, ".", ms=2, alpha=0.5, color=color
        )
        near = slip <= top
        inset.plot(slip[near] * SLIP_SCALE, curve[near] * FORCE_SCALE, "-", color=color, lw=1.0)
        if near.any():
            highest = max(highest, float(np.max(curve[near])))
    inset.set_xlim(0.0, top * SLIP_SCALE)
    if highest > 0:  # the zoom rectangle stays inside the main axes
        inset.set_ylim(0.0, min(1.08 * highest * FORCE_SCALE, ax.get_ylim()[1]))
    inset.set_title("short slips", fontsize="small", pad=2)
    inset.set_xlabel(f"$x$ [{SLIP_UNIT}]", fontsize="small", labelpad=1)
    inset.set_ylabel(f"$F$ [{FORCE_UNIT}]", fontsize="small", labelpad=1)
    inset.tick_params(labelsize="small")
    ax.indicate_inset_zoom(inset, edgecolor="0.5")
    return inset


def _single_velocity(per_load):
    """The one velocity [m/s] behind every per-load alpha v, or None when they differ."""
    ratios = [
        row["alpha_v"][0] / row["alpha"][0]
        for row in per_load
        if row["alpha_v"] is not None and row["alpha"][0]
    ]
    if len(ratios) != len(per_load) or not ratios:
        return None
    first = ratios[0]
    return first if all(math.isclose(r, first, rel_tol=1e-9) for r in ratios) else None


def _check_panels(axes):
    if axes is None:
        import matplotlib.pyplot as plt

        _, axes = plt.subplots(1, 3, figsize=(8.4, 3.1), layout="constrained")
        return list(axes)
    try:
        axes = list(np.ravel(np.asarray(axes, dtype=object)))
    except TypeError:
        raise InvalidParameterError(
            f"axes must be a sequence of three matplotlib Axes, got {type(axes).__name__}"
        ) from None
    if len(axes) != 3:
        raise InvalidParameterError(f"axes must hold three Axes (a, α v, F_d), got {len(axes)}")
    for index, ax in enumerate(axes):
        if ax is None:
            raise InvalidParameterError(f"axes[{index}] must be a matplotlib Axes, got None")
        check_axes(ax, f"axes[{index}]")
    return axes


def plot_amontons(result: AmontonsResult, axes: Sequence[Axes] | None = None) -> Any:
    """Amontons' law (Fig. 2c): a, α v (or α) and F_d against the normal load F_N.

    Per-load means over the repeats with their standard errors as error bars; for a and F_d
    the weighted line through the origin (slope mu_a, mu_d) with its ±1 standard-error band;
    for α v the joint fit's load-independent α (times the velocity, when all runs share
    one) with its band. A load with one repeat has no error bar.

    Parameters
    ----------
    result : AmontonsResult
        From :func:`granflow.fit_amontons`.
    axes : sequence of three matplotlib.axes.Axes, optional
        Panels for a, α v and F_d; a new 1 x 3 figure when None.

    Returns
    -------
    numpy.ndarray of matplotlib.axes.Axes
        The three panels.

    Raises
    ------
    InvalidParameterError
        If ``result`` is not an AmontonsResult or ``axes`` not three Axes.
    """
    from granflow.fitting.joint import AmontonsResult

    if not isinstance(result, AmontonsResult):
        raise InvalidParameterError(
            f"result must be a granflow.AmontonsResult, got {type(result).__name__}"
        )
    axes = _check_panels(axes)
    per_load = result.per_load
    loads = np.array([row["normal_load"] for row in per_load])
    velocity = _single_velocity(per_load)
    use_rate = all(row["alpha_v"] is not None for row in per_load)
    repeats = sorted({int(row["repeats"]) for row in per_load})
    count = f"{repeats[0]}" if len(repeats) == 1 else f"{repeats[0]}–{repeats[-1]}"
    panels = (
        ("a", FORCE_SCALE, f"$a$ [{FORCE_UNIT}]", MU_A),
        (
            "alpha_v" if use_rate else "alpha",
            1.0,
            r"$\alpha v$ [1/s]" if use_rate else r"$\alpha$ [1/m]",
            None,
        ),
        ("Fd", FORCE_SCALE, f"{F_D} [{FORCE_UNIT}]", MU_D),
    )
    span = np.linspace(0.0, loads.max() * 1.1, 50)
    for panel, (ax, (key, scale, label, coefficient)) in enumerate(zip(axes, panels, strict=True)):
        means = np.array([row[key][0] for row in per_load]) * scale
        errors = np.array([row[key][1] for row in per_load]) * scale
        ax.errorbar(
            loads * FORCE_SCALE,
            means,
            yerr=np.where(np.isfinite(errors), errors, 0.0),
            fmt="o",
            ms=5,
            color=f"C{panel}",
            ecolor=f"C{panel}",
            capsize=3,
            label=f"mean ± s.e. (n = {count})",
        )
        if coefficient is not None and key in result.lines:
            slope, error = result.lines[key]
            if math.isfinite(slope):
                _through_origin(ax, span, slope, error, scale, coefficient)
        elif coefficient is None:
            _joint_alpha(ax, result.joint, span, velocity if use_rate else 1.0, use_rate)
        ax.set_xlabel(f"normal load {F_N} [{FORCE_UNIT}]")
        ax.set_ylabel(label)
        ax.set_xlim(0.0, span[-1] * FORCE_SCALE)
        highest = np.nanmax(np.concatenate([means + np.nan_to_num(errors), [0.0]]))
        # room above the data for the legend, which stays inside the frame
        ax.set_ylim(0.0, (1.5 if coefficient is None else 1.45) * highest if highest > 0 else None)
        handles, _ = ax.get_legend_handles_labels()
        ax.legend(
            handles=handles[::-1],
            loc="upper left",
            fontsize="x-small",
            frameon=False,
            borderaxespad=0.2,
            handlelength=1.2,
        )
    return np.array(axes, dtype=object)


def _through_origin(ax, span, slope, error, scale, coefficient):
    band = error if math.isfinite(error) else 0.0
    ax.plot(
        span * FORCE_SCALE,
        slope * span * scale,
        "k-",
        lw=1,
        label=f"{coefficient} = {plus_minus(slope, band)}",
    )
    ax.fill_between(
        span * FORCE_SCALE,
        (slope - band) * span * scale,
        (slope + band) * span * scale,
        color="0.85",
        lw=0,
    )


def _joint_alpha(ax, joint, span, factor, rate):
    """The joint fit's alpha (times ``factor``: the velocity when ``rate``, else 1) as a level
    with its band; nothing when the fit failed or the velocities differ (factor None)."""
    if factor is None or not joint.success or "alpha" not in joint.params:
        return
    value = joint.params["alpha"] * factor
    error = joint.stderr.get("alpha", math.nan) * factor
    name, unit = (r"$\alpha v$", "1/s") if rate else (r"$\alpha$", "1/m")
    label = f"joint fit:\n{name} = {plus_minus(value, error)} {unit}"
    ax.plot(span * FORCE_SCALE, np.full(span.size, value), "k-", lw=1, label=label)
    if math.isfinite(error):
        ax.fill_between(span * FORCE_SCALE, value - error, value + error, color="0.85", lw=0)


def plot_fit_grid(
    fits: Sequence[FitResult],
    names: Sequence[str] | None = None,
    *,
    columns: int = 8,
    panel_size: tuple[float, float] = (1.5, 1.25),
) -> Figure:
    """Small multiples: every start-up fit in its own small panel, so that none goes unseen.

    Each panel shows the data (grey points) and the fit of Eq. 3 (red line), force [mN]
    against slip [µm] (or time [s]), titled with the run's name; a fit that did not succeed
    is titled in red. The axes labels are on the outer panels only.

    Parameters
    ----------
    fits : sequence of FitResult
        The fits (``x``, ``data``, ``best_fit``, ``domain``, ``success``).
    names : sequence of str, optional
        A title per fit (default ``"fit 1"``, ``"fit 2"``, ...).
    columns : int
        Panels per row.
    panel_size : (float, float)
        Width and height of one panel [inch].

    Returns
    -------
    matplotlib.figure.Figure

    Raises
    ------
    InvalidParameterError
        If ``fits`` is empty or ``names`` does not have one entry per fit.
    """
    import matplotlib.pyplot as plt

    fits = list(fits)
    if not fits:
        raise InvalidParameterError("fits is empty: give at least one fit")
    names = [f"fit {i + 1}" for i in range(len(fits))] if names is None else list(names)
    if len(names) != len(fits):
        raise InvalidParameterError(f"names has {len(names)} entries for {len(fits)} fits")
    columns = max(1, min(int(columns), len(fits)))
    rows = -(-len(fits) // columns)
    width, height = panel_size[0] * columns + 0.5, panel_size[1] * rows + 0.5
    figure, axes = plt.subplots(rows, columns, figsize=(width, height), squeeze=False)
    # fixed margins [inch] rather than a constrained layout: as fast for 50 panels as for 5
    figure.subplots_adjust(
        left=0.55 / width,
        right=1.0 - 0.1 / width,
        bottom=0.45 / height,
        top=1.0 - 0.2 / height,
        wspace=0.35,
        hspace=0.55,
    )
    for index, ax in enumerate(axes.flat):
        if index >= len(fits):
            ax.set_axis_off()
            continue
        result = fits[index]
        scale = SLIP_SCALE if getattr(result, "domain", "slip") == "slip" else 1.0
        x, data = finite(result.x, result.data)
        step = max(1, x.size // 200)  # enough points to see the scatter, few to draw
        ax.plot(x[::step] * scale, data[::step] * FORCE_SCALE, ".", ms=1, color="0.6")
        ax.plot(result.x * scale, result.best_fit * FORCE_SCALE, "-", color="C3", lw=1.0)
        ok = getattr(result, "success", True)
        ax.set_title(names[index], fontsize=6, pad=2, color="black" if ok else "C3")
        ax.tick_params(labelsize=6, length=2, pad=1)
        ax.locator_params(nbins=3)  # three ticks a small panel: legible, and far cheaper to draw
        ax.set_ylim(bottom=0.0)
        if index % columns == 0:
            ax.set_ylabel(f"$F$ [{FORCE_UNIT}]", fontsize=7, labelpad=1)
        if index + columns >= len(fits):
            unit = f"$x$ [{SLIP_UNIT}]" if scale == SLIP_SCALE else f"$t$ [{TIME_UNIT}]"
            ax.set_xlabel(unit, fontsize=7, labelpad=1)
    return figure
