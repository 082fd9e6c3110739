"""Gauss-Newton's full steps for a :class:`~granflow.fitting.engine.Problem` (its Python
passes; the compiled Eq. 3 problem has its own in ``_eq3_solver``): the descent from a start
next to a minimum, kept inside the parameters' bounds, and, with parameters pinned, the
envelope theorem's derivatives of the minimum with respect to them."""

import math

import numpy as np

__all__ = ["bounded_step", "gauss_newton"]


def bounded_step(u, g, H, bounds):
    """The Gauss-Newton step from ``u`` kept inside ``bounds`` ((k, 2), internal): a
    parameter that the free step would push through its bound is held there (on it, or
    moved onto it) and the step re-solved over the others. None where a system is
    singular."""
    if not u.size:
        return np.zeros(0)
    try:
        step = np.linalg.solve(H, -g)
    except np.linalg.LinAlgError:
        return None
    target = u + step
    if not (np.any(target < bounds[:, 0]) or np.any(target > bounds[:, 1])):
        return step  # the free step stays inside: the common case, without the bookkeeping
    free = np.ones(u.size, dtype=bool)
    step = np.zeros(u.size)
    for _ in range(u.size + 1):
        index = np.flatnonzero(free)
        if not index.size:
            return step
        held = ~free
        rhs = -g[index] - H[np.ix_(index, held)] @ step[held]
        try:
            step[index] = np.linalg.solve(H[np.ix_(index, index)], rhs)
        except np.linalg.LinAlgError:
            return None
        target = u + step
        low, high = target < bounds[:, 0], target > bounds[:, 1]
        outside = (low | high) & free
        if not outside.any():
            return step
        step[low & free] = bounds[low & free, 0] - u[low & free]
        step[high & free] = bounds[high & free, 1] - u[high & free]
        free &= ~outside
    return step


def gauss_newton(problem, u_start, order, pinned, tolerance, max_steps=4, envelope=False):
    """:meth:`~granflow.fitting.engine.Problem.gauss_newton` by Python passes over
    ``problem`` (see there for the arguments and what is returned). With ``envelope`` each
    pass's sums run over the pinned coordinates too (the same pass), and the last one gives
    the minimum's derivatives with respect to them."""
    k = len(order)
    held = np.array(list(pinned.values()), dtype=float)
    full_order = list(order) + list(pinned)
    bounds = np.array([problem.parameters[i].internal_bounds() for i in order]).reshape(-1, 2)
    u = np.clip(np.asarray(u_start, dtype=float), bounds[:, 0], bounds[:, 1])
    previous = math.inf
    for _ in range(max_steps):
        if envelope:
            cost, gradient, hessian = problem.state(np.concatenate([u, held]), full_order)
            g, H = gradient[:k], hessian[:k, :k]
        else:
            cost, g, H = problem.state(u, order, pinned)
        if cost > previous:
            break  # the quadratic model failed: a full step went uphill
        previous = cost
        step = bounded_step(u, g, H, bounds)
        if step is None:
            break
        decrease = -float(g @ step) - 0.5 * float(step @ H @ step)
        if not (math.isfinite(cost) and decrease >= 0.0):
            break
        u = u + step
        if decrease < tolerance:
            if not envelope:
                return u, cost - decrease
            # g is half chi-square's gradient: the step's model lowers chi-square by twice
            # ``decrease`` (the path above, older, keeps its own reading)
            # the gradient carried to the minimum by the step's linear model
            slopes = 2.0 * (gradient[k:] + hessian[k:, :k] @ step)
            try:
                response = -np.linalg.solve(H, hessian[:k, k:])
            except np.linalg.LinAlgError:
                response = np.full((k, len(pinned)), np.nan)
            return u, cost - 2.0 * decrease, slopes, response
    return (u, None, None, None) if envelope else (u, None)
