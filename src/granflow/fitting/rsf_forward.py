"""The forward model of a rate-and-state fit: friction at the data's times, and its Jacobian.

One window of a record is simulated from steady sliding at the load-point velocity of its
first point (where the window starts, ``v_ref`` is that velocity, so ``mu0`` is the steady
friction there) on a spring of stiffness k, through the record's load-point history, by the
compiled integrator of :mod:`granflow.simulation.ode` (Rodas4 with the analytic Jacobian).
Unlike :func:`granflow.rsf.simulate` the steps do not land on the output times (a record has
thousands of points a step may stride over): the outputs come from the integrator's dense
output, so that the cost follows the dynamics, not the sampling.

A linear trend in load-point displacement (RSFit3000's detrend) is added on top:
``mu(t) + slope * (d_lp(t) - d_lp(t_start))``.

The Jacobian: mu0 and slope enter linearly (exact columns); a, b_i, Dc_i and k by forward
differences of the compiled model at relative steps of 3e-5 (the integration runs at a
relative tolerance of 1e-8, its error in the friction about 1e-10, so the difference
quotients carry three to four digits: plenty for Gauss-Newton steps and a covariance, and
the integration costs a tenth of what it costs at 1e-11).
"""

import math

import numpy as np

from granflow.errors import InvalidParameterError
from granflow.simulation import ode
from granflow.simulation.rsf.model import RateState, State
from granflow.simulation.rsf.pieces import absolute_tolerances, load_point, run

__all__ = ["RELATIVE_TOLERANCE", "History", "Window", "load_point_displacement", "noise_scatter"]

#: Relative tolerance of the integration.
RELATIVE_TOLERANCE = 1e-8
_STEP = 3e-5


def load_point_displacement(pieces, t):
    """Load-point displacement [m] since the protocol's start at the times ``t`` [s].

    ``pieces``: rows (start [s], end [s], velocity at start [m/s], slope [m/s^2]) of a
    rate-controlled protocol, from time 0 on (the velocity is linear over each piece).
    """
    return load_point(pieces, t)[0]


class Window:
    """One fit window of a record: its times, the load-point history over it, and the model.

    Parameters
    ----------
    t : numpy.ndarray
        The window's times [s] (record time, increasing).
    pieces : numpy.ndarray, shape (m, 4)
        The record's load-point history (start, end, velocity at start, slope), record time.
    laws : sequence of str
        The law of each state variable.
    start : float, optional
        Where the simulation starts, at steady sliding [s] (record time, at most ``t[0]``);
        default ``t[0]``.
    """

    def __init__(self, t, pieces, laws, start=None, history=None):
        self.t = np.ascontiguousarray(t, dtype=float)
        #: the :class:`History` this window shares its simulation with (windows that start
        #: their simulation at one time), or None
        self.history = history
        start = float(self.t[0]) if start is None else float(start)
        stop = float(self.t[-1])
        self.start = start
        rows = []
        for t0, t1, v0, slope in pieces:
            lo, hi = max(t0, start), min(t1, stop)
            if hi > lo:
                rows.append((lo - start, hi - start, v0 + slope * (lo - t0), slope))
        self.pieces = np.array(rows, dtype=float)
        self.laws = tuple(laws)
        self.v_ref = float(self.pieces[0, 2])
        # load-point displacement since the window's start, at the window's points
        local = self.t - start
        self.displacement, self.velocity = load_point(self.pieces, local)
        # the trend counts from the window's first point, where the simulation may start earlier
        self.displacement = self.displacement - self.displacement[0]
        #: load-point displacement since the protocol's start [m] (the periodic term's clock)
        self.position = load_point_displacement(pieces, self.t)
        self.local = local
        v_max = float(np.max(np.abs(self.pieces[:, 2:3]))) + float(
            np.max(np.abs(self.pieces[:, 3] * (self.pieces[:, 1] - self.pieces[:, 0])))
        )
        self.v_scale = max(v_max, self.v_ref)

    def model(self, mu0, a, k, states):
        """The :class:`RateState` with these values (``states``: (b, Dc) per state)."""
        return RateState(
            mu0,
            a,
            self.v_ref,
            k,
            [State(b, Dc, law) for (b, Dc), law in zip(states, self.laws, strict=True)],
        )

    def friction(self, mu0, a, k, states, slope=0.0, local=None):
        """Friction [-] at the window's points (or at ``local`` times since its start);
        NaN where the integration failed."""
        local = self.local if local is None else local
        if self.history is not None:
            shape = self.history.friction(self, a, k, states, local)
        else:
            shape = self.shape(a, k, states, local)
        friction = shape + mu0
        if slope:
            displacement = self.displacement if local is self.local else None
            friction = friction + slope * displacement
        return friction

    def shape(self, a, k, states, local):
        """Friction minus mu0 [-] at the ``local`` times since the window's start (NaN
        where the integration failed or the values are out of range)."""
        try:
            model = self.model(0.0, a, k, states)
        except InvalidParameterError:  # a trial step out of range: no value, LM steps back
            return np.full(local.shape, np.nan)
        thetas = model.steady_state(self.v_ref)
        y0 = np.array([0.0, *thetas, 0.0])
        atol = absolute_tolerances(model, RELATIVE_TOLERANCE, self.v_scale)
        out = run(
            ode.RODAS4,
            model.parameters(),
            self.pieces,
            y0,
            local,
            RELATIVE_TOLERANCE,
            atol,
            2_000_000,
            False,
            False,
            1,
        )[2]
        return out[:, 0]

    def jacobian(self, mu0, a, k, states, slope, free):
        """(friction, d friction / d value) for the names in ``free`` (a, k, b1, Dc1, ...,
        mu0, slope), each column in natural units."""
        base = self.friction(mu0, a, k, states, slope)
        columns = {}
        for name in free:
            if name == "mu0":
                columns[name] = np.ones_like(base)
            elif name == "slope":
                columns[name] = self.displacement.copy()
            else:
                values = {"a": a, "k": k}
                changed = [list(state) for state in states]
                if name in values:
                    h = _STEP * values[name]
                    values[name] += h
                else:
                    which, i = name[:-1], int(name[-1]) - 1
                    slot = 0 if which == "b" else 1
                    h = _STEP * max(abs(changed[i][slot]), a if slot == 0 else 0.0)
                    changed[i][slot] += h
                moved = self.friction(mu0, values["a"], values["k"], changed, slope)
                columns[name] = (moved - base) / h
        return base, columns


class History:
    """One simulation shared by the windows that start it at the same time (steady sliding
    at the record's start): the friction of the slider does not depend on mu0 (it enters
    as an offset), so one run over every window's points serves them all. The last few
    runs are kept by their (a, k, states), which the windows and the difference quotients
    of the Jacobian ask for in turn.

    Parameters
    ----------
    windows : sequence of Window
        The windows, all with the same ``start`` and the record's pieces.
    """

    _KEEP = 16

    def __init__(self, windows):
        self.times = np.unique(np.concatenate([w.local for w in windows]))
        self.last = windows[-1]  # its pieces reach the furthest
        self.runs = {}

    def friction(self, window, a, k, states, local):
        """Friction minus mu0 [-] of ``window`` at its ``local`` times [s]."""
        key = (float(a), float(k), tuple((float(b), float(dc)) for b, dc in states))
        shape = self.runs.get(key)
        if shape is None:
            shape = self.last.shape(a, k, states, self.times)
            if len(self.runs) >= self._KEEP:
                self.runs.pop(next(iter(self.runs)))
            self.runs[key] = shape
        index = np.clip(np.searchsorted(self.times, local), 0, self.times.size - 1)
        if not np.array_equal(self.times[index], local):
            return window.shape(a, k, states, local)
        return shape[index]


def noise_scatter(friction, width=25):
    """The record's high-frequency scatter [-]: the standard deviation of the friction about
    its centred running mean over ``width`` points (a window far shorter than the transients
    a fit resolves, and longer than the few samples over which an instrument's filter
    correlates its noise), times sqrt(w / (w - 1)) for the mean's own share."""
    y = np.asarray(friction, dtype=float)
    width = min(width, max(3, y.size // 4))
    mean = np.convolve(y, np.ones(width) / width, mode="valid")
    half = width // 2
    deviation = y[half : half + mean.size] - mean
    return float(np.std(deviation) * math.sqrt(width / (width - 1)))
