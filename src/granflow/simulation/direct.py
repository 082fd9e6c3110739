"""The direct effect's friction ``A asinh(v / (2 v_ref) exp(F/A))`` and its force balance.

Scalar forms for right-hand sides and Jacobians, an array form for recorded output, and the
creep velocity at which the friction equals an imposed force.
"""

import math

import numpy as np

__all__ = ["creep_velocity", "direct_derivatives", "direct_friction", "direct_scalar"]


def direct_friction(effect, v, F):
    """A asinh(v / (2 v_ref) exp(F/A)) for arrays or scalars, without overflow."""
    amplitude = effect.amplitude
    v = np.asarray(v, dtype=float)
    F = np.asarray(F, dtype=float)
    with np.errstate(divide="ignore"):
        log_q = np.log(v / (2.0 * effect.velocity)) + F / amplitude
    big = log_q > 0
    safe = np.where(big, -log_q, log_q)
    out = np.where(
        big,
        log_q + np.log1p(np.sqrt(1.0 + np.exp(2.0 * safe))),
        np.arcsinh(np.exp(safe)),
    )
    out = amplitude * np.where(v > 0, out, 0.0)
    return float(out) if out.ndim == 0 else out


def direct_scalar(amplitude, v_ref, v, F):
    """The scalar form of direct_friction, for right-hand sides."""
    if v <= 0:
        return 0.0
    log_q = math.log(v / (2.0 * v_ref)) + F / amplitude
    if log_q > 0:
        return amplitude * (log_q + math.log1p(math.sqrt(1.0 + math.exp(-2.0 * log_q))))
    return amplitude * math.asinh(math.exp(log_q))


def direct_derivatives(amplitude, v_ref, v, F):
    """d/dv and d/dF of A asinh(v / (2 v_ref) exp(F/A)), finite at v = 0."""
    log_scale = F / amplitude - math.log(2.0 * v_ref)  # log of q / v
    if v <= 0:
        return amplitude * math.exp(min(log_scale, 700.0)), 0.0
    log_q = math.log(v) + log_scale
    share = 1.0 / math.sqrt(1.0 + math.exp(min(-2.0 * log_q, 1400.0)))  # q / sqrt(1 + q^2)
    if log_q < 0:
        share = math.exp(log_q) / math.sqrt(1.0 + math.exp(2.0 * log_q))
    return amplitude * share / v, share


def creep_velocity(effect, sigma, F):
    """The v with A asinh(v / (2 v_ref) exp(F/A)) = sigma (0 for sigma <= 0)."""
    if sigma <= 0:
        return 0.0
    amplitude = effect.amplitude
    z = sigma / amplitude
    log_v = math.log(effect.velocity) + (sigma - F) / amplitude + math.log1p(-math.exp(-2 * z))
    return math.exp(min(log_v, 700.0))
