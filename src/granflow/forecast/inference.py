"""Fit a forecast's problem and scan its profiles: the engine's multistart Levenberg-Marquardt
(:func:`granflow.fitting.multistart.multistart`) and profile scan
(:func:`granflow.fitting.profile.profile_scan`), with the noise estimated from the residuals.

The data's weights are ``sqrt(count) / sigma``, so chi-square is standardised and the
penalty's residuals (nuisance coordinates, priors) add to it as they are. Where sigma is not
known it is estimated: the problem is first solved at a rough noise level (the optimum does
not depend on it without a penalty), then the noise is the residuals' root mean square with
``n - 4`` degrees of freedom (the shape's four parameters; the nuisance coordinates carry
their own prior), and the problem is solved again from that optimum at the estimate.
"""

import dataclasses
import math
from dataclasses import dataclass, field

import numpy as np
from scipy.special import ndtri, stdtrit

from granflow.errors import FitError
from granflow.fitting.engine import Solution
from granflow.fitting.multistart import multistart
from granflow.fitting.profile import ProfilePoint, profile_scan
from granflow.forecast.discrepancy import Check, check_fit
from granflow.forecast.distribution import Distribution

__all__ = ["Estimate", "distribution_of", "estimate", "heights", "scan", "with_points"]

_SHAPE = 4  # the peak coordinates
_PRECISION = 1e-3  # of chi-square, for the fit's stopping rule
_ROOT_PRECISION = 1e-4  # of a profile end's signed root
_POLISH = 1e-15  # of chi-square: the polished optimum's stopping rule
#: Starts always solved: the curve's branches (a deep overshoot or a shallow one, F_peak
#: near Fd) can each fit a record to its noise, the better by tens of chi-square.
_LEAST = 4
#: Other minima kept beside the best: those within this chi-square of it [variance units]
#: (beyond the profiles' highest target, 2.58 squared, with room for the polish to move).
_REACH = 12.0
#: Points another profile lends closer than this to one of a profile's own (in its
#: optimiser's coordinate, relative above 1) are left out (:func:`with_points`).
_APART = 1e-3
#: How much lower than a profile's own a lent point must lie to join it [chi-square]: above
#: the conditional minima's own imprecision (their Gauss-Newton stops at a gain of 0.02).
_LOWER = 0.01


@dataclass(frozen=True)
class Estimate:
    """A solved forecast problem.

    Attributes
    ----------
    problem : Problem
        The engine's problem at the noise ``sigma``.
    values : numpy.ndarray
        The best fit's global values [SI].
    chisqr : float
        Standardised chi-square at the best fit (data and penalty) [-].
    sigma : float
        The noise used [data unit].
    dof : int or None
        Degrees of freedom of the noise estimate; None where the noise was given.
    hessian : numpy.ndarray
        J^T J at the best fit in the optimiser's coordinates.
    nfev : int
        Passes over the data.
    first : numpy.ndarray
        The first stage's optimum (the nuisance held at 0), for a warm start.
    check : Check
        The residuals' verdict on the model (:mod:`granflow.forecast.discrepancy`): its
        inflation is in ``sigma`` already.
    others : tuple of numpy.ndarray
        The other minima of the likelihood within reach of the best (chi-square less than
        12 above it): a record early in its loading can be fitted nearly as well by a far
        other failure, and a profile must reach that valley too (:func:`scan`).
    """

    problem: object
    values: np.ndarray
    chisqr: float
    sigma: float
    dof: int | None
    hessian: np.ndarray
    nfev: int
    first: np.ndarray
    check: Check = field(default_factory=Check)
    others: tuple = ()


def data_chisqr(problem, values):
    """Sum of the squared weighted data residuals at ``values`` (without the penalty)."""
    curve = problem.curves[0]
    model = problem.model.function(curve.z, *values)
    residuals = curve.w * (model - curve.y)
    return float(residuals @ residuals)


def _solve_at(problem, values, rtol):
    """LM from ``values``: (values, chisqr, hessian, steps)."""
    u, chisqr, _, steps, hessian = problem.lm(problem.internal(values), max_iter=200, rtol=rtol)
    return problem.values(u), chisqr, hessian, steps


def _descend(problem, u, rtol):
    """``(u, chisqr, passes)``: the optimum next to ``u`` by Gauss-Newton's full steps (from
    a previous optimum of the same record grown a little it converges in two or three
    passes over the data, where Levenberg-Marquardt's damped steps take five or six), until
    a step promises less than ``rtol`` of chi-square; Levenberg-Marquardt from ``u`` where
    a full step fails (goes uphill, or the system is singular). ``passes`` counts the
    first evaluation and Levenberg-Marquardt's steps; Gauss-Newton's (at most six, which it
    does not report) count as two."""
    cost = problem.chisqr(problem.values(u))
    if math.isfinite(cost) and problem.free:
        found, chisqr = problem.gauss_newton(u, problem.free, {}, rtol * cost, max_steps=6)
        if chisqr is not None and chisqr <= cost:
            return found, chisqr, 3  # the first evaluation and two steps
    found, chisqr, _, steps, _ = problem.lm(u, max_iter=200, rtol=rtol)
    return found, chisqr, steps + 1


def estimate(
    build,
    starts,
    *,
    size,
    within,
    sigma=None,
    rough,
    nuisance=None,
    tries=None,
    warm=None,
    branch=None,
):
    """The best fit of the problem ``build(sigma, values)`` from ``starts``.

    In two stages where the problem has nuisance coordinates (slots ``nuisance`` on, each a
    standard normal): first the curve alone, with them held at 0, from every start (the
    engine's multistart); the noise is estimated there; then everything together from that
    optimum. The nuisance coordinates barely move the optimum, but left free from the start
    they send the first steps far along their own weak curvature.

    Parameters
    ----------
    build : callable
        ``build(sigma, values) -> Problem``.
    starts : sequence of sequence of float
        Candidate slot values.
    size : int
        Number of data points (the noise estimate's n).
    within : float
        The points' sum of squares about their groups' means [data unit^2] (0 ungrouped).
    sigma : float, optional
        The known noise [data unit]; default estimated.
    rough : float
        A rough noise level [data unit] for the first solve.
    nuisance : int, optional
        The first nuisance slot.
    tries : int, optional
        At most this many starts solved (:func:`~granflow.fitting.multistart.multistart`).
    warm : tuple, optional
        ``(first, values[, others])``: a previous estimate's two optima (of the same record
        before it grew), where the two stages start instead of the grid, and its other
        minima, followed too (the best of them all is the optimum).
    branch : int, optional
        A slot that tells the likelihood's branches apart (the curve's Fd / F_peak): the
        best start of each of its values is solved, and the lowest optimum kept.

    Returns
    -------
    Estimate
    """
    first = rough if sigma is None else sigma
    problem = _nuisance_held(build(first, starts[0] if warm is None else warm[0]), nuisance)
    rtol = _PRECISION / max(size, 1)
    solution, candidates = _first_stage(
        problem, starts, size=size, rtol=rtol, tries=tries, warm=warm, branch=branch
    )
    first_values = problem.values(solution.x)
    if not np.all(np.isfinite(first_values)):
        raise FitError("the forecast's fit did not converge to finite values")
    sigma, dof = _noise(problem, first_values, first, sigma=sigma, size=size, within=within)
    # the residuals' verdict (granflow.forecast.discrepancy): correlated ones widen the noise
    check = check_fit(problem, first_values, first, size, within, rough)
    sigma *= math.sqrt(check.inflation)
    values, chisqr, steps = _second_stage(build, sigma, first_values, warm, rtol)
    problem, values, chisqr, hessian = _polished(build, sigma, values, chisqr)
    # the first stage's other optima, by their chi-square at the first noise level: those
    # near enough to the best to matter, polished in the whole problem
    near = _near(candidates, (first / sigma) ** 2)
    minima, more = _other_minima(problem, values, float(chisqr), near, rtol)
    steps += more
    if minima[0][1] < chisqr:
        values = minima[0][0]
        problem = build(sigma, values)
        chisqr, _, hessian = problem.state(problem.internal(values), problem.free)
    others = tuple(v for v, c in minima[1:] if c - chisqr < _REACH)
    return Estimate(
        problem,
        values,
        float(chisqr),
        sigma,
        dof,
        hessian,
        solution.nfev + steps,
        first_values,
        check,
        others,
    )


def _nuisance_held(problem, nuisance):
    """``problem`` with its nuisance slots (``nuisance`` on) held fixed at their values, for
    the first stage; ``problem`` itself where it has none."""
    held = [] if nuisance is None else list(range(nuisance, len(problem.parameters)))
    for index in held:
        problem.parameters[index].fixed = True
    if held:
        problem = type(problem)(
            problem.curves,
            problem.parameters,
            model=problem.model,
            penalty=problem.penalty,
            rough=problem.rough,
        )
    return problem


def _first_stage(problem, starts, *, size, rtol, tries, warm, branch):
    """``(solution, candidates)``: the first stage's multistart solution, from the previous
    optimum where it is still plausible and else from ``starts``, and the candidates for the
    other minima as ``(values, chisqr)`` (chisqr None for a previous estimate's minima)."""
    solution = None if warm is None else _warm_solution(problem, warm, size, rtol)
    candidates = [] if warm is None or len(warm) < 3 else [(v, None) for v in warm[2]]
    if solution is None:
        chosen = starts if branch is None else _diverse(problem, starts, branch)
        least = _LEAST if branch is None else len(chosen)
        solution = multistart(problem, chosen, 1.0, rtol=rtol, tries=tries, least=least)
        candidates = [(problem.values(u), cost) for u, cost in solution.optima]
    return solution, candidates


def _warm_solution(problem, warm, size, rtol):
    """The solution from the previous first-stage optimum ``warm[0]`` (:func:`_descend`);
    None where it has gone implausible (chi-square beyond twice the degrees of freedom), so
    that the grid is solved instead."""
    u, cost, steps = _descend(problem, problem.internal(list(warm[0])), rtol)
    # the descent's chi-square (Gauss-Newton's last predicted: within rtol of the true one)
    if not cost <= 2.0 * max(size - _SHAPE, 1):
        return None
    return Solution(u, 1, "converged (from the previous optimum)", steps)


def _noise(problem, first_values, first, *, sigma, size, within):
    """``(sigma, dof)``: the known noise and None, or the noise estimated from the first
    stage's residuals (at noise ``first``) with ``n - 4`` degrees of freedom [data unit]."""
    if sigma is not None:
        return sigma, None
    dof = max(size - _SHAPE, 1)
    squares = data_chisqr(problem, first_values) * first**2 + within
    return max(math.sqrt(squares / dof), 1e-300), dof


def _second_stage(build, sigma, first_values, warm, rtol):
    """``(values, chisqr, steps)``: the whole problem at noise ``sigma`` solved from the
    first stage's optimum; where ``warm``, from the previous estimate's optimum instead, and
    from the first stage's too where that one does worse."""
    start = first_values
    if warm is not None:
        # the previous optimum, moved as the first stage's moved from the previous one's
        before = np.asarray(warm[1], dtype=float)
        start = before + (first_values - np.asarray(warm[0], dtype=float))
        # a slot that would change sign keeps its previous value (a log slot stays positive)
        start = np.where(np.isfinite(start) & (np.sign(start) == np.sign(before)), start, before)
    problem = build(sigma, start)
    if warm is None:
        values, chisqr, _, steps = _solve_at(problem, start, rtol)
    else:
        # Gauss-Newton converges quadratically from the last optimum: carried on to the
        # polish's precision, it leaves the polish one pass (the Hessian's) to make
        u, chisqr, steps = _descend(problem, problem.internal(start), _POLISH)
        values = problem.values(u)
    if warm is not None and not chisqr <= problem.chisqr(
        problem.values(problem.internal(first_values))
    ):
        # the previous optimum has drifted onto a poorer branch: the stage-1 optimum's
        other, other_chisqr, _, more = _solve_at(problem, first_values, rtol)
        steps += more
        if other_chisqr < chisqr:
            values, chisqr = other, other_chisqr
    return values, chisqr, steps


def _polished(build, sigma, values, chisqr):
    """``(problem, values, chisqr, hessian)``: the optimum polished (Levenberg-Marquardt
    converges quadratically there), then the problem rebuilt about it: what follows depends
    on the optimum, not on the path to it."""
    problem = build(sigma, values)
    u, polished, *_ = problem.lm(problem.internal(values), max_iter=50, rtol=_POLISH)
    if polished <= chisqr and np.all(np.isfinite(u)):
        values = problem.values(u)
        problem = build(sigma, values)
    chisqr, _, hessian = problem.state(problem.internal(values), problem.free)
    return problem, values, chisqr, hessian


def _near(candidates, scale):
    """The candidates' values within reach of the lowest: chi-square (times ``scale``, to
    the final noise level) less than twice the reach above it, or of unknown chi-square."""
    lowest = min((cost for _, cost in candidates if cost is not None), default=0.0)
    return [v for v, cost in candidates if cost is None or (cost - lowest) * scale < 2 * _REACH]


def _other_minima(problem, values, chisqr, candidates, rtol):
    """``([(values, chisqr)] sorted, passes)``: the best fit and the distinct minima reached
    by Levenberg-Marquardt from ``candidates`` (other starts' optima, or a previous
    estimate's other minima) in ``problem``. Distinct: apart by more than 1e-4 relative in
    some slot."""
    minima = [(np.asarray(values, dtype=float), float(chisqr))]
    steps = 0
    for candidate in candidates:
        candidate = np.asarray(candidate, dtype=float)
        if not np.all(np.isfinite(candidate)) or _same(candidate, values):
            continue
        found, cost, _, more = _solve_at(problem, candidate, rtol)
        steps += more
        if not (math.isfinite(cost) and np.all(np.isfinite(found))):
            continue
        if any(_same(found, kept) for kept, _ in minima):
            continue
        minima.append((found, float(cost)))
    minima.sort(key=lambda item: item[1])
    return minima, steps


def _same(one, other):
    """Whether two slot vectors are the same minimum: within 1e-4 relative in every slot
    (1e-4 absolute in a slot below 1 in size, as the nuisance coordinates)."""
    one, other = np.asarray(one, dtype=float), np.asarray(other, dtype=float)
    size = np.maximum(np.maximum(np.abs(one), np.abs(other)), 1.0)
    return bool(np.all(np.abs(one - other) <= 1e-4 * size))


def _diverse(problem, starts, branch):
    """The best start (by chi-square on every 8th point) of each value of slot ``branch``."""
    best = {}
    for start in starts:
        cost = problem.chisqr(problem.values(problem.internal(list(start))), stride=8)
        key = start[branch]
        if math.isfinite(cost) and (key not in best or cost < best[key][0]):
            best[key] = (cost, start)
    chosen = [start for _, start in sorted(best.values(), key=lambda item: item[0])]
    return chosen or list(starts)


def heights(level, dof):
    """The heights of the signed root a forecast's profiles are scanned to: the one-sided
    and two-sided quantiles of ``level``, of Student's t with ``dof`` degrees of freedom
    (the normal where dof is None); the tails beyond are extrapolated."""

    def quantile(p):
        return float(stdtrit(dof, p)) if dof is not None else float(ndtri(p))

    return tuple(sorted({quantile(level), quantile(0.5 * (1 + level))}))


def scan(
    fit,
    index,
    level,
    *,
    offset=0.0,
    problem=None,
    values=None,
    hessian=None,
    starts=None,
    hints=None,
    precision=None,
    others=None,
    hint_offsets=None,
    thorough=False,
):
    """The profile of slot ``index`` of ``fit`` (or of ``problem`` at ``values``, the same
    likelihood in other coordinates) and its :class:`Distribution` (q = ``offset`` +
    the slot's value). ``starts(value)`` gives more starts for a conditional minimum, and
    ``hints`` (a previous scan's ends, as values of q) where each end is sought first (see
    :func:`~granflow.fitting.profile.profile_scan`), ``hint_offsets`` (a previous scan's
    :attr:`~granflow.fitting.profile.Profile.end_offsets`) where the others start there,
    and with hints the ends are reached by Newton's steps on the profile's own slope. The
    ends are found to ``precision`` of the signed root (default 1e-4, so that a scan
    warm-started from a previous one's ends reaches the same ends as one from nothing).
    ``thorough`` solves every point near the ends from the best-ranked of ``starts`` and of
    the last points found as well (for likelihoods whose branches the warm starts miss
    short of a jump).

    ``others`` (default the fit's :attr:`Estimate.others`, in ``problem``'s slots): the
    likelihood's other minima. A scan follows one valley, so each other minimum that lies
    beyond the best one's Wald width gets a scan of its own valley, and its points join
    the profile (the profile is the lower envelope of the valleys; its ends the outermost
    on each side)."""
    precision = _ROOT_PRECISION if precision is None else precision
    problem = fit.problem if problem is None else problem
    values = fit.values if values is None else values
    if hessian is None:
        hessian = fit.hessian if problem is fit.problem else None
    if hessian is None:
        _, _, hessian = problem.state(problem.internal(values), problem.free)
    position = problem.free.index(index)
    try:
        covariance = np.linalg.inv(hessian)
        halfwidth = math.sqrt(max(covariance[position, position], 1e-16))
    except np.linalg.LinAlgError:
        halfwidth = 0.1
    halfwidth = min(max(halfwidth, 1e-6), 2.0)
    targets = heights(level, fit.dof)
    parameter = problem.parameters[index]
    internal_hints = None
    if hints:
        internal_hints = {
            side: [_internal(parameter, q - offset) for q in ends] for side, ends in hints.items()
        }

    def valley(at, at_hessian, at_hints=None, at_offsets=None):
        """The profile scan of the valley whose bottom is ``at``."""
        return profile_scan(
            problem,
            at,
            index,
            fit.chisqr,
            targets,
            halfwidth,
            variance=1.0,
            internal_hessian=at_hessian,
            check=True,
            tolerance=precision,
            starts=starts,
            precision=precision,
            hints=at_hints,
            damped=True,
            newton=bool(at_hints),
            hint_offsets=at_offsets,
            thorough=thorough,
        )

    profile = valley(values, hessian, internal_hints, hint_offsets)
    if others is None:
        others = fit.others if problem is fit.problem else ()
    for other in others:
        u_other = _internal(parameter, float(other[index]))
        if not abs(u_other - profile.optimum.u) > halfwidth:
            continue
        try:
            _, _, other_hessian = problem.state(problem.internal(other), problem.free)
            other_profile = valley(other, other_hessian)
        except (np.linalg.LinAlgError, ValueError, FloatingPointError):
            continue
        profile = _joined(profile, other_profile, problem.chisqr(other) - fit.chisqr)
    return profile, distribution_of(profile, parameter, offset, fit.dof)


def distribution_of(profile, parameter, offset, dof):
    """The :class:`Distribution` of a profile of ``parameter`` (q = ``offset`` + its value),
    from its lower envelope (:meth:`~granflow.fitting.profile.Profile.signed_roots`)."""
    u, r = profile.signed_roots()
    low_end, high_end = parameter.internal_bounds()
    return Distribution(
        u=u,
        r=r,
        offset=float(offset),
        scale=float(parameter.scale),
        log=bool(parameter.log),
        dof=dof,
        open_below=not all(profile.reached[-1]),
        open_above=not all(profile.reached[1]),
        low_end=float(low_end),
        high_end=float(high_end),
    )


def with_points(profile, parameter, index, points):
    """``profile`` with more points of the same likelihood: ``points``, ``(values, delta)``
    pairs of slot vectors (in the profile's problem's slots, ``parameter`` the profiled
    slot ``index``) and their chi-square above the minimum. Each is a parameter set the
    profile's conditional minimum at its value can only undercut, so the profile's lower
    envelope may take it: where the conditional fits missed a branch another profile of the
    same likelihood found (the strength's and the failure time's), the two agree. Points
    without a coordinate (a value out of the slot's range), those within 1e-3 of a point
    the profile has (in its coordinate: where the secant search ended, two points a hair
    apart would make the tail's slope noise), and those not lower by 0.01 in chi-square
    than the profile's own there (a worse conditional minimum says nothing) are left out."""
    known = [p.u for p in profile.points] + [profile.optimum.u]
    nodes_u, nodes_r = profile.signed_roots()
    extra = []
    for values, delta in points:
        value = float(values[index])
        u = _internal(parameter, value)
        if not (math.isfinite(u) and math.isfinite(delta)):
            continue
        if any(abs(u - v) <= _APART * max(1.0, abs(u)) for v in known):
            continue  # next to a point the profile has: it adds nothing there but noise
        if not delta < float(np.interp(u, nodes_u, nodes_r)) ** 2 - _LOWER:
            continue  # no lower than the profile there (beyond its ends: than its last point)
        known.append(u)
        extra.append(ProfilePoint(u, value, float(delta), np.asarray(values, dtype=float)))
    if not extra:
        return profile
    merged = tuple(sorted((*profile.points, *extra), key=lambda p: p.u))
    return dataclasses.replace(profile, points=merged)


def _joined(profile, valley, delta):
    """``profile`` with the points of another minimum's ``valley`` (chi-square ``delta``
    above the best at its bottom) and, on that minimum's side, the outer of the two ends
    per target."""
    bottom = dataclasses.replace(valley.optimum, delta=max(float(delta), 0.0))
    points = tuple(sorted((*profile.points, bottom, *valley.points), key=lambda p: p.u))
    side = 1 if valley.optimum.u > profile.optimum.u else -1
    ends = {key: list(value) for key, value in profile.ends.items()}
    reached = {key: list(value) for key, value in profile.reached.items()}
    end_offsets = {key: list(value) for key, value in (profile.end_offsets or {}).items()}
    for k, (mine, theirs) in enumerate(zip(ends[side], valley.ends[side], strict=False)):
        if (theirs - mine) * side > 0 or not math.isfinite(mine):
            ends[side][k] = theirs
            reached[side][k] = valley.reached[side][k]
            if side in end_offsets:
                # measured from the other valley's bottom, not the optimum's: no start
                end_offsets[side][k] = None
    return dataclasses.replace(
        profile, points=points, ends=ends, reached=reached, end_offsets=end_offsets or None
    )


def _internal(parameter, value):
    """The optimiser's coordinate of ``value``; NaN where it has none (a log parameter at or
    below 0, a value that is not finite)."""
    if not math.isfinite(value) or (parameter.log and not value > 0):
        return math.nan
    return parameter.to_internal(value)
