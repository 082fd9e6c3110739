"""The optimisation of a rate-and-state fit: Levenberg-Marquardt from a ranked grid of starts.

:func:`optimise` runs :func:`multistart` on the problem of
:class:`granflow.fitting.rsf_problem.Setup`, numbers two states of one law by their Dc
(:func:`in_order`) and adds the apparatus ripple where asked
(:func:`granflow.fitting.rsf_problem.with_periodic`). Whether the end is the minimum is
checked afterwards (:mod:`granflow.fitting.rsf_convergence`).
"""

import dataclasses
import math

import numpy as np

from granflow.fitting.engine import Solution
from granflow.fitting.rsf_problem import with_periodic

__all__ = ["MAX_STEPS", "STARTS_RUN", "in_order", "multistart", "optimise"]

#: Levenberg-Marquardt steps from one start.
MAX_STEPS = 60
#: Levenberg-Marquardt runs from at most this many of the best-ranked other starts.
STARTS_RUN = 3


def optimise(setup, starts, noise, sigma, periodic, terms):
    """(names, problem, solution) of Levenberg-Marquardt from the starts, then with the
    ripple when asked for."""
    scaled_noise = noise * (1.0 if sigma is None else 1.0 / sigma)
    problem = setup.problem(starts[0], harmonics=0)
    solution = multistart(problem, starts, scaled_noise)
    problem, solution = in_order(setup, problem, solution)
    # model evaluations, not Levenberg-Marquardt steps (a step may try several)
    solution = dataclasses.replace(solution, nfev=setup.evaluations)
    names = list(setup.names)
    if terms:
        load_point = np.concatenate([w.position for w in setup.record])
        names, problem, solution = with_periodic(
            setup, problem, solution, periodic, terms, load_point
        )
    return names, problem, solution


def in_order(setup, problem, solution):
    """(problem, solution) with two states of one law numbered by their Dc, the shorter
    first: the model is the same with the two exchanged, and a fit that ended with them the
    other way round would report b1 and Dc1 for the longer one (its intervals then miss the
    truth they were meant for). The exchanged values start a problem of their own (whose
    scales follow them) and Levenberg-Marquardt confirms the minimum there."""
    names = setup.names
    laws = setup.record[0].laws
    if len(laws) != 2 or laws[0] != laws[1] or any(n in setup.fixed for n in names[2:6]):
        return problem, solution
    values = dict(zip(names, problem.values(solution.x), strict=True))
    if values["Dc1"] <= values["Dc2"]:
        return problem, solution
    for first, second in (("b1", "b2"), ("Dc1", "Dc2")):
        values[first], values[second] = values[second], values[first]
    start = [values[n] for n in names]
    exchanged = setup.problem(start, harmonics=0)
    u, _, converged, steps, hessian = exchanged.lm(
        exchanged.internal(start), max_iter=MAX_STEPS, rtol=1e-9
    )
    status = solution.status if converged else 0
    message = f"{solution.message}; states numbered by Dc"
    return exchanged, Solution(u, status, message, solution.nfev + steps, hessian)


def multistart(problem, starts, noise):
    """Levenberg-Marquardt from the start read from the data, then from the best-ranked
    others (by chi-square at every 4th point), until chi-square is what the record's scatter
    ``noise`` allows (5 standard deviations of chi-square), or two runs agree on the minimum,
    or :data:`STARTS_RUN` more have run. The lowest chi-square wins."""
    dof = max(problem.ndata - len(problem.free), 1)
    plausible = (1.0 + 10.0 / math.sqrt(dof)) * dof * noise**2
    best, nfev, tried, minima = None, 0, 0, []

    def run(u_start):
        """One Levenberg-Marquardt run; True when the search may stop."""
        nonlocal best, nfev, tried
        u, cost, converged, steps, hessian = problem.lm(u_start, max_iter=MAX_STEPS, rtol=1e-9)
        nfev, tried = nfev + steps, tried + 1
        if not math.isfinite(cost):
            return False
        if best is None or cost < best[1]:
            best = (u, cost, converged, hessian)
        if any(abs(cost - m) <= 1e-6 * cost for m in minima):
            # a second start ends at the same chi-square: that is the minimum, even where
            # Levenberg-Marquardt still creeps along a bound
            best = (best[0], best[1], True, best[3])
            return True
        minima.append(cost)
        return converged and cost <= plausible  # the residuals are the noise

    if not run(problem.internal(list(starts[0]))):
        ranked = []
        for start in starts[1:]:
            u = problem.internal(list(start))
            cost = problem.chisqr(problem.values(u), stride=4)
            ranked.append((cost if math.isfinite(cost) else math.inf, len(ranked), u))
        nfev += len(ranked)
        ranked.sort(key=lambda item: (item[0], item[1]))
        for _, _, u_start in ranked[:STARTS_RUN]:
            if run(u_start):
                break
    if best is None:
        u = problem.internal(list(starts[0]))
        return Solution(u, 0, "the model could not be evaluated at any start", nfev)
    u, cost, converged, hessian = best
    if converged:
        message = f"converged (Levenberg-Marquardt from {tried} of {len(starts)} starts)"
        return Solution(u, 1, message, nfev, hessian)
    return Solution(
        u, 0, f"Levenberg-Marquardt did not converge in {MAX_STEPS} steps", nfev, hessian
    )
