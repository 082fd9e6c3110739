"""The field's reference methods as distributions of the failure time, so that they are
scored as granflow's forecasts are (:func:`granflow.forecast.score`).

Each method has a likelihood with the failure time t_f among its parameters, and its
distribution is that likelihood's confidence distribution, built as granflow's own
(:class:`~granflow.forecast.distribution.Distribution`): the signed root of the profile's
chi-square in t_f, Student's t with the fit's degrees of freedom (the noise estimated from
the residuals), tabulated on the same quantiles. The profile is read on a grid of 120 leads
``t_f - until`` from 1e-4 to 100 times the cut time (log-spaced); where it has not risen to
3.1 at the grid's far end the rest of the probability lies beyond (the record does not bound
the failure); probability before the cut is held at the cut.

* :func:`fukuzono_forecast`, the inverse-velocity method (Fukuzono 1985): 1/v falls on a
  straight line to zero at t_f. The velocities are the slopes of the slip over
  non-overlapping windows (independent estimates), 1/v regressed over the record's second
  half; the profile of the line's root (the likelihood-ratio form of Fieller's interval).
* :func:`ffm_forecast`, the failure forecast method with its exponent fitted by maximum
  likelihood (Voight 1988; Bell, Naylor & Main 2013): ``v = k (t_f - t)^(-p)``, Voight's
  ``alpha = 1 + 1/p`` free, fitted to the slip itself (its integral, Gaussian slip noise)
  over the record's second half. At each (t_f, p) the slip is linear in its offset and k, so
  those are closed-form least squares; p is profiled over 0.1 to 8 (a grid of 10, then a
  golden-section search about its least).
* :func:`current_rate_forecast`, the naive reference: the inverse velocity's current rate of
  fall extrapolated (``t_f - until = v / (dv/dt)`` at the cut, Voight's alpha = 2 locally),
  from the last four velocity windows only.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from granflow.forecast import _inputs
from granflow.forecast.distribution import Distribution
from granflow.forecast.results import BaselineForecast

if TYPE_CHECKING:
    from granflow._typing import ArrayLike

__all__ = [
    "block_velocity",
    "current_rate_forecast",
    "ffm_forecast",
    "fukuzono_forecast",
    "power_law_least",
    "power_law_rss",
]

_LEADS = np.geomspace(1e-4, 100.0, 120)  # t_f - until over until
_POWERS = (0.1, 8.0)  # the range of p
_REACH = 3.1  # the signed root the table's quantiles span (Distribution.table)
_CURRENT = 4  # velocity windows of the current-rate reference


def block_velocity(t, slip, window):
    """Slip rate [m/s] over non-overlapping windows of ``window`` points (the last window
    ends at the last sample; a short first remainder is dropped): each window's least-squares
    slope of slip against time. Returns ``(t_centre, velocity)``."""
    width = max(int(window), 2)
    count = t.size // width
    start = t.size - count * width
    tw = t[start:].reshape(count, width)
    sw = slip[start:].reshape(count, width)
    dt = tw - tw.mean(axis=1, keepdims=True)
    ds = sw - sw.mean(axis=1, keepdims=True)
    return tw.mean(axis=1), np.sum(dt * ds, axis=1) / np.sum(dt * dt, axis=1)


def _zoomed(profile, until, dof):
    """(u, chi-square) of a profile of the lead: ``profile(leads)`` [s] gives the residual
    sum of squares at each lead; read on the coarse grid, then again on as many points
    where it lies within 5 (signed root) of its least, so that a sharp profile is read
    finely. The noise's variance is the least's over ``dof`` (applied by the caller)."""
    leads = _LEADS * until
    rss = profile(leads)
    low = float(np.min(rss))
    near = np.flatnonzero(rss <= low * (1.0 + 25.0 / dof) + 1e-300)  # the root within 5
    lo, hi = max(int(near[0]) - 1, 0), min(int(near[-1]) + 1, leads.size - 1)
    fine = np.geomspace(leads[lo], leads[hi], _LEADS.size)
    u = np.log(np.concatenate([leads, fine]))
    order = np.argsort(u)
    return u[order], np.concatenate([rss, profile(fine)])[order]


def _forecast(method, until, level, exponent, count, u, chisqr, dof, message=""):
    """A BaselineForecast from a profile: ``chisqr`` [-] (the residual sum of squares over the
    noise's estimate) at the leads ``exp(u)`` [s], minimised over the rest."""
    best = int(np.argmin(chisqr))
    least, u_best = float(chisqr[best]), float(u[best])
    if 0 < best < u.size - 1:  # the least between the grid's nodes: a parabola in u
        left, mid, right = chisqr[best - 1 : best + 2]
        h1, h2 = u[best] - u[best - 1], u[best + 1] - u[best]
        if h1 > 0 and h2 > 0:
            slope1, slope2 = (mid - left) / h1, (right - mid) / h2
            curvature = (slope2 - slope1) / (0.5 * (h1 + h2))
            if curvature > 0:
                slope = slope1 + 0.5 * curvature * h1  # at u[best]
                shift = float(np.clip(-slope / curvature, -h1, h2))
                u_best += shift
                least = min(least, max(mid + slope * shift + 0.5 * curvature * shift**2, 0.0))
    deltas = np.maximum(chisqr - least, 0.0)
    root = np.sqrt(deltas) * np.where(u < u_best, -1.0, 1.0)
    keep = u != u_best
    u, root = u[keep], root[keep]
    at = int(np.searchsorted(u, u_best))
    u, root = np.insert(u, at, u_best), np.insert(root, at, 0.0)
    root = np.maximum.accumulate(root)  # one minimum: the profile's monotone envelope
    distribution = Distribution(
        u=u,
        r=root,
        offset=until,
        scale=1.0,
        log=True,
        dof=dof,
        open_below=bool(root[0] > -_REACH),
        open_above=bool(root[-1] < _REACH),
        low_end=float(u[0]),
        high_end=float(u[-1]),
    )
    with np.errstate(over="ignore"):  # quantiles far beyond the grid
        times, probability = distribution.table()
        median = distribution.median()
        interval = distribution.interval(level)
    approaching = math.isfinite(median)
    if not approaching:
        message = message or "the record does not bound the failure: no date"
    return BaselineForecast(
        method=method,
        time=median if approaching else None,
        time_interval=interval,
        until=until,
        level=level,
        exponent=exponent,
        n_points=count,
        approaching=approaching,
        message=message,
        cdf={"time": [float(v) for v in times], "probability": [float(v) for v in probability]},
    )


def _declined(method, until, level, count, message):
    return BaselineForecast(
        method=method,
        time=None,
        time_interval=(math.nan, math.nan),
        until=until,
        level=level,
        exponent=math.nan,
        n_points=count,
        approaching=False,
        message=message,
    )


def _record(t, slip, until):
    time, cut, until = _inputs.record(t, {"slip": (slip, "m")}, until)
    return time, cut["slip"], until


def _line_root_profile(centres, inverse, until):
    """(rss(leads), degrees of freedom, least rss): the residual sum of squares of a straight
    line through (centres, 1/v) forced through zero at ``until + lead``, the unforced
    line's."""
    design = np.column_stack([np.ones_like(centres), centres])
    coef, *_ = np.linalg.lstsq(design, inverse, rcond=None)
    best = float(np.sum((inverse - design @ coef) ** 2))

    def rss(leads):
        remaining = (until + leads)[:, None] - centres[None, :]
        slope = (remaining @ inverse) / np.sum(remaining * remaining, axis=1)
        return np.sum((inverse[None, :] - slope[:, None] * remaining) ** 2, axis=1)

    return rss, centres.size - 2, max(best, 1e-24 * float(inverse @ inverse), 1e-300)


def _velocity_forecast(method, t, slip, until, level, window, last):
    time, slip, until = _record(t, slip, until)
    width = window or max(5, time.size // 20)
    centres, rates = block_velocity(time, slip, width)
    if last is None:
        chosen = centres >= centres[0] + 0.5 * (centres[-1] - centres[0])
    else:
        chosen = np.arange(centres.size) >= centres.size - last
    centres, rates = centres[chosen], rates[chosen]
    if centres.size < 4 or not np.all(rates > 0):
        text = "too few velocity windows" if centres.size < 4 else "the slip does not advance"
        return _declined(method, until, level, centres.size, text)
    rss, dof, least = _line_root_profile(centres, 1.0 / rates, until)
    u, values = _zoomed(rss, until, dof)
    return _forecast(method, until, level, 2.0, centres.size, u, values / (least / dof), dof)


def fukuzono_forecast(
    t: ArrayLike,
    slip: ArrayLike,
    until: float | None = None,
    *,
    level: float = 0.9,
    window: int | None = None,
) -> BaselineForecast:
    """The inverse-velocity method (Fukuzono 1985) as a distribution of the failure time.

    Parameters
    ----------
    t : array_like
        Record time [s], strictly increasing, 0 at the start of loading.
    slip : array_like
        Record slip [m].
    until : float, optional
        The cut [s]; default the whole record.
    level : float
        Level of the interval [-].
    window : int, optional
        Points per velocity window; default a twentieth of the record (at least 5).

    Returns
    -------
    BaselineForecast
        With ``cdf`` and ``probability_within``; ``time`` None where the record does not
        bound the failure.

    Examples
    --------
    >>> import numpy as np
    >>> from granflow.forecast.references import fukuzono_forecast
    >>> t = np.linspace(0.0, 90.0, 400)
    >>> slip = -1e-6 * np.log(1.0 - t / 100.0)  # v = 1e-6 / (100 - t): 1/v a line to 100 s
    >>> bool(abs(fukuzono_forecast(t, slip).time - 100.0) < 0.2)  # windows' slopes: 99.9 s
    True
    """
    return _velocity_forecast("inverse velocity", t, slip, until, level, window, None)


def current_rate_forecast(
    t: ArrayLike,
    slip: ArrayLike,
    until: float | None = None,
    *,
    level: float = 0.9,
    window: int | None = None,
) -> BaselineForecast:
    """The naive reference: 1/v's current rate of fall extrapolated to zero, from the last
    four velocity windows (parameters and return as :func:`fukuzono_forecast`)."""
    return _velocity_forecast("current rate", t, slip, until, level, window, _CURRENT)


def _ffm_rss(time, slip, until, leads, powers, log_ratio=None, out=None):
    """The residual sum of squares of the slip's power law at each (lead, p) pair [m^2],
    offset and amplitude (non-negative) in closed form; ``log_ratio``, ln((until + lead -
    time) / until) for these leads, may be given when it is already known, and ``out``, an
    array of its shape to work in."""
    centred = slip - slip.mean()
    if log_ratio is None:
        log_ratio = _log_ratio(time, until, leads)
    exponent = 1.0 - np.asarray(powers, dtype=float)
    near, zero = np.abs(exponent) < 0.1, np.abs(exponent) < 1e-9  # one (lead, p) a row
    # the slip of v = (tau / T)^(-p) / T is (tau / T)^(1 - p) / (p - 1) up to a constant,
    # which the offset takes: each row's basis is taken up to its factor 1 / (p - 1), whose
    # sign alone matters (the gain, projection^2 / norm, does not see a row's scale); near
    # p = 1 with the constant -1 kept (expm1), whose digits the varying part would lose;
    # -ln(tau / T) at p = 1
    basis = np.multiply(exponent[:, None], log_ratio, out=out)
    with np.errstate(over="ignore", invalid="ignore"):
        if near.any():
            basis[~near] = np.exp(basis[~near])
            basis[near] = np.expm1(basis[near])
            basis[zero] = -log_ratio[zero]
        else:
            np.exp(basis, out=basis)
        basis -= basis.mean(axis=1, keepdims=True)
        norm = np.einsum("ij,ij->i", basis, basis)
        projection = (basis @ centred) * np.where(zero, 1.0, -np.sign(exponent))
    ok = (projection > 0) & np.isfinite(norm) & (norm > 0)
    gain = np.where(ok, projection**2 / np.where(ok, norm, 1.0), 0.0)
    return np.maximum(float(centred @ centred) - gain, 0.0)


def _log_ratio(time, until, leads):
    """ln((until + lead - time) / until) for each lead (rows) and time (columns)."""
    return np.log(((until + leads)[:, None] - time[None, :]) / until)


def _ffm_profile(time, slip, until):
    """rss(leads): the power law's least residual sum of squares over p at each lead, p on
    a grid of 10 from 0.1 to 8, then by golden section in ln p about the grid's least (one
    new evaluation an iteration: the other point is the previous one's) to a hundred-and-
    twentieth of the bracket, and last at the vertex of the parabola through the three
    points about the least (23 passes over the data where 21 golden steps took 31, and a
    least as low or lower: 22 of 40 test records lower, by up to 8e-6 of it); and the p of
    each (a function of the leads too)."""
    grid = np.log(np.geomspace(_POWERS[0], _POWERS[-1], 10))
    golden = 0.5 * (math.sqrt(5.0) - 1.0)

    def solve(leads):
        log_ratio = _log_ratio(time, until, leads)
        work = np.empty_like(log_ratio)

        def rss(log_power):
            return _ffm_rss(time, slip, until, leads, np.exp(log_power), log_ratio, work)

        return _searched(rss, leads.size)

    def _searched(rss, size):
        values = np.array([rss(np.full(size, g)) for g in grid])
        k = np.argmin(values, axis=0)
        columns = np.arange(size)
        below, above = np.maximum(k - 1, 0), np.minimum(k + 1, grid.size - 1)
        lo, hi = grid[below], grid[above]
        f_lo, f_hi = values[below, columns], values[above, columns]
        x1, x2 = hi - golden * (hi - lo), lo + golden * (hi - lo)
        f1, f2 = rss(x1), rss(x2)
        for _ in range(10):
            left = f1 < f2  # the least lies in [lo, x2]: x1 becomes the new x2
            hi, f_hi = np.where(left, x2, hi), np.where(left, f2, f_hi)
            lo, f_lo = np.where(left, lo, x1), np.where(left, f_lo, f1)
            fresh = np.where(left, hi - golden * (hi - lo), lo + golden * (hi - lo))
            f_new = rss(fresh)
            x1, x2, f1, f2 = (
                np.where(left, fresh, x2),
                np.where(left, x1, fresh),
                np.where(left, f_new, f2),
                np.where(left, f1, f_new),
            )
        # the parabola through the three points about the least: (lo, x1, x2) or (x1, x2, hi)
        left = f1 < f2
        a, fa = np.where(left, lo, x1), np.where(left, f_lo, f1)
        b, fb = np.where(left, x1, x2), np.where(left, f1, f2)
        c, fc = np.where(left, x2, hi), np.where(left, f2, f_hi)
        with np.errstate(divide="ignore", invalid="ignore"):
            numerator = (b - a) ** 2 * (fb - fc) - (b - c) ** 2 * (fb - fa)
            denominator = (b - a) * (fb - fc) - (b - c) * (fb - fa)
            vertex = b - 0.5 * numerator / denominator
        inside = np.isfinite(vertex) & (vertex > a) & (vertex < c)
        vertex = np.where(inside, vertex, b)
        f_vertex = rss(vertex)
        best = np.where(f_vertex <= fb, vertex, b)
        least = np.minimum(f_vertex, fb)
        floor = values[k, columns]
        return np.minimum(least, floor), np.where(least <= floor, np.exp(best), np.exp(grid[k]))

    return solve


def power_law_rss(time, slip, until):
    """The least residual sum of squares [m^2] of Voight's power law fitted to ``slip`` [m]
    at ``time`` [s] (before ``until`` [s]), over its four parameters (leads on a coarse grid
    of 40 from 1e-3 to 100 times ``until``)."""
    return power_law_least(time, slip, until)[0]


#: The warm search's half-step in ln p: three points 0.01 apart about the exponent expected.
_NEAR_STEP = 0.01
#: Rounds of the warm search (each re-centred where the last one's vertex fell outside its
#: points, at most four steps on) before a lead is searched in full.
_NEAR_ROUNDS = 2


def power_law_least(time, slip, until, near=None):
    """(least [m^2], exponents): :func:`power_law_rss` and the exponent p of each of its
    leads at its least [-], for a search of the same record grown to start from (``near``).

    With ``near`` (the exponents expected at each lead: a previous call's, or where they
    were heading), each lead's least is sought about it: the parabola through three points
    ``_NEAR_STEP`` apart in ln p, its vertex evaluated (4 passes over the data where the
    full search takes 23); at the range's ends (p = 0.1 and 8), the end itself where the
    parabola's vertex lies beyond it. A lead whose vertex falls elsewhere outside the three
    points is searched again about it (at most four steps on; :data:`_NEAR_ROUNDS` rounds,
    each over the unsettled leads alone), and one still unsettled, or whose parabola does
    not open upwards, in full. The least over p at one lead is then found as closely as
    the full search finds it (one exponent a lead: the search assumes one valley in p, as
    the full search's grid of 10 does between its points)."""
    leads = np.geomspace(1e-3, 100.0, 40) * until
    if near is None:
        least, powers = _ffm_profile(time, slip, until)(leads)
        return float(np.min(least)), powers
    log_ratio = _log_ratio(time, until, leads)
    h = _NEAR_STEP
    low, high = math.log(_POWERS[0]), math.log(_POWERS[1])
    least, powers = np.empty(leads.size), np.empty(leads.size)
    done = np.zeros(leads.size, dtype=bool)
    rows = np.arange(leads.size)
    # three points about the exponent expected, moved inside the range (so that one of
    # them lies at its end where the exponent does)
    centre = np.clip(np.log(np.asarray(near, dtype=float)), low + h, high - h)
    for _ in range(_NEAR_ROUNDS):
        ratio, work = log_ratio[rows], np.empty((rows.size, time.size))

        def rss(log_power, ratio=ratio, work=work, rows=rows):
            return _ffm_rss(time, slip, until, leads[rows], np.exp(log_power), ratio, work)

        f_lo, f_mid, f_hi = rss(centre - h), rss(centre), rss(centre + h)
        curvature = f_lo - 2.0 * f_mid + f_hi
        with np.errstate(divide="ignore", invalid="ignore"):
            vertex = centre - 0.5 * h * (f_hi - f_lo) / curvature
        upwards = curvature > 0
        kept = upwards & (np.abs(vertex - centre) < h)
        # a least at the range's end: the vertex beyond it, the end the lowest point
        at_low = (centre - h <= low) & (f_lo < f_mid) & (f_mid < f_hi) & ~kept
        at_high = (centre + h >= high) & (f_hi < f_mid) & (f_mid < f_lo) & ~kept
        inside = np.where(kept, vertex, centre)
        f_vertex = rss(inside)
        better = f_vertex <= f_mid
        found = np.where(at_low, f_lo, np.where(at_high, f_hi, np.where(better, f_vertex, f_mid)))
        where = np.where(better, inside, centre)
        where = np.where(at_low, low, np.where(at_high, high, where))
        settled = kept | at_low | at_high
        least[rows[settled]], powers[rows[settled]] = found[settled], np.exp(where[settled])
        done[rows[settled]] = True
        # the others: about their vertex, at most four steps on, where it opens upwards
        moving = ~settled & upwards
        centre = np.clip(np.clip(vertex, centre - 4 * h, centre + 4 * h), low + h, high - h)
        centre, rows = centre[moving], rows[moving]
        if not rows.size:
            break
    again = np.flatnonzero(~done)
    if again.size:
        least[again], powers[again] = _ffm_profile(time, slip, until)(leads[again])
    return float(np.min(least)), powers


def ffm_forecast(
    t: ArrayLike,
    slip: ArrayLike,
    until: float | None = None,
    *,
    level: float = 0.9,
) -> BaselineForecast:
    """The failure forecast method with its exponent fitted by maximum likelihood (Voight
    1988; Bell, Naylor & Main 2013), as a distribution of the failure time.

    ``v = k (t_f - t)^(-p)`` integrated, ``slip = c + k T h_p(t_f - t)``, fitted to the slip of
    the record's second half with Gaussian noise (its level estimated, n - 4 degrees of
    freedom); t_f's distribution from its profile likelihood, p and the rest profiled out.

    Parameters
    ----------
    t, slip, until, level
        As :func:`fukuzono_forecast`.

    Returns
    -------
    BaselineForecast
        ``exponent`` is Voight's alpha = 1 + 1/p at the best fit [-].

    Examples
    --------
    >>> import numpy as np
    >>> from granflow.forecast.references import ffm_forecast
    >>> t = np.linspace(0.0, 80.0, 400)
    >>> slip = 2e-6 * (1.0 - np.sqrt(1.0 - t / 100.0))  # p = 1/2: Voight's alpha = 3
    >>> ff = ffm_forecast(t, slip)
    >>> round(ff.time, 1), round(ff.exponent, 1)
    (100.0, 3.0)
    """
    method = "ffm"
    whole, moved, until = _record(t, slip, until)
    half = whole >= 0.5 * (whole[0] + whole[-1])
    time, late = whole[half], moved[half]
    if time.size < 8:
        return _declined(method, until, level, time.size, "too few points")
    solve = _ffm_profile(time, late, until)
    dof = time.size - 4
    u, rss = _zoomed(lambda leads: solve(leads)[0], until, dof)
    spread = float(np.sum((late - late.mean()) ** 2))
    least = max(float(np.min(rss)), 1e-24 * spread, 1e-300)
    power = float(solve(np.exp(u[[int(np.argmin(rss))]]))[1][0])
    alpha = 1.0 + 1.0 / power
    return _forecast(method, until, level, alpha, time.size, u, rss / (least / dof), dof)
