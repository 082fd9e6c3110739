"""Forecast the failure of a force-controlled layer from its slow slip (quasi-static, slip
clock): the slip record before the cut constrains a, alpha, x0 and F_peak on the rising
branch, and the layer fails when the continued force history reaches F_peak."""

from __future__ import annotations

import dataclasses
import math
from typing import TYPE_CHECKING, Any

import numpy as np

from granflow import _validate as check
from granflow.errors import InvalidDataError
from granflow.forecast import _inputs
from granflow.forecast.branch import branch_slip
from granflow.forecast.creeping import (
    CreepLikelihood,
    creep_amplitude,
    fit_creep,
    profile_failure_time,
    staircase_edges,
    timed_likelihood,
    timed_vector,
)
from granflow.forecast.likelihood import Likelihood, _best, fit_and_profile
from granflow.forecast.loading import fit_loading
from granflow.forecast.prior import Prior
from granflow.forecast.results import FailureForecast

if TYPE_CHECKING:
    from granflow._typing import ArrayLike
    from granflow.forecast.results import FailureForecast

__all__ = ["forecast_failure"]

_NAN_PAIR = (math.nan, math.nan)


def _no_date(until, level, loading, n_points, message, prior, bound=None, earliest=math.inf):
    """A forecast without a date; ``bound`` (a force [N]) keeps the lower end the record
    does give: the layer has held the force so far, so it fails no earlier (nor before
    ``earliest`` [s], where that is earlier than the history reaching ``bound``)."""
    interval = _NAN_PAIR
    if bound is not None:
        interval = (min(loading.times_at(bound, math.inf)[0], earliest), math.inf)
    return FailureForecast(
        time=None,
        time_interval=interval,
        force=None,
        force_interval=_NAN_PAIR if bound is None else (bound, math.inf),
        slip=None,
        slip_interval=_NAN_PAIR,
        until=until,
        level=level,
        loading=loading,
        params={},
        noise=math.nan,
        n_points=n_points,
        approaching=False,
        prior=None if prior is None else prior.to_dict(),
        message=message,
    )


def _starts(held, slip, floor, alphas=(0.3, 1.0, 3.0)):
    """Starting values (a, alpha, x0, F_peak) over a small grid of x0, alpha (``alphas``
    over the record's slip) and F_peak."""
    total = max(float(np.max(slip)), 1e-12)
    moving = slip > 0.02 * total
    starts = []
    for x0 in (0.05 * total, 0.2 * total, total):
        x = x0 + slip[moving]
        a = float(np.polyfit(np.log(x), held[moving], 1)[0]) if moving.sum() > 2 else floor
        a = min(max(a, 1e-3 * floor), 10.0 * floor)
        for alpha in alphas:
            for factor in (1.05, 1.3, 2.0):
                starts.append((a, alpha / total, x0, floor * factor))
    return tuple(starts), total


def _loading_error(loading, time, each_level=False):
    """The fitted history's error as standard-normal coordinates z: ``c = root @ z`` (``root``
    a square root of the errors' covariance) ends with the errors (c0, c1) of its offset and
    slope on the regression's abscissa u (time for a ramp, step index for a staircase, both
    about the regression's origin), and the error at the record's times is ``basis @ c``.

    For a ramp or a regular staircase (its levels a fitted line) the error is that line's,
    ``c0 + c1 u``, at every time: two coordinates. For an irregular staircase each level is
    its own step's mean and no line describes the levels' errors: c0 is the last level's
    error and c1, the error of the continuing step, acts beyond the record only. With
    ``each_level`` every earlier level has its own coordinate too (its mean's error, the
    last level's scaled by the samples of each step), before c0; without it they get none.

    Returns ``(root, basis, anchor, slope)``: anchor and slope place the continued history
    on the same abscissa, ``anchor + slope u`` [N] for u > 0, and its error is ``c0 + c1 u``.
    """
    var0, cov, var1, origin = loading.error
    sd0 = math.sqrt(max(var0, 0.0))
    c10 = cov / sd0 if sd0 > 0 else 0.0
    root = np.array([[sd0, 0.0], [c10, math.sqrt(max(var1 - c10 * c10, 0.0))]])
    if loading.kind == "ramp":
        abscissa = time - origin
        anchor, slope = loading.start + loading.rate * origin, loading.rate
        basis = np.column_stack([np.ones_like(abscissa), abscissa])
    else:
        index = np.searchsorted(np.asarray(loading.edges), time, side="right")
        abscissa = index - origin
        anchor, slope = loading.levels[-1], loading.step
        if loading.on_line:
            basis = np.column_stack([np.ones(abscissa.size), abscissa])
        elif each_level and len(loading.levels) > 1:
            count = np.bincount(index, minlength=len(loading.levels)).astype(float)
            sd = sd0 * np.sqrt(count[-1] / np.maximum(count, 1.0))
            root = np.diag([*sd[:-1], sd0, root[1, 1]])
            basis = np.column_stack(
                [index == k for k in range(len(loading.levels))] + [np.zeros(abscissa.size)]
            )
        else:
            basis = np.column_stack([abscissa == 0, np.zeros(abscissa.size)])
    return root, basis.astype(float), anchor, slope


def _offset_and_slope(z, error):
    """(c0, c1): the errors [N, N per unit of u] of the continued history's offset and slope
    at coordinates z (the last two of ``root @ z``)."""
    c = error[0] @ z
    return c[-2], c[-1]


def _on_fitted_history(peak_force, z, error):
    """The force [N] at which the fitted history stands when the true history (the fitted one
    plus its error, coordinates z) reaches ``peak_force``: both are lines on the regression's
    abscissa beyond the record, so the failure's time (or step) is the fitted history's at
    that force."""
    _, _, anchor, slope = error
    if not math.isfinite(peak_force) or z.size == 0:
        return peak_force
    c0, c1 = _offset_and_slope(z, error)
    if not slope + c1 > 0:
        return math.inf
    return anchor + slope * (peak_force - anchor - c0) / (slope + c1)


def _peak_at(level, z, error):
    """The inverse of :func:`_on_fitted_history`: the true history's force [N] where the
    fitted one stands at ``level`` [N] beyond the record."""
    _, _, anchor, slope = error
    if z.size == 0:
        return level
    c0, c1 = _offset_and_slope(z, error)
    return anchor + c0 + (slope + c1) * (level - anchor) / slope


def _time_profile(likelihood, fit, error, level):
    """The profile over the force P [N] at which the fitted history stands when the layer
    fails: the failure's time (or step) is the fitted history's at P, so P's interval is the
    time's. Same likelihood and best fit as ``fit``, F_peak now a function of P and of the
    history's error."""

    def peak_of(level_p, z):
        return _peak_at(level_p, z, error)

    centre = _on_fitted_history(fit.peak_force, fit.nuisance, error)
    vector = fit.vector.copy()
    vector[3] = math.log(max(centre - likelihood.floor, 1e-300))
    best = (vector, fit.chisqr, fit.noise, fit.threshold)
    return fit_and_profile(dataclasses.replace(likelihood, peak_of=peak_of), level, best=best)


_STEP_MASS = 1e-4  # steps less likely than this end the staircase's table
_TABLE_STEPS = 1000  # at most this many steps are listed


def _confidence(fit, likelihood):
    """The confidence distribution of the profiled force P [N] (a function P -> [0, 1]): the
    distribution of the signed root of the profile's statistic, ``r = sign(P - P_best)
    sqrt(delta chi-square)``, interpolated linearly in P over the path, through the interval's
    ends (where it is the level's quantile) and extrapolated from its outermost two nodes.
    ``r`` is Student's t with the fit's degrees of freedom where the noise is estimated
    (the interval's statistic is then F(1, dof)), else standard normal. Above the path of a
    profile not bounded above, and everywhere for a path of fewer than two nodes, it
    returns NaN: the record does not say."""
    from scipy.stats import norm
    from scipy.stats import t as student

    nodes = {fit.peak_force: 0.0}
    for force, delta, *_ in fit.path:
        if math.isfinite(force) and math.isfinite(delta):
            nodes[force] = math.copysign(math.sqrt(max(delta, 0.0)), force - fit.peak_force)
    root = math.sqrt(fit.threshold)
    low, high = fit.interval
    if low > likelihood.floor:
        nodes[low] = -root
    if math.isfinite(high):
        nodes[high] = root
    force = np.array(sorted(nodes))
    signed = np.maximum.accumulate(np.array([nodes[f] for f in force]))
    if likelihood.noise is None:
        dof = max(likelihood.size - 4, 1)

        def cdf(r):
            return student.cdf(r, dof)
    else:
        cdf = norm.cdf

    def at(level):
        if force.size < 2:
            return math.nan  # no profile to read
        if level > force[-1] and not math.isfinite(high):
            return math.nan
        if level < force[0] or level > force[-1]:
            i = (0, 1) if level < force[0] else (-2, -1)
            run = force[i[1]] - force[i[0]]
            slope = (signed[i[1]] - signed[i[0]]) / run if run > 0 else 0.0
            if slope <= 0:
                return 0.0 if level < force[0] else 1.0
            return float(cdf(signed[i[0]] + slope * (level - force[i[0]])))
        return float(cdf(np.interp(level, force, signed)))

    return at


def _steps(timing, likelihood, loading, level):
    """The staircase's failure step by step, from the time profile ``timing`` (over the force
    P at which the fitted history stands when the layer fails): the layer fails at the start of
    the continued step j (level ``L_j = L_last + j step``, j = 1, 2, ...) when
    ``L_(j-1) < P <= L_j``, so that step's probability is ``C(L_j) - C(L_(j-1))`` with C the
    confidence distribution of P (:func:`_confidence`; the record has held ``L_last``, so
    the first step takes all the mass below its level).

    Returns ``(table, interval)``: the table {"step": number of the step, the record's first
    as 1; "level" [N]; "earliest", "latest": the range of its start [s]; "probability" [-];
    "below": the probability of the earlier steps (together less than ``_STEP_MASS``), left
    out; "beyond": the probability left above the last step listed, NaN where the record
    does not bound it}; the interval [s] is the smallest run of steps about the most likely
    ones whose probability reaches ``level``, open above where the record does not bound
    the failure; where the profile is open above, or the table's ``_TABLE_STEPS`` steps
    hold less than ``level``, it is the profile's own, from the step of its low end to that
    of its high end.
    """
    confidence = _confidence(timing, likelihood)
    last, step = loading.levels[-1], loading.step
    fallback = loading.times_at(*timing.interval)

    def reached(j):  # C is monotone in j: the steps before the first reached are left out
        cumulative = confidence(last + j * step)
        return math.isnan(cumulative) or cumulative >= _STEP_MASS

    before, first = 0, 1
    while not reached(first) and first < 2**40:
        before, first = first, 2 * first
    while first - before > 1:
        middle = (before + first) // 2
        before, first = (before, middle) if reached(middle) else (middle, first)
    below = confidence(last + before * step) if before > 0 else 0.0
    rows, held, beyond = [], below, math.nan
    for j in range(first, first + _TABLE_STEPS):
        cumulative = confidence(last + j * step)
        if math.isnan(cumulative):
            break  # above the path of a profile open above: the record does not say
        rows.append((len(loading.levels) + j, last + j * step, max(cumulative - held, 0.0)))
        held = max(held, cumulative)
        if 1.0 - held < _STEP_MASS:
            break
    if rows and not math.isnan(confidence(rows[-1][1] + step)):
        beyond = 1.0 - held
    earliest, latest = loading.step_starts(len(loading.levels) - 1 + first, len(rows))
    table = {
        "step": [row[0] for row in rows],
        "level": [row[1] for row in rows],
        "earliest": earliest.tolist(),
        "latest": latest.tolist(),
        "probability": [row[2] for row in rows],
        "below": float(below),
        "beyond": beyond,
    }
    probability = np.array(table["probability"])
    chosen = np.argsort(-probability, kind="stable")
    enough = np.flatnonzero(np.cumsum(probability[chosen]) >= level - 1e-12)
    if not enough.size or not math.isfinite(timing.interval[1]):
        # open above, or more steps likely than the table lists: the profile's own ends
        return table, fallback
    kept = chosen[: enough[0] + 1]
    best = loading.edge_range(timing.peak_force)
    low = min(table["earliest"][int(kept.min())], best[0])
    return table, (low, max(table["latest"][int(kept.max())], best[1]))


_AMPLITUDE_STARTS = (0.003, 0.01, 0.03)  # A over the quasi-static F_peak
_VELOCITY_STARTS = (-1.0, 0.0, 1.0)  # v_ref: the record's last velocity times exp(3 w)
_ALPHA_STARTS = (0.1, 0.3, 1.0, 3.0)  # alpha over the record's slip


def _forecast_creep(quasi_static, record, until, level, amplitude, prior):
    """The forecast with the direct effect (:mod:`granflow.forecast.creeping`), started from
    the quasi-static fit: v_ref at the record's last velocity (so that the lag of the
    friction behind the force vanishes there) and A at a few fractions of F_peak unless it
    is given."""
    time, slip_cut, loading, error = record
    scale = quasi_static.scale
    u_static, _ = _best(quasi_static, scale, False)
    peak_static = quasi_static.floor + math.exp(u_static[3])
    tail = max(time.size // 10, 3)
    slope = np.polyfit(time[-tail:], slip_cut[-tail:], 1)[0]
    velocity = max(float(slope), float(np.ptp(slip_cut)) / max(float(np.ptp(time)), 1e-300))
    fixed = amplitude is not None
    centre = (amplitude if fixed else 0.01 * peak_static, velocity, peak_static)
    likelihood = CreepLikelihood(
        time=time,
        slip=slip_cut,
        loading=loading,
        error=error,
        centre=centre,
        fixed_amplitude=fixed,
        floor=0.0,
        size=time.size,
        bounds=quasi_static.bounds,
        ceiling=quasi_static.floor,
        window=max((hi - lo for lo, hi in loading.windows), default=0.0),
        edges=staircase_edges(loading),
        prior=quasi_static.prior,
        prior_size=quasi_static.prior_size,
        noise=quasi_static.noise,
        scale=scale,
    )
    # the quasi-static best fit and a wider grid than its starts, at each amplitude and at
    # reference velocities about the last one
    held = np.maximum.accumulate(loading.force(time))
    grid, _ = _starts(held, np.maximum(slip_cut, 0.0), quasi_static.floor, _ALPHA_STARTS)
    starts = []
    for a, alpha, x0, peak_force in [(*np.exp(u_static[:3]), peak_static), *grid]:
        for factor in (0.01,) if fixed else _AMPLITUDE_STARTS:
            for shift in _VELOCITY_STARTS:
                u = np.concatenate([np.log([a, alpha, x0, peak_force]), np.zeros(6)])
                u[4] = math.log(factor / 0.01)
                u[5] = shift
                u[8:] = u_static[-2:]  # the offset's and the slope's (the last two)
                starts.append(u)
    fit, best = fit_creep(likelihood, starts, level)
    state = fit.params
    n_points = time.size
    held = quasi_static.floor
    if state.peak_force > 20.0 * held or not math.isfinite(state.failure_time):
        message = "the fitted creep shows no failure in sight: no sign of approaching failure"
        # the lower ends the record does give: F_peak's, and the failure times on its profile
        earliest = fit.along(lambda s: s.failure_time)[0]
        bound = fit.interval[0]
        return _no_date(until, level, loading, n_points, message, prior, bound, earliest)
    timed = timed_likelihood(likelihood, state, until)
    u_time = timed_vector(likelihood, best[0], state, until)
    timing, time_fit = profile_failure_time(timed, level, (u_time, *best[1:]))
    # the failure times along the strength's profile lie in the time's confidence set too,
    # and the strengths along the time's in the strength's: where one profile stalls (a
    # branch it cannot follow from its warm starts), the other widens it
    along = fit.along(lambda s: s.failure_time)
    interval = (min(timing[0], along[0]), max(timing[1], along[1]))
    along = time_fit.along(lambda s: s.peak_force)
    force_interval = (min(fit.interval[0], along[0]), max(fit.interval[1], along[1]))
    message = ""
    if math.isinf(interval[1]):
        message = "the record does not yet bound the failure from above"
    p = state.params
    return FailureForecast(
        time=state.failure_time,
        time_interval=interval,
        force=state.peak_force,
        force_interval=force_interval,
        slip=state.peak_slip - p.x0,
        slip_interval=fit.along(lambda s: s.peak_slip - s.params.x0),
        until=until,
        level=level,
        loading=loading,
        params={
            "a": p.a,
            "alpha": p.alpha,
            "Fd": p.Fd,
            "x0": p.x0,
            "A": state.amplitude,
            "v_ref": state.velocity,
        },
        noise=fit.noise,
        n_points=n_points,
        approaching=True,
        prior=None if prior is None else prior.to_dict(),
        message=message,
        method="model (creep)",
    )


def _check_prior(prior):
    if prior is None or isinstance(prior, Prior):
        return prior
    if isinstance(prior, dict):
        return Prior(**prior)
    raise InvalidDataError(f"prior must be a granflow.forecast.Prior or a mapping, got {prior!r}")


def forecast_failure(
    t: ArrayLike,
    slip: ArrayLike,
    force: ArrayLike,
    until: float | None = None,
    *,
    prior: Any = None,
    level: float = 0.9,
    noise: float | None = None,
    direct_effect: Any = None,
) -> FailureForecast:
    """Forecast when a layer under a rising imposed force fails, from its slip before ``until``.

    Quasi-static with the slip clock (SPEC §2): the layer creeps up the rising branch of F(x),
    ``x0 + slip(t) = F^-1(sigma(t))``, and fails when the imposed force sigma reaches F_peak.
    The force history is read from ``force`` (a ramp's line, or a staircase's levels) and
    continued beyond the cut. The interval is the profile likelihood's for F_peak (the other
    parameters re-fitted at each F_peak, the slip noise estimated from the residuals).

    The fitted history is itself uncertain (the force column is noisy), and the slip is very
    sensitive to it near the peak: an error of the history of a fraction of the force noise
    can shift the slip by as much as its noise. So the history's error, a line
    ``c0 + c1 u`` on the regression's abscissa (time, or step index) with the regression's
    covariance, enters the likelihood as two standard-normal nuisance coordinates, fitted
    and profiled with the others (errors in variables); the slip record then constrains the
    history too. (An irregular staircase, whose levels are each their own step's mean, has
    no such line: each level then has its own error coordinate, and the slope is the
    continuing step's, as uncertain as the record's step heights differ, which acts beyond
    the record only.) The failure time has its own profile, over
    the force at which the fitted history stands when the true history (fitted plus error)
    reaches F_peak: the time (or step) at which the fitted history reaches that force.
    Under a staircase the layer fails at the start of the first step that reaches F_peak,
    each start bounded by the samples between which the record's steps began (their
    regular spacing continued beyond the record). That outcome is discrete: the forecast gives
    each step beyond the record its probability (``steps``, from the confidence
    distribution of the force at failure, the signed root of its profile likelihood), and
    the time interval is the smallest run of whole steps about the most likely ones whose
    probability reaches ``level``. It holds the failure as often as its steps claim
    (``time_probability``), which is more than ``level`` once one step is nearly certain.

    Parameters
    ----------
    t : array_like
        Record time [s], 0 when loading starts, strictly increasing.
    slip : array_like
        Record slip (displacement) [m], 0 at the start (the model's x = x0 + slip).
    force : array_like
        Imposed force at ``t`` [N].
    until : float, optional
        The cut [s]: only points with ``t <= until`` are used; default the whole record.
    prior : Prior or mapping, optional
        Gaussian priors on a, alpha, Fd from other runs (:class:`~granflow.forecast.Prior`).
    level : float
        Level of the predictive intervals [-]; default 0.9.
    noise : float, optional
        Slip noise standard deviation [m]; default estimated from the fit's residuals.
    direct_effect : bool, float or DirectEffect, optional
        None (default): the quasi-static model above. Otherwise the layer creeps with the
        direct effect of :class:`granflow.DirectEffect`, ``dx/dt = 2 v_ref sinh(sigma/A)
        exp(-F(x)/A)``, and fails when it runs past the peak of F(x), at a continuous time
        even under a staircase, and below F_peak after a long enough hold (static fatigue):
        ``True`` fits the amplitude A [N], a float or ``DirectEffect(amplitude=A)`` holds it
        fixed; v_ref is fitted (:mod:`granflow.forecast.creeping`). ``force`` is then still
        the strength F_peak, which the force at failure exceeds under a fast ramp (the layer
        lags behind) and falls short of after a long hold. The history's error is handled
        as in the quasi-static model (two nuisance coordinates, fitted and profiled).

    Returns
    -------
    FailureForecast
        ``time``, ``time_interval`` [s], ``force``, ``force_interval`` [N], ``slip`` [m] ...;
        ``time`` is None with a ``message`` when the record shows no approaching failure.

    Raises
    ------
    granflow.InvalidDataError
        Non-finite values, time not increasing, or fewer than 12 points up to the cut.

    Examples
    --------
    >>> import numpy as np, granflow as gf
    >>> from granflow.forecast.synthetic import ramp_record
    >>> p = gf.Params(a=3.3e-3, alpha=5e4, Fd=11e-3, x0=0.3e-6)
    >>> t, slip, force, truth = ramp_record(p, rate=0.065e-3, noise=2e-9, seed=1)
    >>> ff = gf.forecast_failure(t, slip, force, until=0.9 * truth)
    >>> bool(ff.time_interval[0] <= truth <= ff.time_interval[1])
    True
    """
    amplitude = None if direct_effect is None else creep_amplitude(direct_effect)
    level = check.real_scalar(level, "level")
    if not 0 < level < 1:
        raise InvalidDataError(f"level must lie between 0 and 1, got {level:g}")
    prior = _check_prior(prior)
    time, cut, until = _inputs.record(t, {"slip": (slip, "m"), "force": (force, "N")}, until)
    if noise is not None:
        noise = check.positive(noise, "noise", "m")
    loading = fit_loading(time, cut["force"])
    if loading.rate <= 0:
        message = "the imposed force does not rise, so it never reaches the peak"
        return _no_date(until, level, loading, time.size, message, prior)
    held = np.maximum.accumulate(loading.force(time))
    slip_cut = cut["slip"]
    spread = 1.4826 * float(np.median(np.abs(np.diff(slip_cut)))) + 1e-300
    if float(np.ptp(slip_cut)) < 10.0 * spread:
        message = "the layer has not slipped beyond the noise: no sign of approaching failure"
        return _no_date(until, level, loading, time.size, message, prior)
    floor = float(held[-1])
    starts, total = _starts(held, np.maximum(slip_cut, 0.0), floor)
    error = _loading_error(loading, time, each_level=True)
    root, basis = error[0], error[1]
    base = loading.force(time)

    def residuals(params, s_peak, z):
        true = np.maximum.accumulate(base + basis @ (root @ z))
        return slip_cut - (branch_slip(true, params, s_peak) - params.x0)

    likelihood = Likelihood(
        residuals=residuals,
        floor=floor,
        starts=starts,
        bounds=((1e-4 * floor, 1e-3 / total, 1e-6 * total), (100 * floor, 1e3 / total, 10 * total)),
        size=time.size,
        prior=None if prior is None else prior.residuals,
        prior_size=0 if prior is None else len(prior.names),
        noise=noise,
        scale=_inputs.rough_noise(slip_cut),
        nuisance=root.shape[0],
    )
    if direct_effect is not None:
        return _forecast_creep(
            likelihood,
            (time, slip_cut, loading, _loading_error(loading, time)),
            until,
            level,
            amplitude,
            prior,
        )
    fit = fit_and_profile(likelihood, level)
    low, high = fit.interval
    message = ""
    if math.isinf(high):
        message = "the record does not yet bound the failure from above"
    if fit.peak_force > 0.99 * 20.0 * floor:
        message = (
            "the fitted peak lies beyond any plausible load: no sign of approaching failure "
            f"(not before {loading.times_at(low, low)[0]:.4g} s)"
        )
        return _no_date(until, level, loading, time.size, message, prior, bound=low)
    params = fit.params
    timing = _time_profile(likelihood, fit, error, level)
    from granflow.model.friction import peak

    def rise(p):
        return peak(p).slip - p.x0

    steps, interval = None, loading.times_at(*timing.interval)
    if loading.kind == "steps":
        steps, interval = _steps(timing, likelihood, loading, level)
    return FailureForecast(
        time=loading.time_at(timing.peak_force),
        time_interval=interval,
        force=fit.peak_force,
        force_interval=fit.interval,
        slip=rise(params),
        slip_interval=fit.along(rise),
        until=until,
        level=level,
        loading=loading,
        params={"a": params.a, "alpha": params.alpha, "Fd": params.Fd, "x0": params.x0},
        noise=fit.noise,
        n_points=time.size,
        approaching=True,
        prior=None if prior is None else prior.to_dict(),
        message=message,
        steps=steps,
    )
