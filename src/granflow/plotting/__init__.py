"""Figures in the manner of the paper: each ``plot_*(result, ax=None) -> Axes``.

matplotlib is imported inside the functions, so importing granflow stays light. Quantities
are plotted in display units (mN, µm, s) with the unit on every axis.
"""

from granflow.plotting.fits import plot_corner, plot_fit
from granflow.plotting.simulation import (
    plot_simulation,
    plot_simulation_force,
    plot_simulation_slip,
    plot_stability_map,
)

__all__ = [
    "plot_corner",
    "plot_fit",
    "plot_simulation",
    "plot_simulation_force",
    "plot_simulation_slip",
    "plot_stability_map",
]
