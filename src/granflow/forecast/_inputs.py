"""Checks at the door of every forecast: finite columns, increasing time, enough points."""

import math

import numpy as np

from granflow import _validate as check
from granflow.errors import InvalidDataError

MIN_POINTS = 12


def column(values, name, unit, length=None):
    """A finite float copy of one column; names the first bad index."""
    array = np.array(check.float_array(values, name, unit), dtype=float).ravel()
    if length is not None and array.size != length:
        raise InvalidDataError(f"{name} has {array.size} values, but t has {length}")
    bad = np.flatnonzero(~np.isfinite(array))
    if bad.size:
        raise InvalidDataError(
            f"{name} must be finite, got {array[bad[0]]} {unit} at index {bad[0]}"
        )
    return array


def record(t, columns, until):
    """(t, columns, until) cut at ``until``: t strictly increasing and at least MIN_POINTS
    points up to the cut; ``columns`` maps name -> (values, unit)."""
    time = column(t, "t", "s")
    if time.size < MIN_POINTS:
        raise InvalidDataError(
            f"too short: {time.size} points in the record, a forecast needs at least {MIN_POINTS}"
        )
    values = {name: column(v, name, unit, time.size) for name, (v, unit) in columns.items()}
    steps = np.diff(time)
    if np.any(steps <= 0):
        where = int(np.flatnonzero(steps <= 0)[0]) + 1
        raise InvalidDataError(
            f"t must increase strictly: t[{where}] = {time[where]:g} s follows "
            f"t[{where - 1}] = {time[where - 1]:g} s"
        )
    until = time[-1] if until is None else check.real_scalar(until, "until", "s")
    keep = time <= until * (1 + 1e-12) + (0.0 if until else 1e-300)
    if int(np.count_nonzero(keep)) < MIN_POINTS:
        raise InvalidDataError(
            f"too short: {int(np.count_nonzero(keep))} points up to until = {until:g} s, "
            f"a forecast needs at least {MIN_POINTS}"
        )
    cut = {name: v[keep] for name, v in values.items()}
    return time[keep], cut, float(min(until, time[-1]) if math.isfinite(until) else time[-1])


def rough_noise(values):
    """A robust noise level of a smooth-plus-noise column (in its unit): the median absolute
    second difference, scaled to a Gaussian standard deviation (second differences remove a
    local trend and have variance 6 sigma^2; the median ignores jumps). Never zero."""
    second = np.diff(values, 2)
    level = 1.4826 * float(np.median(np.abs(second))) / math.sqrt(6.0) if second.size else 0.0
    return max(level, 1e-9 * float(np.ptp(values)), 1e-300)


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
