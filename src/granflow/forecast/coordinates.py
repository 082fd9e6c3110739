"""Eq. 3 in the coordinates of its peak: the forecasts' parametrization.

A forecast is about the peak of F(x): its force F_peak (the static yield, the force at which a
force-controlled layer fails) and its slip x_peak. So the forecasts fit Eq. 3 (paper initial
condition) in the coordinates

    (F_peak, r, s0, x_peak),   r = Fd / F_peak in [0, 1),   s0 = alpha x0 > 0,

in which the curve is ``F(x) = F_peak f(x / x_peak; r, s0)``: F_peak and x_peak are its two
scales and (r, s0) its shape. Every point of the box is a curve with a peak (unlike
``(a, alpha, x0, F_peak)``, where a lower F_peak at the same a, alpha and x0 may have no
Fd >= 0, a trap for a profile), and the two forecast targets are coordinates, so that their
profiles are profiles of a parameter.

With s = alpha x and E(s) = exp(-s) (Ei(s) - Ei(s0)), the curve is
``F = Fd (1 - exp(-s)) + a E(s)``; its peak s_p solves ``F(s_p) - Fd = a / s_p``, i.e.

    q(s_p) = s_p (Ei(s_p) - Ei(s0)) - exp(s_p) + 1 = 1 / (1 - r),

and ``a = F_peak s_p (1 - r)``, ``alpha = s_p / x_peak``, ``Fd = r F_peak``,
``x0 = s0 x_peak / s_p``. q rises from ``1 - exp(s0) < 0`` at s0 to infinity, with
``q' = Ei(s) - Ei(s0) > 0`` and ``q'' = exp(s) / s > 0``, so Newton's method from the right
of the root converges monotonically; ``d s_p / dr = 1 / ((1 - r)^2 q'(s_p))`` and
``d s_p / d s0 = s_p exp(s0) / (s0 q'(s_p))``.
"""

import math

import numpy as np

from granflow.model.params import Params
from granflow.model.special import (
    compiled,
    compiled_inline,
    scaled_ei_diff_scalar,
    scaled_ei_scalar,
)

__all__ = [
    "LARGEST_RATIO",
    "from_params",
    "natural",
    "peak_root",
    "to_params",
]

#: The largest r = Fd / F_peak the coordinates take (s_p about 23 there).
LARGEST_RATIO = 1.0 - 1e-9
_LARGEST_S = 600.0  # exp(s) stays finite


@compiled_inline
def _excess(s, s0, scaled_s0):
    """(exp(-s) (q(s) - 1), E(s) = exp(-s) (Ei(s) - Ei(s0))) at s > s0."""
    diff = scaled_ei_diff_scalar(s, s0, scaled_s0, math.exp(s0 - s))
    return s * diff - 1.0, diff


@compiled_inline
def peak_root(r, s0):
    """The peak's s_p = alpha x_peak of the curve with r = Fd / F_peak and s0 = alpha x0, and
    its derivatives: ``(s_p, d s_p / d r, d s_p / d s0)``; NaN where r is outside [0, 1) or
    s0 is not positive."""
    if not (r >= 0.0 and r < 1.0 and s0 > 0.0 and s0 < _LARGEST_S):
        return math.nan, math.nan, math.nan
    target = 1.0 / (1.0 - r)  # q(s_p)
    scaled_s0 = scaled_ei_scalar(s0)
    # a point right of the root: q(s) >= target
    s = max(s0 + 1.0, math.log(target) + 2.0)
    for _ in range(60):
        excess, _diff = _excess(s, s0, scaled_s0)
        # q(s) - target = exp(s) excess + 1 - target
        if excess > 0.0 and math.log(excess) + s >= math.log(target - 1.0 + 1e-300):
            break
        s *= 2.0
        if s > _LARGEST_S:
            return math.nan, math.nan, math.nan
    # Newton on q(s) - target from the right of the root: monotone, q being convex. Both
    # scaled by exp(-s): the step (q - target) / q' = gap / diff.
    for _ in range(100):
        excess, diff = _excess(s, s0, scaled_s0)
        gap = excess - (target - 1.0) * math.exp(-s)  # exp(-s) (q - target)
        s_new = s - gap / diff
        if s_new <= s0:
            s_new = 0.5 * (s + s0)
        if abs(s_new - s) <= 1e-15 * s:
            s = s_new
            break
        s = s_new
    _excess_value, diff = _excess(s, s0, scaled_s0)
    # q'(s_p) = Ei(s_p) - Ei(s0) = exp(s_p) diff
    d_r = math.exp(-s) / (diff * (1.0 - r) ** 2)
    d_s0 = s * math.exp(s0 - s) / (s0 * diff)
    return s, d_r, d_s0


@compiled
def natural(peak_force, r, s0, peak_slip, jacobian):
    """Eq. 3's parameters from the peak coordinates, and their derivatives.

    Parameters
    ----------
    peak_force, r, s0, peak_slip : float
        F_peak [N], Fd / F_peak [-], alpha x0 [-], x_peak [m].
    jacobian : numpy.ndarray
        (4, 4), filled with d(a, alpha, Fd, x0) / d(F_peak, r, s0, x_peak).

    Returns
    -------
    tuple of float
        ``(a, alpha, Fd, x0, s_p)`` [N, 1/m, N, m, -]; NaN where the coordinates are outside
        their box.
    """
    s_p, d_r, d_s0 = peak_root(r, s0)
    if not math.isfinite(s_p):
        jacobian[:, :] = math.nan
        return math.nan, math.nan, math.nan, math.nan, math.nan
    a = peak_force * s_p * (1.0 - r)
    alpha = s_p / peak_slip
    fd = r * peak_force
    x0 = s0 * peak_slip / s_p
    jacobian[:, :] = 0.0
    # a = F_peak s_p (1 - r)
    jacobian[0, 0] = s_p * (1.0 - r)
    jacobian[0, 1] = peak_force * ((1.0 - r) * d_r - s_p)
    jacobian[0, 2] = peak_force * (1.0 - r) * d_s0
    # alpha = s_p / x_peak
    jacobian[1, 1] = d_r / peak_slip
    jacobian[1, 2] = d_s0 / peak_slip
    jacobian[1, 3] = -s_p / peak_slip**2
    # Fd = r F_peak
    jacobian[2, 0] = r
    jacobian[2, 1] = peak_force
    # x0 = s0 x_peak / s_p
    jacobian[3, 1] = -s0 * peak_slip * d_r / s_p**2
    jacobian[3, 2] = peak_slip / s_p - s0 * peak_slip * d_s0 / s_p**2
    jacobian[3, 3] = s0 / s_p
    return a, alpha, fd, x0, s_p


def to_params(peak_force, r, s0, peak_slip):
    """:class:`~granflow.Params` (a [N], alpha [1/m], Fd [N], x0 [m]) of the curve whose peak is
    at ``peak_force`` [N] and ``peak_slip`` [m] with r = Fd / F_peak and s0 = alpha x0; None
    outside the box."""
    jacobian = np.empty((4, 4))
    a, alpha, fd, x0, _ = natural(
        float(peak_force), float(r), float(s0), float(peak_slip), jacobian
    )
    if not all(math.isfinite(v) for v in (a, alpha, fd, x0)) or a <= 0:
        return None
    return Params(a=a, alpha=alpha, Fd=fd, x0=x0)


def from_params(params):
    """The peak coordinates ``(F_peak [N], r [-], s0 [-], x_peak [m])`` of ``params`` (paper
    initial condition)."""
    from granflow.model.friction import peak

    top = peak(params)
    return top.force, params.Fd / top.force, params.alpha * params.x0, top.slip
