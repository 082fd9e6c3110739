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
from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import least_squares
from scipy.stats import chi2 as chi2_distribution

from granflow.special import _jit, _scaled_ei_diff_scalar, _scaled_ei_scalar

SLOTS = ("a", "alpha", "Fd", "x0")
_SMALL_S = 0.5
PROFILE_LEVEL = float(chi2_distribution.ppf(0.95, 1))  # 3.841...
WALD_Z = 1.959963984540054


class FrozenMap(Mapping):
    """A read-only mapping that, unlike ``types.MappingProxyType``, can be pickled (results
    travel between processes in batch fits)."""

    __slots__ = ("_data",)

    def __init__(self, data=()):
        object.__setattr__(self, "_data", dict(data))

    def __getitem__(self, key):
        return self._data[key]

    def __iter__(self):
        return iter(self._data)

    def __len__(self):
        return len(self._data)

    def __repr__(self):
        return f"FrozenMap({self._data!r})"

    def __reduce__(self):
        return (FrozenMap, (self._data,))


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
        zi = z[i]
        if zi <= x0:
            F[i] = Fd * start_rise
            J[i, 0] = 0.0
            J[i, 1] = Fd * x0 * exp_minus_s0
            J[i, 2] = start_rise
            J[i, 3] = Fd * alpha * exp_minus_s0
            continue
        s = alpha * zi
        decay = math.exp(s0 - s)
        diff = _scaled_ei_diff_scalar(s, s0, scaled_ei_s0, decay)
        exp_minus_s = decay * exp_minus_s0
        rise_s = -math.expm1(-s) if s < _SMALL_S else 1.0 - exp_minus_s
        rise_h = -math.expm1(s0 - s)
        F[i] = a * diff + Fd * rise_s
        J[i, 0] = diff
        J[i, 1] = a * (rise_h / alpha - zi * diff) + Fd * zi * exp_minus_s
        J[i, 2] = rise_s
        J[i, 3] = -a * decay / x0


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
            F, J = model_and_jacobian(curve.z, *self.model_params(curve, values))
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

    def refine(self, u_start, order, pinned, max_iter=30):
        """Levenberg-Marquardt from a nearby start (profile steps): cheaper than least_squares.

        Steps that would leave the search range are clipped to it; the best point seen is
        returned.
        """
        fun, jac = self.fun_and_jac(order, pinned)
        bounds = np.array([self.parameters[i].internal_bounds() for i in order]).T
        u = np.clip(np.array(u_start, dtype=float), bounds[0], bounds[1])
        residuals = fun(u)
        cost = residuals @ residuals
        damping = 1e-3
        for _ in range(max_iter):
            J = jac(u)
            gradient = J.T @ residuals
            hessian = J.T @ J
            diagonal = np.diag(hessian).copy()
            diagonal[diagonal == 0] = 1.0
            improved = False
            for _ in range(10):
                try:
                    step = np.linalg.solve(hessian + damping * np.diag(diagonal), -gradient)
                except np.linalg.LinAlgError:
                    damping *= 10.0
                    continue
                trial = np.clip(u + step, bounds[0], bounds[1])
                trial_residuals = fun(trial)
                trial_cost = trial_residuals @ trial_residuals
                if trial_cost < cost:
                    improved = True
                    break
                damping *= 10.0
            if not improved:
                break
            decrease = cost - trial_cost
            u, residuals, cost = trial, trial_residuals, trial_cost
            damping = max(damping / 10.0, 1e-12)
            if decrease <= 1e-10 * cost:
                break
        return u, float(cost) * self.force_scale**2

    def chisqr(self, values):
        residuals, _ = self.evaluate(values, with_jacobian=False)
        return float(residuals @ residuals) * self.force_scale**2


def covariance(problem, values, variance):
    """Covariance of the free global parameter values: variance * (J^T J)^-1 (natural units).

    Returns (covariance, ok); the pseudo-inverse is used when J^T J is singular (ok False).
    """
    _, jac = problem.evaluate(values)
    jac = jac[:, problem.free] * problem.force_scale
    norms = np.sqrt(np.sum(jac**2, axis=0))
    norms[norms == 0] = 1.0
    scaled = jac / norms
    hessian = scaled.T @ scaled
    ok = bool(np.all(np.isfinite(hessian)))
    if ok and np.linalg.cond(hessian) < 1e14:
        inverse = np.linalg.inv(hessian)
    else:
        ok = False
        inverse = np.linalg.pinv(hessian) if np.all(np.isfinite(hessian)) else hessian * np.nan
    return variance * inverse / np.outer(norms, norms), ok


def profile_interval(problem, values, index, variance, chisqr_min, wald_halfwidth_u):
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
    ends = []
    exact = True
    for direction in (-1.0, 1.0):
        limit = upper_u if direction > 0 else lower_u
        u_others = u_others_hat.copy()

        def gap(u, u_others_start):
            pinned = {index: u}
            if others:
                u_found, chisqr = problem.refine(u_others_start, others, pinned)
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
                value, u_others = gap(u, u_others)
                if value < 0:
                    end = limit
                    exact = False
                    break
            else:
                value, u_others = gap(u, u_others)
            points.append((u, value))
            if abs(value) < 1e-3:
                end = u
                break
            (u1, g1), (u2, g2) = points[-2], points[-1]
            slope = (g2 - g1) / (u2 - u1) if u2 != u1 else 0.0
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
