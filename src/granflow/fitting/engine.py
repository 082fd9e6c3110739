"""The least-squares engine behind every fit: one curve or many, with parameters tied by name.

A fit is a :class:`Model` -- a function and its Jacobian over named slots, optionally with a
fused one-pass kernel for the normal equations -- fitted to a list of curves (abscissa z,
data y, weights w) through a list of global parameters: each curve's model slots are
``factor * global`` for one global parameter each. A single fit is the case of one curve and
the identity map; joint fits tie parameters by name; Amontons fits use the normal load as the
factor of a and Fd. :data:`EQ3` is Eq. 3 (slots a, alpha, Fd, x0 -- or a, k, Fd, t0 in the
time domain, the same mathematics with z = t), whose fused pass
(:func:`granflow.model.kernel.normal_equations`) makes its fits ten times faster than
``curve_fit``; the creep law and the comparison models are :class:`Model` s too.

The optimiser (Levenberg-Marquardt on the normal equations, trust-region reflective as the
fallback) works in transformed coordinates: scale parameters (declared ``log``) as
``log(value / scale)``, the others as ``value / scale``. x0 sits next to the logarithmic
singularity of Ei, where a log coordinate keeps the problem well scaled.

Data below x0 (Eq. 3): points of the fit window that fall below the current x0 are compared
with the initial force F(x0) (``below="hold"`` of the kernel), so the objective is a
continuous function of x0 and no point ever leaves or enters the sum.
"""

import math
from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import least_squares

from granflow.fitting import _eq3_solver, descent
from granflow.fitting.results import FrozenMap as FrozenMap  # re-exported for callers
from granflow.model import kernel
from granflow.model.special import compiled

SLOTS = ("a", "alpha", "Fd", "x0")
#: The fewest points a strided chi-square (ranking starts) reads.
_RANKED = 64


@dataclass(frozen=True)
class Model:
    """A model the engine fits: a function of the abscissa and named parameters, its Jacobian.

    Parameters
    ----------
    slots : tuple of str
        The parameter names, in the order the functions take them.
    function : callable
        ``function(z, *values) -> F`` (n,).
    jacobian : callable
        ``jacobian(z, *values) -> (F, J)`` with J of shape (n, len(slots)).
    log : tuple of bool
        Per slot: optimise in ``log(value)`` (positive scale parameters).
    normal : callable, optional
        A fused pass ``normal(z, y, w, *values) -> (cost, J^T J, J^T r)`` with r = w (F - y);
        default: built from ``jacobian``.
    """

    slots: tuple
    function: object
    jacobian: object
    log: tuple
    normal: object = None

    def normal_equations(self, z, y, w, *values):
        """(cost, J^T J, J^T r) of one curve in the model's slots."""
        if self.normal is not None:
            return self.normal(z, y, w, *values)
        F, J = self.jacobian(z, *values)
        return normal_sums(
            np.ascontiguousarray(J, dtype=float),
            np.ascontiguousarray(F, dtype=float),
            np.ascontiguousarray(y, dtype=float),
            np.ascontiguousarray(w, dtype=float),
        )


@compiled
def normal_sums(jacobian, model, data, weights):
    """(cost, J^T J, J^T r) with r = w (model - data) and the rows of J weighted by w, summed
    in one compiled pass: no BLAS call, whose threads cost more than these small products on
    a loaded machine."""
    size, k = jacobian.shape
    jtj = np.zeros((k, k))
    jtr = np.zeros(k)
    cost = 0.0
    for i in range(size):
        w = weights[i]
        r = w * (model[i] - data[i])
        cost += r * r
        for a in range(k):
            ja = w * jacobian[i, a]
            jtr[a] += ja * r
            for b in range(a, k):
                jtj[a, b] += ja * w * jacobian[i, b]
    for a in range(k):
        for b in range(a):
            jtj[a, b] = jtj[b, a]
    return cost, jtj, jtr


def _eq3_normal(z, y, w, a, alpha, Fd, x0):
    jtj = np.empty((4, 4))
    jtr = np.empty(4)
    cost = kernel.normal_equations(z, y, w, a, alpha, Fd, x0, jtj, jtr)
    return cost, jtj, jtr


def model_only(z, a, alpha, Fd, x0):
    """F [N] of Eq. 3 (paper initial condition) at the points z, held at F(x0) below x0."""
    F = np.empty(z.shape[0])
    kernel.eq3_values(z, 1.0, -math.inf, x0, a, alpha, Fd, x0, 0.0, True, True, F)
    return F


def model_and_jacobian(z, a, alpha, Fd, x0):
    """(F, J) of Eq. 3 at z: F [N] of shape (n,), J of shape (n, 4) in SLOTS order."""
    F = np.empty(z.shape[0])
    J = np.empty((z.shape[0], 5))
    kernel.jacobian_loop(z, a, alpha, Fd, x0, 0.0, True, True, F, J)
    return F, J[:, :4]


def normal_equations(z, y, w, a, alpha, Fd, x0):
    """(cost, J^T J, J^T r) of one curve of Eq. 3 in its four parameters."""
    return _eq3_normal(z, y, w, a, alpha, Fd, x0)


#: Eq. 3 with the paper's initial condition, held at F(x0) below x0.
EQ3 = Model(
    slots=SLOTS,
    function=model_only,
    jacobian=model_and_jacobian,
    log=(False, True, False, True),
    normal=_eq3_normal,
)


@dataclass
class Solution:
    """Where the optimiser stopped: internal coordinates x of the free parameters, status
    (> 0 converged), message, model evaluations and J^T J in internal coordinates when known;
    ``optima``, every start's optimum as ``(x, chi-square)`` (a multistart's other minima)."""

    x: np.ndarray
    status: int
    message: str
    nfev: int
    hessian: np.ndarray | None = None
    optima: tuple = ()


def _exp(u):
    """exp(u), +inf past float64's range (a profile walked off to an unbounded end) instead
    of math.exp's OverflowError."""
    return math.exp(u) if u < 709.0 else math.inf


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
        return self.scale * _exp(u) if self.log else self.scale * u

    def derivative(self, u):
        """d value / d u."""
        return self.scale * _exp(u) if self.log else self.scale

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
    """Residuals and Jacobian of a set of curves over the free global parameters.

    ``model`` is the :class:`Model` every curve follows (default :data:`EQ3`).

    ``rough`` marks a likelihood with faces and cliffs (a creeping staircase's: its best
    curve often lies on its box's face, Fd = 0, and its edges' fit moves a burst of creep
    across the samples):
    Levenberg-Marquardt then keeps the coordinates a bound holds still (:meth:`lm`), and a
    profile's end search keeps the crossing it has bracketed
    (:func:`~granflow.fitting.profile_search.search_side`). The compiled solver of a single
    Eq. 3 curve has no such likelihood and ignores it.

    ``penalty`` (optional) adds standardised residuals that are not data: Gaussian priors on
    parameters or on quantities derived from them, and standard-normal nuisance coordinates.
    It is ``penalty(values) -> (residuals, jacobian)`` over all global values (natural
    units): residuals of shape (m,) and their derivatives, shape (m, n_global). They enter
    chi-square, its gradient and J^T J as they are (not scaled by the data's weights), so the
    data's weights must standardise the data too (``w = 1 / sigma``) for the sum to be a
    log-likelihood.
    """

    def __init__(self, curves, parameters, model=None, penalty=None, rough=False):
        self.model = EQ3 if model is None else model
        self.penalty = penalty
        self.rough = rough
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
        # one curve whose slots are the global parameters in order, factor 1
        self._identity = len(curves) == 1 and [tuple(link) for link in curves[0].links] == [
            (slot, 1.0) for slot in range(len(parameters))
        ]
        self._plans = {}
        self._strided = {}  # stride: every stride-th point of each curve, for chisqr
        # one Eq. 3 curve whose slots are the global parameters: the compiled solver's case
        self._compiled = self._identity and self.model is EQ3 and penalty is None
        if self._compiled:
            curve = curves[0]
            data = (curve.z, curve.y, curve.w)
            self._data = tuple(np.ascontiguousarray(a, dtype=float) for a in data)

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
                F, J = self.model.jacobian(curve.z, *params)
            else:
                F = self.model.function(curve.z, *params)
            weight = curve.w / self.force_scale
            residuals[start:stop] = weight * (F - curve.y)
            if with_jacobian:
                for slot, (index, factor) in enumerate(curve.links):
                    jac[start:stop, index] += weight * J[:, slot] * factor
            start = stop
        if self.penalty is not None:
            extra, extra_jac = self.penalty(values)
            residuals = np.concatenate([residuals, np.asarray(extra) / self.force_scale])
            if with_jacobian:
                jac = np.vstack([jac, np.asarray(extra_jac) / self.force_scale])
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

    def solve_from(self, u_start, *, max_iter=200, rtol=1e-10, max_nfev=200, label=""):
        """Levenberg-Marquardt from ``u_start``; trust-region reflective if it does not converge.

        Returns a :class:`Solution` (``label`` is added to the message, e.g. the starts tried).
        """
        u, _, converged, steps, hessian = self.lm(u_start, max_iter=max_iter, rtol=rtol)
        if converged:
            return Solution(u, 1, f"converged (Levenberg-Marquardt{label})", steps, hessian)
        try:
            solution = self.solve(u, max_nfev=max_nfev)
        except ValueError as exc:  # e.g. residuals that are not finite at the start
            return Solution(u, 0, f"the optimiser failed: {exc}", steps)
        return Solution(solution.x, solution.status, solution.message, steps + solution.nfev)

    def normal(self, values):
        """(chi-square, gradient J^T r, J^T J) over all global parameters, natural units."""
        normal = self.model.normal_equations
        if self._identity:
            curve = self.curves[0]
            cost, jtj, jtr = normal(curve.z, curve.y, curve.w, *values)
            return self._penalised(values, cost, jtr, jtj)
        size = len(self.parameters)
        gradient = np.zeros(size)
        hessian = np.zeros((size, size))
        cost = 0.0
        for curve, (index, factor) in zip(self.curves, self._links, strict=True):
            params = values[index] * factor
            part, jtj, jtr = normal(curve.z, curve.y, curve.w, *params)
            cost += part
            # the four slots of one curve map to four different global parameters
            gradient[index] += jtr * factor
            hessian[np.ix_(index, index)] += jtj * np.outer(factor, factor)
        return self._penalised(values, cost, gradient, hessian)

    def _penalised(self, values, cost, gradient, hessian):
        """(cost, gradient, J^T J) with the penalty's residuals added."""
        if self.penalty is None:
            return cost, gradient, hessian
        extra, extra_jac = self.penalty(values)
        return (
            cost + float(extra @ extra),
            gradient + extra_jac.T @ extra,
            hessian + extra_jac.T @ extra_jac,
        )

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
        if self._compiled:
            return _eq3_solver.eq3_state(
                *self._data,
                self._base,
                self._scale,
                self._log,
                full_order,
                np.asarray(full_u, dtype=float),
                order_array.size,
            )
        values, chain = self.natural(full_u, full_order)
        cost, gradient, hessian = self.normal(values)
        chain = chain[: order_array.size]
        return cost, gradient[order_array] * chain, hessian[block] * np.outer(chain, chain)

    def gauss_newton(self, u_start, order, pinned, tolerance, max_steps=4, envelope=False):
        """Minimum of chi-square over ``order`` (``pinned`` held) next to ``u_start``.

        At most ``max_steps`` Gauss-Newton steps (it converges quadratically there), until a
        step's predicted decrease is below ``tolerance``. Returns (u, chi-square), with
        chi-square None when it did not get there (a singular or non-finite step).

        With ``envelope``, returns (u, chi-square, slopes, response): the derivatives of
        the minimum's chi-square with respect to the pinned coordinates (by the envelope
        theorem, ``2 (g_p + H_po step)`` from the last pass, the step's linear model
        carrying the gradient to the minimum) and how the minimum moves with them as
        Gauss-Newton's model has it (``-H_oo^-1 H_op``, H = J^T J without the residuals'
        curvature; one column per pinned coordinate), both internal; None where chi-square
        is. The same passes: the pinned rows come with each pass's sums.
        """
        if self._compiled and not envelope:
            full_order = np.array(list(order) + list(pinned), dtype=np.int64)
            start = np.concatenate([np.asarray(u_start, dtype=float), list(pinned.values())])
            u, chisqr, found = _eq3_solver.eq3_gauss_newton(
                *self._data,
                self._base,
                self._scale,
                self._log,
                full_order,
                start,
                len(order),
                tolerance,
                max_steps,
            )
            return u, (float(chisqr) if found else None)
        return descent.gauss_newton(self, u_start, order, pinned, tolerance, max_steps, envelope)

    def lm(self, u_start, order=None, pinned=None, max_iter=100, rtol=1e-10, damping=1e-2):
        """Levenberg-Marquardt on the normal equations (one fused kernel pass per step).

        Steps are clipped to the search range. Returns (u, chi-square, converged, steps,
        J^T J in internal coordinates at u).
        """
        order = list(self.free if order is None else order)
        bounds = np.array([self.parameters[i].internal_bounds() for i in order]).reshape(-1, 2).T
        if self._compiled:
            pinned = pinned or {}
            full_order = np.array(order + list(pinned), dtype=np.int64)
            start = np.concatenate([np.asarray(u_start, dtype=float), list(pinned.values())])
            u, cost, converged, steps, hessian = _eq3_solver.eq3_lm(
                *self._data,
                self._base,
                self._scale,
                self._log,
                full_order,
                start,
                len(order),
                np.ascontiguousarray(bounds[0]),
                np.ascontiguousarray(bounds[1]),
                max_iter,
                rtol,
                damping,
            )
            return u, float(cost), bool(converged), int(steps), hessian
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
            moving = self._moving(u, g, bounds)
            accepted = False
            for _ in range(12):
                try:
                    step = np.zeros(u.size)
                    system = (H + damping * np.diag(diagonal))[np.ix_(moving, moving)]
                    step[moving] = np.linalg.solve(system, -g[moving])
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

    def _moving(self, u, g, bounds):
        """The coordinates a Levenberg-Marquardt step moves: all of them, or with
        ``rough`` those not held at a bound by a gradient pointing out of the box
        (a step solved with them in is clipped back to a crawl along the bound: a likelihood
        whose best curve lies on its box's face, such as Fd = 0, never converges)."""
        if not self.rough:
            return np.ones(u.size, dtype=bool)
        held = ((u <= bounds[0]) & (g > 0)) | ((u >= bounds[1]) & (g < 0))
        return ~held

    def best_fit(self, values):
        """The model of each curve at its points, for the global values ``values``."""
        return [
            self.model.function(curve.z, *(values[index] * factor))
            for curve, (index, factor) in zip(self.curves, self._links, strict=True)
        ]

    def chisqr(self, values, stride=1):
        """Weighted sum of squared residuals (every ``stride``-th point only, for ranking;
        every point where that would leave fewer than 64: a staircase's few steps, each one
        point of its grouped record, are not ranked by one of them)."""
        stride = min(stride, max(self.ndata // _RANKED, 1))
        if stride > 1:
            if stride not in self._strided:
                self._strided[stride] = [
                    tuple(np.ascontiguousarray(a[::stride]) for a in (c.z, c.y, c.w))
                    for c in self.curves
                ]
            total = 0.0
            for (z, y, w), (index, factor) in zip(self._strided[stride], self._links, strict=True):
                residuals = w * (self.model.function(z, *(values[index] * factor)) - y)
                total += float(residuals @ residuals)
            if self.penalty is not None:
                extra = self.penalty(values)[0]
                total += float(extra @ extra)
            return total
        return self._chisqr(values)

    def _chisqr(self, values):
        residuals, _ = self.evaluate(values, with_jacobian=False)
        return float(residuals @ residuals) * self.force_scale**2
