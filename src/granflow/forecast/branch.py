"""The quasi-static slip under a rising force: the layer follows the rising branch of F(x).

With the slip clock nothing evolves at rest, so under an imposed force sigma(t) the aging
coordinate is ``x(t) = F^-1(max_{t' <= t} sigma(t'))`` on the rising branch [x0, x_peak]
(x0 while sigma is below F(x0)), the record's slip is ``x - x0``, and the layer fails when
sigma reaches F_peak. No integration is needed.

The inversion is compiled (:func:`branch_values`): points in order of the held force, each
warm-started from the last by the tangent (F is concave on the rising branch, so the tangent
from below never overshoots), then Newton's method on ``sqrt(F_peak - F(x))``, which is
linear in x at the peak where F itself is flat, kept inside a bracket. The derivatives follow
from the implicit function theorem: ``dx/dH = 1 / F'(x)`` with ``F'(x) = a/x - alpha (F - Fd)``,
and ``dx/dp = -(dF/dp) / F'(x)`` for each parameter p.
"""

import math

import numpy as np

from granflow.model.kernel import curve_start, point
from granflow.model.special import compiled

__all__ = ["branch_slip", "branch_values"]

_BEYOND = 1e3  # the slope of the penalty past the peak, in units of the branch's mean slope


@compiled
def _invert(h, lo, x_peak, peak_force, a, alpha, fd, x0, s0, start, f_lo, slope_lo):
    """The root x in [lo, x_peak] of F(x) = h (F(lo) <= h < F_peak); ``f_lo`` and
    ``slope_lo`` are F and F' at ``lo`` where they are known (the previous point's root),
    else NaN.

    Each step takes the larger of Newton's step on F (from the left of the root it stays
    left: F is concave) and Newton's step on ``sqrt(F_peak - F)`` (linear at the peak, where
    F is flat) while the latter stays inside the bracket; it stops when the step is below
    1e-13 of x or below what the rounding of F allows there (1e-15 F_peak / F'(x)).

    Returns ``(x, at, values)``: the root, the point ``at`` of the last evaluation and
    :func:`~granflow.model.kernel.point`'s values there (F and its derivatives: ``at`` is
    within the tolerance of x, so they serve for x's Jacobian without another pass; ``at``
    NaN where the root was not reached by such a step).
    """
    hi = x_peak
    target = math.sqrt(peak_force - h)
    x = lo
    f, derivative = f_lo, slope_lo
    at = math.nan
    values = (math.nan, math.nan, math.nan, math.nan, math.nan, math.nan)
    for iteration in range(60):
        known = iteration == 0 and not (math.isnan(f) or math.isnan(derivative))
        if not known:
            s = alpha * x
            values = point(x, s, math.exp(s0 - s), a, alpha, fd, x0, 0.0, True, False, start)
            f = values[0]
            derivative = a / x - alpha * (f - fd)
            at = x
        if f <= h:
            lo = x
        else:
            hi = x
        if not derivative > 0.0:
            x_new = 0.5 * (lo + hi)
        else:
            # F'' = -a / x^2 - alpha F', from F' = a / x - alpha (F - Fd)
            curvature = -a / (x * x) - alpha * derivative
            newton = (h - f) / derivative
            x_new = x + newton
            if known:  # from the last root: the second-order step, to where the next
                # evaluation's Newton step lands on this root to the tolerance
                discriminant = derivative * derivative + 2.0 * curvature * (h - f)
                if discriminant > 0.0:
                    x_new = x + 2.0 * (h - f) / (derivative + math.sqrt(discriminant))
            gap = peak_force - f
            if gap > 0.0:
                w = math.sqrt(gap)
                x_root = x + (w - target) * 2.0 * w / derivative
                if x_root > x_new and x_root < hi:
                    x_new = x_root
            if not (x_new >= lo and x_new <= hi):
                x_new = 0.5 * (lo + hi)
            tolerance = 1e-13 * x + 1e-15 * peak_force / derivative
            step = x_new - x
            if abs(step) <= tolerance:
                return x_new, at, values
            # Newton's error after this step, |F'' / 2F'| step^2 (quadratic convergence),
            # ten times under the tolerance: the step lands on the root
            if (
                not known
                and step == newton
                and abs(curvature) * step * step <= (0.2 * derivative * tolerance)
            ):
                return x_new, at, values
        x = x_new
        if hi - lo <= 1e-15 * x_peak:
            return x, math.nan, values
    return x, math.nan, values


@compiled
def branch_values(base, error, nuisance, params, peak, transform, slip, jacobian):
    """The model's slip under a held force, and its derivatives in the caller's coordinates.

    Parameters
    ----------
    base : numpy.ndarray
        (n,) the fitted force history at the points (or groups of points) [N].
    error : numpy.ndarray
        (n, m) d(history) / d(nuisance) at the points [N].
    nuisance : numpy.ndarray
        (m,) the nuisance coordinates z [-]: the true history is ``base + error @ z``.
    params : tuple of float
        ``(a, alpha, Fd, x0)`` [N, 1/m, N, m] (paper initial condition).
    peak : tuple of float
        ``(F_peak, x_peak)`` [N, m] of that curve.
    transform : numpy.ndarray
        (4, k): d(a, alpha, Fd, x0) / d(coordinates) (the identity for Eq. 3's own).
    slip : numpy.ndarray
        (n,) filled with the slip x - x0 [m] on the rising branch under the held force (the
        running maximum of the true history).
    jacobian : numpy.ndarray
        (n, k + m) filled with d slip / d(coordinates, z).

    Past the peak (a held force at or above F_peak, which a true history with the nuisance
    shifted far may reach) the slip goes on linearly, 1e3 times steeper than the branch on
    average: a penalty that points back (its derivative in F_peak's direction only, taken
    as the first coordinate), not physics.
    """
    n, m = error.shape
    k = transform.shape[1]
    a, alpha, fd, x0 = params
    peak_force, peak_slip = peak
    start = curve_start(alpha, x0)
    s0 = start[0]
    f0 = fd * start[3]
    held = -math.inf
    argmax = 0
    lo = x0
    f_lo = slope_lo = math.nan  # F and F' at lo, once lo is a root
    beyond = _BEYOND * (peak_slip - x0) / max(peak_force - f0, 1e-300)
    for i in range(n):
        h = base[i]
        for q in range(m):
            h += error[i, q] * nuisance[q]
        if h > held:
            held = h
            argmax = i
        h = held
        if h <= f0:
            slip[i] = 0.0
            jacobian[i, :] = 0.0
            continue
        if h >= peak_force:
            slip[i] = peak_slip - x0 + (h - peak_force) * beyond
            jacobian[i, :] = 0.0
            jacobian[i, 0] = -beyond
            for q in range(m):
                jacobian[i, k + q] = beyond * error[argmax, q]
            lo = peak_slip
            f_lo = slope_lo = math.nan
            continue
        if lo >= peak_slip:
            lo = x0
            f_lo = slope_lo = math.nan
        x, at, values = _invert(
            h, lo, peak_slip, peak_force, a, alpha, fd, x0, s0, start, f_lo, slope_lo
        )
        lo = x
        if math.isnan(at):  # the root came by bisection or the bracket: evaluate it
            at = x
            s = alpha * x
            values = point(x, s, math.exp(s0 - s), a, alpha, fd, x0, 0.0, True, False, start)
        derivative = a / at - alpha * (values[0] - fd)
        # F and F' at the root (the last evaluation lies within the tolerance of it)
        f_lo, slope_lo = values[0] + derivative * (x - at), derivative
        slip[i] = x - x0
        # dx/d(a, alpha, Fd, x0) = -dF/d(...) / F'(x); then through the coordinates
        for j in range(k):
            total = 0.0
            for q in range(4):
                total -= values[1 + q] * transform[q, j]
            jacobian[i, j] = total / derivative - transform[3, j]
        for q in range(m):
            jacobian[i, k + q] = error[argmax, q] / derivative
    return 0


def branch_slip(force, params, s_peak=None):
    """The aging coordinate x [m] on the rising branch at imposed forces ``force`` [N].

    Parameters
    ----------
    force : numpy.ndarray
        Imposed force [N], already the running maximum of the history.
    params : Params
        Model parameters (paper initial condition).
    s_peak : float, optional
        Ignored (the peak is found from ``params``); kept for callers of the earlier
        signature.

    Returns
    -------
    numpy.ndarray
        x [m]: x0 below F(x0), x_peak at or above F_peak, else the root of F(x) = force.
    """
    from granflow.model.friction import peak

    top = peak(params)
    force = np.ascontiguousarray(force, dtype=float)
    order = np.argsort(force, kind="stable")
    slip = np.empty(force.size)
    branch_values(
        force[order],
        np.zeros((force.size, 0)),
        np.zeros(0),
        (params.a, params.alpha, params.Fd, params.x0),
        (top.force, top.slip),
        np.eye(4),
        slip,
        np.empty((force.size, 4)),
    )
    x = np.empty(force.size)
    x[order] = slip + params.x0
    return np.minimum(x, top.slip)
