"""Records that granflow's model did not make, beside its own: the fleet of the forecast
league (:mod:`granflow.forecast.league`).

Every record is a force-controlled layer from t = 0 to its failure, sampled 200 to 300
times to failure (log-uniform: the low end of the calibration study's design, which is what
a live forecast sees), its slip with white Gaussian noise of 0.1 % to 3 % of its slip range
(log-uniform; the range is the slip to failure, or to 90 % of the time to failure where the
slip diverges there) and its force with noise of 0.03 % to 1 % of the force at failure. Each
seed draws its own point of the design (:func:`family_record`). The families
(:data:`FAMILIES`):

* ``model``: granflow's own, a force ramp from zero up the quasi-static rising branch (SPEC
  §4's blue set, each of a, alpha, Fd, x0 a factor 1/3 to 3 about it, as in
  :mod:`~granflow.forecast.calibration`).
* ``red noise``: the same, the slip noise red as in real apparatus records: white plus an
  Ornstein-Uhlenbeck component whose share and correlation time are those measured in the
  residuals of one of the two real velocity-step records (:data:`SPECTRA`, drawn at random).
* ``gaps``: the same with the sampling jittered (the sepiolite record's measured jitter,
  6.3 % of the interval, times 1 to 5) and one to three gaps, each 2 to 8 % of the time to
  failure, anywhere in the record.
* ``rsf ramp``: a rate-and-state slider (aging law, velocity weakening: b/a from 1.2 to 2)
  under a stress ramp from steady sliding until it fails (its velocity 1e8 times the
  initial one); different physics, the same observables. The slider's equations are
  scale-free in time and slip (t in units of Dc / v_init, slip of Dc), so each record is
  one dimensionless run (:func:`rate_state_run`) stretched to its duration.
* ``rsf creep``: the same slider with its stress stepped up by 0.2 to 2 times a and held
  until it fails (creep to failure under a constant force).
* ``power law``: Voight's acceleration, ``v = k (t_f - t)^(-p)`` with alpha = 1 + 1/p from
  1.5 to 3, under a force ramp from zero.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from granflow.forecast.branch import branch_slip
from granflow.forecast.calibration import CENTRE, FACTOR, FORCE_NOISE, SLIP_NOISE
from granflow.model.friction import peak
from granflow.model.params import Params

__all__ = [
    "FAMILIES",
    "SPECTRA",
    "Record",
    "family_record",
    "planted_drift",
    "rate_state_run",
    "red_noise",
]

FAMILIES = ("model", "red noise", "gaps", "rsf ramp", "rsf creep", "power law")

#: The residuals of the two real velocity-step records (../shared/data/rate-state-velocity-
#: steps, Giacomel et al. 2024) about their aging-law fits, measured by
#: ``tools/noise_spectra.py``: white noise plus one Ornstein-Uhlenbeck component, its
#: standard deviation over the white noise's (``red``) and its correlation time over the
#: record's length (``tau``).
SPECTRA = {
    # 16 466 samples over 2233 s: the record wanders by 1e-3 over hundreds of seconds
    "sepiolite": {"red": 3.11, "tau": 0.0308},
    # 5849 samples over 118 s (0.1 s, then 0.01 s; read at 0.1 s)
    "basalt": {"red": 0.485, "tau": 0.0684},
}
#: The sepiolite record's sampling jitter: the standard deviation of its sampling interval
#: over the median (``tools/noise_spectra.py``).
JITTER = 0.063

SAMPLES = (200, 300)  # to failure: the low end of the calibration study's
DURATION = (100.0, 1000.0)  # s to failure, as the calibration study's
_FAILURE_SPEED = 1e8  # the rate-and-state slider's failure: its velocity over the initial one


@dataclass(frozen=True)
class Record:
    """One seed's record of a family and its truth.

    Attributes
    ----------
    family : str
        One of :data:`FAMILIES`.
    seed : int
    t, slip, force : numpy.ndarray
        The record [s, m, N], from t = 0 to the last sample before failure.
    failure : float
        The true failure time [s].
    noise : float
        The white slip noise over the slip range [-].
    samples : int
        Samples to failure (before gaps).
    details : dict
        The family's own draws (parameters, exponent, spectrum, ...).
    """

    family: str
    seed: int
    t: np.ndarray
    slip: np.ndarray
    force: np.ndarray
    failure: float
    noise: float
    samples: int
    details: dict = field(default_factory=dict)


def _log_uniform(rng, low, high):
    return float(math.exp(rng.uniform(math.log(low), math.log(high))))


def red_noise(t, sigma, tau, rng):
    """An Ornstein-Uhlenbeck series at times ``t`` [s] (any spacing): standard deviation
    ``sigma``, correlation time ``tau`` [s], stationary from its first sample (the exact
    autoregression over each interval)."""
    out = np.empty(t.size)
    out[0] = sigma * rng.standard_normal()
    decay = np.exp(-np.diff(t) / tau)
    kick = sigma * np.sqrt(1.0 - decay**2) * rng.standard_normal(t.size - 1)
    for k in range(1, t.size):
        out[k] = decay[k - 1] * out[k - 1] + kick[k - 1]
    return out


def planted_drift(record, share=0.5, shape="wave"):
    """``record`` with a slow apparatus drift planted in its slip, the truth unchanged:
    ``shape="wave"`` a slow wander, one period of a sine over the time to failure with an
    amplitude of ``share`` of the slip range (as the sepiolite record wanders); ``"line"``
    a straight line rising to ``share`` of the slip range by the failure."""
    rise = share * float(np.ptp(record.slip))
    phase = record.t / record.failure
    drift = rise * (np.sin(2.0 * np.pi * phase) if shape == "wave" else phase)
    slip = record.slip + drift
    return Record(
        record.family,
        record.seed,
        record.t,
        slip,
        record.force,
        record.failure,
        record.noise,
        record.samples,
        {**record.details, "drift": (shape, rise)},
    )


def _params(rng):
    return Params(*[c * _log_uniform(rng, 1.0 / FACTOR, FACTOR) for c in CENTRE])


def _times(rng, duration, samples, family):
    """Sampling times in [0, duration): regular, or jittered with gaps."""
    dt = duration / samples
    if family != "gaps":
        return np.arange(samples) * dt, {}
    jitter = JITTER * rng.uniform(1.0, 5.0)
    steps = dt * np.clip(1.0 + jitter * rng.standard_normal(samples), 0.2, None)
    t = np.concatenate([[0.0], np.cumsum(steps)[:-1]]) * (duration / np.sum(steps))
    gaps = []
    for _ in range(int(rng.integers(1, 4))):
        width = rng.uniform(0.02, 0.08) * duration
        start = rng.uniform(0.05, 0.95) * duration - width
        gaps.append((start, start + width))
        t = t[(t < start) | (t > start + width)]
    return t, {"jitter": jitter, "gaps": gaps}


def _model_record(rng, family):
    params = _params(rng)
    top = peak(params)
    duration = _log_uniform(rng, *DURATION)
    samples = round(_log_uniform(rng, *SAMPLES))
    t, details = _times(rng, duration, samples, family)
    rate = top.force / duration
    slip = branch_slip(rate * t, params) - params.x0
    return params, top.force, duration, samples, t, slip, rate * t, {**details, "params": params}


def rate_state_run(ratio, ramp, step, points=4000):
    """A stress-controlled rate-and-state slider (aging law) from steady sliding, in
    dimensionless units: time in theta_0 = Dc / v_init, slip in Dc, stress in a.

    ``v' = exp(step + ramp t' - ratio ln theta')``, ``d theta' / dt' = 1 - v' theta'``
    (``ratio`` = b / a). Integrated (LSODA) until ``v'`` reaches 1e8, the failure. Returns
    ``(t', slip', failure t')``, the slip at ``points`` times up to the failure.
    """
    from scipy.integrate import solve_ivp

    def rhs(t, y):
        speed = math.exp(min(step + ramp * t - ratio * y[0], 700.0))
        return [math.exp(-y[0]) - speed, speed]

    def failed(t, y):
        return step + ramp * t - ratio * y[0] - math.log(_FAILURE_SPEED)

    failed.terminal = True
    failed.direction = 1
    solution = solve_ivp(
        rhs, (0.0, 1e4), [0.0, 0.0], method="LSODA", events=failed, rtol=1e-9, atol=1e-12,
        dense_output=True,
    )  # fmt: skip
    if not solution.t_events[0].size:
        raise RuntimeError("the rate-and-state slider did not fail")
    end = float(solution.t_events[0][0])
    times = np.linspace(0.0, end, points)
    return times, solution.sol(times)[1], end


def _rate_state_record(rng, family):
    ratio = rng.uniform(1.2, 2.0)
    if family == "rsf ramp":
        ramp, step = _log_uniform(rng, 0.05, 5.0), 0.0
    else:
        ramp, step = 0.0, rng.uniform(0.2, 2.0)
    unit_t, unit_slip, unit_end = rate_state_run(ratio, ramp, step)
    duration = _log_uniform(rng, *DURATION)
    samples = round(_log_uniform(rng, *SAMPLES))
    theta0 = duration / unit_end
    dc = 10e-6  # m: the slip's scale
    a, normal, friction = rng.uniform(0.005, 0.015), 30e-3, 0.6  # -, N, -
    t = np.arange(samples) * (duration / samples)
    slip = dc * np.interp(t / theta0, unit_t, unit_slip)
    force = normal * (friction + a * (step + ramp * t / theta0))
    details = {"ratio": ratio, "ramp": ramp, "step": step, "theta0": theta0, "a": a}
    strength = normal * (friction + a * (step + ramp * unit_end))
    return strength, duration, samples, t, slip, force, details


def _power_law_record(rng):
    power = 1.0 / rng.uniform(0.5, 2.0)  # alpha - 1 = 1 / p from 0.5 to 2
    duration = _log_uniform(rng, *DURATION)
    samples = round(_log_uniform(rng, *SAMPLES))
    t = np.arange(samples) * (duration / samples)
    scale = 1e-6  # m: the slip's scale
    remaining = (duration - t) / duration
    if abs(power - 1.0) < 1e-9:
        slip = -scale * np.log(remaining)
    else:
        slip = scale * (1.0 - remaining ** (1.0 - power)) / (1.0 - power)
    strength = 10e-3  # N: the force at failure
    force = strength * t / duration
    return strength, duration, samples, t, slip, force, {"alpha": 1.0 + 1.0 / power}


def family_record(seed: int, family: str) -> Record:
    """The :class:`Record` of one seed of a family (see the module's docstring).

    Parameters
    ----------
    seed : int
        The seed: every random draw of the record comes from it (and the family).
    family : str
        One of :data:`FAMILIES`.

    Returns
    -------
    Record

    Examples
    --------
    >>> from granflow.forecast.families import family_record
    >>> record = family_record(1, "rsf creep")
    >>> bool(record.t[-1] < record.failure) and record.slip.size == record.t.size
    True
    """
    if family not in FAMILIES:
        raise ValueError(f"family must be one of {', '.join(FAMILIES)}, got {family!r}")
    rng = np.random.default_rng([seed, FAMILIES.index(family), 29])
    if family in ("model", "red noise", "gaps"):
        _, strength, duration, samples, t, slip, force, details = _model_record(rng, family)
    elif family in ("rsf ramp", "rsf creep"):
        strength, duration, samples, t, slip, force, details = _rate_state_record(rng, family)
    else:
        strength, duration, samples, t, slip, force, details = _power_law_record(rng)
    noise = _log_uniform(rng, *SLIP_NOISE)
    late = t <= 0.9 * duration
    span = float(np.ptp(slip[late])) if family in ("rsf ramp", "rsf creep", "power law") else 0.0
    span = span or float(np.ptp(slip))
    sigma = noise * span
    noisy = slip + sigma * rng.standard_normal(t.size)
    if family == "red noise":
        name = ("sepiolite", "basalt")[int(rng.integers(2))]
        spectrum = SPECTRA[name]
        noisy = noisy + red_noise(t, spectrum["red"] * sigma, spectrum["tau"] * duration, rng)
        details = {**details, "spectrum": name}
    force_noise = _log_uniform(rng, *FORCE_NOISE) * strength
    force = force + force_noise * rng.standard_normal(t.size)
    return Record(family, seed, t, noisy, force, duration, noise, samples, details)
