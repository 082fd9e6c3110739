"""The forecasts' likelihoods as models of the fitting engine (:mod:`granflow.fitting.engine`).

Each is a :class:`~granflow.fitting.engine.Model` over the peak coordinates
(:mod:`granflow.forecast.coordinates`) -- function and Jacobian in one compiled pass -- fitted
by the engine's Levenberg-Marquardt from a few starts, with the standardised extra residuals
(the nuisance coordinates of an uncertain force history, a prior from the campaign) as the
engine's ``penalty``. Its intervals are the engine's profiles (:func:`profile_scan`).

* :func:`branch_problem`: the slip of a force-controlled layer on the rising branch of F(x),
  quasi-static with the slip clock. Slots ``(gap, ratio, s0, z_1, ..., z_m)`` (x_peak
  projected out, :class:`BranchCurve`): F_peak
  is ``floor + gap`` (``floor`` the largest force held), or, with ``continuation``, the gap
  is that of P, the force at which the fitted history stands when the true one (fitted plus
  its error ``error @ z``) reaches F_peak: the failure's time (or step) is the fitted
  history's at P.
* :func:`startup_problem`: the force of a rate-controlled start-up, Eq. 3 in time with the
  force held at F(x0) below x0. Slots ``(F_peak, ratio, s0, x_peak)``.

Points of a record that share their held force (the samples of one step of a staircase) are
one group: their mean with weight ``sqrt(count) / sigma`` carries all they say about the
parameters, and their scatter about it enters the noise estimate only.
"""

import math
from dataclasses import dataclass

import numpy as np

from granflow.fitting.engine import Curve, GlobalParameter, Model, Problem
from granflow.forecast.branch_curve import BranchCurve
from granflow.forecast.coordinates import natural
from granflow.model.kernel import curve_start, point
from granflow.model.special import compiled

__all__ = [
    "NUISANCE_BOUND",
    "RATIO_RANGE",
    "S0_RANGE",
    "BranchCurve",
    "Continuation",
    "Groups",
    "Penalty",
    "branch_problem",
    "group_points",
    "projects",
    "ratio_parameter",
    "startup_problem",
    "startup_values",
]

NUISANCE_BOUND = 8.0  # standard deviations
#: F_peak - floor, in units of the floor: a peak 20 times the largest force held is no
#: failure in sight.
_GAP_RANGE = (1e-9, 20.0)
#: The shape's search range: r = Fd / F_peak and s0 = alpha x0 (about 0.01 for the paper's
#: curves; 5 is a layer that starts nearly rejuvenated).
RATIO_RANGE = (0.0, 0.999)
S0_RANGE = (1e-9, 5.0)


@dataclass(frozen=True)
class Groups:
    """A record's points grouped by their held force.

    Attributes
    ----------
    index : numpy.ndarray
        (n,) the group of each point (groups in the record's order).
    base : numpy.ndarray
        (g,) the fitted force history of each group [N].
    error : numpy.ndarray
        (g, m) d(history) / d(nuisance) of each group [N].
    count : numpy.ndarray
        (g,) points in each group.
    mean : numpy.ndarray
        (g,) the mean slip of each group [m].
    within : float
        The sum of squares of the points about their group's mean [m^2].
    """

    index: np.ndarray
    base: np.ndarray
    error: np.ndarray
    count: np.ndarray
    mean: np.ndarray
    within: float

    @property
    def size(self):
        """Number of points."""
        return int(self.index.size)


def group_points(base, error, slip):
    """:class:`Groups` of the points that share their history (``base`` [N] and ``error``
    rows, consecutive): one group a point on a ramp, one a step on a staircase."""
    base = np.asarray(base, dtype=float)
    error = np.asarray(error, dtype=float).reshape(base.size, -1)
    slip = np.asarray(slip, dtype=float)
    if base.size > 1:
        changed = (np.diff(base) != 0) | np.any(np.diff(error, axis=0) != 0, axis=1)
        starts = np.concatenate([[0], np.flatnonzero(changed) + 1])
    else:
        starts = np.zeros(1, dtype=int)
    count = np.diff(np.append(starts, base.size)).astype(float)
    index = np.repeat(np.arange(starts.size), count.astype(int))
    mean = np.add.reduceat(slip, starts) / count
    within = float(np.sum((slip - mean[index]) ** 2))
    return Groups(index, base[starts], np.ascontiguousarray(error[starts]), count, mean, within)


@dataclass(frozen=True)
class Continuation:
    """How the continued history's error moves F_peak at a given P (the time variant):
    ``F_peak = P + c0 + c1 g((P - anchor) / slope)`` with (c0, c1) = ``offset @ z``,
    ``tilt @ z`` [N, N per unit of the history's abscissa].

    ``g(u) = u`` where the history's error grows linearly (a ramp's or a regular
    staircase's line, and any u <= 1). An irregular staircase's steps to come are new
    draws: k of them spread about k times the record's median height as ``k s^2 + k^2
    s_m^2`` (s^2 the heights' variance, s_m^2 = ``growth`` s^2 the median's), so beyond
    the first step ``g(u) = sqrt((u + growth u^2) / (1 + growth))``, 1 at u = 1, where c1's
    variance is the next height's (:func:`granflow.forecast.loading.continuing_growth`)."""

    anchor: float
    slope: float
    offset: np.ndarray
    tilt: np.ndarray
    growth: float | None = None

    def _g(self, along):
        """(g(u), g'(u)) at u = ``along``."""
        if self.growth is None or along <= 1.0:
            return along, 1.0
        b = self.growth
        g = math.sqrt((along + b * along * along) / (1.0 + b))
        return g, (1.0 + 2.0 * b * along) / (2.0 * (1.0 + b) * g)

    def peak_force(self, level, nuisance):
        """(F_peak [N], dF_peak/dP, dF_peak/dz) at P = ``level`` [N]."""
        c0 = float(self.offset @ nuisance)
        c1 = float(self.tilt @ nuisance)
        g, slope_g = self._g((level - self.anchor) / self.slope)
        return level + c0 + c1 * g, 1.0 + c1 * slope_g / self.slope, self.offset + self.tilt * g

    def level(self, peak_force, nuisance):
        """The inverse: P [N] at which the fitted history stands when the true one reaches
        ``peak_force`` [N]; inf where the true continuation does not rise (``slope + c1 <=
        0``; g' <= 1 everywhere, so otherwise it rises)."""
        c0 = float(self.offset @ nuisance)
        c1 = float(self.tilt @ nuisance)
        if not self.slope + c1 > 0:
            return math.inf
        rest = peak_force - self.anchor - c0
        along = rest / (self.slope + c1)
        if self.growth is not None and along > 1.0:
            # slope u + c1 g(u) = rest for u > 1: it rises, and g(u) <= u bounds the root
            from scipy.optimize import brentq

            def excess(u):
                return self.slope * u + c1 * self._g(u)[0] - rest

            high = max(rest / (self.slope + min(c1, 0.0)), 1.0)
            if c1 == 0.0 or excess(high) <= 0.0:  # the bound is the root (c1 = 0: exactly)
                along = high
            elif excess(1.0) >= 0.0:  # u = 1 within rounding
                along = 1.0
            else:
                along = brentq(excess, 1.0, high, xtol=1e-12, rtol=1e-14)
        return self.anchor + self.slope * along


class Penalty:
    """The standardised residuals that are not data: the nuisance coordinates themselves
    (a standard normal prior each, slots ``first`` to ``first + count``), and a Gaussian
    prior on a, alpha, Fd (a :class:`~granflow.forecast.Prior`, or None) read through
    ``natural(values) -> ((a, alpha, Fd, x0), d(a, alpha, Fd, x0) / d slots)``."""

    def __init__(self, first, count, prior, natural):
        self.first, self.count, self.prior, self.natural = first, count, prior, natural
        self.names = () if prior is None else prior.names
        self.size = count + len(self.names)

    def __call__(self, values):
        residuals = np.zeros(self.size)
        jacobian = np.zeros((self.size, values.size))
        residuals[: self.count] = values[self.first : self.first + self.count]
        jacobian[: self.count, self.first : self.first + self.count] = np.eye(self.count)
        if self.names:
            found = self.natural(values)
            if found is None:
                residuals[self.count :] = 1e3
                return residuals, jacobian
            natural_values, chain = found
            position = {"a": 0, "alpha": 1, "Fd": 2}
            for row, name in enumerate(self.names, start=self.count):
                mean, stderr = getattr(self.prior, name)
                k = position[name]
                residuals[row] = (natural_values[k] - mean) / stderr
                jacobian[row, : chain.shape[1]] = chain[k] / stderr
        return residuals, jacobian


def _nuisance_parameters(values, first, m):
    """The nuisance coordinates' parameters: standard normal, so their own scale is 1 (the
    engine would take their value's, which may be tiny)."""
    out = []
    for k in range(m):
        parameter = GlobalParameter(
            f"z{k}",
            float(values[first + k]),
            log=False,
            lower=-NUISANCE_BOUND,
            upper=NUISANCE_BOUND,
        )
        parameter.scale = 1.0
        out.append(parameter)
    return out


def ratio_parameter(value):
    """The engine's parameter of r = Fd / F_peak [-] at ``value``, in :data:`RATIO_RANGE`,
    on its own scale (it lives in [0, 1))."""
    parameter = GlobalParameter(
        "ratio", float(value), log=False, lower=RATIO_RANGE[0], upper=RATIO_RANGE[1]
    )
    parameter.scale = 1.0
    return parameter


def branch_problem(groups, floor, sigma, values, *, prior=None, continuation=None, curve=None):
    """The engine's :class:`~granflow.fitting.engine.Problem` of a force-controlled record on
    the rising branch, and its :class:`BranchCurve`.

    Parameters
    ----------
    groups : Groups
        The record's points grouped by held force.
    floor : float
        The largest force the layer has held (the fitted history's) [N]: F_peak (or P) lies
        above it.
    sigma : float
        Slip noise standard deviation [m] (the weights are ``sqrt(count) / sigma``).
    values : sequence of float
        Starting (or best) slot values: ``(gap [N], ratio, s0, z...)``, with
        ``x_peak`` [m] after s0 where a prior on alpha asks for it (:func:`projects`).
    prior : Prior, optional
        Gaussian priors on a, alpha, Fd.
    continuation : Continuation, optional
        The time variant: the first slot is P's gap above ``floor``, not F_peak's.
    curve : BranchCurve, optional
        The curve of an earlier problem of the same record, ``prior`` and ``continuation``
        (at another noise level, from other values), whose evaluations it keeps: reused.

    Returns
    -------
    tuple of (Problem, BranchCurve)
    """
    m = groups.error.shape[1]
    project = projects(prior)
    if curve is None:
        curve = BranchCurve(groups, floor, continuation, project)
    shape = curve.shape

    def function(z, *current):
        current = np.array(current, dtype=float)
        if z.shape[0] != curve.size:
            return curve.subset(z.astype(np.int64), current)
        return curve(current)[0]

    def jacobian(z, *current):
        slip, jac, _ = curve(np.array(current, dtype=float))
        return slip, jac

    names = ("gap", "ratio", "s0", "x_peak")[:shape]
    slots = (*names, *(f"z{k}" for k in range(m)))
    model = Model(
        slots=slots,
        function=function,
        jacobian=jacobian,
        log=(True, False, True, True)[:shape] + (False,) * m,
    )
    penalty = None
    if m or prior is not None:
        penalty = Penalty(shape, m, prior, curve.natural)
    slip_range = max(float(np.ptp(groups.mean)), float(np.max(np.abs(groups.mean))), 1e-12)
    parameters = [
        GlobalParameter(
            "gap",
            float(values[0]),
            log=True,
            lower=_GAP_RANGE[0] * floor,
            upper=_GAP_RANGE[1] * floor,
        ),
        ratio_parameter(values[1]),
        GlobalParameter("s0", float(values[2]), log=True, lower=S0_RANGE[0], upper=S0_RANGE[1]),
    ]
    if not project:
        parameters.append(
            GlobalParameter(
                "x_peak",
                float(values[3]),
                log=True,
                lower=1e-6 * slip_range,
                upper=1e6 * slip_range,
            )
        )
    parameters += _nuisance_parameters(values, shape, m)
    weights = np.sqrt(groups.count) / sigma
    data = Curve(
        z=np.arange(groups.base.size, dtype=float),
        y=np.ascontiguousarray(groups.mean),
        w=weights,
        links=tuple((k, 1.0) for k in range(len(slots))),
    )
    return Problem([data], parameters, model=model, penalty=penalty), curve


def projects(prior):
    """Whether the branch model projects x_peak out (no prior on alpha)."""
    return prior is None or prior.alpha is None


@compiled
def startup_values(t, velocity, peak_force, r, s0, peak_slip, force, jacobian):
    """Eq. 3 (paper initial condition, held at F(x0) below x0) at x = v t [m] (t [s],
    velocity [m/s]) into ``force`` [N], and its derivatives in the peak coordinates (F_peak,
    r, s0, x_peak) into ``jacobian``; returns 1 where the coordinates are outside their box,
    else 0."""
    transform = np.empty((4, 4))
    a, alpha, fd, x0, _ = natural(peak_force, r, s0, peak_slip, transform)
    if not (math.isfinite(a) and a > 0.0):
        force[:] = math.nan
        jacobian[:, :] = math.nan
        return 1
    start = curve_start(alpha, x0)
    for i in range(t.shape[0]):
        x = velocity * t[i]
        s = alpha * x
        values = point(x, s, math.exp(start[0] - s), a, alpha, fd, x0, 0.0, True, x <= x0, start)
        force[i] = values[0]
        for j in range(4):
            total = 0.0
            for q in range(4):
                total += values[1 + q] * transform[q, j]
            jacobian[i, j] = total
    return 0


def startup_problem(t, force, velocity, sigma, values, *, prior=None):
    """The engine's Problem of a start-up's force ``force`` [N] at times ``t`` [s] (velocity
    [m/s]), slots ``(F_peak [N], ratio, s0, x_peak [m])``, noise ``sigma`` [N]."""
    t = np.ascontiguousarray(t, dtype=float)
    size = t.size
    cache = {}

    def evaluate(current):
        key = current.tobytes()
        if key not in cache:
            cache.clear()
            out = np.empty(size)
            jacobian = np.empty((size, 4))
            status = startup_values(t, velocity, *current, out, jacobian)
            if status or not np.all(np.isfinite(out)):
                out[:] = 1e3 * (np.max(np.abs(force)) + 1e-300)
                jacobian[:] = 0.0
            cache[key] = (out, jacobian)
        return cache[key]

    def function(z, *current):
        current = np.array(current, dtype=float)
        if z.shape[0] == size:
            return evaluate(current)[0]
        out = np.empty(z.shape[0])
        status = startup_values(
            np.ascontiguousarray(z), velocity, *current, out, np.empty((z.shape[0], 4))
        )
        if status or not np.all(np.isfinite(out)):
            out[:] = 1e3 * (np.max(np.abs(force)) + 1e-300)
        return out

    def jacobian(z, *current):
        return evaluate(np.array(current, dtype=float))

    model = Model(
        slots=("peak_force", "ratio", "s0", "x_peak"),
        function=function,
        jacobian=jacobian,
        log=(True, False, True, True),
    )

    def natural_of(current):
        transform = np.empty((4, 4))
        found = natural(*np.asarray(current[:4], dtype=float), transform)
        if not math.isfinite(found[0]):
            return None
        return np.array(found[:4]), transform

    penalty = None
    if prior is not None:
        penalty = Penalty(4, 0, prior, natural_of)
    top = float(np.max(np.abs(force)))
    span = velocity * float(t[-1])
    peak_force, ratio, s0, peak_slip = values[:4]
    parameters = [
        GlobalParameter(
            "peak_force", float(peak_force), log=True, lower=1e-3 * top, upper=1e3 * top
        ),
        ratio_parameter(ratio),
        GlobalParameter("s0", float(s0), log=True, lower=S0_RANGE[0], upper=S0_RANGE[1]),
        GlobalParameter("x_peak", float(peak_slip), log=True, lower=1e-6 * span, upper=1e6 * span),
    ]
    curve = Curve(
        z=t,
        y=np.ascontiguousarray(force, dtype=float),
        w=np.full(size, 1.0 / sigma),
        links=tuple((k, 1.0) for k in range(4)),
    )
    return Problem([curve], parameters, model=model, penalty=penalty)
