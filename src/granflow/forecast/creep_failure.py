"""When a creeping layer fails: the first time past the peak at which its velocity
``2 v_ref sinh(sigma/A) exp(-F/A)`` reaches ``FAILURE_VELOCITY``, force and slip both moving
(:func:`first_passage`), and the inverse, the creep rate that puts the failure at a given
time (:func:`rate_for_passage`), on the grids of :mod:`granflow.forecast.creep`.

A layer whose F_peak stands only a few A above Fd runs away for seconds past the peak (F
falls towards Fd as a / (alpha x) only), and the rising force then decides when it reaches
the threshold: holding the force at one value over the run-away put such failures up to 6 %
early. Beyond the grid's end (2000 x_peak, or where F has fallen 12 A below the peak) F is
taken as the end's.
"""

import math

import numpy as np

from granflow.forecast.creep import (
    FAILURE_VELOCITY,
    cell_position,
    history_integral,
    history_time_of,
    log_sinh,
)
from granflow.model.special import compiled, compiled_inline

__all__ = ["creep_failure_time", "first_passage", "rate_for_passage", "velocity_for_failure"]


@compiled_inline
def _level(x, exponent, gamma, target):
    """(F - F_ref)/A [-] where Gamma reaches ``target`` (the quadrature's own interpolant;
    beyond the grid's end, the end's: its last and lowest F)."""
    last = x.shape[0] - 1
    if target >= gamma[last]:
        return exponent[last]
    index, slope, step = cell_position(target, x, exponent, gamma)
    return exponent[index] + slope * step


@compiled_inline
def _asinh_exp(log_value):
    """asinh(exp(``log_value``)) without overflow."""
    if log_value > 20.0:
        return log_value + math.log(2.0)
    return math.asinh(math.exp(log_value))


@compiled_inline
def _force_at(t, starts, begin, rate):
    """The history's force [N] at ``t`` [s]."""
    index = max(np.searchsorted(starts, t, side="right") - 1, 0)
    return begin[index] + rate[index] * (t - starts[index])


@compiled_inline
def _time_of_force(level, after, starts, begin, rate):
    """The first time [s] not before ``after`` at which the history's force reaches
    ``level`` [N] (inf if never)."""
    pieces = starts.shape[0]
    first = max(np.searchsorted(starts, after, side="right") - 1, 0)
    for i in range(first, pieces):
        lo = max(starts[i], after)
        hi = starts[i + 1] if i + 1 < pieces else math.inf
        if begin[i] + rate[i] * (lo - starts[i]) >= level:
            return lo
        if rate[i] > 0.0:
            when = starts[i] + (level - begin[i]) / rate[i]
            if when <= hi:
                return max(when, lo)
    return math.inf


@compiled_inline
def _trial(lo, f_lo, hi, f_hi):
    """The secant's point in a bracket [lo, hi] whose ends' values have opposite signs (the
    middle where it falls outside)."""
    mid = hi - f_hi * (hi - lo) / (f_hi - f_lo)
    return mid if lo < mid < hi else 0.5 * (lo + hi)


@compiled_inline
def _bracketed(mid, f_mid, lo, f_lo, hi, f_hi, side):
    """The bracket after a trial at ``mid`` (the Illinois step: the end kept twice running
    has its value halved); ``side`` says which end moved last."""
    if f_mid >= 0.0:
        if side == 1:
            f_lo *= 0.5
        return lo, f_lo, mid, f_mid, 1
    if side == -1:
        f_hi *= 0.5
    return mid, f_mid, hi, f_hi, -1


@compiled_inline
def _excess(log_base, t, target, curve):
    """ln(v / FAILURE_VELOCITY) at ``t`` [s] of a layer at Gamma = ``target`` [m]:
    ``log_base`` = ln(2 v_ref) - F_ref/A - ln FAILURE_VELOCITY; ``curve`` = (starts, begin,
    rate, A, x, exponent, gamma)."""
    starts, begin, rate, amplitude, x, exponent, gamma = curve
    sigma = _force_at(t, starts, begin, rate)
    return log_base + log_sinh(sigma / amplitude) - _level(x, exponent, gamma, target)


@compiled
def first_passage(
    starts, begin, rate, cumulative, amplitude, reference, x, exponent, gamma, peak, w, velocity
):
    """The failure time [s] of a layer whose Gamma is ``2 w S(t)`` (``w`` [m/s, or 1/s on
    a unit curve]): the first time past the peak (Gamma[``peak``]) at which its velocity
    ``2 v_ref sinh(sigma/A) exp(-F/A)`` (v_ref = ``velocity`` [m/s]) reaches
    ``FAILURE_VELOCITY``, as the simulator's run has it; inf if never. The force and the
    slip both move during the run-away: their joint condition is solved (bisection with
    the Illinois step on the time), not the force held at one value."""
    log_base = math.log(2.0 * velocity) - reference / amplitude - math.log(FAILURE_VELOCITY)
    args = (starts, begin, rate, cumulative, amplitude, reference)
    curve = (starts, begin, rate, amplitude, x, exponent, gamma)
    lo = history_time_of(gamma[peak] / (2.0 * w), *args)
    if not math.isfinite(lo):
        return math.inf
    f_lo = _excess(log_base, lo, gamma[peak], curve)
    if f_lo >= 0.0:
        return lo
    last = x.shape[0] - 1
    hi = history_time_of(gamma[last] / (2.0 * w), *args)
    if not math.isfinite(hi):
        return math.inf
    f_hi = _excess(log_base, hi, gamma[last], curve)
    if f_hi < 0.0:
        # beyond the grid F stays at its end: the force alone must rise, until
        # ln sinh(sigma/A) = exponent[last] - log_base
        level = amplitude * _asinh_exp(exponent[last] - log_base)
        return _time_of_force(level, hi, starts, begin, rate)
    one = np.empty(1)
    side = 0
    for _ in range(200):
        if hi - lo <= 1e-13 * hi:
            break
        mid = _trial(lo, f_lo, hi, f_hi)
        history_integral(np.array([mid]), *args, one)
        f_mid = _excess(log_base, mid, 2.0 * w * max(one[0], 0.0), curve)
        lo, f_lo, hi, f_hi, side = _bracketed(mid, f_mid, lo, f_lo, hi, f_hi, side)
    return hi


@compiled
def rate_for_passage(scaled, sigma, amplitude, reference, x, exponent, gamma, peak, scale):
    """``w`` whose :func:`first_passage` is a time t_f [s], given S(t_f) = ``scaled`` [s]
    and the force there ``sigma`` [N] (v_ref = ``scale`` w: ``scale`` is x_peak on a unit
    curve, 1 on a physical one): its velocity reaches the threshold exactly at t_f, past
    the peak (the peak's own w where the layer is that fast there already). For a force
    that does not fall over the run-away (a ramp, a staircase between its edges) this is
    the failure at t_f; inf where S(t_f) is 0."""
    if not scaled > 0.0:
        return math.inf
    # ln(v / FAILURE_VELOCITY) = ln(2 scale w) + log_fixed - level(2 w S(t_f))
    log_fixed = log_sinh(sigma / amplitude) - reference / amplitude - math.log(FAILURE_VELOCITY)
    last = x.shape[0] - 1
    lo = math.log(gamma[peak] / (2.0 * scaled))
    f_lo = math.log(2.0 * scale) + lo + log_fixed - _level(x, exponent, gamma, gamma[peak])
    if f_lo >= 0.0:
        return math.exp(lo)
    hi = math.log(gamma[last] / (2.0 * scaled))
    f_hi = math.log(2.0 * scale) + hi + log_fixed - exponent[last]
    if f_hi < 0.0:
        # beyond the grid F stays at its end: v_ref alone must rise
        return math.exp(hi - f_hi)
    side = 0
    for _ in range(200):
        if hi - lo <= 1e-14:
            break
        mid = _trial(lo, f_lo, hi, f_hi)
        f_mid = (
            math.log(2.0 * scale)
            + mid
            + log_fixed
            - _level(x, exponent, gamma, 2.0 * math.exp(mid) * scaled)
        )
        lo, f_lo, hi, f_hi, side = _bracketed(mid, f_mid, lo, f_lo, hi, f_hi, side)
    return math.exp(hi)


def creep_failure_time(curve, velocity, history):
    """The time [s] at which the layer fails (inf if never): the first time past the peak
    at which its velocity passes ``FAILURE_VELOCITY``, as :func:`granflow.simulate` has it
    by default under force control (:func:`first_passage`)."""
    amplitude, reference = curve.amplitude, curve.peak_force
    return float(
        first_passage(
            history.starts,
            history.begin,
            history.rate,
            history.cumulative(amplitude, reference),
            amplitude,
            reference,
            curve.x,
            curve.exponent,
            curve.gamma,
            _peak_index(curve),
            float(velocity),
            float(velocity),
        )
    )


def _peak_index(curve):
    """The grid's node at the peak."""
    return int(min(np.searchsorted(curve.x, curve.peak_slip), curve.x.size - 1))


def velocity_for_failure(curve, history, failure_time):
    """v_ref [m/s] that puts the failure at ``failure_time`` [s] (the inverse of
    :func:`creep_failure_time`, :func:`rate_for_passage`)."""
    scaled = float(history.integral(np.array([failure_time]), curve.amplitude, curve.peak_force)[0])
    return float(
        rate_for_passage(
            scaled,
            float(history.force(np.array([failure_time]))[0]),
            curve.amplitude,
            curve.peak_force,
            curve.x,
            curve.exponent,
            curve.gamma,
            _peak_index(curve),
            1.0,
        )
    )
