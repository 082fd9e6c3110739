"""Uncertainties of a solved :class:`granflow.fitting.engine.Problem`: the covariance of its
free parameters and their 95 % profile-likelihood intervals.

The covariance is ``variance * (J^T J)^-1`` in natural units (the pseudo-inverse when J^T J is
singular, flagged). A profile interval's ends are where the minimum of chi-square over the
other parameters exceeds its minimum by ``3.84 * variance`` (the 95 % quantile of chi-square
with one degree of freedom); the root is found on sqrt(delta chi-square), nearly linear in the
optimiser's coordinate, by the secant method from the Wald estimate, or from hints by Newton's
steps on the profile's own slope (the search itself: :mod:`granflow.fitting.profile_search`).
"""

import math
from dataclasses import dataclass

import numpy as np
from scipy.stats import chi2 as chi2_distribution

from granflow.fitting.profile_search import Conditional, ProfilePoint, search_side

PROFILE_LEVEL = float(chi2_distribution.ppf(0.95, 1))  # 3.841...


def covariance(problem, values, variance, internal_hessian=None):
    """Covariance of the free global parameter values: variance * (J^T J)^-1 (natural units).

    ``internal_hessian`` (J^T J in the optimiser's coordinates at ``values``, as returned by
    :meth:`Problem.lm`) saves a pass over the data. Returns (covariance, ok); the
    pseudo-inverse is used when J^T J is singular (ok False).
    """
    if internal_hessian is None:
        _, _, hessian = problem.normal(values)
        hessian = hessian[np.ix_(problem.free, problem.free)]
    else:
        u = problem.internal(values)
        _, chain = problem.natural(u, problem.free)
        hessian = internal_hessian / np.outer(chain, chain)
    norms = np.sqrt(np.abs(np.diag(hessian)))
    norms[norms == 0] = 1.0
    scaled = hessian / np.outer(norms, norms)
    ok = bool(np.all(np.isfinite(scaled)))
    if ok and np.linalg.cond(scaled) < 1e14:
        inverse = np.linalg.inv(scaled)
    else:
        ok = False
        inverse = np.linalg.pinv(scaled) if np.all(np.isfinite(scaled)) else scaled * np.nan
    return variance * inverse / np.outer(norms, norms), ok


@dataclass(frozen=True)
class Profile:
    """A profile of one parameter scanned to one or more heights on each side.

    Attributes
    ----------
    index : int
        The profiled global parameter.
    optimum : ProfilePoint
        The best fit (delta 0).
    points : tuple of ProfilePoint
        Every conditional minimum evaluated, sorted by ``u``.
    ends : dict
        ``{-1: [...], +1: [...]}``: per side and per target height, the internal coordinate
        where sqrt(delta) reaches it, or the search range's end where it never does.
    reached : dict
        ``{-1: [...], +1: [...]}``: per side and target, whether the height was reached.
    end_offsets : dict or None
        ``{-1: [...], +1: [...]}``: per side and target, how far the others stood at the
        end from where the optimum's linear response puts them (natural units for a
        linear parameter, log for a log one; None where the search ran out): where the
        next scan of the record grown starts its others, the profile's shape changing far
        less between two such scans than its ends.
    """

    index: int
    optimum: ProfilePoint
    points: tuple
    ends: dict
    reached: dict
    end_offsets: dict | None = None

    def signed_roots(self):
        """(u, r) arrays over the points and the optimum, sorted by u: r = sign(u - u_hat)
        sqrt(delta). A profile is a minimum, and a conditional minimum that was not found
        can only lie too high; taken as unimodal, each side's delta is the lowest found at
        or beyond each point (its lower envelope outward), so r is non-decreasing."""
        u_hat = self.optimum.u
        lowest = {}
        for point in self.points:
            if math.isfinite(point.u) and not math.isnan(point.delta):
                lowest[point.u] = min(lowest.get(point.u, math.inf), point.delta)
        lowest[u_hat] = 0.0
        u = np.array(sorted(lowest))
        delta = np.array([lowest[v] for v in u])
        above = u > u_hat
        below = u < u_hat
        # outward: upward above the optimum, downward below it
        delta[above] = np.minimum.accumulate(delta[above][::-1])[::-1]
        delta[below] = np.minimum.accumulate(delta[below])
        r = np.sign(u - u_hat) * np.sqrt(np.maximum(delta, 0.0))
        keep = np.isfinite(r)
        return u[keep], r[keep]


def profile_scan(
    problem,
    values,
    index,
    chisqr_min,
    targets,
    wald_halfwidth_u,
    *,
    variance=1.0,
    internal_hessian=None,
    check=False,
    tolerance=None,
    starts=None,
    precision=2e-2,
    hints=None,
    damped=False,
    newton=False,
    hint_offsets=None,
    thorough=False,
):
    """Scan the profile likelihood of the global parameter ``index`` (free) on both sides of
    the optimum ``values`` to the heights ``targets`` of sqrt(delta chi-square / variance).

    Parameters
    ----------
    problem : Problem
        The solved problem.
    values : numpy.ndarray
        The optimum's global values [SI].
    index : int
        The profiled parameter.
    chisqr_min : float
        Chi-square at the optimum.
    targets : sequence of float
        Heights of the signed root to reach on each side, increasing (e.g. the two-sided
        level's quantile, then a tail quantile for a distribution).
    wald_halfwidth_u : float
        A first step [internal coordinate].
    variance : float
        The unit of delta chi-square (1 for standardised residuals).
    internal_hessian : numpy.ndarray, optional
        J^T J at the optimum in the optimiser's coordinates (saves a pass).
    check : bool
        Solve each point past a target from more starts (for likelihoods whose conditional
        minima a warm start can miss); the default is the warm start alone.
    tolerance : float, optional
        The precision of delta [variance units] the conditional minima need (their
        optimiser stops there); default a relative 1e-9 of chi-square.
    starts : callable, optional
        ``starts(value) -> iterable of global values``: more starts for a conditional minimum
        at the profiled parameter's ``value`` (a likelihood with several branches), tried
        where the warm starts jump (see :class:`~granflow.fitting.profile_search.Conditional`).
    precision : float
        How close to each target sqrt(delta) must come (2e-2: 0.5 % of the 95 % height).
    hints : dict, optional
        ``{-1: [...], 1: [...]}``: internal coordinates per side and target where each search
        looks first (a previous scan's :attr:`Profile.ends`, for a record that has grown).
    damped : bool
        Where Gauss-Newton's full steps fail, restart Levenberg-Marquardt from the predicted
        start rather than from where Gauss-Newton stopped (for likelihoods curved too much
        for full steps, where that point may lie far off).
    hint_offsets : dict, optional
        ``{-1: [...], 1: [...]}``: per side and target (or None), where the others start at
        each hint (a previous scan's :attr:`Profile.end_offsets`).
    newton : bool
        Step to each target by Newton's method on the profile's own slope, which the
        envelope theorem gives at each conditional minimum from its last pass (see
        :meth:`~granflow.fitting.engine.Problem.gauss_newton`), and end the search from a
        point within a tenth of the target whose quadratic model is sure to the
        precision: the end is then a point of the profile, delta its target and the others
        moved by Gauss-Newton's response (the model's curvature term there within 5 times
        the precision). Fewer conditional minima where good hints put the first point
        near the end (a running forecast); the default is the secant search.
    thorough : bool
        Also solve each point whose delta is past half its target's (sqrt(delta) past 0.71
        of the target: where the ends are sought) from the best-ranked of ``starts`` and of
        the others of the last 12 points found (on either side), and restart a jump from
        those points too (for likelihoods whose other branches the warm starts miss
        short of a jump: a creeping staircase's failure time pinned across a step's edge).

    Returns
    -------
    Profile
    """
    solved = (problem, values, index, variance, chisqr_min, internal_hessian, tolerance)
    conditional = Conditional(*solved, starts, damped, newton, thorough)
    record = []
    ends, reached, end_offsets = {}, {}, {}
    step = max(wald_halfwidth_u, 1e-8)
    for direction in (-1, 1):
        ends[direction], reached[direction], end_offsets[direction] = search_side(
            conditional,
            direction,
            list(targets),
            step,
            record,
            check,
            precision,
            () if hints is None else hints.get(direction, ()),
            damped,
            () if hint_offsets is None else hint_offsets.get(direction, ()),
        )
    optimum = ProfilePoint(
        conditional.u_hat, float(values[index]), 0.0, np.asarray(values, dtype=float)
    )
    points = tuple(sorted(record, key=lambda p: p.u))
    return Profile(index, optimum, points, ends, reached, end_offsets)


def profile_interval(
    problem,
    values,
    index,
    variance,
    chisqr_min,
    wald_halfwidth_u,
    internal_hessian=None,
    *,
    threshold=PROFILE_LEVEL,
):
    """95 % profile-likelihood interval of the global parameter ``index`` (free).

    The boundary is where min over the other parameters of chi-square exceeds its minimum by
    ``threshold * variance`` (default 3.84, the 95 % quantile of chi-square with one degree of
    freedom). The root is found on sqrt(delta chi-square), which is nearly linear in the
    internal coordinate, by the secant method from the Wald estimate.
    Returns ((low, high), exact) with exact False when a side ran into a bound.
    """
    parameter = problem.parameters[index]
    profile = profile_scan(
        problem,
        values,
        index,
        chisqr_min,
        (math.sqrt(threshold),),
        wald_halfwidth_u,
        variance=variance,
        internal_hessian=internal_hessian,
    )
    low_u, high_u = profile.ends[-1][0], profile.ends[1][0]
    exact = profile.reached[-1][0] and profile.reached[1][0]
    low = parameter.from_internal(low_u) if math.isfinite(low_u) else low_u
    high = parameter.from_internal(high_u) if math.isfinite(high_u) else high_u
    if parameter.log and not math.isfinite(low):
        low = 0.0
    return (float(low), float(high)), exact
