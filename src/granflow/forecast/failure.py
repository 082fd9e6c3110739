"""Forecast the failure of a force-controlled layer from its slow slip (quasi-static, slip
clock): the slip record before the cut constrains the rising branch of F(x), and the layer
fails when the continued force history reaches F_peak.

The likelihood is the engine's (:func:`granflow.forecast.models.branch_problem`), in the
peak coordinates (:mod:`granflow.forecast.coordinates`); F_peak's distribution is its
profile's, and the failure time's is the profile of P, the force at which the fitted history
stands when the true one reaches F_peak (:class:`~granflow.forecast.models.Continuation`).
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from granflow import _validate as check
from granflow.errors import InvalidDataError
from granflow.fitting.results import FrozenMap
from granflow.forecast import _inputs
from granflow.forecast.branch import branch_values
from granflow.forecast.coordinates import natural
from granflow.forecast.discrepancy import review
from granflow.forecast.inference import data_chisqr, estimate, scan
from granflow.forecast.loading import fit_loading
from granflow.forecast.models import Continuation, branch_problem, group_points, projects
from granflow.forecast.observed import find_failure
from granflow.forecast.prior import Prior
from granflow.forecast.results import FailureForecast
from granflow.forecast.steps import step_cdf, step_table
from granflow.model.params import Params

if TYPE_CHECKING:
    from granflow._typing import ArrayLike
    from granflow.forecast.results import FailureForecast

__all__ = [
    "Warm",
    "check_level",
    "check_prior",
    "forecast_failure",
    "loading_error",
    "no_date",
    "observed_dict",
    "quasi_static",
    "sigma_argument",
    "warm_forecast",
]

_NAN_PAIR = (math.nan, math.nan)
_RATIOS = (0.3, 0.7, 0.9, 0.98, 0.995)
_INITIAL_STATES = (1e-3, 1e-2, 1e-1)
_PEAK_FACTORS = (1.05, 1.3, 2.0)
_RANKED = 256  # groups used to scale the starts
#: The trend test's p-value above which the record says nothing yet.
NO_TREND = 0.01


def check_prior(prior):
    """A :class:`Prior` from a Prior, a mapping or None."""
    if prior is None or isinstance(prior, Prior):
        return prior
    if isinstance(prior, dict):
        return Prior(**prior)
    raise InvalidDataError(f"prior must be a granflow.forecast.Prior or a mapping, got {prior!r}")


def check_level(level):
    """The confidence level, checked: a number strictly between 0 and 1."""
    level = check.real_scalar(level, "level")
    if not 0 < level < 1:
        raise InvalidDataError(f"level must lie between 0 and 1, got {level:g}")
    return level


def sigma_argument(sigma, noise, unit):
    """The noise level from ``sigma=`` or from the deprecated ``noise=`` (with a warning that
    names ``sigma``); None where neither is given."""
    if noise is not None:
        warnings.warn(
            "the forecasts' noise= is deprecated: pass sigma= (the same standard deviation, "
            "as the fits take it)",
            DeprecationWarning,
            stacklevel=3,
        )
        if sigma is not None:
            raise InvalidDataError("give sigma= or its old name noise=, not both")
        sigma = noise
    return None if sigma is None else check.positive(sigma, "sigma", unit)


def loading_error(loading, time, each_level=False):
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


def no_date(until, level, loading, n_points, message, prior, observed=None, bound=None):
    """A :class:`FailureForecast` without a date; ``bound`` (a force [N]) keeps the lower end
    the record does give: the layer has held the force so far, so it fails no earlier."""
    interval = _NAN_PAIR
    if bound is not None:
        interval = (loading.times_at(bound, math.inf)[0], math.inf)
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
        params=FrozenMap(),
        sigma=math.nan,
        n_points=n_points,
        approaching=False,
        prior=None if prior is None else prior.to_dict(),
        message=message,
        cdf={"time": [], "probability": []},
        observed_failure=None if observed is None else observed.time,
        observed=None if observed is None else observed_dict(observed),
    )


def observed_dict(observed):
    """An :class:`~granflow.forecast.observed.ObservedFailure` as the forecast stores it."""
    return {"window": list(observed.window), "force": observed.force, "index": observed.index}


def _starts(groups, floor, m, project):
    """Starting slot values (gap, ratio, s0[, x_peak], z = 0) over a grid of the curve's
    shape and F_peak. The slip scales with x_peak at fixed F_peak, ratio and s0, so each
    start takes the x_peak that fits the record best (a linear least-squares scale), which
    the projected model finds itself."""
    stride = max(groups.base.size // _RANKED, 1)
    base = np.ascontiguousarray(groups.base[::stride])
    weight = groups.count[::stride]
    data = groups.mean[::stride]
    unit = np.empty(base.size)
    scratch = np.empty((base.size, 4))
    transform = np.empty((4, 4))
    starts = []
    for factor in _PEAK_FACTORS:
        peak_force = floor * factor
        for ratio in _RATIOS:
            for s0 in _INITIAL_STATES:
                a, alpha, fd, x0, _ = natural(peak_force, ratio, s0, 1.0, transform)
                if not math.isfinite(alpha):
                    continue
                start = [peak_force - floor, ratio, s0]
                if not project:
                    branch_values(
                        base,
                        np.zeros((base.size, 0)),
                        np.zeros(0),
                        (a, alpha, fd, x0),
                        (peak_force, 1.0),
                        transform,
                        unit,
                        scratch,
                    )
                    norm = float(np.sum(weight * unit * unit))
                    x_peak = float(np.sum(weight * unit * data)) / norm if norm > 0 else 0.0
                    if not (math.isfinite(x_peak) and x_peak > 0):
                        continue
                    start.append(x_peak)
                starts.append(start + [0.0] * m)
    return starts


def forecast_failure(
    t: ArrayLike,
    slip: ArrayLike,
    force: ArrayLike,
    until: float | None = None,
    *,
    prior: Any = None,
    level: float = 0.9,
    sigma: float | None = None,
    direct_effect: Any = None,
    noise: float | None = None,
) -> FailureForecast:
    """Forecast when a layer under a rising imposed force fails, from its slip before ``until``.

    Quasi-static with the slip clock (SPEC §2): the layer creeps up the rising branch of F(x),
    ``x0 + slip(t) = F^-1(sigma(t))``, and fails when the imposed force sigma reaches F_peak.
    The force history is read from ``force`` (a ramp's line, or a staircase's levels) and
    continued beyond the cut. F_peak's distribution is its profile likelihood's (the other
    parameters re-fitted at each F_peak, the slip noise estimated from the residuals: Student's
    t), and every interval, probability and step probability of the forecast comes from it.

    The fitted history is itself uncertain (the force column is noisy), and the slip is very
    sensitive to it near the peak. So the history's error, a line ``c0 + c1 u`` on the
    regression's abscissa (time, or step index) with the regression's covariance, enters the
    likelihood as standard-normal nuisance coordinates, fitted and profiled with the others
    (errors in variables). (An irregular staircase, whose levels are each their own step's
    mean, has no such line: each level then has its own coordinate, and the slope is the
    continuing step's, as uncertain as the record's step heights differ.) The failure time
    has its own profile, over the force at which the fitted history stands when the true
    history reaches F_peak.

    Under a staircase the layer fails at the start of the first step that reaches F_peak,
    each start bounded by the samples between which the record's steps began (their regular
    spacing continued beyond the record): the forecast gives each step beyond the record its
    probability (``steps``), and the time interval is the smallest run of whole steps about
    the most likely ones whose probability reaches ``level``.

    A record that already shows its failure (the slip running away: see
    :mod:`granflow.forecast.observed`) says so: ``observed_failure`` is its time, and the
    forecast uses the samples before it only (``until`` is cut there).

    Parameters
    ----------
    t : array_like
        Record time [s], 0 when loading starts, strictly increasing.
    slip : array_like
        Record slip (displacement) [m], 0 at the start (the model's x = x0 + slip); a
        record whose start stands off zero (more than five times its noise) does not
        follow the model, and its forecast says so.
    force : array_like
        Imposed force at ``t`` [N].
    until : float, optional
        The cut [s]: only points with ``t <= until`` are used; default the whole record (or,
        where it shows its failure, up to the last sample before it).
    prior : Prior or mapping, optional
        Gaussian priors on a, alpha, Fd from other runs (:class:`~granflow.forecast.Prior`).
    level : float
        Level of the predictive intervals [-]; default 0.9.
    sigma : float, optional
        Slip noise standard deviation [m]; default estimated from the fit's residuals.
    direct_effect : bool, float or DirectEffect, optional
        None (default): the quasi-static model above. Otherwise the layer creeps with the
        direct effect of :class:`granflow.DirectEffect` (:mod:`granflow.forecast.creeping`):
        ``True`` fits the amplitude A [N], a float or ``DirectEffect(amplitude=A)`` holds it.
    noise : float, optional
        Deprecated name of ``sigma``.

    Returns
    -------
    FailureForecast
        ``time``, ``time_interval`` [s], ``force``, ``force_interval`` [N], ``slip`` [m],
        ``probability_within(seconds)``; ``time`` is None with a ``message`` when the record
        shows no approaching failure.

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
    from granflow.forecast.creep_model import creep_amplitude

    amplitude = None if direct_effect is None else creep_amplitude(direct_effect)
    level = check_level(level)
    prior = check_prior(prior)
    sigma = sigma_argument(sigma, noise, "m")
    record = _prepared(t, slip, force, until)
    time, slip_cut, loading, until, observed, message = record
    if loading.rate <= 0:
        text = "the imposed force does not rise, so it never reaches the peak"
        return no_date(until, level, loading, time.size, text, prior, observed)
    if direct_effect is not None:
        from granflow.forecast.creeping import forecast_creep

        return forecast_creep(
            time, slip_cut, loading, until, level, amplitude, prior, sigma, observed, message
        )
    return quasi_static(time, slip_cut, loading, until, level, prior, sigma, observed, message)[0]


def _prepared(t, slip, force, until):
    """(time, slip, loading, until, observed failure, message) of a record: checked, cut at
    ``until``, and where it shows its failure cut before it."""
    whole, columns, _ = _inputs.record(t, {"slip": (slip, "m"), "force": (force, "N")}, None)
    observed = find_failure(whole, columns["slip"], columns["force"])
    message = ""
    if observed is not None:
        last = float(whole[observed.index])
        if until is None or check.real_scalar(until, "until", "s") > last:
            if until is not None:
                message = (
                    f"the record fails at {observed.time:.4g} s: forecast from the samples "
                    f"before it (up to {last:.4g} s), not up to until = {float(until):.4g} s"
                )
            until = last
    time, cut, until = _inputs.record(
        whole, {"slip": (columns["slip"], "m"), "force": (columns["force"], "N")}, until
    )
    return time, cut["slip"], fit_loading(time, cut["force"]), until, observed, message


def warm_forecast(t, slip, force, *, prior=None, level=0.9, sigma=None, warm=None):
    """The quasi-static :func:`forecast_failure` of a whole record, warm-started from the
    :class:`Warm` state of its forecast before it grew; ``(forecast, warm state)`` (the
    state None where there was no fit)."""
    level = check_level(level)
    prior = check_prior(prior)
    sigma = sigma_argument(sigma, None, "m")
    time, slip_cut, loading, until, observed, message = _prepared(t, slip, force, None)
    if loading.rate <= 0:
        text = "the imposed force does not rise, so it never reaches the peak"
        return no_date(until, level, loading, time.size, text, prior, observed), None
    return quasi_static(
        time, slip_cut, loading, until, level, prior, sigma, observed, message, warm
    )


def _trend_test(fit, groups):
    """The p-value of the fitted rising branch against a slip that does not move (a
    constant): an F test of the data's chi-square, 3 parameters more, ``n - 4`` degrees of
    freedom (the normal's chi-square where the noise was given)."""
    from scipy.special import chdtrc, fdtrc

    weights = groups.count / fit.sigma**2
    mean = float(np.sum(weights * groups.mean) / np.sum(weights))
    within = groups.within / fit.sigma**2
    flat = float(np.sum(weights * (groups.mean - mean) ** 2)) + within
    fitted = data_chisqr(fit.problem, fit.values) + within
    gain = max(flat - fitted, 0.0)
    if fit.dof is None:
        return float(chdtrc(3, gain))
    return float(fdtrc(3, fit.dof, (gain / 3.0) / max(fitted / fit.dof, 1e-300)))


@dataclass(frozen=True)
class Warm:
    """What a quasi-static forecast leaves for the forecast of the same record grown (a
    :class:`~granflow.forecast.running.RunningForecast`'s next update): its two optima and
    its profiles' ends, valid while the slots stay the same (``layout``), and the
    likelihood's other minima within reach (followed too: the best of them is the
    optimum)."""

    layout: tuple
    first: np.ndarray
    values: np.ndarray
    force_ends: dict
    time_ends: dict
    others: tuple = ()


def _branch(time, slip_cut, loading, prior, sigma, tries=None, warm=None):
    """(fit, build, groups, floor, continuation, shape) of the quasi-static model of a
    record: the engine's best fit (:func:`~granflow.forecast.inference.estimate`) and the
    pieces to rebuild its problem, in the strength's or the time's coordinates; ``warm``
    (a :class:`Warm` of the same layout) starts the fit from its optima."""
    root, basis, anchor, slope = loading_error(loading, time, each_level=True)
    base = loading.force(time)
    groups = group_points(base, basis @ root, slip_cut)
    floor = float(np.max(base))
    m = root.shape[1]
    continuation = Continuation(anchor, slope, root[-2].copy(), root[-1].copy())
    project = projects(prior)
    shape = 3 if project else 4

    def build(noise, values, timed=False):
        return branch_problem(
            groups,
            floor,
            noise,
            values,
            prior=prior,
            continuation=continuation if timed else None,
        )

    fit = estimate(
        lambda noise, values: build(noise, values)[0],
        _starts(groups, floor, m, project),
        size=groups.size,
        within=groups.within,
        sigma=sigma,
        rough=_inputs.rough_noise(slip_cut),
        nuisance=shape,
        tries=tries,
        warm=None if warm is None else (warm.first, warm.values, warm.others),
        branch=1,
    )
    return fit, build, groups, floor, continuation, shape


def quasi_static_fit(time, slip_cut, loading, prior, sigma):
    """((F_peak [N], r, s0), x_peak [m], trend p-value) of the quasi-static model's best fit
    to a record (the creep forecast's first start; from its two best starts only, since a
    creeping record does not follow it to its noise; the p-value of :func:`_trend_test`)."""
    fit, build, groups, floor, _, _ = _branch(time, slip_cut, loading, prior, sigma, tries=2)
    found = build(fit.sigma, fit.values)[1](fit.values)[2]
    peak_slip = found[1][1] if found is not None else max(float(np.ptp(slip_cut)), 1e-12)
    shape = (floor + fit.values[0], fit.values[1], fit.values[2])
    return shape, peak_slip, _trend_test(fit, groups)


def _layout(loading, time, prior):
    """The slots' layout of a record's quasi-static problem: warm starts carry over while
    it stays the same."""
    root = loading_error(loading, time, each_level=True)[0]
    return (loading.kind, loading.on_line, root.shape[1], projects(prior))


def quasi_static(time, slip_cut, loading, until, level, prior, sigma, observed, message, warm=None):
    """The quasi-static forecast of a checked record cut at ``until``, and the :class:`Warm`
    state it leaves (None without a fit); ``warm`` is the previous one's, of the same
    record before it grew."""
    layout = _layout(loading, time, prior)
    if warm is not None and warm.layout != layout:
        warm = None
    fit, build, groups, floor, continuation, shape = _branch(
        time, slip_cut, loading, prior, sigma, warm=warm
    )
    values = fit.values
    curve = build(fit.sigma, values)[1]
    trend = _trend_test(fit, groups)
    if trend > NO_TREND:
        text = (
            "the layer has not slipped beyond the noise (the slip's trend against none: "
            f"p = {trend:.2g}): no information on the failure yet"
        )
        forecast = no_date(until, level, loading, time.size, text, prior, observed, bound=floor)
        return review(forecast, fit, time, slip_cut), Warm(
            layout, fit.first, values, {}, {}, fit.others
        )

    def shapes(gap):
        """More starts at a gap (the shape grid, the nuisance at its optimum)."""
        return [
            [gap, ratio, s0, *values[3:shape], *values[shape:]]
            for ratio in _RATIOS
            for s0 in _INITIAL_STATES
        ]

    force_profile, strength = scan(
        fit, 0, level, offset=floor, starts=shapes, hints=None if warm is None else warm.force_ends
    )

    # the time: the same likelihood with P (the fitted history's force at failure) for F_peak
    def timed_slots(slots):
        out = np.array(slots, dtype=float)
        level_p = continuation.level(floor + slots[0], slots[shape:])
        out[0] = max(level_p - floor, 1e-9 * floor) if math.isfinite(level_p) else 99.0 * floor
        return out

    timed = timed_slots(values)
    time_problem = build(fit.sigma, timed, timed=True)[0]
    time_profile, timing = scan(
        fit,
        0,
        level,
        offset=floor,
        problem=time_problem,
        values=timed,
        starts=shapes,
        hints=None if warm is None else warm.time_ends,
        others=[timed_slots(other) for other in fit.others],
    )
    force_interval = strength.interval(level)
    level_interval = timing.interval(level)
    steps = None
    if loading.kind == "steps":
        steps, time_interval = step_table(timing, loading, level)
        cdf_time, cdf_probability = step_cdf(steps)
    else:
        time_interval = loading.times_at(*level_interval)
        nodes, probabilities = timing.table()
        cdf_time = [loading.time_at(q) for q in nodes]
        cdf_probability = probabilities
    median = timing.median()
    approaching = math.isfinite(median)
    if not approaching:
        message = message or "the record does not yet bound the failure: no date"
    elif math.isinf(time_interval[1]):
        message = message or "the record does not yet bound the failure from above"
    best = curve(values)[2]
    params = None if best is None else Params(*best[0])
    slips = [] if best is None else [best[1][1] - params.x0]
    for point in force_profile.points:
        if force_interval[0] <= floor + point.value <= force_interval[1]:
            found = curve(point.values)[2]
            if found is not None:
                slips.append(found[1][1] - found[0][3])
    slip_interval = (min(slips), max(slips)) if slips else _NAN_PAIR
    if math.isinf(force_interval[1]):
        slip_interval = (slip_interval[0], math.inf)
    forecast = FailureForecast(
        time=loading.time_at(median) if approaching else None,
        time_interval=time_interval,
        force=floor + values[0] if approaching else None,
        force_interval=force_interval,
        slip=slips[0] if approaching and slips else None,
        slip_interval=slip_interval,
        until=until,
        level=level,
        loading=loading,
        params=FrozenMap(
            {} if params is None else {n: getattr(params, n) for n in ("a", "alpha", "Fd", "x0")}
        ),
        sigma=fit.sigma,
        n_points=time.size,
        approaching=approaching,
        prior=None if prior is None else prior.to_dict(),
        message=message,
        steps=steps,
        cdf={"time": [float(v) for v in cdf_time], "probability": list(cdf_probability)},
        observed_failure=None if observed is None else observed.time,
        observed=None if observed is None else observed_dict(observed),
    )
    left = Warm(
        layout,
        fit.first,
        values,
        _absolute(force_profile, floor),
        _absolute(time_profile, floor),
        fit.others,
    )
    return review(forecast, fit, time, slip_cut), left


#: exp(u) overflows beyond this: an end that far out is no hint.
_EXP_LIMIT = 700.0


def _absolute(profile, floor):
    """A profile's ends as the profiled quantity's values [N] (their internal coordinates
    depend on the problem's scales): the hints of the next scan, converted back there."""
    parameter = profile.optimum
    scale = parameter.value
    return {
        side: [
            floor + scale * math.exp(u) if math.isfinite(u) and u < _EXP_LIMIT else math.nan
            for u in ends
        ]
        for side, ends in profile.ends.items()
    }
