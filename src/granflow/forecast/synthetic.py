"""Synthetic force-controlled records for the calibration study, the examples and the tests: a
ramp from zero or a staircase, sampled once a second, with Gaussian slip and force noise.
Quasi-static (slip clock) from the rising branch, or creeping with the direct effect from
:func:`granflow.simulate` (independent of the creep forecast's closed form)."""

import numpy as np

from granflow.forecast.branch import branch_slip
from granflow.model.friction import peak

__all__ = [
    "creep_ramp_record",
    "creep_staircase_record",
    "levels_record",
    "ramp_record",
    "staircase_record",
]


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


def levels_record(params, levels, duration, *, noise, force_noise=0.0, seed=0, dt=1.0):
    """A staircase of force ``levels`` [N] (increasing; each held ``duration`` [s]) from
    t = 0 up to failure (the start of the first level at or above F_peak):
    ``(t, slip, force, failure)``."""
    levels = np.asarray(levels, dtype=float)
    above = np.flatnonzero(levels >= peak(params).force)
    if not above.size:
        raise ValueError("no level reaches F_peak: the layer never fails")
    failure = float(above[0]) * duration

    def force_of_time(t):
        return levels[np.minimum(np.floor(t / duration).astype(int), levels.size - 1)]

    return _record(params, force_of_time, failure, noise, force_noise, seed, dt)


def _simulated(
    params, protocol, direct_effect, points, noise, force_noise, seed, dt, max_evaluations
):
    """Sample a simulated creeping run up to its failure, with Gaussian noise."""
    from granflow.simulation import simulate

    result = simulate(
        params,
        protocol,
        direct_effect=direct_effect,
        points=points,
        max_evaluations=max_evaluations,
    )
    if not result.failed:
        raise RuntimeError(f"the simulated creeping layer did not fail: {result.message}")
    failure = float(result.failure.time)
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, failure, dt)
    slip = np.interp(t, result.t, result.displacement) + noise * rng.standard_normal(t.size)
    return t, slip, failure, rng


def creep_ramp_record(
    params,
    rate,
    direct_effect,
    *,
    noise,
    force_noise=0.0,
    seed=0,
    dt=1.0,
    points=20000,
    max_evaluations=2_000_000,
):
    """A creeping layer under a force ramp from zero, simulated with the direct effect
    (:func:`granflow.simulate`, an ODE integration independent of the forecast's closed
    form) up to its failure (the velocity passing the simulator's threshold):
    ``(t, slip, force, failure_time)``.

    Parameters
    ----------
    params : Params
        Model parameters.
    rate : float
        Loading rate [N/s].
    direct_effect : DirectEffect
        Amplitude A [N] and reference velocity v_ref [m/s].
    noise, force_noise : float
        Standard deviations of the slip [m] and force [N] noise.
    seed : int
        Seed of the noise.
    dt : float
        Sampling interval [s].
    points : int
        Output points of the simulation (the record interpolates them linearly).
    max_evaluations : int
        The simulation's budget of right-hand-side evaluations; a layer that has not failed
        within it raises RuntimeError.
    """
    from granflow.simulation import ForceRamp, Protocol

    duration = 20.0 * peak(params).force / rate
    protocol = Protocol([ForceRamp(rate=rate, duration=duration, start=0.0)])
    t, slip, failure, rng = _simulated(
        params, protocol, direct_effect, points, noise, force_noise, seed, dt, max_evaluations
    )
    force = rate * t + force_noise * rng.standard_normal(t.size)
    return t, slip, force, failure


def creep_staircase_record(
    params,
    step,
    duration,
    direct_effect,
    *,
    noise,
    force_noise=0.0,
    seed=0,
    dt=1.0,
    points=400,
    max_evaluations=2_000_000,
):
    """A creeping layer under force steps ``step, 2 step, ...`` of ``duration`` each,
    simulated with the direct effect (as :func:`creep_ramp_record`); the layer fails inside
    a step, at a continuous time: ``(t, slip, force, failure_time)``.

    ``points`` are the simulation's output points per step; ``max_evaluations`` its budget
    (as :func:`creep_ramp_record`).
    """
    from granflow.simulation import ForceSteps, Protocol

    count = int(np.ceil(peak(params).force / step)) + 20
    levels = tuple(step * np.arange(1, count + 1))
    protocol = Protocol([ForceSteps(levels=levels, step_duration=duration)])
    t, slip, failure, rng = _simulated(
        params, protocol, direct_effect, points, noise, force_noise, seed, dt, max_evaluations
    )
    force = step * (1.0 + np.floor(t / duration)) + force_noise * rng.standard_normal(t.size)
    return t, slip, force, failure
