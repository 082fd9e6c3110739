"""Multistart Levenberg-Marquardt over an engine :class:`~granflow.fitting.engine.Problem`:
the starts ranked by chi-square, solved from the best until the noise is reached, an optional
restart from the optimum, and trust-region reflective where Levenberg-Marquardt does not
converge."""

import math

import numpy as np

from granflow.fitting.engine import Solution

__all__ = ["multistart"]


def multistart(
    problem, starts, noise, *, restart=None, insist=False, rtol=1e-10, tries=None, least=1
):
    """Levenberg-Marquardt from the start with the smallest chi-square, confirmed by the others.

    Parameters
    ----------
    problem : Problem
    starts : sequence of sequence of float
        Candidate global values [SI].
    noise : float
        Point-to-point noise of the data (0 if unknown): when the converged fit leaves a
        residual variance above twice its square, the other starts are tried as well and the
        best optimum is kept.
    restart : callable, optional
        ``restart(values) -> values or None``: one more start derived from the optimum (Eq. 3:
        x0 below the first point). It is pursued when its first step promises a gain, when
        chi-square exceeds what the noise allows (5 standard deviations of chi-square plus the
        error of the noise estimate), or always with ``insist``.

    rtol : float
        Levenberg-Marquardt stops when a step gains less than this fraction of chi-square.
    tries : int, optional
        At most this many starts are solved (the best ranked); default all, as needed.
    least : int
        At least this many starts are solved (the best ranked), however good the first
        optimum looks (a likelihood with branches whose optima all fit to the noise).

    Returns
    -------
    Solution
        Its ``optima``: each solved start's optimum. If LM does not converge, scipy's
        least_squares (trust-region reflective) takes over.
    """
    ranked = []
    for start in starts:
        u = problem.internal(list(start))
        cost = problem.chisqr(problem.values(u), stride=8)
        ranked.append((cost if math.isfinite(cost) else math.inf, u))
    ranked.sort(key=lambda item: item[0])
    dof = max(problem.ndata - len(problem.free), 1)
    expected = 2.0 * noise**2 * dof
    best, nfev, optima = None, len(starts), []
    for count, (_, u_start) in enumerate(ranked, start=1):
        u, cost, converged, steps, hessian = problem.lm(u_start, max_iter=200, rtol=rtol)
        nfev += steps
        optima.append((u, cost))
        if best is None or cost < best[1]:
            best = (u, cost, converged, count, hessian)
        if noise > 0 and best[1] <= expected and count >= least:
            break
        if tries is not None and count >= tries:
            break
    u, cost, converged, tried, hessian = best
    values = None if restart is None else restart(problem.values(u))
    start = None if values is None else problem.internal(values)
    if start is not None and problem.free:
        start_cost, g, H = problem.state(start, problem.free)
        nfev += 1
        try:
            promised = start_cost + 0.5 * float(g @ np.linalg.solve(H, -g))
        except np.linalg.LinAlgError:
            promised = -math.inf
        implausible = noise <= 0 or cost > (1.0 + 10.0 / math.sqrt(dof)) * dof * noise**2
        if promised < cost or implausible or insist:
            u_new, cost_new, converged_new, steps, hessian_new = problem.lm(
                start, max_iter=200, rtol=rtol
            )
            nfev += steps
            if cost_new < cost:
                u, cost, converged, hessian = u_new, cost_new, converged_new, hessian_new
    if converged:
        message = f"converged (Levenberg-Marquardt, {tried} of {len(starts)} starts)"
        return Solution(u, 1, message, nfev, hessian, tuple(optima))
    try:
        solution = problem.solve(u)
    except ValueError as exc:  # e.g. residuals that are not finite at the start
        return Solution(u, 0, f"the optimiser failed: {exc}", nfev)
    return Solution(solution.x, solution.status, solution.message, nfev + solution.nfev)
