"""The quasi-static slip under a rising force: the layer follows the rising branch of F(x).

With the slip clock nothing evolves at rest, so under an imposed force sigma(t) the aging
coordinate is ``x(t) = F^-1(max_{t' <= t} sigma(t'))`` on the rising branch [x0, x_peak]
(x0 while sigma is below F(x0)), the record's slip is ``x - x0``, and the layer fails when
sigma reaches F_peak. No integration is needed.
"""

import numpy as np

from granflow.model.friction import friction_slip

__all__ = ["branch_slip"]

_GRID = 1200
_NEWTON = 3


def branch_slip(force, params, s_peak):
    """The aging coordinate x [m] on the rising branch at imposed forces ``force`` [N].

    Parameters
    ----------
    force : numpy.ndarray
        Imposed force [N], already the running maximum of the history.
    params : Params
        Model parameters (paper initial condition).
    s_peak : float
        ``alpha x_peak`` [-], the end of the rising branch.

    Returns
    -------
    numpy.ndarray
        x [m]: x0 below F(x0), x_peak at or above F_peak, else the root of F(x) = force
        (linear interpolation in ln x on a grid, then Newton steps, which converge from
        either side because F is concave on the rising branch).
    """
    x0, x_peak = params.x0, s_peak / params.alpha
    grid = np.geomspace(x0, x_peak, _GRID)
    curve = friction_slip(grid, params)
    curve = np.maximum.accumulate(curve)
    x = np.exp(np.interp(force, curve, np.log(grid)))
    for _ in range(_NEWTON):
        value = friction_slip(x, params)
        slope = params.a / x - params.alpha * (value - params.Fd)
        inside = slope > 0
        step = np.where(inside, (value - force) / np.where(inside, slope, 1.0), 0.0)
        x = np.clip(x - step, x0, x_peak)
    x = np.where(force <= curve[0], x0, x)
    return np.where(force >= curve[-1], x_peak, x)
