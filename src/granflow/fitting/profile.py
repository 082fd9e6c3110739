"""Uncertainties of a solved :class:`granflow.fitting.engine.Problem`: the covariance of its
free parameters and their 95 % profile-likelihood intervals.

The covariance is ``variance * (J^T J)^-1`` in natural units (the pseudo-inverse when J^T J is
singular, flagged). A profile interval's ends are where the minimum of chi-square over the
other parameters exceeds its minimum by ``3.84 * variance`` (the 95 % quantile of chi-square
with one degree of freedom); the root is found on sqrt(delta chi-square), nearly linear in the
optimiser's coordinate, by the secant method from the Wald estimate.
"""

import math
from dataclasses import dataclass

import numpy as np
from scipy.stats import chi2 as chi2_distribution

PROFILE_LEVEL = float(chi2_distribution.ppf(0.95, 1))  # 3.841...
_LARGEST_MOVE = 2.0  # of the others' predicted move per point, in the optimiser's coordinates
_UNDERCUT = 0.01  # in variance units: a conditional minimum this far above a known point failed
_FOUND = 12  # the last points found whose others a thorough profile restarts from


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
class ProfilePoint:
    """One conditional minimum of a profile.

    Attributes
    ----------
    u : float
        The profiled parameter in the optimiser's coordinate.
    value : float
        The profiled parameter [its unit].
    delta : float
        Chi-square above the minimum, in units of the variance [-].
    values : numpy.ndarray
        Every global parameter at the conditional minimum [SI].
    """

    u: float
    value: float
    delta: float
    values: np.ndarray


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
    """

    index: int
    optimum: ProfilePoint
    points: tuple
    ends: dict
    reached: dict

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


class _Conditional:
    """The conditional minimum of chi-square over the other free parameters, with the profiled
    one pinned: warm-started along the profile by the linear response at the optimum."""

    def __init__(
        self,
        problem,
        values,
        index,
        variance,
        chisqr_min,
        internal_hessian,
        tolerance,
        starts,
        damped=False,
        thorough=False,
    ):
        self.problem, self.index, self.starts, self.damped = problem, index, starts, damped
        self.thorough = thorough
        self.found = []  # the others at each conditional minimum found so far (internal)
        # Levenberg-Marquardt's relative tolerance: 1e-9, or what a precision ``tolerance`` of
        # delta (in variance units) asks of chi-square
        self.rtol = 1e-9
        if tolerance is not None:
            self.rtol = max(1e-9, tolerance * variance / max(abs(chisqr_min), 1e-300))
        self.variance, self.chisqr_min = variance, chisqr_min
        self.parameter = problem.parameters[index]
        self.others = [i for i in problem.free if i != index]
        self.u_hat = self.parameter.to_internal(values[index])
        self.u_others_hat = np.array(
            [problem.parameters[i].to_internal(values[i]) for i in self.others]
        )
        # how the other parameters follow this one near the optimum: -H_oo^-1 H_oj (internal)
        if internal_hessian is None:
            _, _, internal_hessian = problem.state(problem.internal(values), problem.free)
        position = {i: k for k, i in enumerate(problem.free)}
        rows = [position[i] for i in self.others]
        H_oo = internal_hessian[np.ix_(rows, rows)]
        H_oj = internal_hessian[rows, position[index]]
        try:
            self.follow = -np.linalg.solve(H_oo, H_oj) if self.others else np.zeros(0)
        except np.linalg.LinAlgError:
            self.follow = np.zeros(len(self.others))
        if not np.all(np.isfinite(self.follow)):
            self.follow = np.zeros(len(self.others))
        # the profile's curvature at the optimum (variance units per internal unit^2)
        own = position[index]
        try:
            self.curvature = 1.0 / np.linalg.inv(internal_hessian)[own, own] / variance
        except np.linalg.LinAlgError:
            self.curvature = math.nan
        if not (math.isfinite(self.curvature) and self.curvature > 0):
            self.curvature = 0.0

    def _wald(self, u):
        """The optimum's quadratic model of the profile at ``u`` (variance units)."""
        return self.curvature * (u - self.u_hat) ** 2

    def __call__(self, u, u_others_start, u_last, height=math.inf):
        """(delta, u_others) at ``u``: chi-square above the minimum in variance units.

        Gauss-Newton from the linear prediction, Levenberg-Marquardt from it where that
        fails. A conditional minimum found far above ``height`` (the height a search is
        after: twice it and 4 more, a jump that the secant search would read as a crossing
        next to the last point) is checked from three starts, the prediction, the previous
        point's others unmoved and the optimum's (and the caller's own starts, where it has
        any), and the lowest is kept: a warm start can follow a poor branch, and a profile is
        a minimum. A thorough conditional also solves a point past half ``height`` (where
        the ends are sought) from the best-ranked of the caller's starts and of the last
        points' others (:meth:`_polished`)."""
        problem, index = self.problem, self.index
        pinned = {index: u}
        if not self.others:
            full = np.array([p.value for p in problem.parameters])
            full[index] = self.parameter.from_internal(u)
            chisqr = problem.chisqr(full)
            if not math.isfinite(chisqr):
                return math.inf, u_others_start
            return max(chisqr - self.chisqr_min, 0.0) / self.variance, u_others_start
        move = self.follow * (u - u_last)
        largest = float(np.max(np.abs(move))) if move.size else 0.0
        if largest > _LARGEST_MOVE:  # a near-singular response: trust it only so far
            move *= _LARGEST_MOVE / largest
        predicted = u_others_start + move
        # the tolerance: so close that one Gauss-Newton step's quadratic model gives
        # the conditional minimum to far better than 1e-3 of 3.84 variance
        tolerance = 0.02 * self.variance
        u_found, chisqr = problem.gauss_newton(predicted, self.others, pinned, tolerance)
        if chisqr is None:
            u_found, chisqr, *_ = problem.lm(
                predicted if self.damped else u_found,
                self.others,
                pinned,
                max_iter=30,
                rtol=self.rtol,
            )
        delta = self._delta(chisqr)
        if delta > 2.0 * self._wald(u) + _UNDERCUT:
            # a profile is a minimum: a descent that ends above where the previous point's
            # others or the optimum's, unmoved, already are has failed (a near-singular
            # response predicts into another valley, a damped descent can stall there, and
            # the next point starts from it); it is made again from the lower of them.
            # Looked at where the point stands well above the optimum's quadratic model
            unmoved, start = min(
                (self._delta(self.problem.chisqr(self._values(u, start))), k, start)
                for k, start in enumerate((u_others_start, self.u_others_hat))
            )[::2]
            if unmoved < delta - _UNDERCUT:
                candidate, found, *_ = problem.lm(
                    start, self.others, pinned, max_iter=30, rtol=self.rtol
                )
                u_found, delta = start, unmoved
                if self._delta(found) < unmoved:
                    u_found, delta = candidate, self._delta(found)
        if delta > 2.0 * height + 4.0:
            candidates = [predicted, u_others_start, self.u_others_hat, *self._restarts(u)]
            if self.thorough:
                candidates += self.found[-_FOUND:]
            for rank, start in enumerate(self._ranked(u, candidates)[:2]):
                candidate, found, *_ = problem.lm(
                    start, self.others, pinned, max_iter=30, rtol=self.rtol
                )
                gain = delta - self._delta(found)
                if gain > 0:
                    u_found, delta = candidate, self._delta(found)
                if rank == 0 and not gain > 1.0:
                    break  # the best-ranked start finds no other branch: a true rise
        elif self.thorough and delta > 0.5 * height:
            u_found, delta = self._polished(u, pinned, u_found, delta)
        if not math.isfinite(delta):
            return math.inf, u_others_start
        self.found.append(u_found)
        return delta, u_found

    def _polished(self, u, pinned, u_found, delta):
        """The lower of the conditional minimum ``(u_found, delta)`` at ``u`` (delta in
        variance units) and the one Levenberg-Marquardt finds from the best-ranked of the
        caller's starts and the others of the last points found (another branch, which the
        warm start did not follow, a neighbour may have found)."""
        candidates = [*self._restarts(u), *self.found[-_FOUND:]]
        for start in self._ranked(u, candidates)[:1]:
            candidate, found, *_ = self.problem.lm(
                start, self.others, pinned, max_iter=30, rtol=self.rtol
            )
            if self._delta(found) < delta:
                u_found, delta = candidate, self._delta(found)
        return u_found, delta

    def _restarts(self, u):
        """The caller's own starts at ``u`` (``starts(value) -> global values``) as internal
        coordinates of the others."""
        if self.starts is None:
            return []
        value = self.parameter.from_internal(u)
        out = []
        for values in self.starts(value):
            values = np.array(values, dtype=float)
            out.append(
                np.array([self.problem.parameters[i].to_internal(values[i]) for i in self.others])
            )
        return out

    def _values(self, u, u_others):
        """Every global parameter [SI] with the profiled one at ``u`` and the others at
        ``u_others`` (internal coordinates)."""
        pinned = {self.index: u, **dict(zip(self.others, u_others, strict=True))}
        values = np.array([p.value for p in self.problem.parameters])
        for i, ui in pinned.items():
            values[i] = self.problem.parameters[i].from_internal(ui)
        return values

    def _ranked(self, u, candidates):
        """``candidates`` (the others' internal coordinates) ranked by chi-square on every 8th
        point with the profiled parameter at ``u``; those that are not finite left out."""
        ranked = []
        for start in candidates:
            cost = self.problem.chisqr(self._values(u, start), stride=8)
            if math.isfinite(cost):
                ranked.append((cost, start))
        ranked.sort(key=lambda item: item[0])
        return [start for _, start in ranked]

    def _delta(self, chisqr):
        if chisqr is None or not math.isfinite(chisqr):
            return math.inf
        return max(chisqr - self.chisqr_min, 0.0) / self.variance

    def point(self, u, delta, u_others):
        """The :class:`ProfilePoint` at ``u`` with the others at ``u_others``."""
        values = self._values(u, u_others)
        return ProfilePoint(u, float(values[self.index]), float(delta), values)


def _side(
    conditional,
    direction,
    targets,
    step,
    record,
    check=False,
    precision=2e-2,
    hints=(),
    expand=False,
):
    """Secant searches, one after the other, for the coordinates where sqrt(delta) reaches
    each of ``targets`` (increasing) on one side, to ``precision`` of sqrt(delta). With
    ``check``, a point past a target is solved from more starts (see :class:`_Conditional`);
    ``hints`` (one internal coordinate per target, or NaN) are where each search looks
    first (a previous scan's ends); with ``expand`` the step grows fourfold wherever the
    profile is flat. Returns (ends, reached)."""
    parameter = conditional.parameter
    lower_u, upper_u = parameter.internal_bounds()
    limit = upper_u if direction > 0 else lower_u
    u_hat = conditional.u_hat
    u_others = conditional.u_others_hat.copy()
    u_last = u_hat
    origin = (u_hat, 0.0)  # where this target's search starts: (u, sqrt delta)
    ends, reached = [], []
    stopped = False
    for count, target in enumerate(targets):
        if stopped:
            ends.append(limit)
            reached.append(False)
            continue
        if count:
            # from the previous end, a step scaled by how far the previous target lay
            previous = targets[count - 1]
            span = abs(ends[-1] - u_hat)
            step = max(span * (target - previous) / max(previous, 1e-12), 1e-8)
            origin = (ends[-1], previous)
        points = [(origin[0], origin[1] - target)]
        u = origin[0] + direction * step
        hint = hints[count] if count < len(hints) else math.nan
        if math.isfinite(hint) and (hint - origin[0]) * direction > 0:
            u = hint
            step = max(0.25 * abs(hint - origin[0]), 1e-8)
        height = target**2 if check else math.inf
        end = None
        for _ in range(12):
            if (direction > 0 and u >= limit) or (direction < 0 and u <= limit):
                u = limit
                delta, u_others = conditional(u, u_others, u_last, height)
                u_last = u
                record.append(conditional.point(u, delta, u_others))
                if math.sqrt(delta) - target < 0:
                    end = limit
                    stopped = True
                    break
            else:
                delta, u_others = conditional(u, u_others, u_last, height)
                u_last = u
                record.append(conditional.point(u, delta, u_others))
            value = math.sqrt(delta) - target
            points.append((u, value))
            if abs(value) < precision:
                end = u
                break
            (u1, g1), (u2, g2) = points[-2], points[-1]
            slope = (g2 - g1) / (u2 - u1) if u2 != u1 else 0.0
            if abs(value) < 5.0 * precision and slope * direction > 0:
                # sqrt(delta chi-square) is nearly linear in u: the secant root is within
                # a small fraction of the tolerance of the true root, no evaluation needed
                end = u2 - g2 / slope
                break
            proposal = u + direction * step if slope * direction <= 0 else u2 - g2 / slope
            if expand and g2 < 0 and abs(g2 - g1) < 0.05 * target:
                step *= 4.0  # a flat stretch: cross it in a few evaluations, not dozens
            # do not jump more than four steps at once, nor back past where the search began
            proposal = min(max(proposal, u - 4 * step), u + 4 * step)
            if (proposal - origin[0]) * direction <= 0:
                proposal = origin[0] + 0.5 * (u - origin[0])
            u = proposal
        if end is None:
            # no crossing within the search's steps: the profile is too flat to say; the
            # higher targets are not sought
            end = u
            stopped = True
            reached.append(False)
        else:
            reached.append(end != limit or not stopped)
        ends.append(end)
    return ends, reached


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
        where the warm starts jump (see :class:`_Conditional`).
    precision : float
        How close to each target sqrt(delta) must come (2e-2: 0.5 % of the 95 % height).
    hints : dict, optional
        ``{-1: [...], 1: [...]}``: internal coordinates per side and target where each search
        looks first (a previous scan's :attr:`Profile.ends`, for a record that has grown).
    damped : bool
        Where Gauss-Newton's full steps fail, restart Levenberg-Marquardt from the predicted
        start rather than from where Gauss-Newton stopped (for likelihoods curved too much
        for full steps, where that point may lie far off).

    Returns
    -------
    Profile
    """
    conditional = _Conditional(
        problem,
        values,
        index,
        variance,
        chisqr_min,
        internal_hessian,
        tolerance,
        starts,
        damped,
        thorough,
    )
    record = []
    ends, reached = {}, {}
    step = max(wald_halfwidth_u, 1e-8)
    for direction in (-1, 1):
        ends[direction], reached[direction] = _side(
            conditional,
            direction,
            list(targets),
            step,
            record,
            check,
            precision,
            () if hints is None else hints.get(direction, ()),
            damped,
        )
    optimum = ProfilePoint(
        conditional.u_hat, float(values[index]), 0.0, np.asarray(values, dtype=float)
    )
    points = tuple(sorted(record, key=lambda p: p.u))
    return Profile(index, optimum, points, ends, reached)


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
