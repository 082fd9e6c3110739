"""The failure forecast of a creeping layer: the direct effect (:mod:`granflow.forecast.creep`)
fitted to the slip before the cut.

The fitted coordinates are ``(ln a, ln alpha, ln x0, q, w_A, w_v, w_e, w_d, z0, z1)``: Eq. 3's curve
by its peak force (Fd in closed form, as in :mod:`~granflow.forecast.likelihood`), the
direct effect's amplitude A and reference velocity v_ref about their starting values
and a staircase's shift and stretch of its edges inside their sampling windows (``w``,
unpenalised), and the force history's error as two standard-normal coordinates (as
in the quasi-static forecast). Two likelihoods share them and differ in the profiled
coordinate q:

* the strength's: ``q = ln F_peak``; v_ref is ``w_v``'s and the failure time follows;
* the time's: ``q = ln(t_f - until)``; F_peak is ``w_v``'s instead, and v_ref follows from
  t_f in closed form, ``Gamma(x_fail) = 2 v_ref S(t_f)``, so the profile over the failure
  time is a profile over one fitted coordinate.

Both duck-type :class:`~granflow.forecast.likelihood.Likelihood` for
:func:`~granflow.forecast.likelihood.fit_and_profile`: ``floor`` is 0 for the strength (under
creep the layer can hold more than F_peak for a while, or fail below it) and ``until`` for
the time, so the profiled quantity is ``floor + exp(q)`` in both.
"""

import dataclasses
import math
from dataclasses import dataclass

import numpy as np
from scipy.optimize import least_squares
from scipy.stats import f as f_dist

from granflow.errors import InvalidDataError
from granflow.forecast.creep import (
    History,
    creep_curve,
    creep_failure_time,
    creep_slip,
    ramp_history,
    velocity_for_failure,
)
from granflow.forecast.likelihood import _bounds, _side, fit_and_profile, params_from_peak
from granflow.forecast.likelihood import _solve as _solve_fixed

__all__ = [
    "CreepLikelihood",
    "CreepState",
    "creep_amplitude",
    "fit_creep",
    "profile_failure_time",
]

_FREE = 4  # w_A, w_v, w_e, w_d
_NUISANCE = 2  # the history's error
_AMPLITUDE_SCALE = 1.0  # ln A = ln A_c + w_A
_VELOCITY_SCALE = 3.0  # ln v_ref = ln v_c + 3 w_v
_PEAK_SCALE = 0.5  # time likelihood: ln F_peak = ln F_c + 0.5 w_v (a factor e^4 either way)
_EDGE_SCALE = 0.1  # steps: the edges move by 0.1 w_e sampling intervals
_PERIOD_SCALE = 0.02  # steps: and each step lasts 0.02 w_d sampling intervals longer
_CONTINUED_STEPS = 400
_EDGE_MARGIN = 0.95  # a repaired start's Fd = 0 curve peaks at this fraction of F_peak
_FITTED = 6  # a, alpha, x0, F_peak, A, v_ref
_SOLVED = 4  # starts solved, the best by their chi-square
_MORE_SOLVED = 16  # at most, while the best fit's noise exceeds the record's
_LOCAL = 2.0  # a fit's noise over the record's rough noise that marks a local optimum


@dataclass(frozen=True)
class CreepState:
    """One point of a creep fit: Eq. 3's parameters, the direct effect and the failure.

    Attributes
    ----------
    params : Params
        a [N], alpha [1/m], Fd [N], x0 [m].
    amplitude : float
        A [N].
    velocity : float
        v_ref [m/s].
    peak_force : float
        F_peak [N].
    peak_slip : float
        x_peak [m].
    failure_time : float
        When the layer runs past the peak under the continued history [s] (inf if never).
    """

    params: object
    amplitude: float
    velocity: float
    peak_force: float
    peak_slip: float
    failure_time: float


def creep_amplitude(direct_effect):
    """The amplitude A [N] a forecast holds fixed, or None where it is fitted.

    ``True`` fits A; a positive float, or a :class:`granflow.DirectEffect` without a
    velocity, fixes it. v_ref is always fitted (the failure time is profiled through it).
    """
    from granflow.simulation.options import DirectEffect

    if direct_effect is True:
        return None
    if isinstance(direct_effect, DirectEffect):
        if direct_effect.velocity is not None:
            raise InvalidDataError(
                "direct_effect: the forecast fits the reference velocity v_ref (it profiles "
                "the failure time through it); give DirectEffect(amplitude=A) without a "
                f"velocity, got velocity={direct_effect.velocity:g} m/s"
            )
        return direct_effect.amplitude
    if isinstance(direct_effect, bool) or not isinstance(direct_effect, int | float):
        raise InvalidDataError(
            "direct_effect must be None (quasi-static), True (amplitude fitted), an amplitude "
            f"A [N] or a granflow.DirectEffect, got {direct_effect!r}"
        )
    if not (math.isfinite(direct_effect) and direct_effect > 0):
        raise InvalidDataError(
            f"direct_effect amplitude must be positive and finite, got {direct_effect!r} N"
        )
    return float(direct_effect)


def staircase_edges(loading):
    """The edges of a staircase's steps [s] in the record, and when its first continued
    step begins [s]; (None, 0) for a ramp. Computed once per record.

    A creeping layer slips fastest just after an edge, so its time matters to within a
    fraction of the sampling interval: where the edges' sampling windows allow a regular
    staircase (the midpoints within a window's width of their straight line against the
    step index), the edges are that line (and the continued steps go on along it), else
    the midpoints (and the continuation of :meth:`Loading.force`).
    """
    if loading.kind == "ramp":
        return None, 0.0
    found = np.asarray(loading.edges, dtype=float)
    if found.size >= 3:
        index = np.arange(1, found.size + 1, dtype=float)
        slope, intercept = np.polyfit(index, found, 1)
        line = intercept + slope * index
        width = max(hi - lo for lo, hi in loading.windows)
        if np.max(np.abs(line - found)) <= width:
            return line, max(intercept + slope * (found.size + 1), loading.end)
    first = loading.edge_range(loading.levels[-1] + 0.5 * loading.step)
    return found, max(0.5 * (first[0] + first[1]), loading.end)


def history_with_error(loading, error, z, ceiling, shift=(0.0, 0.0), edges=None):
    """The imposed force history: the fitted one plus its error (coordinates ``z``), and its
    continuation beyond the record (steps up to ``ceiling`` [N], then the last level).

    A staircase's edges (:func:`staircase_edges`, or ``edges``: its result) are known to
    within their sampling windows only, and a creeping layer slips fastest just after each
    edge, so they move: ``shift`` = (offset [s], stretch [s]) puts edge k (1 the first,
    n the record's last) ``offset + (k - n) stretch`` later (both fitted)."""
    root, _, _, _ = error
    c0, c1 = root @ z if z.size else (0.0, 0.0)
    if loading.kind == "ramp":
        origin = loading.error[3]
        start = loading.start + c0 - c1 * origin
        return ramp_history(start, max(loading.rate + c1, 1e-9 * abs(loading.rate)))
    levels = np.asarray(loading.levels, dtype=float)
    origin = levels.size - 1
    index = np.arange(levels.size, dtype=float) - origin
    levels = levels + (c0 + c1 * index if loading.on_line else c0 * (index == 0))
    step = loading.step + c1
    known, begin = staircase_edges(loading) if edges is None else edges
    count = 0
    if step > 0:
        count = int(min(max(math.ceil((ceiling - levels[-1]) / step), 1), _CONTINUED_STEPS))
    continued = levels[-1] + step * np.arange(1, count + 1)
    edges = np.concatenate([known, begin + loading.duration * np.arange(count)])
    offset, stretch = shift
    edges = edges + offset + stretch * (np.arange(1, edges.size + 1) - known.size)
    starts = np.concatenate([[0.0], edges])
    values = np.concatenate([levels, continued])
    return History(starts, values, np.zeros(values.size))


@dataclass(frozen=True)
class CreepLikelihood:
    """The slip record against the creep model; see the module's docstring.

    ``timed`` False: the strength's likelihood (q = ln F_peak, ``floor`` 0); True: the
    time's (q = ln(t_f - floor), ``floor`` the cut).
    """

    time: np.ndarray
    slip: np.ndarray
    loading: object
    error: tuple
    centre: tuple  # (A_c, v_c, F_c)
    fixed_amplitude: bool
    floor: float
    size: int
    bounds: tuple
    timed: bool = False
    ceiling: float = math.inf
    window: float = 0.0
    edges: tuple | None = None
    prior: object = None
    prior_size: int = 0
    noise: float | None = None
    scale: float = 1.0
    nuisance: int = _FREE + _NUISANCE
    starts: tuple = ()
    peak_of: object = None
    restarts: bool = True  # profile points near the threshold solved from more starts

    def curve(self, u):
        """(CreepState, (CreepCurve, History)) at internal vector u, or None where
        infeasible."""
        with np.errstate(all="ignore"):
            return self._curve(u)

    def _curve(self, u):
        a, alpha, x0 = (float(v) for v in np.exp(u[:3]))
        amplitude_c, velocity_c, peak_c = self.centre
        amplitude = amplitude_c * (1.0 if self.fixed_amplitude else math.exp(u[4]))
        z = np.asarray(u[8:], dtype=float)
        shift = (_EDGE_SCALE * u[6] * self.window, _PERIOD_SCALE * u[7] * self.window)
        if self.timed:
            peak_force = peak_c * math.exp(_PEAK_SCALE * u[5])
            failure_time = self.floor + math.exp(u[3])
        else:
            peak_force = math.exp(u[3])
            velocity = velocity_c * math.exp(_VELOCITY_SCALE * u[5])
        found = params_from_peak(a, alpha, x0, peak_force)
        if found is None:
            return None
        params, s_peak = found
        peak_slip = s_peak / alpha
        shape = creep_curve(params, amplitude, peak_slip, peak_force)
        ceiling = max(self.ceiling, peak_force + 40.0 * amplitude)
        history = history_with_error(self.loading, self.error, z, ceiling, shift, self.edges)
        if self.timed:
            velocity = velocity_for_failure(shape, history, failure_time)
            if not (math.isfinite(velocity) and velocity > 0):
                return None
        else:
            failure_time = creep_failure_time(shape, velocity, history)
            if not math.isfinite(velocity):
                return None
        state = CreepState(params, amplitude, velocity, peak_force, peak_slip, failure_time)
        return (state, (shape, history))

    def repaired(self, u, target):
        """A start ``u`` with the profiled coordinate at ``target``, made feasible where F_peak
        lies below the peak of the Fd = 0 curve at its a (a fit on the family's edge, Fd ->
        0, whose profile lowers F_peak): a lowered so that the Fd = 0 curve peaks at
        ``_EDGE_MARGIN`` of F_peak. A start only: the likelihood itself is unchanged."""
        from granflow.model.friction import peak
        from granflow.model.params import Params

        u = np.array(u, dtype=float)
        u[3] = target
        if self.curve(u) is not None:
            return u
        timed = self.centre[2] * math.exp(_PEAK_SCALE * u[5])
        peak_force = timed if self.timed else math.exp(u[3])
        a, alpha, x0 = (float(v) for v in np.exp(u[:3]))
        try:
            unit = peak(Params(a=1.0, alpha=alpha, Fd=0.0, x0=x0)).force
        except (ValueError, ArithmeticError):
            return u
        if unit > 0 and peak_force < a * unit:
            u[0] = math.log(_EDGE_MARGIN * peak_force / unit)
        return u

    def model(self, u):
        """The model's slip [m] at the record's times, or None where u is infeasible."""
        found = self.curve(u)
        if found is None:
            return None
        state, (shape, history) = found
        return creep_slip(self.time, shape, state.velocity, history) - state.params.x0

    def vector(self, u, noise, with_prior):
        """The standardised residual vector at u (large and flat where u is infeasible)."""
        with np.errstate(all="ignore"):
            return self._vector(u, noise, with_prior)

    def _vector(self, u, noise, with_prior):
        size = self.size + _NUISANCE + (self.prior_size if with_prior else 0)
        found = self.curve(u)
        if found is None:
            return np.full(size, 1e6)
        state, (shape, history) = found
        model = creep_slip(self.time, shape, state.velocity, history) - state.params.x0
        out = np.concatenate([(self.slip - model) / noise, np.asarray(u[8:], dtype=float)])
        if with_prior:
            out = np.concatenate([out, self.prior(state.params)])
        return np.where(np.isfinite(out), out, 1e6)


def _bounded(likelihood, u):
    low, high = _bounds(likelihood)
    return np.clip(u, low + 1e-9, high - 1e-9), (low, high)


def _solve(likelihood, u, noise, with_prior):
    start, bounds = _bounded(likelihood, u)
    result = least_squares(
        lambda v: likelihood.vector(v, noise, with_prior),
        start,
        bounds=bounds,
        max_nfev=400,
    )
    return result.x, 2.0 * result.cost


def fit_creep(likelihood, starts, level):
    """The best fit of the strength's likelihood from ``starts`` (internal vectors) and the
    profile of F_peak: ``(Fit, best)`` with ``best`` the ``(vector, chisqr, noise,
    threshold)`` of :func:`~granflow.forecast.likelihood.fit_and_profile`.

    The noise is estimated as in the quasi-static forecast unless the likelihood fixes it:
    fitted in units of a rough scale, rescaled to the residuals' variance with
    ``size - 6`` degrees of freedom (``size - 8`` for a staircase; F(1, dof) threshold),
    then refitted at that noise (the nuisance coordinates make the optimum depend on it).
    """
    with_prior = likelihood.prior is not None
    noise = likelihood.noise
    fixed = noise is not None
    first = likelihood.scale if noise is None else noise
    scored = []
    for u in starts:
        value = likelihood.vector(u, first, with_prior)
        scored.append((float(value @ value), tuple(u)))
    scored.sort()
    # the staircase's edges are two more fitted coordinates
    dof = max(likelihood.size - _FITTED - (2 if likelihood.window > 0 else 0), 1)
    fits = []
    for count, (_, u) in enumerate(scored[:_MORE_SOLVED]):
        if count >= _SOLVED:
            # a fit far worse than the record's own noise is a local optimum: more starts
            best_value = min(item[1] for item in fits)
            if first * math.sqrt(best_value / dof) < _LOCAL * likelihood.scale:
                break
        fits.append(_solve(likelihood, np.array(u), first, with_prior))
    u, value = min(fits, key=lambda item: item[1])
    if fixed:
        from scipy.stats import chi2

        threshold = float(chi2.ppf(level, 1))
        chisqr = value
    else:
        data = likelihood.vector(u, first, False)[: likelihood.size]
        noise = max(first * math.sqrt(float(data @ data) / dof), 1e-300)
        threshold = float(f_dist.ppf(level, 1, dof))
        u, chisqr = _solve(likelihood, u, noise, with_prior)
    best = (u, chisqr, noise, threshold)
    return fit_and_profile(likelihood, level, best=best), best


def timed_likelihood(likelihood, state, until):
    """The time's likelihood sharing the strength's data, centred on ``state``."""
    centre = (likelihood.centre[0], likelihood.centre[1], state.peak_force)
    return dataclasses.replace(likelihood, centre=centre, floor=until, timed=True)


def timed_vector(likelihood, u, state, until):
    """The strength's best vector ``u`` in the time likelihood's coordinates."""
    out = np.array(u, dtype=float)
    out[3] = math.log(max(state.failure_time - until, 1e-300))
    out[5] = 0.0
    return out


_PROBED_EDGES = 1  # steps beyond each end of the time's interval where another mode is sought


def _continued_edges(likelihood):
    """The staircase's edges [s]: the record's and those of its continued steps (unshifted)."""
    known, begin = likelihood.edges
    count = _CONTINUED_STEPS
    return np.concatenate([known, begin + likelihood.loading.duration * np.arange(count)])


def _crossing_between(inside, outside, threshold):
    """The profiled coordinate where the signed root of the chi-square, linear between an
    ``inside`` and an ``outside`` profile point ``(q, delta, u)``, meets the threshold's."""
    (q_a, d_a, _), (q_b, d_b, _) = inside, outside
    r_a, r_b = math.sqrt(d_a), math.sqrt(d_b)
    return q_a + (math.sqrt(threshold) - r_a) * (q_b - q_a) / (r_b - r_a)


def profile_failure_time(likelihood, level, best):
    """The time likelihood's interval of t_f [s] and its profile (a
    :class:`~granflow.forecast.likelihood.Fit`), from its best fit ``best`` (the
    ``(vector, chisqr, noise, threshold)`` of :func:`fit_creep`): the profile
    (:func:`~granflow.forecast.likelihood.fit_and_profile`), and under a staircase the
    modes beyond it.

    A creeping layer under a staircase fails soon after an edge or, by static fatigue,
    later in a hold; between one edge's mode and the next the profile rises over the hold,
    so a search that stops at the first crossing of the threshold misses a failure one step
    earlier or later that fits as well. So beyond each end, the failure at the same delay
    after each of the next edges is solved (with F_peak moved by the steps between, and
    from the best fit); where one is inside the threshold, the profile goes on from it to
    its own crossing, and the probing from there.
    """
    fit = fit_and_profile(likelihood, level, best=best)
    low, high = fit.interval
    if likelihood.edges is None or likelihood.loading.kind == "ramp":
        return (low, high), fit
    u_best, chisqr, noise, threshold = best
    found = likelihood.curve(u_best)
    if found is None:
        return (low, high), fit
    state = found[0]
    edges = _continued_edges(likelihood)
    until = likelihood.floor
    k_best = int(np.searchsorted(edges, state.failure_time, side="right")) - 1
    delay = state.failure_time - (edges[k_best] if k_best >= 0 else 0.0)
    step = likelihood.loading.step
    with_prior = likelihood.prior is not None
    low_bound, high_bound = _bounds(likelihood)

    def probe(k):
        target = edges[k] + delay
        if not target > until:
            return None
        q = math.log(target - until)
        start = np.array(u_best, dtype=float)
        ratio = 1.0 + (k - k_best) * step / state.peak_force
        if ratio > 0:
            start[5] = math.log(ratio) / _PEAK_SCALE
        start = np.clip(start, low_bound + 1e-9, high_bound - 1e-9)
        u, value = _solve_fixed(likelihood, start, noise, with_prior, fixed=q)
        return q, max(value - chisqr, 0.0), u

    for direction in (-1, 1):
        end = low if direction < 0 else high
        if not math.isfinite(end) or end <= until:
            continue
        k = int(np.searchsorted(edges, end - delay, side="left" if direction > 0 else "right"))
        k = k if direction > 0 else k - 1
        missed = 0
        while missed < _PROBED_EDGES and 0 <= k < edges.size:
            point = probe(k)
            if point is None:
                break
            k += direction
            if point[1] > threshold:
                missed += 1
                continue
            # another mode inside: go on from it to its own crossing
            missed = 0
            points, bounded = _side(
                likelihood,
                point[2],
                chisqr,
                noise,
                with_prior,
                direction,
                0.02,
                threshold,
                point[0] + direction * 12.0,
            )
            inside = point
            for item in points:
                if item[1] > threshold:
                    break
                inside = item
            if not bounded:
                end = until if direction < 0 else math.inf
                break
            outside = next(item for item in points if item[1] > threshold)
            end = until + math.exp(_crossing_between(inside, outside, threshold))
            k = int(np.searchsorted(edges, end - delay, side="left" if direction > 0 else "right"))
            k = k if direction > 0 else k - 1
        if direction < 0:
            low = min(low, end)
        else:
            high = max(high, end)
    return (low, high), fit
