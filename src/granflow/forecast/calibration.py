"""The calibration study of the failure forecasts: simulated ramps and staircases from several
parameter sets with slip noise, cut at lead times of 50 %, 25 % and 10 % of the time to
failure; for each method the median absolute error of t_f and the coverage of its intervals.
The creep study does the same for creeping layers (the direct effect, simulated by
granflow.simulate) and the creep forecast.
"""

import functools
import math
from dataclasses import dataclass

import numpy as np

from granflow.forecast.baselines import inverse_velocity_forecast, voight_forecast
from granflow.forecast.failure import forecast_failure
from granflow.forecast.synthetic import levels_record, ramp_record, staircase_record
from granflow.model.friction import peak
from granflow.model.params import Params

__all__ = [
    "LEADS",
    "PARAMETER_SETS",
    "calibrate",
    "creep_study",
    "one_creep_seed",
    "one_seed",
    "step_pit",
    "step_summary",
    "summarise",
]

LEADS = (0.5, 0.25, 0.1)
#: (a [N], alpha [1/m], Fd [N], x0 [m]): the demo's tube at 55 mN, a heavier and a lighter one.
PARAMETER_SETS = (
    (3.3e-3, 5.0e4, 11.0e-3, 0.3e-6),
    (6.0e-3, 7.0e4, 20.0e-3, 0.5e-6),
    (1.5e-3, 3.5e4, 5.0e-3, 0.2e-6),
)
SLIP_NOISE = (2e-9, 10e-9)  # m
FORCE_NOISE = 3e-5  # N
IRREGULAR = 0.25  # the scatter of an irregular staircase's step heights over their mean
METHODS = ("model", "inverse velocity", "voight")


@dataclass(frozen=True)
class Outcome:
    """One forecast of the study: protocol, lead, method, error [s], whether the time interval
    covered the true failure time, (model only, else None) whether the force interval
    covered the true F_peak, and whether the time interval was open above."""

    protocol: str
    lead: float
    method: str
    error: float
    covered: bool
    force_covered: bool | None = None
    open_above: bool = False
    claimed: float = math.nan
    pit: float = math.nan


def step_pit(forecast, truth, rng):
    """The randomised probability integral transform [-] of the true failure time ``truth``
    [s] under a staircase forecast's step probabilities: ``C(before) + V p(step)``, V uniform
    from ``rng``, C the probability of the steps before the one that starts at ``truth``
    (Czado, Gneiting & Held 2009). Uniform on [0, 1] where the step probabilities are
    calibrated, however discrete the outcome. The truth's step is the one whose window of
    starts holds it, or the nearest (by the windows' middles) where none does; a truth more
    than half a step before the first step listed, or after the last, lies among the steps
    left out (``below``, ``beyond``). NaN where the forecast has no steps, or where the truth
    lies above the steps listed by a forecast that does not bound them."""
    steps = forecast.steps
    if steps is None or not steps["step"]:
        return math.nan
    low, high = np.array(steps["earliest"]), np.array(steps["latest"])
    probability = np.array(steps["probability"])
    inside = np.flatnonzero((low <= truth) & (truth <= high))
    middle = 0.5 * (low + high)
    half = 0.5 * float(np.median(np.diff(middle))) if middle.size > 1 else 0.0
    if inside.size:
        index = int(inside[0])
    elif middle[0] - half <= truth <= middle[-1] + half:
        index = int(np.argmin(np.abs(middle - truth)))
    elif truth > middle[-1]:
        beyond = steps["beyond"]
        if math.isnan(beyond):
            return math.nan
        return float(1.0 - beyond + rng.uniform() * beyond)
    else:
        return float(steps["below"] * rng.uniform())
    before = steps["below"] + float(np.sum(probability[:index]))
    return float(before + rng.uniform() * probability[index])


def _record(seed, protocol):
    """``(t, slip, force, failure time)`` of one seed's record: "ramp", "steps" (a staircase
    of 10-15 steps whose last level before failure lies half a step below F_peak), "steps
    anywhere" (the same staircases, F_peak anywhere in its step), or "steps irregular" (their
    heights scattered by ``IRREGULAR`` of the mean, the record's and the ones to come)."""
    rng = np.random.default_rng(seed)
    params = Params(*PARAMETER_SETS[seed % len(PARAMETER_SETS)])
    noise = SLIP_NOISE[(seed // len(PARAMETER_SETS)) % len(SLIP_NOISE)]
    strength = peak(params).force
    failure_time = float(rng.uniform(150.0, 300.0))
    if protocol == "ramp":
        rate = strength / failure_time
        return ramp_record(params, rate, noise=noise, force_noise=FORCE_NOISE, seed=seed)
    steps = int(rng.integers(10, 16))
    # "steps": F_peak half way between two levels; "steps anywhere": anywhere in the step
    offset = 0.5 if protocol == "steps" else float(rng.uniform(0.0, 1.0))
    step = strength / (steps - offset)
    duration = failure_time / steps
    if protocol == "steps irregular":
        heights = step * np.clip(1.0 + IRREGULAR * rng.standard_normal(4 * steps), 0.3, None)
        return levels_record(
            params,
            np.cumsum(heights),
            duration,
            noise=noise,
            force_noise=FORCE_NOISE,
            seed=seed,
        )
    return staircase_record(params, step, duration, noise=noise, force_noise=FORCE_NOISE, seed=seed)


def one_seed(seed, protocols=("ramp", "steps"), leads=LEADS):
    """The outcomes of every method at every lead on the records of one seed."""
    out = []
    for protocol in protocols:
        t, slip, force, truth = _record(seed, protocol)
        strength = peak(Params(*PARAMETER_SETS[seed % len(PARAMETER_SETS)])).force
        for lead in leads:
            until = (1.0 - lead) * truth
            forecasts = {
                "model": forecast_failure(t, slip, force, until=until),
                "inverse velocity": inverse_velocity_forecast(t, slip, until=until),
                "voight": voight_forecast(t, slip, until=until),
            }
            for method, fc in forecasts.items():
                time = math.inf if fc.time is None else fc.time
                low, high = fc.time_interval
                covered = bool(low <= truth <= high)  # False where NaN (no interval)
                force_covered = None
                if method == "model":
                    force_low, force_high = fc.force_interval
                    force_covered = bool(force_low <= strength <= force_high)
                error = abs(time - truth)
                open_above = bool(high == math.inf)
                claimed, pit = math.nan, math.nan
                if method == "model" and fc.steps is not None:
                    claimed = fc.time_probability
                    pit = step_pit(fc, truth, np.random.default_rng([seed, int(1000 * lead)]))
                out.append(
                    Outcome(
                        protocol,
                        lead,
                        method,
                        error,
                        covered,
                        force_covered,
                        open_above,
                        claimed,
                        pit,
                    )
                )
    return out


def calibrate(seeds, protocols=("ramp", "steps"), leads=LEADS, executor=None):
    """Outcomes over ``seeds`` (a process pool's ``map`` when ``executor`` is given)."""
    mapper = map if executor is None else executor.map
    work = functools.partial(one_seed, protocols=tuple(protocols), leads=tuple(leads))
    return [item for chunk in mapper(work, seeds) for item in chunk]


def summarise(outcomes):
    """{(protocol, lead, method): (median absolute error [s], coverage of the time interval
    [-], count, coverage of the F_peak interval [-] (NaN for the baselines), fraction of
    time intervals open above [-])}."""
    table = {}
    keys = sorted({(o.protocol, o.lead, o.method) for o in outcomes}, key=str)
    for key in keys:
        chosen = [o for o in outcomes if (o.protocol, o.lead, o.method) == key]
        errors = np.array([o.error for o in chosen])
        forces = [o.force_covered for o in chosen if o.force_covered is not None]
        table[key] = (
            float(np.median(errors)),
            float(np.mean([o.covered for o in chosen])),
            len(chosen),
            float(np.mean(forces)) if forces else math.nan,
            float(np.mean([o.open_above for o in chosen])),
        )
    return table


def step_summary(outcomes, level=0.9, protocol="steps"):
    """{lead: (coverage of the time interval [-], mean probability its steps claim [-],
    fraction of randomised PITs inside the central ``level`` [-], count of PITs)} of the
    model's forecasts of the staircases ``protocol`` ("steps" or "steps anywhere"): the
    interval of whole steps holds the failure as often as its steps claim, and the PIT's
    central interval holds it ``level`` of the time, where the step probabilities are
    calibrated."""
    table = {}
    tail = 0.5 * (1.0 - level)
    for lead in sorted({o.lead for o in outcomes}, reverse=True):
        chosen = [
            o for o in outcomes if (o.protocol, o.lead, o.method) == (protocol, lead, "model")
        ]
        pits = np.array([o.pit for o in chosen if math.isfinite(o.pit)])
        claimed = [o.claimed for o in chosen if math.isfinite(o.claimed)]
        table[lead] = (
            float(np.mean([o.covered for o in chosen])) if chosen else math.nan,
            float(np.mean(claimed)) if claimed else math.nan,
            float(np.mean((pits > tail) & (pits < 1.0 - tail))) if pits.size else math.nan,
            int(pits.size),
        )
    return table


#: The peak study's start-up: the demo's tube at 55 mN, sheared at 0.86 um/s, force noise
#: 0.03 mN, four points a second from 1 s, cut at 70 % of the peak time.
PEAK_PARAMS = (3.3e-3, 5.0e4, 11.0e-3, 0.3e-6)
PEAK_VELOCITY = 0.86e-6  # m/s
PEAK_LOAD = 0.055  # N
#: Priors of the peak study: (mu_a, mu_d, alpha) standard errors of an Amontons fit, or a
#: previous run's Fd [N] alone.
PEAK_PRIORS = {
    "none": None,
    "material, alpha +- 0.2 %": (3.1e-4, 2.2e-4, 83.0),
    "material, alpha +- 1 %": (3.1e-4, 2.2e-4, 500.0),
    "previous run's Fd +- 10 uN": 1e-5,
}


def one_peak_seed(seed, fraction=0.7):
    """{prior name: (covered, interval width [N])} of the peak forecasts of one start-up; each
    prior's values are drawn about the truth by its standard errors (seeded)."""
    from granflow.forecast.peak import forecast_peak
    from granflow.forecast.prior import Prior
    from granflow.model.friction import friction_time

    params = Params(*PEAK_PARAMS)
    truth = peak(params, velocity=PEAK_VELOCITY)
    rng = np.random.default_rng(seed)
    t = np.arange(1.0, fraction * truth.time, 0.25)
    force = friction_time(t, params, PEAK_VELOCITY) + FORCE_NOISE * rng.standard_normal(t.size)
    out = {}
    for name, errors in PEAK_PRIORS.items():
        if errors is None:
            prior = None
        elif isinstance(errors, float):
            prior = Prior(Fd=(params.Fd + errors * rng.standard_normal(), errors))
        else:
            means = (params.a / PEAK_LOAD, params.Fd / PEAK_LOAD, params.alpha)
            drawn = [(m + e * rng.standard_normal(), e) for m, e in zip(means, errors, strict=True)]
            prior = Prior.from_material(*drawn, PEAK_LOAD)
        low, high = forecast_peak((t, force), velocity=PEAK_VELOCITY, prior=prior).force_interval
        out[name] = (bool(low <= truth.force <= high), high - low)
    return out


def peak_study(seeds, executor=None):
    """{prior name: (coverage [-], median width [N], median width without a prior over the
    median width with it [-])} over ``seeds``."""
    mapper = map if executor is None else executor.map
    rows = list(mapper(one_peak_seed, seeds))
    alone = float(np.median([row["none"][1] for row in rows]))
    table = {}
    for name in PEAK_PRIORS:
        width = float(np.median([row[name][1] for row in rows]))
        table[name] = (float(np.mean([row[name][0] for row in rows])), width, alone / width)
    return table


#: The creep study: the direct effect's amplitude A over a [-] and reference velocity [m/s].
CREEP_AMPLITUDE = 0.03
CREEP_VELOCITY = 1e-7


def _creep_record(seed, protocol):
    """A creeping record of one seed (simulated with granflow.simulate and the direct effect),
    drawn as the quasi-static study's records are."""
    from granflow.forecast.synthetic import creep_ramp_record, creep_staircase_record
    from granflow.simulation.options import DirectEffect

    rng = np.random.default_rng(seed)
    params = Params(*PARAMETER_SETS[seed % len(PARAMETER_SETS)])
    effect = DirectEffect(amplitude=CREEP_AMPLITUDE * params.a, velocity=CREEP_VELOCITY)
    noise = SLIP_NOISE[(seed // len(PARAMETER_SETS)) % len(SLIP_NOISE)]
    strength = peak(params).force
    failure_time = float(rng.uniform(150.0, 300.0))
    if protocol == "ramp":
        return creep_ramp_record(
            params, strength / failure_time, effect, noise=noise, force_noise=FORCE_NOISE, seed=seed
        )
    steps = int(rng.integers(10, 16))
    return creep_staircase_record(
        params,
        strength / (steps - 0.5),
        failure_time / steps,
        effect,
        noise=noise,
        force_noise=FORCE_NOISE,
        seed=seed,
    )


def one_creep_seed(seed, protocols=("ramp", "steps"), leads=LEADS):
    """The creep forecast's outcomes (``direct_effect=True``) at every lead on the creeping
    records of one seed; the true failure is the simulator's (velocity threshold)."""
    out = []
    strength = peak(Params(*PARAMETER_SETS[seed % len(PARAMETER_SETS)])).force
    for protocol in protocols:
        t, slip, force, truth = _creep_record(seed, protocol)
        for lead in leads:
            fc = forecast_failure(t, slip, force, until=(1.0 - lead) * truth, direct_effect=True)
            time = math.inf if fc.time is None else fc.time
            low, high = fc.time_interval
            force_low, force_high = fc.force_interval
            out.append(
                Outcome(
                    protocol,
                    lead,
                    "model (creep)",
                    abs(time - truth),
                    bool(low <= truth <= high),
                    bool(force_low <= strength <= force_high),
                    bool(high == math.inf),
                )
            )
    return out


def creep_study(seeds, executor=None):
    """The creep forecasts' outcomes over ``seeds`` (for :func:`summarise`)."""
    mapper = map if executor is None else executor.map
    return [item for chunk in mapper(one_creep_seed, seeds) for item in chunk]
