"""Uncertainties of a solved :class:`granflow.fitting.engine.Problem`: the covariance of its
free parameters and their 95 % profile-likelihood intervals.

The covariance is ``variance * (J^T J)^-1`` in natural units (the pseudo-inverse when J^T J is
singular, flagged). A profile interval's ends are where the minimum of chi-square over the
other parameters exceeds its minimum by ``3.84 * variance`` (the 95 % quantile of chi-square
with one degree of freedom); the root is found on sqrt(delta chi-square), nearly linear in the
optimiser's coordinate, by the secant method from the Wald estimate.
"""

import math

import numpy as np
from scipy.stats import chi2 as chi2_distribution

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
                # the tolerance: so close that one Gauss-Newton step's quadratic model gives
                # the conditional minimum to far better than 1e-3 of 3.84 variance
                u_found, chisqr = problem.gauss_newton(u_found, others, pinned, 0.02 * variance)
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
