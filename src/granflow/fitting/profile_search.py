"""The search behind a profile likelihood's scan (:func:`granflow.fitting.profile.profile_scan`):
the conditional minimum of chi-square with one parameter pinned (:class:`Conditional`), and
the search along one side of the optimum for where sqrt(delta chi-square) reaches each of its
target heights (:func:`search_side`), by the secant method or by Newton's steps on the
profile's own slope (the envelope theorem's, from each minimum's last pass)."""

import math
from dataclasses import dataclass

import numpy as np

__all__ = ["Conditional", "ProfilePoint", "search_side"]

_LARGEST_MOVE = 2.0  # of the others' predicted move per point, in the optimiser's coordinates
_UNDERCUT = 0.01  # in variance units: a conditional minimum this far above a known point failed
_NEWTON_TOLERANCE = 5e-3  # of the variance: where a conditional minimum a Newton step may end
# from stops (Gauss-Newton's model of a forecast's likelihood predicts gains of 2e-3 and
# less no better than the rounding of chi-square: its steps go uphill there)
_NEWTON_REACH = 0.1  # of sqrt(delta): the farthest a target may lie from such a point
_NEWTON_BEND = 5.0  # of the precision: the largest curvature term such a step may carry
_FOUND = 12  # the last points found whose others a thorough profile restarts from


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


class Conditional:
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
        newton=False,
        thorough=False,
    ):
        self.problem, self.index, self.starts, self.damped = problem, index, starts, damped
        self.newton, self.thorough = newton, thorough
        self.found = []  # the others at each conditional minimum found so far (internal)
        # the last conditional minimum's d delta / du and d u_others / du (``newton``), or
        # None where it came otherwise than by the envelope's Gauss-Newton
        self.last = None
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
        a minimum. A ``thorough`` conditional also solves a point past half ``height`` (where
        the ends are sought) from the best-ranked of the caller's starts and of the last
        points' others (:meth:`_polished`), and restarts a jump from those points too."""
        problem, index = self.problem, self.index
        pinned = {index: u}
        if not self.others:
            full = np.array([p.value for p in problem.parameters])
            full[index] = self.parameter.from_internal(u)
            chisqr = problem.chisqr(full)
            if not math.isfinite(chisqr):
                return math.inf, u_others_start
            return max(chisqr - self.chisqr_min, 0.0) / self.variance, u_others_start
        predicted = self.predicted(u, u_others_start, u_last)
        # the tolerance: so close that one Gauss-Newton step's quadratic model gives
        # the conditional minimum to far better than 1e-3 of 3.84 variance
        tolerance = 0.02 * self.variance
        self.last = None
        if self.newton:
            # a point Newton's step may end the search from: its delta closer than the
            # secant search's points need
            u_found, chisqr, slopes, response = problem.gauss_newton(
                predicted,
                self.others,
                pinned,
                _NEWTON_TOLERANCE * self.variance,
                max_steps=6,
                envelope=True,
            )
            if chisqr is not None:
                self.last = (float(slopes[0]) / self.variance, response[:, 0])
        else:
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
                self.last = None
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
                    self.last = None
                if rank == 0 and not gain > 1.0:
                    break  # the best-ranked start finds no other branch: a true rise
        elif self.thorough and delta > 0.5 * height:
            u_found, delta = self._polished(u, pinned, u_found, delta)
        if not math.isfinite(delta):
            return math.inf, u_others_start
        if self.thorough:
            self.found.append(u_found)
        return delta, u_found

    def _polished(self, u, pinned, u_found, delta):
        """The lower of the conditional minimum ``(u_found, delta)`` at ``u`` (delta in
        variance units) and the one Levenberg-Marquardt finds from the best-ranked of the
        caller's starts and the others of the last points found, on either side (another
        branch, which the warm start did not follow, another point may have found)."""
        candidates = [*self._restarts(u), *self.found[-_FOUND:]]
        for start in self._ranked(u, candidates)[:1]:
            candidate, found, *_ = self.problem.lm(
                start, self.others, pinned, max_iter=30, rtol=self.rtol
            )
            if self._delta(found) < delta:
                u_found, delta = candidate, self._delta(found)
                self.last = None
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

    def predicted(self, u, u_others_start, u_last):
        """Where the others start at ``u``: from ``u_others_start`` (at ``u_last``) along
        the optimum's linear response, a move no larger than ``_LARGEST_MOVE``."""
        move = self.follow * (u - u_last)
        largest = float(np.max(np.abs(move))) if move.size else 0.0
        if largest > _LARGEST_MOVE:  # a near-singular response: trust it only so far
            move *= _LARGEST_MOVE / largest
        return u_others_start + move

    def offset(self, u, u_others):
        """How far ``u_others`` at ``u`` lie from the optimum's linear response there, in
        units that do not depend on the optimum (see :attr:`Profile.end_offsets`)."""
        gap = u_others - self.predicted(u, self.u_others_hat, self.u_hat)
        return gap * self._units

    def from_offset(self, offset):
        """The others' internal start at the optimum for an :meth:`offset` (NaN where it
        is not finite)."""
        return self.u_others_hat + np.asarray(offset, dtype=float) / self._units

    @property
    def _units(self):
        parameters = self.problem.parameters
        return np.array([1.0 if parameters[i].log else parameters[i].scale for i in self.others])

    def point(self, u, delta, u_others):
        """The :class:`ProfilePoint` at ``u`` with the others at ``u_others``."""
        values = self._values(u, u_others)
        return ProfilePoint(u, float(values[self.index]), float(delta), values)


def _newton_step(points, slopes):
    """(move, bend): the root of the last point's quadratic model of ``g = sqrt(delta) -
    target`` (its value and slope, the curvature from the slope at the point before where
    it is known) as a move in u from it, and the model's curvature term at that move (inf
    where the curvature is unknown or the model has no root: Newton's step, not to end on)."""
    (u1, _), (u2, g2) = points[-2], points[-1]
    s1, s2 = slopes[-2], slopes[-1]
    if not (math.isfinite(s1) and u2 != u1):
        return -g2 / s2, math.inf
    curvature = (s2 - s1) / (u2 - u1)
    discriminant = s2 * s2 - 2.0 * curvature * g2
    if not discriminant > 0.0:
        return -g2 / s2, math.inf
    move = -2.0 * g2 / (s2 + math.copysign(math.sqrt(discriminant), s2))
    return move, 0.5 * curvature * move * move


_ROUGH_STEPS = 24  # a rough likelihood's end search: bracketing a cliff takes more steps


def _bracket(below, past, point, direction, moved):
    """A rough end search's bracket after ``point`` ``(u, sqrt(delta) - target)``:
    ``(below, past, again)``, the outermost point below the target inside the first one
    past it, that point, and whether ``point`` fell on the side the last one did. A point
    below the target beyond the one past it drops that one (the profile fell back: its
    lower envelope crosses further out); a point past the target beyond a bracket leaves it
    as it is; an infinite delta is past."""
    u, value = point
    side = value > 0
    if side:
        if past is None or (past[0] - u) * direction > 0:
            past = point
    else:
        if past is not None and (u - past[0]) * direction > 0:
            past = None
        if below is None or (u - below[0]) * direction > 0:
            below = point
    return below, past, side == moved


def _falsi(below, past):
    """Regula falsi's point inside a bracket ``(u, g)`` below and past the target (its
    middle where the point past it is infinite)."""
    (ua, ga), (ub, gb) = below, past
    if not math.isfinite(gb):
        return 0.5 * (ua + ub)
    return ub - gb * (ub - ua) / (gb - ga)


def search_side(
    conditional,
    direction,
    targets,
    step,
    record,
    check=False,
    precision=2e-2,
    hints=(),
    expand=False,
    hint_offsets=(),
):
    """Secant searches, one after the other, for the coordinates where sqrt(delta) reaches
    each of ``targets`` (increasing) on one side, to ``precision`` of sqrt(delta) (a rough
    problem's, once bracketed, to a thousandth of the end's distance from the optimum). With
    ``check``, a point past a target is solved from more starts (see :class:`Conditional`);
    ``hints`` (one internal coordinate per target, or NaN) are where each search looks
    first (a previous scan's ends), and ``hint_offsets`` (per target, or None: a previous
    scan's :attr:`Profile.end_offsets`) where the others start there; with ``expand`` the
    step grows fourfold wherever the profile is flat. Returns (ends, reached, offsets)."""
    parameter = conditional.parameter
    lower_u, upper_u = parameter.internal_bounds()
    limit = upper_u if direction > 0 else lower_u
    u_hat = conditional.u_hat
    u_others = conditional.u_others_hat.copy()
    u_last = u_hat
    origin = (u_hat, 0.0)  # where this target's search starts: (u, sqrt delta)
    ends, reached, offsets = [], [], []
    stopped = False
    for count, target in enumerate(targets):
        if stopped:
            ends.append(limit)
            reached.append(False)
            offsets.append(None)
            continue
        if count:
            # from the previous end, a step scaled by how far the previous target lay
            previous = targets[count - 1]
            span = abs(ends[-1] - u_hat)
            step = max(span * (target - previous) / max(previous, 1e-12), 1e-8)
            origin = (ends[-1], previous)
        points = [(origin[0], origin[1] - target)]
        # d sqrt(delta) / du at each point (``newton``): the first target's origin is the
        # optimum, where sqrt(delta) rises as the Wald model's
        if count == 0:
            origin_slope = (
                direction * math.sqrt(conditional.curvature)
                if conditional.curvature > 0
                else math.nan
            )
        slopes = [origin_slope if conditional.newton else math.nan]
        origin_slope = math.nan  # until this target's end gives one
        u = origin[0] + direction * step
        hint = hints[count] if count < len(hints) else math.nan
        if math.isfinite(hint) and (hint - origin[0]) * direction > 0:
            u = hint
            step = max(0.25 * abs(hint - origin[0]), 1e-8)
            offset = hint_offsets[count] if count < len(hint_offsets) else None
            if offset is not None:
                # the optimum's linear response at the hint, off it as much as the others
                # stood off it at this end before
                start = conditional.from_offset(offset)
                if np.all(np.isfinite(start)):
                    u_others, u_last = start, u_hat
        height = target**2 if check else math.inf
        end = None
        # a rough likelihood's bracket: the last points below and past the target, and
        # whether the last two points fell on the same side of it
        rough = conditional.problem.rough
        below = (origin[0], origin[1] - target) if rough else None
        past, moved, again = None, None, False
        for _ in range(_ROUGH_STEPS if rough else 12):
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
            if rough and not math.isnan(value):
                below, past, again = _bracket(below, past, (u, value), direction, moved)
                moved = value > 0
            here = math.nan
            if conditional.last is not None and delta > 0:
                here = conditional.last[0] / (2.0 * math.sqrt(delta))
            slopes.append(here)
            if abs(value) < precision:
                end, origin_slope = u, here
                break
            if here * direction > 0:
                move, bend = _newton_step(points, slopes)
                if (
                    abs(value) <= _NEWTON_REACH
                    and abs(bend) <= _NEWTON_BEND * precision
                    and (u + move - origin[0]) * direction > 0
                    and (limit - (u + move)) * direction > 0
                ):
                    # the step's quadratic model lands on the target far closer than the
                    # precision: the end, the others moved by Gauss-Newton's response
                    end = u + move
                    u_others = u_others + conditional.last[1] * move
                    u_last = end
                    record.append(conditional.point(end, target * target, u_others))
                    origin_slope = here + 2.0 * bend / move if move else here
                    break
                if abs(move) > 4 * step:
                    step *= 4.0  # the root lies further than the steps reach: widen them
                proposal = min(max(u + move, u - 4 * step), u + 4 * step)
                if (proposal - origin[0]) * direction <= 0:
                    proposal = origin[0] + 0.5 * (u - origin[0])
                u = proposal
                continue
            (u1, g1), (u2, g2) = points[-2], points[-1]
            slope = (g2 - g1) / (u2 - u1) if u2 != u1 else 0.0
            if abs(value) < 5.0 * precision and slope * direction > 0:
                # sqrt(delta chi-square) is nearly linear in u: the secant root is within
                # a small fraction of the tolerance of the true root, no evaluation needed
                end = u2 - g2 / slope
                if past is not None:  # a rough search's end stays inside its bracket
                    end = min(max(end, min(below[0], past[0])), max(below[0], past[0]))
                break
            if past is not None:
                # a crossing bracketed on a rough likelihood: regula falsi inside it, halved
                # where the last two points fell on one side (the secant through the last
                # two points stalls on the flat side of a cliff), and the end where the
                # bracket is a thousandth of its distance from the optimum (at a cliff the
                # signed root's precision is no measure)
                falsi = _falsi(below, past)
                if abs(past[0] - below[0]) <= 1e-3 * abs(falsi - u_hat) + 1e-12:
                    end = falsi
                    break
                u = 0.5 * (below[0] + past[0]) if again else falsi
                continue
            proposal = u + direction * step if slope * direction <= 0 else u2 - g2 / slope
            if expand and g2 < 0 and abs(g2 - g1) < 0.05 * target:
                step *= 4.0  # a flat stretch: cross it in a few evaluations, not dozens
            # do not jump more than four steps at once, nor back past where the search began
            proposal = min(max(proposal, u - 4 * step), u + 4 * step)
            if (proposal - origin[0]) * direction <= 0:
                proposal = origin[0] + 0.5 * (u - origin[0])
            u = proposal
        if end is None and past is not None:
            # a rough search's steps ran out inside its bracket: its outer end, where the
            # profile is known past the target (the interval errs wide, not short)
            end = past[0]
        if end is None:
            # no crossing within the search's steps: the profile is too flat to say; the
            # higher targets are not sought
            end = u
            stopped = True
            reached.append(False)
            offsets.append(None)
        else:
            reached.append(end != limit or not stopped)
            offsets.append(conditional.offset(u_last, u_others) if conditional.others else None)
        ends.append(end)
    return ends, reached, offsets
