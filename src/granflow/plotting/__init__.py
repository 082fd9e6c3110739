"""Figures in the manner of the paper: each ``plot_*(result, ax=None) -> Axes``.

matplotlib is imported inside the functions, so importing granflow stays light. Quantities
are plotted in their display units (:data:`granflow.model.units.QUANTITIES`: mN, µm, s) with
the unit on every axis. Fig. 2a, 3a and 3b are in :mod:`granflow.plotting.paper`, Fig. 3c in
:mod:`granflow.plotting.switch`, Fig. 2b and 2c in :mod:`granflow.plotting.fits`, simulations
and stability maps in :mod:`granflow.plotting.simulation`, rate-and-state fits and runs in
:mod:`granflow.plotting.rsf`, the healing of slide-hold-slide records in
:mod:`granflow.plotting.healing`, :func:`save_figure` in
:mod:`granflow.plotting.files`.
"""

from granflow.plotting.files import save_figure
from granflow.plotting.fits import (
    plot_amontons,
    plot_collapse,
    plot_corner,
    plot_fit,
    plot_fit_grid,
)
from granflow.plotting.forecast import plot_forecast
from granflow.plotting.healing import plot_healing
from granflow.plotting.paper import plot_creep, plot_startup, plot_stress_ramp
from granflow.plotting.rsf import plot_rsf_fit, plot_rsf_simulation
from granflow.plotting.simulation import (
    plot_simulation,
    plot_simulation_force,
    plot_simulation_slip,
    plot_stability_map,
)
from granflow.plotting.switch import plot_switch

__all__ = [
    "plot_amontons",
    "plot_collapse",
    "plot_corner",
    "plot_creep",
    "plot_fit",
    "plot_fit_grid",
    "plot_forecast",
    "plot_healing",
    "plot_rsf_fit",
    "plot_rsf_simulation",
    "plot_simulation",
    "plot_simulation_force",
    "plot_simulation_slip",
    "plot_stability_map",
    "plot_startup",
    "plot_stress_ramp",
    "plot_switch",
    "save_figure",
]
