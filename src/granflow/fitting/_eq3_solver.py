"""Levenberg-Marquardt on one Eq. 3 curve, compiled: the single fit's inner loop without Python.

:meth:`granflow.fitting.engine.Problem.lm` and :meth:`~granflow.fitting.engine.Problem.state`
run here when the problem is one curve of :data:`~granflow.fitting.engine.EQ3` with its four
slots as the global parameters (every single fit, and its profile intervals). The algorithm is
the engine's, step for step; only the Python around each fused pass over the data
(:func:`granflow.model.kernel.normal_equations`) and the 4 x 4 solves is gone.

Internal coordinates: parameter j is ``scale[j] exp(u)`` where ``log[j]``, else ``scale[j] u``.
``order`` lists the parameters the optimiser moves, followed by the pinned ones (held at
their coordinate in ``u``); ``moving`` of them move.
"""

import math

import numpy as np

from granflow.model.kernel import normal_equations
from granflow.model.special import compiled

__all__ = ["eq3_gauss_newton", "eq3_lm", "eq3_state"]


@compiled
def eq3_state(z, y, w, base, scale, log, order, u, moving):
    """(chi-square, gradient, J^T J) over the first ``moving`` parameters of ``order``, in
    internal coordinates, at the coordinates ``u`` of every parameter of ``order``."""
    values = base.copy()
    chain = np.empty(moving)
    for k in range(order.shape[0]):
        j = order[k]
        grow = math.exp(u[k]) if log[j] else 1.0
        values[j] = scale[j] * grow if log[j] else scale[j] * u[k]
        if k < moving:
            chain[k] = scale[j] * grow
    jtj = np.empty((4, 4))
    jtr = np.empty(4)
    cost = normal_equations(z, y, w, values[0], values[1], values[2], values[3], jtj, jtr)
    gradient = np.empty(moving)
    hessian = np.empty((moving, moving))
    for k in range(moving):
        gradient[k] = jtr[order[k]] * chain[k]
        for m in range(moving):
            hessian[k, m] = jtj[order[k], order[m]] * chain[k] * chain[m]
    return cost, gradient, hessian


@compiled
def _solve(matrix, rhs):
    """x with matrix x = rhs by Gaussian elimination with partial pivoting; (x, False) when
    a pivot is exactly zero (numpy.linalg.solve's LinAlgError)."""
    n = rhs.shape[0]
    a = matrix.copy()
    b = rhs.copy()
    for col in range(n):
        pivot = col
        for row in range(col + 1, n):
            if abs(a[row, col]) > abs(a[pivot, col]):
                pivot = row
        if a[pivot, col] == 0.0:
            return b, False
        if pivot != col:
            for m in range(n):
                a[col, m], a[pivot, m] = a[pivot, m], a[col, m]
            b[col], b[pivot] = b[pivot], b[col]
        for row in range(col + 1, n):
            factor = a[row, col] / a[col, col]
            for m in range(col, n):
                a[row, m] -= factor * a[col, m]
            b[row] -= factor * b[col]
    for row in range(n - 1, -1, -1):
        total = b[row]
        for m in range(row + 1, n):
            total -= a[row, m] * b[m]
        b[row] = total / a[row, row]
    return b, True


@compiled
def eq3_lm(
    z, y, w, base, scale, log, order, u_start, moving, lower, upper, max_iter, rtol, damping
):
    """Levenberg-Marquardt over the first ``moving`` parameters of ``order`` (the others
    pinned at their coordinate in ``u_start``) from the damping ``damping``; steps clipped
    to [lower, upper].

    Returns (u of the moving parameters, chi-square, converged, steps, J^T J at u), as
    :meth:`granflow.fitting.engine.Problem.lm`.
    """
    full = u_start.copy()
    for k in range(moving):
        full[k] = min(max(full[k], lower[k]), upper[k])
    cost, g, H = eq3_state(z, y, w, base, scale, log, order, full, moving)
    finite = math.isfinite(cost)
    for k in range(moving):
        for m in range(moving):
            finite = finite and math.isfinite(H[k, m])
    if not finite:
        return full[:moving].copy(), cost, False, 1, H
    converged = False
    steps = 0
    trial = full.copy()
    while steps < max_iter:
        steps += 1
        diagonal = np.empty(moving)
        for k in range(moving):
            diagonal[k] = H[k, k] if H[k, k] > 0 else 1.0
        accepted = False
        trial_cost, trial_g, trial_H = cost, g, H
        for _ in range(12):
            damped = H.copy()
            for k in range(moving):
                damped[k, k] += damping * diagonal[k]
            step, ok = _solve(damped, -g)
            if not ok:
                damping *= 10.0
                continue
            predicted = 0.0
            for k in range(moving):
                trial[k] = min(max(full[k] + step[k], lower[k]), upper[k])
            for k in range(moving):
                moved_k = trial[k] - full[k]
                predicted -= g[k] * moved_k
                for m in range(moving):
                    predicted -= 0.5 * moved_k * H[k, m] * (trial[m] - full[m])
            if 0.0 <= predicted <= 0.1 * rtol * cost:
                break  # the quadratic model promises nothing worth a pass over the data
            trial_cost, trial_g, trial_H = eq3_state(
                z, y, w, base, scale, log, order, trial, moving
            )
            if trial_cost <= cost and math.isfinite(trial_cost):
                accepted = True
                break
            damping *= 10.0
        if not accepted:
            converged = True  # no descent left at this precision
            break
        decrease = cost - trial_cost
        moved = 0.0
        for k in range(moving):
            moved = max(moved, abs(trial[k] - full[k]))
        full[:moving] = trial[:moving]
        cost, g, H = trial_cost, trial_g, trial_H
        damping = max(damping * 0.2, 1e-12)
        if decrease <= rtol * cost or moved < 1e-10:
            converged = True
            break
    return full[:moving].copy(), cost, converged, steps, H


@compiled
def eq3_gauss_newton(z, y, w, base, scale, log, order, u_start, moving, tolerance, max_steps):
    """The minimum of chi-square over the first ``moving`` parameters of ``order`` next to
    ``u_start``, by at most ``max_steps`` Gauss-Newton steps.

    Returns (u, chi-square, found): found once a step's predicted decrease falls below
    ``tolerance`` (chi-square is then the quadratic model's minimum); as
    :meth:`granflow.fitting.engine.Problem.gauss_newton`.
    """
    full = u_start.copy()
    for _ in range(max_steps):
        cost, g, H = eq3_state(z, y, w, base, scale, log, order, full, moving)
        minus_g = -g
        step, ok = _solve(H, minus_g)
        if not ok:
            break
        decrease = 0.0
        for k in range(moving):
            decrease -= 0.5 * g[k] * step[k]
        if not (math.isfinite(cost) and decrease >= 0.0):
            break
        for k in range(moving):
            full[k] += step[k]
        if decrease < tolerance:
            return full[:moving].copy(), cost - decrease, True
    return full[:moving].copy(), math.nan, False
