"""Whether a rate-and-state fit reached its minimum: three measured checks, not a flag.

Levenberg-Marquardt stops when a step gains little, which is not the same as being at the
minimum (a slow crawl along a curved valley gains little per step too). :func:`verify` measures
the minimum instead, at the optimiser's end point, with a Jacobian of its own (central
differences at a relative step of 1e-3, whose error, about 1e-5 of each column, is far below
the forward differences' few 1e-4 that Levenberg-Marquardt steps with):

``gradient``
    The largest decrease of chi-square a Newton step in one parameter alone predicts,
    ``max_i (J^T r)_i^2 / (J^T J)_ii`` (the gradient of chi-square in coordinates scaled by
    each parameter's curvature).
``predicted``
    The decrease of chi-square a full Gauss-Newton step predicts, ``|J s|^2`` with ``s`` the
    least-squares solution of ``J s = -r``. While it is above the tolerance, the step is
    taken (halved until chi-square falls; at most four steps). Where no fraction of it lowers
    chi-square, the promise lies in the residuals' roughness (the integrator's error seen
    through the differences), not in the valley: ``rough`` is then True and this check and
    the gradient's (read from the same differences) are passed; the restart's stands.
``restart``
    How much lower chi-square a Levenberg-Marquardt run from the optimum, every free
    coordinate moved by 0.1 (10 % for a, Dc and k), ends; a lower end becomes the optimum
    and is restarted from again (at most three restarts: the last must gain nothing).

Each must be at most ``tolerance``: the larger of the chi-square the integration's own error
allows (``n (eps / sigma)^2``, eps the integrator's relative tolerance times the friction's
range) and a thousandth of the noise variance (``1e-3 chisqr / dof``: a step that gains less
moves no parameter by more than 0.03 of its standard error).
"""

import math

import numpy as np

from granflow.fitting.engine import Solution

__all__ = ["RESTART_MOVE", "integration_floor", "measure", "verify"]

#: How far the restart moves every free internal coordinate from the optimum.
RESTART_MOVE = 0.1
_DIFFERENCE = 1e-3  # relative step of the central differences
_RESTARTS = 2
_NOISE_SHARE = 1e-3
_POLISH = 4  # Gauss-Newton steps after the optimiser's end


def _jacobian(problem, u):
    """Residuals (chi-square = r.r) and their central-difference Jacobian over the free
    internal coordinates ``u``."""
    scale = problem.force_scale

    def residuals(x):
        return problem.evaluate(problem.values(x), with_jacobian=False)[0] * scale

    r = residuals(u)
    columns = []
    for i in range(u.size):
        step = np.zeros_like(u)
        step[i] = _DIFFERENCE
        columns.append((residuals(u + step) - residuals(u - step)) / (2 * _DIFFERENCE))
    return r, np.column_stack(columns) if columns else np.zeros((r.size, 0))


def measure(problem, u):
    """(chi-square, gradient, predicted) at the free internal coordinates ``u``."""
    return _measured(problem, u)[:3]


def _measured(problem, u):
    """(chi-square, gradient, predicted, Gauss-Newton step over ``u``, zero where a
    coordinate is pinned at a bound) at the free internal coordinates ``u``."""
    r, J = _jacobian(problem, u)
    chisqr = float(r @ r)
    none = np.zeros_like(u)
    if not (np.all(np.isfinite(r)) and np.all(np.isfinite(J))):
        return chisqr, math.inf, math.inf, none
    if J.shape[1] == 0:
        return chisqr, 0.0, 0.0, none
    # a parameter held at a bound by the gradient drops out of the checks
    g = J.T @ r
    bounds = np.array([problem.parameters[i].internal_bounds() for i in problem.free])
    pinned = ((u <= bounds[:, 0] + 1e-9) & (g > 0)) | ((u >= bounds[:, 1] - 1e-9) & (g < 0))
    J, g = J[:, ~pinned], g[~pinned]
    if J.shape[1] == 0:
        return chisqr, 0.0, 0.0, none
    curvature = np.einsum("ij,ij->j", J, J)
    safe = np.where(curvature > 0, curvature, 1.0)
    gradient = float(np.max(np.where(curvature > 0, g**2 / safe, 0.0)))
    step = np.linalg.lstsq(J, -r, rcond=None)[0]
    predicted = float(np.sum((J @ step) ** 2))
    full = none.copy()
    full[~pinned] = step
    return chisqr, gradient, predicted, full


def _polished(problem, u, floor, dof):
    """``u`` after Gauss-Newton steps (each halved until chi-square falls, at most
    :data:`_POLISH` of them) while a step promises more than the tolerance
    (:func:`_limit`): the last few hundredths of a standard error that Levenberg-Marquardt,
    stopping when a step gains little, leaves.

    Returns (u, chi-square, gradient, predicted, what the steps gained, rough): ``rough``
    when the last step promised more than the tolerance and no fraction of it lowered
    chi-square (the promise then lies in the residuals' own roughness, the integrator's
    error seen through the differences, not in the valley)."""
    chisqr, gradient, predicted, step = _measured(problem, u)
    gained, rough = 0.0, False
    for _ in range(_POLISH):
        if not (math.isfinite(predicted) and predicted > _limit(floor, chisqr, dof)):
            break
        for fraction in (1.0, 0.5, 0.25, 0.125):
            trial = u + fraction * step
            value = float(np.sum((problem.evaluate(problem.values(trial), with_jacobian=False)[0]
                                  * problem.force_scale) ** 2))  # fmt: skip
            if math.isfinite(value) and value < chisqr:
                break
        else:
            rough = True  # no step lowers chi-square: the promise is the residuals' roughness
            break
        gained += chisqr - value
        u = trial
        chisqr, gradient, predicted, step = _measured(problem, u)
    return u, chisqr, gradient, predicted, gained, rough


def _limit(floor, chisqr, dof):
    """The tolerance of every check: the integration's ``floor`` or a thousandth of the
    noise variance, ``chisqr / dof``, whichever is larger."""
    return max(floor, _NOISE_SHARE * chisqr / dof)


def integration_floor(ndata, friction_range, relative_error, sigma):
    """The chi-square the integration's own error allows: ``ndata (eps / sigma)^2`` with
    eps the integrator's ``relative_error`` times the data's ``friction_range`` [-] and
    ``sigma`` the known noise [-] (None: weights 1)."""
    weight = 1.0 if sigma is None else 1.0 / sigma
    return ndata * (relative_error * friction_range * weight) ** 2


def verify(problem, solution, floor, max_steps):
    """The solution after the checks, and the checks.

    Returns a :class:`Solution` whose status is 1 only when every check passed (its message
    naming the one that failed otherwise), and a dict of the checks in chi-square units:
    ``chisqr``, ``gradient``, ``predicted``, ``restart`` (the last restart's gain),
    ``tolerance``, ``restarts`` (how many ran), ``improved`` (what the restarts gained in
    all: the optimiser had stopped short by this much) and ``passed``.

    ``floor``: the chi-square the integration's error allows (:func:`integration_floor`);
    ``max_steps``: Levenberg-Marquardt steps of a restart.
    """
    u = np.asarray(solution.x, dtype=float)
    dof = max(problem.ndata - len(problem.free), 1)
    hessian, nfev, improved, gain, restarts = solution.hessian, solution.nfev, 0.0, 0.0, 0
    chisqr, gradient, predicted = measure(problem, u)
    limit = _limit(floor, chisqr, dof)
    signs = np.where(np.arange(u.size) % 2 == 0, 1.0, -1.0)
    while restarts <= _RESTARTS and math.isfinite(chisqr) and u.size:
        restarts += 1
        x, cost, _, steps, H = problem.lm(u + RESTART_MOVE * signs, max_iter=max_steps, rtol=1e-10)
        nfev += steps
        gain = max(chisqr - float(cost), 0.0) if math.isfinite(cost) else 0.0
        if gain <= limit:
            break
        improved += gain
        u, hessian = np.asarray(x, dtype=float), H
        chisqr, gradient, predicted = measure(problem, u)
        limit = _limit(floor, chisqr, dof)
        signs = -signs
    if u.size and math.isfinite(chisqr):
        u, chisqr, gradient, predicted, polish, rough = _polished(problem, u, floor, dof)
        improved += polish
        limit = _limit(floor, chisqr, dof)
    else:
        rough = False
    failed = [
        text
        for text, value in (
            (f"the gradient promises {gradient:.3g}", 0.0 if rough else gradient),
            (f"a Gauss-Newton step promises {predicted:.3g}", 0.0 if rough else predicted),
            (f"a restart from the optimum found {gain:.3g} lower", gain),
        )
        if not value <= limit
    ]
    checks = {
        "chisqr": chisqr,
        "gradient": gradient,
        "predicted": predicted,
        "restart": gain,
        "tolerance": limit,
        "rough": rough,
        "restarts": restarts,
        "improved": improved,
        "passed": not failed,
    }
    if failed:
        message = (
            f"not at the minimum: {'; '.join(failed)} (a chi-square above the tolerance "
            f"{limit:.3g}); {solution.message}"
        )
        return Solution(u, 0, message, nfev, hessian, solution.optima), checks
    message = solution.message
    if solution.status <= 0 or improved > 0:
        message = f"converged (checked; restarts from the optimum gained {improved:.3g})"
    return Solution(u, 1, message, nfev, hessian, solution.optima), checks
