"""Synthetic force-controlled records from the model (quasi-static, slip clock), for the
calibration study, the examples and the tests: a ramp from zero or a staircase, sampled once a
second, with Gaussian slip and force noise."""

import numpy as np

from granflow.forecast.branch import branch_slip
from granflow.model.friction import peak

__all__ = ["ramp_record", "staircase_record"]


def _record(params, force_of_time, failure, noise, force_noise, seed, dt):
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, failure, dt)
    held = np.maximum.accumulate(force_of_time(t))
    pk = peak(params)
    x = branch_slip(held, params, params.alpha * pk.slip)
    slip = x - params.x0 + noise * rng.standard_normal(t.size)
    force = force_of_time(t) + force_noise * rng.standard_normal(t.size)
    return t, slip, force, failure


def ramp_record(params, rate, *, noise, force_noise=0.0, seed=0, dt=1.0):
    """A linear force ramp from zero up to failure: ``(t, slip, force, failure_time)``.

    Parameters
    ----------
    params : Params
        Model parameters.
    rate : float
        Loading rate [N/s].
    noise, force_noise : float
        Standard deviations of the slip [m] and force [N] noise.
    seed : int
        Seed of the noise.
    dt : float
        Sampling interval [s].
    """
    failure = peak(params).force / rate
    return _record(params, lambda t: rate * t, failure, noise, force_noise, seed, dt)


def staircase_record(params, step, duration, *, noise, force_noise=0.0, seed=0, dt=1.0):
    """A staircase of force steps ``step, 2 step, ...`` of ``duration`` each, from t = 0 up
    to failure (the start of the first step above F_peak): ``(t, slip, force, failure)``."""
    count = int(np.ceil(peak(params).force / step))
    failure = (count - 1) * duration

    def force_of_time(t):
        return step * (1.0 + np.floor(t / duration))

    return _record(params, force_of_time, failure, noise, force_noise, seed, dt)
