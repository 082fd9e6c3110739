"""The least-squares engine behind every fit of Eq. 3: one curve or many with tied parameters.

A problem is a list of curves (abscissa z, force y, weights w) and a list of global
parameters; each curve's four model parameters (a, alpha, Fd, x0 -- or a, k, Fd, t0 in the
time domain, the same mathematics with z = t) are ``factor * global`` for one global parameter
each. A single fit is the case of one curve and the identity map; joint fits tie parameters
by name; Amontons fits use the normal load as the factor of a and Fd.

The optimiser works in transformed coordinates: scale parameters (alpha, x0, and anything
declared ``log``) as ``log(value / scale)``, the others as ``value / scale``. x0 sits next
to the logarithmic singularity of Ei, where a log coordinate keeps the problem well scaled.

Data below x0: the model is only defined from x0 on. Points of the fit window that fall
below the current x0 are compared with the initial force F(x0) (the model held at its
initial state). The objective is then a continuous function of x0 (F(x) tends to F(x0) as x
tends to x0), and no point ever leaves or enters the sum, so chi-square stays comparable
between trial values of x0.
"""

import math
from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import least_squares
from scipy.stats import chi2 as chi2_distribution

from granflow.fitting.results import FrozenMap as FrozenMap  # re-exported for callers
from granflow.model.special import _inline, _jit, _scaled_ei_diff_scalar, _scaled_ei_scalar

SLOTS = ("a", "alpha", "Fd", "x0")
_SMALL_S = 0.5
PROFILE_LEVEL = float(chi2_distribution.ppf(0.95, 1))  # 3.841...
WALD_Z = 1.959963984540054


@_inline
def _point(zi, a, alpha, Fd, x0, s0, scaled_ei_s0, exp_minus_s0, start_rise):
    """F and its four derivatives (a, alpha, Fd, x0) at one point; held below x0.

    ``1 - exp(-u)`` is computed with expm1 only for u < 0.5, where cancellation would cost
    digits; above, the plain difference is exact to rounding and much cheaper.
    """
    if zi <= x0:
        return (
            Fd * start_rise,
            0.0,
            Fd * x0 * exp_minus_s0,
            start_rise,
            Fd * alpha * exp_minus_s0,
        )
    s = alpha * zi
    h = s - s0
    decay = math.exp(-h)
    diff = _scaled_ei_diff_scalar(s, s0, scaled_ei_s0, decay)
    exp_minus_s = decay * exp_minus_s0
    rise_s = -math.expm1(-s) if s < _SMALL_S else 1.0 - exp_minus_s
    rise_h = -math.expm1(-h) if h < _SMALL_S else 1.0 - decay
    return (
        a * diff + Fd * rise_s,
        diff,
        a * (rise_h / alpha - zi * diff) + Fd * zi * exp_minus_s,
        rise_s,
        -a * decay / x0,
    )


@_jit
def _model_and_jacobian(z, a, alpha, Fd, x0, F, J):
    """Eq. 3 (paper initial condition) and its four partial derivatives at the points z.

    Points below x0 get the initial force Fd (1 - exp(-alpha x0)) and its derivatives.
    Columns of J: d/da, d/dalpha, d/dFd, d/dx0.
    """
    s0 = alpha * x0
    scaled_ei_s0 = _scaled_ei_scalar(s0)
    exp_minus_s0 = math.exp(-s0)
    start_rise = -math.expm1(-s0)
    for i in range(z.shape[0]):
        F[i], J[i, 0], J[i, 1], J[i, 2], J[i, 3] = _point(
            z[i], a, alpha, Fd, x0, s0, scaled_ei_s0, exp_minus_s0, start_rise
        )


@_jit
def _model_only(z, a, alpha, Fd, x0, F):
    """Eq. 3 alone (no derivatives) with the same rule below x0 as _model_and_jacobian."""
    s0 = alpha * x0
    scaled_ei_s0 = _scaled_ei_scalar(s0)
    exp_minus_s0 = math.exp(-s0)
    start = -Fd * math.expm1(-s0)
    for i in range(z.shape[0]):
        zi = z[i]
        if zi <= x0:
            F[i] = start
            continue
        s = alpha * zi
        decay = math.exp(s0 - s)
        rise_s = -math.expm1(-s) if s < _SMALL_S else 1.0 - decay * exp_minus_s0
        F[i] = a * _scaled_ei_diff_scalar(s, s0, scaled_ei_s0, decay) + Fd * rise_s


@_jit
def _normal_equations(z, y, w, a, alpha, Fd, x0, jtj, jtr):
    """Sum of squared weighted residuals; J^T J into jtj (4x4) and J^T r into jtr (4).

    r = w (F - y); J = dr/d(a, alpha, Fd, x0). One pass, scalar accumulators, no n-by-4 array.
    """
    s0 = alpha * x0
    scaled_ei_s0 = _scaled_ei_scalar(s0)
    exp_minus_s0 = math.exp(-s0)
    start_rise = -math.expm1(-s0)
    cost = 0.0
    g0 = g1 = g2 = g3 = 0.0
    h00 = h01 = h02 = h03 = h11 = h12 = h13 = h22 = h23 = h33 = 0.0
    for i in range(z.shape[0]):
        F, j0, j1, j2, j3 = _point(
            z[i], a, alpha, Fd, x0, s0, scaled_ei_s0, exp_minus_s0, start_rise
        )
        wi = w[i]
        r = wi * (F - y[i])
        j0 *= wi
        j1 *= wi
        j2 *= wi
        j3 *= wi
        cost += r * r
        g0 += j0 * r
        g1 += j1 * r
        g2 += j2 * r
        g3 += j3 * r
        h00 += j0 * j0
        h01 += j0 * j1
        h02 += j0 * j2
        h03 += j0 * j3
        h11 += j1 * j1
        h12 += j1 * j2
        h13 += j1 * j3
        h22 += j2 * j2
        h23 += j2 * j3
        h33 += j3 * j3
    jtr[0], jtr[1], jtr[2], jtr[3] = g0, g1, g2, g3
    jtj[0, 0], jtj[1, 1], jtj[2, 2], jtj[3, 3] = h00, h11, h22, h33
    jtj[0, 1] = jtj[1, 0] = h01
    jtj[0, 2] = jtj[2, 0] = h02
    jtj[0, 3] = jtj[3, 0] = h03
    jtj[1, 2] = jtj[2, 1] = h12
    jtj[1, 3] = jtj[3, 1] = h13
    jtj[2, 3] = jtj[3, 2] = h23
    return cost


def normal_equations(z, y, w, a, alpha, Fd, x0):
    """(cost, J^T J, J^T r) of one curve in its four model parameters."""
    jtj = np.empty((4, 4))
    jtr = np.empty(4)
    cost = _normal_equations(z, y, w, a, alpha, Fd, x0, jtj, jtr)
    return cost, jtj, jtr


def model_only(z, a, alpha, Fd, x0):
    """F [N] of one curve at the points z (held at the initial force below x0)."""
    F = np.empty(z.shape[0])
    _model_only(z, a, alpha, Fd, x0, F)
    return F


def model_and_jacobian(z, a, alpha, Fd, x0):
    """(F, J) for one curve: F [N] of shape (n,), J of shape (n, 4) in SLOTS order."""
    F = np.empty(z.shape[0])
    J = np.empty((z.shape[0], 4))
    _model_and_jacobian(z, a, alpha, Fd, x0, F, J)
    return F, J


@dataclass
class GlobalParameter:
    """One parameter the optimiser sees (a model parameter, or a tie of several)."""

    name: str
    value: float
    log: bool
    fixed: bool = False
    lower: float = -math.inf
    upper: float = math.inf
    scale: float = field(default=1.0)

    def __post_init__(self):
        self.scale = abs(self.value) if self.value != 0 else 1.0

    def to_internal(self, value):
        return math.log(value / self.scale) if self.log else value / self.scale

    def from_internal(self, u):
        return self.scale * math.exp(u) if self.log else self.scale * u

    def derivative(self, u):
        """d value / d u."""
        return self.scale * math.exp(u) if self.log else self.scale

    def internal_bounds(self):
        if self.log:
            lower = math.log(self.lower / self.scale) if self.lower > 0 else -math.inf
            upper = math.log(self.upper / self.scale) if math.isfinite(self.upper) else math.inf
            return lower, upper
        return self.lower / self.scale, self.upper / self.scale


@dataclass
class Curve:
    """One data set: abscissa z (slip [m] or time [s]), force y [N], weights w, and its links.

    ``links[m] = (global index, factor)`` for m over SLOTS.
    """

    z: np.ndarray
    y: np.ndarray
    w: np.ndarray
    links: tuple


class Problem:
    """Residuals and Jacobian of a set of curves over the free global parameters."""

    def __init__(self, curves, parameters):
        self.curves = curves
        self.parameters = parameters
        self.free = [i for i, p in enumerate(parameters) if not p.fixed]
        self.ndata = sum(c.z.shape[0] for c in curves)
        forces = np.concatenate([np.abs(c.y) for c in curves])
        self.force_scale = float(np.max(forces)) if forces.size and np.max(forces) > 0 else 1.0
        self._log = np.array([p.log for p in parameters])
        self._scale = np.array([p.scale for p in parameters])
        self._base = np.array([p.value for p in parameters])
        self._links = [
            (np.array([i for i, _ in c.links]), np.array([f for _, f in c.links])) for c in curves
        ]
        # one curve whose slots are the four global parameters in order, factor 1
        self._identity = len(curves) == 1 and [tuple(link) for link in curves[0].links] == [
            (slot, 1.0) for slot in range(4)
        ]
        self._plans = {}

    def natural(self, u, order):
        """Global values with the parameters ``order`` set from internal coordinates ``u``,
        and d value / d u for them."""
        values = self._base.copy()
        scale, log = self._scale[order], self._log[order]
        grow = np.exp(np.where(log, u, 0.0))
        derivative = np.where(log, scale * grow, scale)
        values[order] = np.where(log, scale * grow, scale * u)
        return values, derivative

    def values(self, u_free, pinned=None):
        """Global parameter values from the free internal coordinates (pinned: {index: u})."""
        values = np.array([p.value for p in self.parameters])
        for index, u in zip(self.free, u_free, strict=True):
            values[index] = self.parameters[index].from_internal(u)
        if pinned:
            for index, u in pinned.items():
                values[index] = self.parameters[index].from_internal(u)
        return values

    def internal(self, values=None):
        values = [p.value for p in self.parameters] if values is None else values
        return np.array([self.parameters[i].to_internal(values[i]) for i in self.free])

    def model_params(self, curve, values):
        return [factor * values[index] for index, factor in curve.links]

    def evaluate(self, values, with_jacobian=True):
        """Scaled residuals (n,) and d residual / d global value (n, n_global)."""
        residuals = np.empty(self.ndata)
        jac = np.zeros((self.ndata, len(self.parameters))) if with_jacobian else None
        start = 0
        for curve in self.curves:
            stop = start + curve.z.shape[0]
            params = self.model_params(curve, values)
            if with_jacobian:
                F, J = model_and_jacobian(curve.z, *params)
            else:
                F = model_only(curve.z, *params)
            weight = curve.w / self.force_scale
            residuals[start:stop] = weight * (F - curve.y)
            if with_jacobian:
                for slot, (index, factor) in enumerate(curve.links):
                    jac[start:stop, index] += weight * J[:, slot] * factor
            start = stop
        return residuals, jac

    def fun_and_jac(self, order, pinned=None):
        """Residual and Jacobian callables over the internal coordinates of ``order``."""
        cache = {}

        def compute(u):
            key = u.tobytes()
            if key not in cache:
                cache.clear()
                full = dict(zip(order, u, strict=True))
                if pinned:
                    full.update(pinned)
                values = np.array([p.value for p in self.parameters])
                for index, ui in full.items():
                    values[index] = self.parameters[index].from_internal(ui)
                residuals, jac = self.evaluate(values)
                chain = np.array([self.parameters[i].derivative(full[i]) for i in order])
                cache[key] = (residuals, jac[:, order] * chain)
            return cache[key]

        return (lambda u: compute(u)[0]), (lambda u: compute(u)[1])

    def solve(self, u_start, order=None, pinned=None, max_nfev=200):
        """least_squares from ``u_start`` over ``order`` (default: all free parameters)."""
        order = self.free if order is None else order
        fun, jac = self.fun_and_jac(order, pinned)
        bounds = np.array([self.parameters[i].internal_bounds() for i in order]).T
        u_start = np.clip(u_start, bounds[0] + 1e-12, bounds[1] - 1e-12)
        return least_squares(
            fun,
            u_start,
            jac=jac,
            bounds=(bounds[0], bounds[1]),
            method="trf",
            x_scale="jac",
            xtol=1e-12,
            ftol=1e-12,
            gtol=1e-12,
            max_nfev=max_nfev,
        )

    def normal(self, values):
        """(chi-square, gradient J^T r, J^T J) over all global parameters, natural units."""
        if self._identity:
            curve = self.curves[0]
            cost, jtj, jtr = normal_equations(curve.z, curve.y, curve.w, *values)
            return cost, jtr, jtj
        size = len(self.parameters)
        gradient = np.zeros(size)
        hessian = np.zeros((size, size))
        cost = 0.0
        for curve, (index, factor) in zip(self.curves, self._links, strict=True):
            params = values[index] * factor
            part, jtj, jtr = normal_equations(curve.z, curve.y, curve.w, *params)
            cost += part
            # the four slots of one curve map to four different global parameters
            gradient[index] += jtr * factor
            hessian[np.ix_(index, index)] += jtj * np.outer(factor, factor)
        return cost, gradient, hessian

    def state(self, u, order, pinned=None):
        """(chi-square, gradient, J^T J) in the internal coordinates of ``order``."""
        pinned = pinned or {}
        key = (tuple(order), tuple(pinned))
        plan = self._plans.get(key)
        if plan is None:
            full_order = np.array(list(order) + list(pinned), dtype=int)
            order_array = np.array(order, dtype=int)
            plan = (full_order, order_array, np.ix_(order_array, order_array))
            self._plans[key] = plan
        full_order, order_array, block = plan
        full_u = np.concatenate([u, list(pinned.values())]) if pinned else u
        values, chain = self.natural(full_u, full_order)
        cost, gradient, hessian = self.normal(values)
        chain = chain[: order_array.size]
        return cost, gradient[order_array] * chain, hessian[block] * np.outer(chain, chain)

    def lm(self, u_start, order=None, pinned=None, max_iter=100, rtol=1e-10, damping=1e-2):
        """Levenberg-Marquardt on the normal equations (one fused kernel pass per step).

        Steps are clipped to the search range. Returns (u, chi-square, converged, steps,
        J^T J in internal coordinates at u).
        """
        order = list(self.free if order is None else order)
        bounds = np.array([self.parameters[i].internal_bounds() for i in order]).reshape(-1, 2).T
        u = np.clip(np.array(u_start, dtype=float), bounds[0], bounds[1])

        def state(u):
            return self.state(u, order, pinned)

        cost, g, H = state(u)
        if not (math.isfinite(cost) and np.all(np.isfinite(H))):
            return u, float(cost), False, 1, H
        converged = False
        steps = 0
        while steps < max_iter:
            steps += 1
            diagonal = np.diag(H).copy()
            diagonal[~(diagonal > 0)] = 1.0
            accepted = False
            for _ in range(12):
                try:
                    step = np.linalg.solve(H + damping * np.diag(diagonal), -g)
                except np.linalg.LinAlgError:
                    damping *= 10.0
                    continue
                trial = np.clip(u + step, bounds[0], bounds[1])
                moved = trial - u
                predicted = -float(g @ moved) - 0.5 * float(moved @ H @ moved)
                if 0.0 <= predicted <= 0.1 * rtol * cost:
                    break  # the quadratic model promises nothing worth a pass over the data
                trial_cost, trial_g, trial_H = state(trial)
                if trial_cost <= cost and math.isfinite(trial_cost):
                    accepted = True
                    break
                damping *= 10.0
            if not accepted:
                converged = True  # no descent left at this precision
                break
            decrease = cost - trial_cost
            moved = float(np.max(np.abs(trial - u))) if trial.size else 0.0
            u, cost, g, H = trial, trial_cost, trial_g, trial_H
            damping = max(damping * 0.2, 1e-12)
            if decrease <= rtol * cost or moved < 1e-10:
                converged = True
                break
        return u, float(cost), converged, steps, H

    def chisqr(self, values, stride=1):
        """Weighted sum of squared residuals (every ``stride``-th point only, for ranking)."""
        if stride > 1:
            total = 0.0
            for curve, (index, factor) in zip(self.curves, self._links, strict=True):
                z = np.ascontiguousarray(curve.z[::stride])
                F = model_only(z, *(values[index] * factor))
                total += float(np.sum((curve.w[::stride] * (F - curve.y[::stride])) ** 2))
            return total
        return self._chisqr(values)

    def _chisqr(self, values):
        residuals, _ = self.evaluate(values, with_jacobian=False)
        return float(residuals @ residuals) * self.force_scale**2


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


def profile_interval(
    problem, values, index, variance, chisqr_min, wald_halfwidth_u, internal_hessian=None
):
    """95 % profile-likelihood interval of the global parameter ``index`` (free).

    The boundary is where min over the other parameters of chi-square exceeds its minimum by
    ``3.84 * variance``. The root is found on sqrt(delta chi-square), which is nearly linear
    in the internal coordinate, by the secant method from the Wald estimate.
    Returns ((low, high), exact) with exact False when a side ran into a bound.
    """
    parameter = problem.parameters[index]
    others = [i for i in problem.free if i != index]
    u_hat = parameter.to_internal(values[index])
    lower_u, upper_u = parameter.internal_bounds()
    target = math.sqrt(PROFILE_LEVEL)
    u_others_hat = np.array([problem.parameters[i].to_internal(values[i]) for i in others])
    # how the other parameters follow this one near the optimum: -H_oo^-1 H_oj (internal)
    if internal_hessian is None:
        _, _, internal_hessian = problem.state(problem.internal(values), problem.free)
    position = {i: k for k, i in enumerate(problem.free)}
    rows = [position[i] for i in others]
    H_oo = internal_hessian[np.ix_(rows, rows)]
    H_oj = internal_hessian[rows, position[index]]
    try:
        follow = -np.linalg.solve(H_oo, H_oj) if others else np.zeros(0)
    except np.linalg.LinAlgError:
        follow = np.zeros(len(others))
    ends = []
    exact = True
    for direction in (-1.0, 1.0):
        limit = upper_u if direction > 0 else lower_u
        u_others = u_others_hat.copy()
        u_last = u_hat

        def gap(u, u_others_start, u_last):
            pinned = {index: u}
            if others:
                u_found = u_others_start + follow * (u - u_last)
                chisqr = None
                for _ in range(4):
                    cost, g, H = problem.state(u_found, others, pinned)
                    try:
                        step = np.linalg.solve(H, -g)
                        decrease = -0.5 * float(g @ step)
                    except np.linalg.LinAlgError:
                        break
                    if not (math.isfinite(cost) and decrease >= 0.0):
                        break
                    if decrease < 0.02 * variance:
                        # so close that one Gauss-Newton step's quadratic model gives the
                        # conditional minimum to far better than 1e-3 of 3.84 variance
                        u_found, chisqr = u_found + step, cost - decrease
                        break
                    u_found = u_found + step  # Gauss-Newton converges quadratically here
                if chisqr is None:
                    u_found, chisqr, *_ = problem.lm(
                        u_found, others, pinned, max_iter=30, rtol=1e-9
                    )
            else:
                u_found = u_others_start
                full = np.array([p.value for p in problem.parameters])
                full[index] = parameter.from_internal(u)
                chisqr = problem.chisqr(full)
            rise = max(chisqr - chisqr_min, 0.0) / variance
            return math.sqrt(rise) - target, u_found

        step = max(wald_halfwidth_u, 1e-8)
        points = [(u_hat, -target)]
        u = u_hat + direction * step
        end = None
        for _ in range(12):
            if (direction > 0 and u >= limit) or (direction < 0 and u <= limit):
                u = limit
                value, u_others = gap(u, u_others, u_last)
                u_last = u
                if value < 0:
                    end = limit
                    exact = False
                    break
            else:
                value, u_others = gap(u, u_others, u_last)
            u_last = u
            points.append((u, value))
            if abs(value) < 2e-2:
                end = u
                break
            (u1, g1), (u2, g2) = points[-2], points[-1]
            slope = (g2 - g1) / (u2 - u1) if u2 != u1 else 0.0
            if abs(value) < 0.1 and slope * direction > 0:
                # sqrt(delta chi-square) is nearly linear in u: the secant root is within
                # a small fraction of the tolerance of the true root, no evaluation needed
                end = u2 - g2 / slope
                break
            proposal = u + direction * step if slope * direction <= 0 else u2 - g2 / slope
            # do not jump more than four steps at once, nor back past the estimate
            proposal = min(max(proposal, u - 4 * step), u + 4 * step)
            if (proposal - u_hat) * direction <= 0:
                proposal = u_hat + 0.5 * (u - u_hat)
            u = proposal
        if end is None:
            end = u
            exact = False
        ends.append(parameter.from_internal(end) if math.isfinite(end) else end)
    low, high = ends
    if parameter.log and not math.isfinite(low):
        low = 0.0
    return (float(low), float(high)), exact
