"""The slip of a creeping layer under an imposed force: the direct effect, quasi-static, slip
clock, in closed form up to two quadratures.

With the direct effect (:class:`granflow.DirectEffect`) the friction while sliding is
``A asinh(v / (2 v_ref) exp(F/A))``; under an imposed force sigma(t) and without inertia it
equals sigma, so

    dx/dt = 2 v_ref sinh(sigma(t) / A) exp(-F(x) / A),

with F(x) the paper's curve (Eq. 3 along the slip, nothing evolves at rest). The equation is
separable: with a reference force F_ref (the peak force here, so that no exponential
overflows),

    Gamma(x) = int_{x0}^{x} exp((F(x') - F_ref) / A) dx'
             = 2 v_ref int_0^t sinh(sigma(t') / A) exp(-F_ref / A) dt' = 2 v_ref S(t),

so the slip at any time is Gamma^-1(2 v_ref S(t)): no ODE is solved. Gamma is a cumulative
quadrature on a grid of x, exact for an exponent linear in x on each cell (the integrand
changes by orders of magnitude along the rising branch), and inverted with the same
interpolant; S is exact on each linear piece of a force history (a ramp, or the flat steps
of a staircase).

The layer fails when x runs past the peak of F: the velocity then grows without bound. As in
the simulator, the failure is the velocity passing a threshold (``FAILURE_VELOCITY``, the
simulator's default under force control) past the peak, at the first time both the slip
and the force allow it (:func:`first_passage`: a layer whose F_peak stands only a few A
above Fd runs away for seconds, and the force's own rise then decides when). The grid of x
runs on to where F has fallen ``_DROP`` A below F_peak, or to 2000 x_peak where it never
does (past the peak F falls towards Fd as a / (alpha x) only; beyond the grid F is taken as
its end's, within a two-thousandth of F_peak - Fd of Fd).
"""

import math
from dataclasses import dataclass

import numpy as np

from granflow.model.kernel import curve_start, point, point_value
from granflow.model.special import compiled, compiled_inline

__all__ = [
    "FAILURE_VELOCITY",
    "FALLING",
    "FIT_FALLING",
    "FIT_RISING",
    "RISING",
    "CreepCurve",
    "History",
    "cell_position",
    "creep_curve",
    "creep_slip",
    "curve_grid_slopes",
    "log_sinh",
    "ramp_history",
    "slip_jacobian",
    "steps_history",
]

_RISING_POINTS = 4000  # geometric in x - x0 from x0 up to half the rise
_PEAK_POINTS = 1500  # geometric in x_peak - x towards the peak
_FALLING_POINTS = 1070  # from the peak to the failure point
_RISING_FROM = 1e-6  # of x_peak - x0
_PEAK_FROM = 1e-5  # from the peak to the failure point
_DROP = 12.0  # the failure point: F has fallen this many A below the peak past it
_LARGEST_EXPONENT = 700.0
#: The velocity [m/s] at which a layer fails: granflow.simulate's default under force
#: control (1000 times its 1 um/s velocity scale).
FAILURE_VELOCITY = 1e-3
# the grids as fractions of x_peak - x0 (rising, increasing, from 0 to 1 with both ends),
# of x_fail - x_peak (falling, above 0) and of x_peak (the look past the peak)
_RISING = np.concatenate(
    [
        [0.0],
        np.geomspace(_RISING_FROM, 0.5, _RISING_POINTS),
        1.0 - np.geomspace(0.5, _PEAK_FROM, _PEAK_POINTS)[1:],
        [1.0],
    ]
)
_FALLING = np.geomspace(1e-8, 1.0, _FALLING_POINTS)
# past the peak F falls towards Fd as a / (alpha x) only: the grid looks on to 2000 x_peak,
# where F stands within a two-thousandth of F_peak - Fd of its end
_PROBE = 1.0 + np.geomspace(1e-5, 2000.0, 160)
#: The grid of the public functions (slip to a tenth of a nanometre on 20 um)...
RISING, FALLING = _RISING, _FALLING
#: ... and the forecast's coarser one, 2500 nodes (2e-5 of the rise: far below the slip
#: noise of any record granflow forecasts, 1e-3 of the rise and more).
FIT_RISING = np.concatenate(
    [
        [0.0],
        np.geomspace(_RISING_FROM, 0.5, 1500),
        1.0 - np.geomspace(0.5, _PEAK_FROM, 600)[1:],
        [1.0],
    ]
)
FIT_FALLING = np.geomspace(1e-8, 1.0, 400)


@compiled_inline
def _exp_relative(base, k):
    """exp(base) (exp(k) - 1) / k without overflow for large k (the exponent clipped)."""
    if k > 0:
        top, k = base + k, -k
    else:
        top = base
    scale = math.expm1(k) / k if k != 0.0 else 1.0
    return math.exp(min(top, _LARGEST_EXPONENT)) * scale


@compiled_inline
def _piece(begin, rate, span, amplitude, reference):
    """int over ``span`` [s] from a piece's start of sinh(sigma/A) exp(-reference/A) dt [s],
    sigma = begin + rate t."""
    k = rate * span / amplitude
    up = _exp_relative((begin - reference) / amplitude, k)
    down = _exp_relative(-(begin + reference) / amplitude, -k)
    return 0.5 * span * (up - down)


@compiled
def history_cumulative(starts, begin, rate, amplitude, reference, out):
    """S at every piece's start [s] into ``out``."""
    out[0] = 0.0
    for i in range(starts.shape[0] - 1):
        span = starts[i + 1] - starts[i]
        out[i + 1] = out[i] + _piece(begin[i], rate[i], span, amplitude, reference)


@compiled
def history_integral(t, starts, begin, rate, cumulative, amplitude, reference, out):
    """``S(t) = int_0^t sinh(sigma/A) exp(-reference/A) dt'`` [s] at ``t`` [s] into ``out``,
    from the pieces' ``cumulative`` (:func:`history_cumulative`)."""
    pieces = starts.shape[0]
    for j in range(t.shape[0]):
        tj = t[j]
        index = np.searchsorted(starts, tj, side="right") - 1
        index = min(max(index, 0), pieces - 1)
        out[j] = cumulative[index] + _piece(
            begin[index], rate[index], tj - starts[index], amplitude, reference
        )


@compiled
def history_time_of(target, starts, begin, rate, cumulative, amplitude, reference):
    """The time [s] at which S reaches ``target`` [s]; inf if it never does (the force
    stops rising below what the target needs)."""
    index = np.searchsorted(cumulative, target, side="right") - 1
    index = max(index, 0)
    remaining = target - cumulative[index]
    first, slope = begin[index], rate[index]
    level = math.sinh(min(first / amplitude, _LARGEST_EXPONENT)) * math.exp(
        max(-reference / amplitude, -_LARGEST_EXPONENT)
    )
    if slope <= 0.0:
        if not level > 0.0:
            return math.inf
        when = remaining / level
        if index < starts.shape[0] - 1 and when > starts[index + 1] - starts[index]:
            when = starts[index + 1] - starts[index]
        return starts[index] + when
    # the rising exponential alone, then Newton on the whole integrand
    if not remaining > 0.0:
        return starts[index]
    ratio = math.log(2.0 * slope * remaining / amplitude) - (first - reference) / amplitude
    # span = (A / r) ln(1 + exp(ratio)), without overflow
    softplus = ratio + math.log1p(math.exp(-ratio)) if ratio > 0 else math.log1p(math.exp(ratio))
    span = amplitude / slope * softplus
    for _ in range(4):
        value = _piece(first, slope, span, amplitude, reference) - remaining
        sigma = first + slope * span
        derivative = math.sinh(min(sigma / amplitude, _LARGEST_EXPONENT)) * math.exp(
            max(-reference / amplitude, -_LARGEST_EXPONENT)
        )
        if not derivative > 0.0:
            break
        span = max(span - value / derivative, 0.0)
    return starts[index] + span


@compiled_inline
def _place(params, peak_force, peak_slip, amplitude, start, rising, falling, x):
    """The grid's nodes [m] into ``x``: rising from x0 to the peak (``rising``: fractions of
    the rise), then past it up to where F has fallen ``_DROP`` A below the peak (or as far as
    the probe looks; ``falling``: fractions of that)."""
    a, alpha, fd, x0 = params
    s0 = start[0]
    rise = peak_slip - x0
    n_rising = rising.shape[0]
    for i in range(n_rising):
        x[i] = x0 + rise * rising[i]
    end = peak_slip * _PROBE[_PROBE.shape[0] - 1]
    for i in range(_PROBE.shape[0]):
        z = peak_slip * _PROBE[i]
        s = alpha * z
        if point_value(s, math.exp(s0 - s), a, fd, 0.0, True, False, start) <= (
            peak_force - _DROP * amplitude
        ):
            end = z
            break
    for i in range(falling.shape[0]):
        x[n_rising + i] = peak_slip + (end - peak_slip) * falling[i]


@compiled
def curve_grid(params, peak_force, peak_slip, amplitude, rising, falling, x, exponent, gamma):
    """Gamma(x) = int_{x0}^{x} exp((F - F_peak) / A) dx' [m] on a grid (``rising`` and
    ``falling`` fractions: :data:`RISING` and :data:`FALLING`, or the coarser
    :data:`FIT_RISING` and :data:`FIT_FALLING`) into ``x``, ``exponent`` and ``gamma``
    (each as long as the two together)."""
    a, alpha, fd, x0 = params
    start = curve_start(alpha, x0)
    s0 = start[0]
    _place(params, peak_force, peak_slip, amplitude, start, rising, falling, x)
    for i in range(x.shape[0]):
        s = alpha * x[i]
        value = point_value(s, math.exp(s0 - s), a, fd, 0.0, True, x[i] <= x0, start)
        exponent[i] = (min(value, peak_force) - peak_force) / amplitude
    gamma[0] = 0.0
    for i in range(x.shape[0] - 1):
        width = x[i + 1] - x[i]
        gamma[i + 1] = gamma[i] + width * _exp_relative(exponent[i], exponent[i + 1] - exponent[i])


@compiled_inline
def _exp_moment(base, k):
    """int_0^1 s exp(base + k s) ds without overflow (the exponent clipped)."""
    if abs(k) < 1e-6:
        return math.exp(min(base, _LARGEST_EXPONENT)) * (0.5 + k / 3.0)
    if k > 0:
        # exp(base + k) (k - 1 + exp(-k)) / k^2
        return math.exp(min(base + k, _LARGEST_EXPONENT)) * (k - 1.0 + math.exp(-k)) / (k * k)
    # exp(base) (exp(k) (k - 1) + 1) / k^2
    return math.exp(min(base, _LARGEST_EXPONENT)) * (math.exp(k) * (k - 1.0) + 1.0) / (k * k)


@compiled
def curve_grid_slopes(params, transform, peak_force, amplitude, x, exponent, slope, cumulative):
    """The derivatives of a unit curve's grid (x_peak = 1, as :func:`curve_grid` built it) in
    its shape coordinates: ``slope[k, i]`` = d exponent / d theta_k at node i (at fixed x),
    and ``cumulative[k, i]`` = int_{x0}^{x_i} exp(exponent) d exponent / d theta_k dx (each
    cell's integrand linear in x between its nodes). theta is (F_peak, r, s0) with
    ``transform`` (4, 3) = d(a, alpha, Fd, x0) / d(F_peak, r, s0), and A where ``slope``
    has a fourth row. So d Gamma(x) / d theta_k at fixed x is ``cumulative[k](x) - exp(
    exponent[0]) d x0 / d theta_k``."""
    a, alpha, fd, x0 = params
    start = curve_start(alpha, x0)
    s0 = start[0]
    rows = slope.shape[0]
    for i in range(x.shape[0]):
        z = x[i]
        s = alpha * z
        values = point(z, s, math.exp(s0 - s), a, alpha, fd, x0, 0.0, True, z <= x0, start)
        clamped = values[0] >= peak_force
        for k in range(3):
            derivative = 0.0
            if not clamped:
                for q in range(4):
                    derivative += values[1 + q] * transform[q, k]
            slope[k, i] = (derivative - (1.0 if k == 0 else 0.0)) / amplitude
        if rows == 4:
            slope[3, i] = -exponent[i] / amplitude
    for k in range(rows):
        cumulative[k, 0] = 0.0
    for i in range(x.shape[0] - 1):
        width = x[i + 1] - x[i]
        step = exponent[i + 1] - exponent[i]
        total = width * _exp_relative(exponent[i], step)
        moment = width * _exp_moment(exponent[i], step)
        for k in range(rows):
            change = slope[k, i + 1] - slope[k, i]
            cumulative[k, i + 1] = cumulative[k, i] + slope[k, i] * total + change * moment


@compiled_inline
def cell_position(value, x, exponent, gamma):
    """(cell i, the exponent's slope in it [1/m], x - x_i [m]) where Gamma reaches ``value``
    [m] inside the grid: the inverse of the quadrature's own interpolant, an exponent linear
    in x on each cell (x - x_i = ln(1 + k) / slope, k = slope (Gamma - Gamma_i) exp(-e_i))."""
    last = x.shape[0] - 1
    index = np.searchsorted(gamma, value, side="right") - 1
    index = min(max(index, 0), last - 1)
    width = x[index + 1] - x[index]
    slope = (exponent[index + 1] - exponent[index]) / width
    scaled = max(value - gamma[index], 0.0) * math.exp(-exponent[index])
    k = slope * scaled
    factor = 1.0 - 0.5 * k if abs(k) < 1e-10 else math.log1p(max(k, -1.0 + 1e-16)) / k
    return index, slope, min(scaled * factor, width)


@compiled
def slip_jacobian(target, d_target, x, exponent, gamma, slope, cumulative, d_start, out, jac):
    """The inverse of Gamma at ``target`` [m] into ``out`` (as :func:`slip_at`) and its
    derivatives into ``jac`` (n, k): ``d_target`` (n, k) the targets' own, and the first
    ``slope.shape[0]`` columns also the curve's (``d_start`` (k,): d x0 / d theta)."""
    last = x.shape[0] - 1
    rows = slope.shape[0]
    k_all = d_target.shape[1]
    lowest = math.exp(exponent[0])
    for j in range(target.shape[0]):
        value = target[j]
        if value >= gamma[last]:
            out[j] = x[last]
            for k in range(k_all):
                jac[j, k] = 0.0
            continue
        index, rate, step = cell_position(value, x, exponent, gamma)
        remaining = max(value - gamma[index], 0.0)
        out[j] = x[index] + step
        fraction = step / (x[index + 1] - x[index])
        # Gamma'(xi) = exp(exponent at xi), the exponent linear in the cell
        density = math.exp(exponent[index] + rate * step)
        for k in range(k_all):
            change = d_target[j, k]
            if k < rows:
                slope_here = slope[k, index] + fraction * (slope[k, index + 1] - slope[k, index])
                curve = cumulative[k, index] + 0.5 * (slope[k, index] + slope_here) * remaining
                change -= curve - lowest * d_start[k]
            jac[j, k] = change / density


@compiled
def slip_at(target, x, exponent, gamma, out):
    """x [m] at which Gamma reaches each ``target`` [m] (the grid's end beyond it) into
    ``out``: the inverse of the quadrature's own interpolant (an exponent linear in x on
    each cell)."""
    last = x.shape[0] - 1
    for j in range(target.shape[0]):
        value = target[j]
        if value >= gamma[last]:
            out[j] = x[last]
            continue
        index, _, step = cell_position(value, x, exponent, gamma)
        out[j] = x[index] + step


@compiled_inline
def log_sinh(y):
    """ln sinh(y) for y > 0 without overflow."""
    return y + math.log1p(-math.exp(-2.0 * y)) - math.log(2.0) if y > 0 else -math.inf


@dataclass(frozen=True)
class History:
    """An imposed force history made of linear pieces: piece i runs from ``starts[i]`` [s]
    (``starts[0]`` = 0) to the next start (the last piece for ever), with force
    ``begin[i] + rate[i] (t - starts[i])`` [N].

    A ramp is one piece; a staircase is one flat piece per step.
    """

    starts: np.ndarray
    begin: np.ndarray
    rate: np.ndarray

    def force(self, t):
        """The imposed force [N] at ``t`` [s]."""
        t = np.asarray(t, dtype=float)
        index = np.clip(np.searchsorted(self.starts, t, side="right") - 1, 0, None)
        return self.begin[index] + self.rate[index] * (t - self.starts[index])

    def cumulative(self, amplitude, reference):
        """S at every piece's start [s]."""
        out = np.empty(self.starts.size)
        history_cumulative(self.starts, self.begin, self.rate, amplitude, reference, out)
        return out

    def integral(self, t, amplitude, reference):
        """``S(t) = int_0^t sinh(sigma/A) exp(-reference/A) dt'`` [s] at ``t`` [s]."""
        t = np.ascontiguousarray(t, dtype=float)
        out = np.empty(t.shape)
        history_integral(
            t.ravel(),
            self.starts,
            self.begin,
            self.rate,
            self.cumulative(amplitude, reference),
            amplitude,
            reference,
            out.ravel(),
        )
        return out

    def time_of(self, target, amplitude, reference):
        """The time [s] at which :meth:`integral` reaches ``target`` (a scalar [s]); inf if
        it never does (the force stops rising below what the target needs)."""
        return float(
            history_time_of(
                float(target),
                self.starts,
                self.begin,
                self.rate,
                self.cumulative(amplitude, reference),
                amplitude,
                reference,
            )
        )


def ramp_history(start, rate):
    """A ramp ``start + rate t`` [N] from t = 0."""
    return History(np.array([0.0]), np.array([float(start)]), np.array([float(rate)]))


def steps_history(edges, levels):
    """A staircase: ``levels[0]`` [N] from t = 0, ``levels[i]`` from ``edges[i - 1]`` [s]."""
    starts = np.concatenate([[0.0], np.asarray(edges, dtype=float)])
    levels = np.asarray(levels, dtype=float)
    if levels.size != starts.size:
        raise ValueError(f"a staircase needs one level more than edges, got {levels.size}")
    return History(starts, levels, np.zeros(levels.size))


@dataclass(frozen=True)
class CreepCurve:
    """Gamma(x) = int_{x0}^{x} exp((F - F_peak) / A) dx' [m] on a grid of x, for one set of
    parameters and amplitude A.

    Attributes
    ----------
    x : numpy.ndarray
        Grid of the aging coordinate [m], from x0 to the failure point past the peak.
    exponent : numpy.ndarray
        (F(x) - F_peak) / A on the grid [-].
    gamma : numpy.ndarray
        Gamma at the grid [m], 0 at x0.
    peak_force : float
        F_peak [N].
    peak_slip : float
        x_peak [m].
    amplitude : float
        A [N].
    """

    x: np.ndarray
    exponent: np.ndarray
    gamma: np.ndarray
    peak_force: float
    peak_slip: float
    amplitude: float

    @property
    def end_gamma(self):
        """Gamma [m] at the grid's end (F fallen ``_DROP`` A below the peak past it, or as
        far as the grid goes where F never falls that far)."""
        return float(self.gamma[-1])

    def slip_at(self, gamma):
        """x [m] at which Gamma reaches ``gamma`` [m] (the grid's end beyond it): the
        inverse of the quadrature's own interpolant (an exponent linear in x per cell)."""
        gamma = np.ascontiguousarray(gamma, dtype=float)
        out = np.empty(gamma.shape)
        slip_at(gamma.ravel(), self.x, self.exponent, self.gamma, out.ravel())
        return out


def creep_curve(params, amplitude, peak_slip, peak_force):
    """The :class:`CreepCurve` of ``params`` (paper initial condition) with direct-effect
    amplitude ``amplitude`` [N], whose peak is at ``peak_slip`` [m] and ``peak_force`` [N]."""
    size = RISING.size + FALLING.size
    x, exponent, gamma = np.empty(size), np.empty(size), np.empty(size)
    natural = (params.a, params.alpha, params.Fd, params.x0)
    curve_grid(
        natural,
        float(peak_force),
        float(peak_slip),
        float(amplitude),
        RISING,
        FALLING,
        x,
        exponent,
        gamma,
    )
    return CreepCurve(x, exponent, gamma, float(peak_force), float(peak_slip), float(amplitude))


def creep_slip(t, curve, velocity, history):
    """The aging coordinate x [m] at times ``t`` [s]: Gamma(x) = 2 v_ref S(t).

    Parameters
    ----------
    t : numpy.ndarray
        Times [s] (0 at the start of the history, the layer then at x0).
    curve : CreepCurve
        The layer's Gamma.
    velocity : float
        v_ref [m/s].
    history : History
        The imposed force.
    """
    scaled = history.integral(t, curve.amplitude, curve.peak_force)
    return curve.slip_at(2.0 * velocity * np.maximum(scaled, 0.0))
