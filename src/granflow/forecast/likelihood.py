"""The likelihood of a forecast and its profile over the peak force F_peak.

A forecast fits Eq. 3's four parameters to the record before the cut, written as
``(ln a, ln alpha, ln x0, ln(F_peak - floor))``: the peak force is a parameter, and Fd follows
from it in closed form along the peak condition. With s = alpha x, s0 = alpha x0 and
G(s) = exp(-s) [Ei(s) - Ei(s0)], the paper's curve is ``F = Fd (1 - exp(-s)) + a G(s)``; its
peak s_p solves ``Fd = a exp(s_p) (G(s_p) - 1/s_p)`` and ``F_peak = Fd + a / s_p``, and
``dF_peak/ds_p = a (exp(s_p) - 1) / s_p^2 > 0``, so one bracketed root gives s_p (and Fd)
from F_peak. ``floor`` is the largest force the layer is known to have held (0 for a
start-up), so every parameter vector respects it.

The interval of F_peak is the profile likelihood's: the set of F_peak whose best fit over the
other three parameters is within ``chi2_1(level)`` of the best fit, in units of the noise
variance (``F(1, n - 4)`` when the noise is estimated from the residuals, as by default).
Derived quantities (the peak slip, the time of failure) are carried along the profile path,
not linearised at the best fit.

A likelihood may carry ``nuisance`` standard-normal coordinates after these four (the error of
a regressor known only to within a Gaussian, such as a fitted force history): the residuals
receive them, each adds itself as a residual, and the profile re-fits them with the others.
"""

import math
from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import brentq, least_squares
from scipy.stats import chi2
from scipy.stats import f as f_dist

from granflow.errors import FitError
from granflow.model.params import Params
from granflow.model.special import scaled_ei_diff_scalar, scaled_ei_scalar

__all__ = ["Fit", "Likelihood", "fit_and_profile", "params_from_peak"]

_LARGEST_S = 600.0  # exp(s) stays finite
_PROFILE_STEPS = 14  # per side
_BISECTIONS = 3


def _excess(s, s0, scaled_ei_s0):
    """G(s) - 1/s, with G(s) = exp(-s) (Ei(s) - Ei(s0))."""
    return scaled_ei_diff_scalar(s, s0, scaled_ei_s0, math.exp(s0 - s)) - 1.0 / s


def params_from_peak(a, alpha, x0, peak_force):
    """The parameters whose curve peaks at ``peak_force``, and the peak's dimensionless slip.

    Parameters
    ----------
    a : float
        Aging amplitude [N].
    alpha : float
        Rejuvenation constant [1/m].
    x0 : float
        Initial state [m].
    peak_force : float
        The peak force F_peak [N].

    Returns
    -------
    tuple of (Params, float) or None
        ``(params, alpha x_peak)``, or None when no Fd >= 0 gives that peak (F_peak below the
        peak of the Fd = 0 curve, or absurdly far above a).
    """
    s0 = alpha * x0
    if not s0 < _LARGEST_S:
        return None
    scaled_ei_s0 = scaled_ei_scalar(s0)

    def gap(s):
        return a * math.exp(s) * _excess(s, s0, scaled_ei_s0) + a / s - peak_force

    low = s0 * (1.0 + 1e-9)
    if gap(low) >= 0 or gap(_LARGEST_S) <= 0:
        return None
    s_peak = brentq(gap, low, _LARGEST_S, xtol=1e-13, rtol=1e-13)
    fd = a * math.exp(s_peak) * _excess(s_peak, s0, scaled_ei_s0)
    if not fd >= 0:
        return None
    return Params(a=a, alpha=alpha, Fd=fd, x0=x0), s_peak


@dataclass(frozen=True)
class Likelihood:
    """What a forecast fits: residuals of a record against the model, and an optional prior.

    Parameters
    ----------
    residuals : callable
        ``residuals(params, s_peak) -> ndarray``: data minus model in the data's unit.
    floor : float
        F_peak is above it [N]: the largest force held (failure), or 0 (start-up).
    starts : sequence of tuple
        Starting values ``(a, alpha, x0, peak_force)`` in SI units.
    bounds : tuple of (tuple, tuple)
        Lower and upper bounds of ``(a, alpha, x0)`` [N, 1/m, m].
    size : int
        Number of data residuals.
    prior : callable, optional
        ``prior(params) -> ndarray`` of ``prior_size`` standardised prior residuals
        (value - mean) / stderr.
    prior_size : int
        Number of prior residuals.
    noise : float, optional
        Noise standard deviation in the data's unit; default estimated from the best fit.
    scale : float
        A rough noise level in the data's unit (the unit of the first fit when ``noise`` is
        estimated, so that the optimiser's tolerances are relative to the noise).
    nuisance : int
        Number of standard-normal nuisance coordinates; where positive, ``residuals`` is
        called as ``residuals(params, s_peak, z)`` with z their values, and z itself is part
        of the standardised residual vector (a standard normal prior).
    peak_of : callable, optional
        ``peak_of(q, z) -> F_peak``: profile a coordinate q [N] other than F_peak (both above
        ``floor``), mapped to F_peak with the nuisance values z; default q is F_peak.
    """

    residuals: object
    floor: float
    starts: tuple
    bounds: tuple
    size: int
    prior: object = None
    prior_size: int = 0
    noise: float | None = None
    scale: float = 1.0
    nuisance: int = 0
    peak_of: object = None

    def curve(self, u):
        """(Params, s_peak) at internal vector u, or None where infeasible."""
        a, alpha, x0 = np.exp(u[:3])
        peak_force = self.floor + math.exp(u[3])
        if self.peak_of is not None:
            peak_force = self.peak_of(peak_force, u[4:])
        if not math.isfinite(peak_force):
            return None
        return params_from_peak(float(a), float(alpha), float(x0), peak_force)

    def vector(self, u, noise, with_prior):
        """The standardised residual vector at u (large and flat where u is infeasible)."""
        curve = self.curve(u)
        size = self.size + self.nuisance + (self.prior_size if with_prior else 0)
        if curve is None:
            return np.full(size, 1e6)
        if self.nuisance:
            extra = np.asarray(u[4:], dtype=float)
            out = np.concatenate([self.residuals(*curve, extra) / noise, extra])
        else:
            out = self.residuals(*curve) / noise
        if with_prior:
            out = np.concatenate([out, self.prior(curve[0])])
        return np.where(np.isfinite(out), out, 1e6)


@dataclass(frozen=True)
class Fit:
    """A best fit and its profile over F_peak.

    Attributes
    ----------
    params : Params
        Best-fit parameters.
    peak_force : float
        Best-fit F_peak [N].
    chisqr : float
        Best standardised sum of squares [-].
    noise : float
        Noise standard deviation used [data unit].
    path : tuple of (float, float, Params, ndarray)
        Profile points ``(F_peak, delta chi-square, params, nuisance)``, sorted by F_peak.
    interval : tuple of float
        F_peak interval (low, high) [N]; high is inf where the record does not bound it.
    threshold : float
        The delta chi-square of the interval's level [-].
    nuisance : ndarray
        Best-fit nuisance coordinates (empty without them).
    vector : ndarray
        The best fit's internal vector.

    With the likelihood's ``peak_of``, ``peak_force``, the path's first column and
    ``interval`` are the profiled coordinate's.
    """

    params: Params
    peak_force: float
    chisqr: float
    noise: float
    path: tuple
    interval: tuple
    threshold: float
    nuisance: np.ndarray = field(default_factory=lambda: np.empty(0))
    vector: np.ndarray = field(default_factory=lambda: np.empty(0))

    def along(self, quantity):
        """(low, high) of ``quantity(params)`` over the profile path inside the interval, and
        at its ends (interpolated between the path's last point inside and first outside,
        linearly in the profiled coordinate)."""
        inside = [quantity(p) for q, d, p, _ in self.path if d <= self.threshold]
        inside.append(quantity(self.params))
        for end in self.interval:
            value = self._at(end, quantity)
            if value is not None:
                inside.append(value)
        low, high = min(inside), max(inside)
        if math.isinf(self.interval[1]):
            high = math.inf
        return (float(low), float(high))

    def _at(self, end, quantity):
        """``quantity`` interpolated at the interval's ``end`` from the path's neighbours
        of it, one inside and one outside; None where the path has no such pair."""
        if not math.isfinite(end):
            return None
        below = [item for item in self.path if item[0] <= end]
        above = [item for item in self.path if item[0] > end]
        if not below or not above:
            return None
        (q_a, _, p_a, _), (q_b, _, p_b, _) = below[-1], above[0]
        v_a, v_b = quantity(p_a), quantity(p_b)
        if not (math.isfinite(v_a) and math.isfinite(v_b)) or q_b == q_a:
            return None
        return v_a + (v_b - v_a) * (end - q_a) / (q_b - q_a)


_NUISANCE_BOUND = 8.0  # standard deviations


def _bounds(likelihood):
    """Bounds of the internal vector: (ln a, ln alpha, ln x0, ln gap, nuisance...)."""
    lower, upper = likelihood.bounds
    extra = np.full(likelihood.nuisance, _NUISANCE_BOUND)
    low = np.concatenate([np.log(lower), [-60.0], -extra])
    high = np.concatenate([np.log(upper), [20.0], extra])
    return low, high


def _solve(likelihood, u, noise, with_prior, fixed=None):
    """Least squares from u; with ``fixed`` the peak coordinate u[3] is held at that value."""
    low, high = _bounds(likelihood)
    if fixed is None:
        start = np.clip(u, low + 1e-9, high - 1e-9)
        result = least_squares(
            lambda v: likelihood.vector(v, noise, with_prior),
            start,
            bounds=(low, high),
            x_scale=1.0,
            max_nfev=300,
        )
        return result.x, 2 * result.cost

    def fun(v):
        return likelihood.vector(np.insert(v, 3, fixed), noise, with_prior)

    low, high = np.delete(low, 3), np.delete(high, 3)
    start = np.clip(np.delete(u, 3), low + 1e-9, high - 1e-9)
    result = least_squares(fun, start, bounds=(low, high), max_nfev=200)
    return np.insert(result.x, 3, fixed), 2 * result.cost


def _internal(likelihood, start):
    a, alpha, x0, peak_force = start
    gap = max(peak_force - likelihood.floor, 1e-12 * max(abs(peak_force), 1e-12))
    return np.concatenate([np.log([a, alpha, x0, gap]), np.zeros(likelihood.nuisance)])


def _best(likelihood, noise, with_prior):
    scored = []
    for start in likelihood.starts:
        u = _internal(likelihood, start)
        value = likelihood.vector(u, noise, with_prior)
        scored.append((float(value @ value), tuple(u)))
    scored.sort()
    fits = [_solve(likelihood, np.array(u), noise, with_prior) for _, u in scored[:3]]
    return min(fits, key=lambda item: item[1])


def _stderr_last(likelihood, u, noise, with_prior):
    """Standard error of the peak coordinate u[3] from the Gauss-Newton Hessian (a step size
    for the profile search only)."""
    step = 1e-4
    base = likelihood.vector(u, noise, with_prior)
    jac = np.empty((base.size, u.size))
    for k in range(u.size):
        shifted = u.copy()
        shifted[k] += step
        jac[:, k] = (likelihood.vector(shifted, noise, with_prior) - base) / step
    try:
        cov = np.linalg.pinv(jac.T @ jac)
        return float(min(max(math.sqrt(max(cov[3, 3], 0.0)), 1e-6), 0.5))
    except np.linalg.LinAlgError:
        return 0.5


def _profile_point(likelihood, warm, noise, with_prior, target, chisqr, threshold, others):
    """The profile's best fit at ``target`` of the peak coordinate, warm-started from
    ``warm``: ``(u, delta)``. Where the likelihood asks for ``restarts`` (and then has a
    ``repaired(u, target)`` that makes a start feasible at the target), and the point is
    past the threshold, the ``others`` starts are solved too and the lowest kept (a
    warm start can follow one branch of a profile with several, or stall where the
    previous point's neighbourhood is infeasible)."""
    restarts = getattr(likelihood, "restarts", False)
    if restarts:
        warm = likelihood.repaired(warm, target)
    u, value = _solve(likelihood, warm, noise, with_prior, fixed=target)
    if restarts and value - chisqr > threshold:
        for start in others:
            if start is None:
                continue
            start = likelihood.repaired(start, target)
            candidate, found = _solve(likelihood, start, noise, with_prior, fixed=target)
            if found < value:
                u, value = candidate, found
    return u, max(value - chisqr, 0.0)


def _predicted(before, last, target):
    """The secant predictor of a continuation: the fitted vector at ``target`` extrapolated
    linearly from the profile points ``before`` and ``last`` (``(u4, delta, u)``), or None."""
    if before is None or last[0] == before[0]:
        return None
    return last[2] + (last[2] - before[2]) * (target - last[0]) / (last[0] - before[0])


def _side(likelihood, u_best, chisqr, noise, with_prior, direction, step, threshold, limit):
    """Profile points one side of the best fit: (list of (u4, delta, u), bounded)."""
    points, u = [], u_best
    last = u_best[3]
    for _ in range(_PROFILE_STEPS):
        target = last + direction * step
        if direction * (target - limit) > 0:
            return points, False
        before = points[-2] if len(points) > 1 else (u_best[3], 0.0, u_best)
        others = (u_best, _predicted(before, points[-1], target) if points else None)
        u, delta = _profile_point(
            likelihood, u, noise, with_prior, target, chisqr, threshold, others
        )
        points.append((target, delta, u))
        if delta > threshold:
            return points, True
        last, step = target, step * 1.6
    return points, False


def _crossing(likelihood, points, best, chisqr, noise, with_prior, threshold):
    """The peak coordinate u[3] where the profile crosses the threshold: bisection between
    the last point inside and the first outside (warm-started), then linear interpolation of
    the signed root of the chi-square."""
    inside = (best[3], 0.0, best)
    for point in points:
        if point[1] > threshold:
            outside = point
            break
        inside = point
    for _ in range(_BISECTIONS):
        middle = 0.5 * (inside[0] + outside[0])
        u, delta = _profile_point(
            likelihood, inside[2], noise, with_prior, middle, chisqr, threshold, (best,)
        )
        point = (middle, delta, u)
        points.append(point)
        if point[1] > threshold:
            outside = point
        else:
            inside = point
    # The signed root of the profile's chi-square is close to linear in the parameter where
    # the chi-square itself is close to quadratic: interpolate the root.
    (u_a, d_a, _), (u_b, d_b, _) = inside, outside
    r_a, r_b = math.sqrt(d_a), math.sqrt(d_b)
    return u_a + (math.sqrt(threshold) - r_a) * (u_b - u_a) / (r_b - r_a)


def fit_and_profile(likelihood, level=0.9, best=None):
    """The best fit of ``likelihood`` and the profile-likelihood interval of F_peak.

    Parameters
    ----------
    likelihood : Likelihood
        The record's residuals, the floor of F_peak, starts, bounds and prior.
    level : float
        Confidence level of the interval (0.9: 90 %).
    best : tuple, optional
        ``(vector, chisqr, noise, threshold)`` of a best fit already found (of the same data,
        with the peak coordinate u[3] in this likelihood's terms): only the profile is run.

    Returns
    -------
    Fit
    """
    noise = likelihood.noise
    with_prior = likelihood.prior is not None
    dof = max(likelihood.size - 4, 1)
    if best is not None:
        u_best, chisqr, noise, threshold = best
    elif noise is None:
        # Fit in units of a rough noise scale (so the optimiser's tolerances mean something),
        # then rescale to the residuals' own variance; with an estimated variance the profile
        # statistic is F(1, dof), not chi2(1) (the least-squares optimum does not depend on
        # the scale, so no refit is needed without a prior).
        # Nuisance coordinates carry their own unit residuals, so with them the optimum
        # depends on the scale: a warm-started refit at the estimated noise follows.
        scale = likelihood.scale
        u, value = _best(likelihood, scale, False)
        data = likelihood.vector(u, scale, False)[: likelihood.size]
        noise = max(scale * math.sqrt(float(data @ data) / dof), 1e-300)
        threshold = float(f_dist.ppf(level, 1, dof))
        if with_prior:
            u_best, chisqr = _best(likelihood, noise, with_prior)
        elif likelihood.nuisance:
            u_best, chisqr = _solve(likelihood, u, noise, False)
        else:
            u_best, chisqr = u, value * (scale / noise) ** 2
    else:
        threshold = float(chi2.ppf(level, 1))
        u_best, chisqr = _best(likelihood, noise, with_prior)
    curve = likelihood.curve(u_best)
    if curve is None:
        raise FitError("the forecast fit found no curve with a peak above the largest force")
    step = _stderr_last(likelihood, u_best, noise, with_prior)
    scale = max(likelihood.floor, 1e-30)
    upper_limit = math.log(20.0 * scale) if likelihood.floor > 0 else u_best[3] + 3.0
    up, bounded_up = _side(
        likelihood, u_best, chisqr, noise, with_prior, 1.0, step, threshold, upper_limit
    )
    down, bounded_down = _side(
        likelihood, u_best, chisqr, noise, with_prior, -1.0, step, threshold, u_best[3] - 12.0
    )
    high = math.inf
    crossing = (likelihood, u_best, chisqr, noise, with_prior, threshold)
    if bounded_up:
        high = likelihood.floor + math.exp(_crossing(likelihood, up, *crossing[1:]))
    low = likelihood.floor
    if bounded_down:
        low = likelihood.floor + math.exp(_crossing(likelihood, down, *crossing[1:]))
    path = []
    for u4, delta, u in down + up:
        found = likelihood.curve(u)
        if found is not None:
            path.append((likelihood.floor + math.exp(u4), delta, found[0], u[4:]))
    path.sort(key=lambda item: item[0])
    return Fit(
        params=curve[0],
        peak_force=likelihood.floor + math.exp(u_best[3]),
        chisqr=float(chisqr),
        noise=float(noise),
        path=tuple(path),
        interval=(float(low), float(high)),
        threshold=threshold,
        nuisance=u_best[4:],
        vector=np.asarray(u_best, dtype=float),
    )
