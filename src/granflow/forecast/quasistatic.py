"""The quasi-static forecast of a checked record (slip clock): the best fit of the rising
branch of F(x) to the slip before the cut, its trend test, and the profiles of F_peak and of
the failure time, with the warm state a running forecast carries from one update to the next.

:func:`granflow.forecast.failure.forecast_failure` checks the record and calls
:func:`quasi_static` (or, with a direct effect, the creep forecast of
:mod:`granflow.forecast.creeping`, which starts from :func:`quasi_static_fit`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from granflow.fitting.results import FrozenMap
from granflow.forecast import _inputs
from granflow.forecast.branch import branch_values
from granflow.forecast.coordinates import natural
from granflow.forecast.discrepancy import reviewed
from granflow.forecast.inference import (
    data_chisqr,
    distribution_of,
    estimate,
    scan,
    with_points,
)
from granflow.forecast.loading import continuing_growth
from granflow.forecast.models import Continuation, branch_problem, group_points, projects
from granflow.forecast.results import FailureForecast
from granflow.forecast.steps import step_cdf, step_table
from granflow.model.params import Params

__all__ = [
    "NO_TREND",
    "Warm",
    "loading_error",
    "no_date",
    "observed_dict",
    "quasi_static",
    "quasi_static_fit",
]

_NAN_PAIR = (math.nan, math.nan)
_RATIOS = (0.3, 0.7, 0.9, 0.98, 0.995)
_INITIAL_STATES = (1e-3, 1e-2, 1e-1)
_PEAK_FACTORS = (1.05, 1.3, 2.0)
_RANKED = 256  # groups used to scale the starts
_RUNNING_PEAK_REACH = 3e-2  # relative: a running scan's end from its last evaluation, for x_peak
#: The trend test's p-value above which the record says nothing yet.
NO_TREND = 0.01


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
    optimum); the power law's exponents at its leads (the review's, ``exponents``); the
    number of points it saw (``size``) and what the forecast before it left (``before``:
    ``(size, force_ends, time_ends, exponents)``), from which the next scans' hints and
    the next review's expected exponents are drawn; each profile's
    :attr:`~granflow.fitting.profile.Profile.end_offsets` (``starts``, by ``"force_ends"``
    and ``"time_ends"``), where the next scans' others start; and the largest force the
    record held (``floor`` [N]), by which the next fit's gap slot moves."""

    layout: tuple
    first: np.ndarray
    values: np.ndarray
    force_ends: dict
    time_ends: dict
    others: tuple = ()
    exponents: np.ndarray | None = None
    size: int = 0
    before: tuple | None = None
    starts: dict | None = None
    floor: float = math.nan

    def moved(self, floor):
        """``(first, values, others)``: the two optima as starts for the record grown, whose
        largest held force is now ``floor`` [N] (the gap slot, F_peak less the floor, less
        what the floor rose: F_peak staying put, where the gap stays positive), and the other
        minima as they were (each is solved again from there, and lands where it lands)."""
        rise = floor - self.floor if math.isfinite(self.floor) else 0.0

        def shifted(slots):
            out = np.array(slots, dtype=float)
            if out[0] - rise > 0:
                out[0] -= rise
            return out

        return shifted(self.first), shifted(self.values), self.others

    def offsets(self, which):
        """Where the others start at each hint of the profile ``which`` (``"force_ends"`` or
        ``"time_ends"``): its :attr:`~granflow.fitting.profile.Profile.end_offsets` (None
        where unknown)."""
        return (self.starts or {}).get(which)

    def hints(self, size, which, floor, gap):
        """The ends ``which`` (``"force_ends"`` or ``"time_ends"``) where the scans of the
        record grown to ``size`` points look first, as values [N] about its new optimum
        (``floor + gap`` [N]): each end kept where it stood relative to the optimum (the
        profile's own coordinate, the log of the gap over the optimum's: the optimum moves
        with each new point far more than the profile's shape about it does), and moved on
        as it moved since the forecast before, in proportion to the points added."""
        ends = getattr(self, which)
        earlier = {}
        ratio = 0.0
        if self.before is not None and self.size > self.before[0]:
            size_before, force_before, time_before, _ = self.before
            earlier = force_before if which == "force_ends" else time_before
            ratio = (size - self.size) / (self.size - size_before)
        out = {}
        for side, values in ends.items():
            old = list(earlier.get(side, ()))
            moved = [
                u + ratio * (u - old[k]) if k < len(old) and math.isfinite(u - old[k]) else u
                for k, u in enumerate(values)
            ]
            out[side] = [
                floor + gap * math.exp(u) if math.isfinite(u) and u < _EXP_LIMIT else math.nan
                for u in moved
            ]
        return out

    def near(self, size):
        """The power law's exponents expected at each lead of the review
        (:func:`~granflow.forecast.references.power_law_least`) of the record grown to
        ``size`` points: the last ones moved on (in ln p) as they moved since the review
        before, in proportion to the points added; None where there are none."""
        if self.exponents is None:
            return None
        before = None if self.before is None else self.before[3]
        if before is None or not self.size > self.before[0]:
            return self.exponents
        ratio = (size - self.size) / (self.size - self.before[0])
        log_now, log_before = np.log(self.exponents), np.log(before)
        return np.exp(log_now + ratio * (log_now - log_before))


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
    continuation = Continuation(
        anchor, slope, root[-2].copy(), root[-1].copy(), continuing_growth(loading)
    )
    project = projects(prior)
    shape = 3 if project else 4

    curves = {}  # one curve per variant, whatever the noise: its evaluations carry over

    def build(noise, values, timed=False):
        problem, curve = branch_problem(
            groups,
            floor,
            noise,
            values,
            prior=prior,
            continuation=continuation if timed else None,
            curve=curves.get(timed),
        )
        curves[timed] = curve
        return problem, curve

    fit = estimate(
        lambda noise, values: build(noise, values)[0],
        _starts(groups, floor, m, project),
        size=groups.size,
        within=groups.within,
        sigma=sigma,
        rough=_inputs.rough_noise(slip_cut),
        nuisance=shape,
        tries=tries,
        warm=None if warm is None else warm.moved(floor),
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
    near = None if warm is None else warm.near(time.size)
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
        forecast, exponents = reviewed(forecast, fit, time, slip_cut, near=near)
        left = Warm(
            layout, fit.first, values, {}, {}, fit.others, exponents, time.size, floor=floor
        )
        return forecast, left

    def shapes(gap):
        """More starts at a gap (the shape grid, the nuisance at its optimum)."""
        return [
            [gap, ratio, s0, *values[3:shape], *values[shape:]]
            for ratio in _RATIOS
            for s0 in _INITIAL_STATES
        ]

    force_profile, strength = scan(
        fit,
        0,
        level,
        offset=floor,
        starts=shapes,
        hints=None if warm is None else warm.hints(time.size, "force_ends", floor, values[0]),
        hint_offsets=None if warm is None else warm.offsets("force_ends"),
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
        hints=None if warm is None else warm.hints(time.size, "time_ends", floor, timed[0]),
        hint_offsets=None if warm is None else warm.offsets("time_ends"),
        others=[timed_slots(other) for other in fit.others],
    )
    # one likelihood, two profiles: each takes the other's points (its conditional fits can
    # miss a branch the other found), so that the strength and the time agree
    scanned = force_profile.points
    force_profile, strength, time_profile, timing = _exchanged(
        fit, time_problem, force_profile, time_profile, floor, continuation, shape
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
    best = curve.found(values)
    params = None if best is None else Params(*best[0])
    slips = [] if best is None else [best[1][1] - params.x0]
    # the strength's own points (the time's would each cost a pass); a running forecast's
    # scans end on points a Newton step from their last evaluation (see profile_scan)
    reach = _RUNNING_PEAK_REACH if warm is not None else 1e-3
    for point in scanned:
        if force_interval[0] <= floor + point.value <= force_interval[1]:
            found = curve.peak_at(point.values, reach)
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
    forecast, exponents = reviewed(forecast, fit, time, slip_cut, near=near)
    left = Warm(
        layout,
        fit.first,
        values,
        _relative(force_profile),
        _relative(time_profile),
        fit.others,
        exponents,
        time.size,
        None if warm is None else (warm.size, warm.force_ends, warm.time_ends, warm.exponents),
        {"force_ends": force_profile.end_offsets, "time_ends": time_profile.end_offsets},
        floor,
    )
    return forecast, left


def _exchanged(fit, time_problem, force_profile, time_profile, floor, continuation, shape):
    """``(force_profile, strength, time_profile, timing)``: each profile with the other's
    points (:func:`~granflow.forecast.inference.with_points`), F_peak's gap and P's
    converted through the continuation (``F_peak = P + c0 + c1 g(...)`` and its inverse,
    exact: the same curve, the same chi-square), and their distributions rebuilt. A point
    whose P the continuation never reaches (it does not rise) is left out."""

    def to_time(values):
        level_p = continuation.level(floor + values[0], values[shape:])
        if not math.isfinite(level_p):
            return None
        out = np.array(values, dtype=float)
        out[0] = level_p - floor
        return out

    def to_force(values):
        out = np.array(values, dtype=float)
        out[0] = continuation.peak_force(floor + values[0], values[shape:])[0] - floor
        return out

    def converted(points, convert):
        pairs = ((convert(p.values), p.delta) for p in points)
        return [(values, delta) for values, delta in pairs if values is not None]

    force_parameter = fit.problem.parameters[0]
    time_parameter = time_problem.parameters[0]
    from_force = converted(force_profile.points, to_time)
    from_time = converted(time_profile.points, to_force)
    force_profile = with_points(force_profile, force_parameter, 0, from_time)
    time_profile = with_points(time_profile, time_parameter, 0, from_force)
    return (
        force_profile,
        distribution_of(force_profile, force_parameter, floor, fit.dof),
        time_profile,
        distribution_of(time_profile, time_parameter, floor, fit.dof),
    )


#: exp(u) overflows beyond this: an end that far out is no hint.
_EXP_LIMIT = 700.0


def _relative(profile):
    """A profile's ends in its own coordinate (the log of the gap over the optimum's), which
    the next scan's hints start from (:meth:`Warm.hints`)."""
    return {side: [float(u) for u in ends] for side, ends in profile.ends.items()}
