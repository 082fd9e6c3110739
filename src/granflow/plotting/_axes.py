"""Shared helpers of the plotting functions: scales, colours, argument checks, legends."""

from pathlib import Path

import numpy as np

from granflow.errors import InvalidParameterError
from granflow.model.units import QUANTITIES

# Display scales and units from the one unit table: forces in mN, slips in µm,
# velocities in µm/s, times in s.
FORCE_SCALE = QUANTITIES["force"].scale
FORCE_UNIT = QUANTITIES["force"].display
SLIP_SCALE = QUANTITIES["slip"].scale
SLIP_UNIT = QUANTITIES["slip"].display
VELOCITY_SCALE = QUANTITIES["velocity"].scale
VELOCITY_UNIT = QUANTITIES["velocity"].display
TIME_UNIT = QUANTITIES["time"].display

# One colour per quantity, the same in every figure (as in Fig. 3 of the paper).
SLIP_COLOR = "C0"  # measured slip (blue, left axis)
FORCE_COLOR = "black"  # measured or imposed force (right axis)
MODEL_COLOR = "0.55"  # rate-controlled model curve (grey)
PEAK_COLOR = "C3"  # static yield: F_peak and the predicted failure (red)
STEADY_COLOR = "C2"  # steady-state friction F_d (green, dashed)
SWITCH_COLOR = "C1"  # the switch from rate to force control (orange)

# Symbols as mathtext, the same in every label.
F_D = r"$F_\mathrm{d}$"
F_N = r"$F_\mathrm{N}$"
F_PEAK = r"$F_\mathrm{peak}$"
MU_A = r"$\mu_\mathrm{a}$"
MU_D = r"$\mu_\mathrm{d}$"

#: Runs named in a legend before the rest are summarised as "+ n more".
MAX_LEGEND_RUNS = 8


def new_axes(ax=None, *, figsize=(6.0, 4.0)):
    """Return ``ax``, or a fresh Axes on a new figure when ``ax`` is None."""
    if ax is not None:
        return ax
    import matplotlib.pyplot as plt

    _, ax = plt.subplots(figsize=figsize, layout="constrained")
    return ax


def check_axes(ax, name):
    """``ax`` if it is None or a matplotlib Axes; else InvalidParameterError naming ``name``."""
    if ax is None:
        return None
    from matplotlib.axes import Axes

    if not isinstance(ax, Axes):
        raise InvalidParameterError(
            f"{name} must be a matplotlib Axes or None, got {type(ax).__name__}"
        )
    return ax


def run_colors(count):
    """Colours of ``count`` runs: matplotlib's tab10 cycle, viridis beyond ten runs."""
    if count <= 10:
        return [f"C{index}" for index in range(count)]
    import matplotlib

    return list(matplotlib.colormaps["viridis"](np.linspace(0.0, 0.9, count)))


def velocity_colors(count):
    """Colours of ``count`` ordered velocities: plasma from dark blue to orange, spread so that
    neighbouring velocities differ in hue (viridis' neighbours are two blues)."""
    import matplotlib

    return list(matplotlib.colormaps["plasma"](np.linspace(0.0, 0.85, max(count, 1))))[:count]


def panel_letter(ax, letter):
    """A bold panel letter at the upper left corner of ``ax``, outside the frame (left of the
    tick labels), so that it never covers data, an inset or a legend."""
    return ax.annotate(
        letter,
        xy=(0.0, 1.0),
        xycoords="axes fraction",
        xytext=(-26, 2),
        textcoords="offset points",
        ha="right",
        va="bottom",
        fontweight="bold",
        fontsize="large",
    )


def run_label(run, width=28):
    """A short legend label for a Run: its ``name`` metadata, else ``file#interval``."""
    if "name" in run.meta:
        label = str(run.meta["name"])
    else:
        source = run.meta.get("source")
        stem = Path(str(source)).stem if source else "run"
        interval = run.meta.get("interval")
        label = stem if interval is None else f"{stem}#{interval}"
    if len(label) <= width:
        return label
    head = (width - 1) // 3  # keep the end: file names differ there (run number, interval)
    return label[:head] + "…" + label[len(label) - (width - 1 - head) :]


def finite(*columns):
    """The columns restricted to the rows where every one of them is finite."""
    keep = np.ones(np.shape(columns[0]), dtype=bool)
    for column in columns:
        keep &= np.isfinite(column)
    return tuple(np.asarray(column)[keep] for column in columns)


def legend_above(ax, handles=None, *, ncols=2, title=None):
    """A legend above the axes, so it never hides data or an inset."""
    if handles is None:
        handles, _ = ax.get_legend_handles_labels()
    if not handles:
        return None
    # mode="expand" would be neater, but then constrained layout collapses when a figure is
    # saved as SVG after a PNG at another dpi (matplotlib 3.11)
    return ax.legend(
        handles=handles,
        loc="lower left",
        bbox_to_anchor=(0.0, 1.0),
        ncols=max(1, min(ncols, len(handles))),
        fontsize="small",
        title=title,
        title_fontsize="small",
        frameon=False,
        borderaxespad=0.3,
        columnspacing=1.5,
    )


def plus_minus(value, error):
    """``value ± error`` rounded to the first significant digit of the error."""
    if not (np.isfinite(error) and error > 0):
        return f"{value:.3g}"
    digits = max(0, -int(np.floor(np.log10(error))))
    return f"{value:.{digits}f} ± {error:.{digits}f}"
