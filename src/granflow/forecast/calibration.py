"""The calibration study of the forecasts, over a design rather than a fleet.

Each seed draws its own point of the design (:func:`draw`): Eq. 3's a, alpha, Fd and x0 each
a factor of 1/3 to 3 (log-uniform) about SPEC §4's blue set (a = 3.31 mN, alpha = 4.19e4 /m,
Fd = 10 mN, x0 = 0.198 um), the slip noise 0.1 % to 3 % of the slip to failure (x_peak -
x0), 200 to 20 000 samples to failure, and force-history noise 0.03 % to 1 % of F_peak (all
log-uniform). The records are the cells' (:data:`CELLS`):

* ``ramp``: a force ramp from zero to failure (the quasi-static rising branch, slip clock);
* ``steps``: a staircase of 8 to 20 equal steps, F_peak anywhere in its step;
* ``steps irregular``: the same with the step heights scattered by 25 % (the record's and
  the ones to come alike);
* ``creep ramp`` and ``creep steps``: a layer that creeps with the direct effect (A a factor
  0.003 to 0.03 of F_peak, v_ref 1e-8 to 1e-6 m/s), simulated by :func:`granflow.simulate`
  (an ODE integration, independent of the creep forecast's closed form) until it fails;
* ``start-up``: a rate-controlled start-up at 0.3 to 3 um/s, the force noise that of the
  force history, forecast by :func:`~granflow.forecast_peak`.

Each record is cut at leads of 50, 25 and 10 % of its time to failure (or to the peak), and
each forecast is scored (:class:`Outcome`): whether its intervals hold the truth, the
randomised PIT of a staircase's true step (Czado, Gneiting & Held 2009), and
``probability_within`` at a set of horizons against whether the failure came within them.
"""

from __future__ import annotations

import math
import time as clock
from dataclasses import dataclass, field, replace

import numpy as np

from granflow.model.friction import friction_time, peak
from granflow.model.params import Params

__all__ = [
    "CELLS",
    "LEADS",
    "Case",
    "Outcome",
    "coverage",
    "draw",
    "one_case",
    "reliability",
    "step_pit",
    "study",
]

LEADS = (0.5, 0.25, 0.1)
CELLS = ("ramp", "steps", "steps irregular", "creep ramp", "creep steps", "start-up")
#: SPEC §4's blue set: a [N], alpha [1/m], Fd [N], x0 [m].
CENTRE = (3.31e-3, 4.19e4, 10e-3, 0.198e-6)
FACTOR = 3.0  # each parameter a factor 1/3 to 3 about the centre
SLIP_NOISE = (1e-3, 3e-2)  # of x_peak - x0
SAMPLES = (200, 20000)  # to failure
FORCE_NOISE = (3e-4, 1e-2)  # of F_peak
IRREGULAR = 0.25  # the scatter of an irregular staircase's step heights over their mean
AMPLITUDE = (3e-3, 3e-2)  # the direct effect's A over F_peak
REFERENCE_VELOCITY = (1e-8, 1e-6)  # m/s
#: A creeping staircase's simulation stops after this many right-hand-side evaluations; one
#: that has not failed by then is drawn again, at most REDRAWS times.
CREEP_EVALUATIONS = 200_000
REDRAWS = 8
STARTUP_VELOCITY = (0.3e-6, 3e-6)  # m/s
#: ``probability_within`` is read at these horizons, as fractions of the cut time: from well
#: inside the time left at 10 % lead (0.11 of the cut) to beyond it at 50 % lead (1.0), so
#: that at every lead some horizons hold the failure and some do not.
HORIZONS = (0.05, 0.1, 0.2, 0.4, 0.8, 1.2, 1.6)


def _log_uniform(rng, low, high):
    return float(math.exp(rng.uniform(math.log(low), math.log(high))))


@dataclass(frozen=True)
class Case:
    """One seed's record and its truth.

    Attributes
    ----------
    cell : str
        One of :data:`CELLS`.
    seed : int
        The seed.
    t, slip, force : numpy.ndarray
        The record [s, m, N] (a start-up: slip empty, force the friction).
    failure : float
        The true failure time [s] (a start-up: the peak's time).
    strength : float
        The true F_peak [N].
    params : Params
        The true parameters.
    noise : float
        The slip noise over x_peak - x0 [-] (a start-up: the force noise over F_peak).
    samples : int
        Samples to failure.
    velocity : float
        A start-up's velocity [m/s] (0 otherwise).
    redraws : int
        How many times a creeping staircase's point of the design was drawn again because
        the simulator could not bring the layer to failure (0 otherwise).
    """

    cell: str
    seed: int
    t: np.ndarray
    slip: np.ndarray
    force: np.ndarray
    failure: float
    strength: float
    params: Params
    noise: float
    samples: int
    velocity: float = 0.0
    redraws: int = 0


def draw(seed, cell):
    """The :class:`Case` of one seed and cell: its point of the design and its record."""
    if cell != "creep steps":
        return _draw(np.random.default_rng([seed, CELLS.index(cell)]), seed, cell)
    # a creeping staircase the simulator cannot bring to failure (a stiff layer: A under
    # about 0.4 % of F_peak, or LSODA stopping at a step's jump) is drawn again from the
    # seed's next stream, and the redraws are counted (Case.redraws)
    for redraws in range(REDRAWS + 1):
        stream = [seed, CELLS.index(cell)] + ([redraws] if redraws else [])
        try:
            return replace(_draw(np.random.default_rng(stream), seed, cell), redraws=redraws)
        except RuntimeError as exc:
            if "did not fail" not in str(exc) or redraws == REDRAWS:
                raise


def _draw(rng, seed, cell):
    from granflow.forecast.synthetic import (
        creep_ramp_record,
        creep_staircase_record,
        levels_record,
        ramp_record,
        staircase_record,
    )

    values = [c * _log_uniform(rng, 1.0 / FACTOR, FACTOR) for c in CENTRE]
    params = Params(*values)
    top = peak(params)
    rise = top.slip - params.x0
    noise = _log_uniform(rng, *SLIP_NOISE)
    samples = round(_log_uniform(rng, *SAMPLES))
    force_noise = _log_uniform(rng, *FORCE_NOISE) * top.force
    noise_seed = int(rng.integers(2**31))
    if cell == "start-up":
        velocity = _log_uniform(rng, *STARTUP_VELOCITY)
        peak_time = top.slip / velocity
        dt = peak_time / samples
        t = np.arange(1, samples + 1) * dt
        t = t[velocity * t > params.x0]
        force = friction_time(t, params, velocity)
        force = force + force_noise * np.random.default_rng(noise_seed).standard_normal(t.size)
        return Case(
            cell,
            seed,
            t,
            np.empty(0),
            force,
            peak_time,
            top.force,
            params,
            force_noise / top.force,
            samples,
            velocity,
        )
    duration = _log_uniform(rng, 100.0, 1000.0)  # s to failure
    dt = duration / samples
    slip_noise = noise * rise
    if cell == "ramp":
        record = ramp_record(
            params,
            top.force / duration,
            noise=slip_noise,
            force_noise=force_noise,
            seed=noise_seed,
            dt=dt,
        )
    elif cell in ("steps", "steps irregular", "creep steps"):
        steps = int(rng.integers(8, 21))
        offset = float(rng.uniform())
        step = top.force / (steps - offset)
        hold = duration / steps
        if cell == "steps":
            record = staircase_record(
                params,
                step,
                hold,
                noise=slip_noise,
                force_noise=force_noise,
                seed=noise_seed,
                dt=dt,
            )
        elif cell == "steps irregular":
            heights = step * np.clip(1.0 + IRREGULAR * rng.standard_normal(4 * steps), 0.3, None)
            record = levels_record(
                params,
                np.cumsum(heights),
                hold,
                noise=slip_noise,
                force_noise=force_noise,
                seed=noise_seed,
                dt=dt,
            )
        else:
            record = creep_staircase_record(
                params,
                step,
                hold,
                _direct_effect(rng, top.force),
                noise=slip_noise,
                force_noise=force_noise,
                seed=noise_seed,
                dt=dt,
                max_evaluations=CREEP_EVALUATIONS,
            )
    else:  # creep ramp
        record = creep_ramp_record(
            params,
            top.force / duration,
            _direct_effect(rng, top.force),
            noise=slip_noise,
            force_noise=force_noise,
            seed=noise_seed,
            dt=dt,
        )
    t, slip, force, failure = record
    return Case(cell, seed, t, slip, force, failure, top.force, params, noise, samples)


def _direct_effect(rng, strength):
    from granflow.simulation.options import DirectEffect

    return DirectEffect(
        amplitude=_log_uniform(rng, *AMPLITUDE) * strength,
        velocity=_log_uniform(rng, *REFERENCE_VELOCITY),
    )


@dataclass(frozen=True)
class Outcome:
    """One forecast of the study.

    Attributes
    ----------
    cell, seed, lead : str, int, float
        Which record, cut where (the lead: the fraction of the time to failure left).
    noise, samples : float, int
        The record's point of the design (:class:`Case`).
    issued : bool
        Whether the forecast gave an interval of the failure time (declined: False).
    time_covered, force_covered : bool
        Whether the intervals held the true failure time and F_peak.
    open_above : bool
        Whether the time interval was open above.
    pit : float
        A staircase's randomised PIT of the true step (NaN otherwise).
    within : tuple of (float, bool)
        ``(probability_within(h), failed within h)`` at each horizon h.
    error : float
        |t_f - truth| [s] (inf without a date).
    cpu : float
        CPU time of the forecast [s].
    message : str
        The forecast's message.
    redraws : int
        The record's :attr:`Case.redraws`.
    time_pit : float
        ``probability_within(truth - until)``: the confidence distribution of the failure
        (a start-up's peak) time read at the truth, uniform on [0, 1] where that
        distribution is calibrated at every level (NaN for a staircase: ``pit`` is its
        randomised counterpart).
    """

    cell: str
    seed: int
    lead: float
    noise: float
    samples: int
    issued: bool
    time_covered: bool
    force_covered: bool
    open_above: bool
    pit: float
    within: tuple = field(default_factory=tuple)
    error: float = math.inf
    cpu: float = 0.0
    message: str = ""
    redraws: int = 0
    time_pit: float = math.nan


def step_pit(forecast, truth, rng):
    """The randomised probability integral transform [-] of the true failure time ``truth``
    [s] under a staircase forecast's step probabilities: ``C(before) + V p(step)``, V uniform
    from ``rng``, C the probability of the steps before the one that starts at ``truth``
    (Czado, Gneiting & Held 2009). Uniform on [0, 1] where the step probabilities are
    calibrated, however discrete the outcome. The truth's step is the one whose window of
    starts holds it, or the nearest (by the windows' middles) where none does; a truth more
    than half a step before the first step listed, or after the last, lies among the steps
    left out (``below``, ``beyond``). NaN where the forecast has no steps."""
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
        return float(1.0 - beyond + rng.uniform() * beyond)
    else:
        return float(steps["below"] * rng.uniform())
    before = steps["below"] + float(np.sum(probability[:index]))
    return float(before + rng.uniform() * probability[index])


def _forecast(case, until):
    from granflow.forecast.failure import forecast_failure
    from granflow.forecast.peak import forecast_peak

    if case.cell == "start-up":
        return forecast_peak((case.t, case.force), velocity=case.velocity, until=until)
    creeping = case.cell.startswith("creep")
    return forecast_failure(
        case.t, case.slip, case.force, until=until, direct_effect=True if creeping else None
    )


def one_case(seed, cell, leads=LEADS):
    """The :class:`Outcome` s of one seed's record of ``cell`` at each lead."""
    case = draw(seed, cell)
    out = []
    for lead in leads:
        until = (1.0 - lead) * case.failure
        started = clock.process_time()
        forecast = _forecast(case, until)
        cpu = clock.process_time() - started
        low, high = forecast.time_interval
        issued = math.isfinite(low) and forecast.time_interval != (math.nan, math.nan)
        force_low, force_high = forecast.force_interval
        pit = math.nan
        if getattr(forecast, "steps", None) is not None:
            pit = step_pit(forecast, case.failure, np.random.default_rng([seed, int(100 * lead)]))
        # the probabilities read off the distribution alone: the study hands the forecast
        # the whole record, and one whose run-away shows after the cut would say "already
        # failed" (probability 1) from data that no one has at the cut
        read = forecast
        if getattr(forecast, "observed_failure", None) is not None:
            read = replace(forecast, observed_failure=None)
        within = tuple(
            (
                float(read.probability_within(h * forecast.until)),
                bool(case.failure <= forecast.until * (1.0 + h)),
            )
            for h in HORIZONS
        )
        point = forecast.time if forecast.time is not None else math.inf
        time_pit = math.nan
        if getattr(forecast, "steps", None) is None:
            time_pit = float(read.probability_within(case.failure - forecast.until))
        out.append(
            Outcome(
                cell,
                seed,
                lead,
                case.noise,
                case.samples,
                bool(issued),
                bool(low <= case.failure <= high),
                bool(force_low <= case.strength <= force_high),
                bool(high == math.inf),
                pit,
                within,
                abs(point - case.failure),
                cpu,
                forecast.message,
                case.redraws,
                time_pit,
            )
        )
    return out


def _one(arguments):
    seed, cell, leads = arguments
    try:
        return one_case(seed, cell, leads)
    except Exception as exc:  # a failed forecast is an outcome of the study, not its end
        return [
            Outcome(
                cell,
                seed,
                lead,
                math.nan,
                0,
                False,
                False,
                False,
                False,
                math.nan,
                message=f"error: {type(exc).__name__}: {exc}",
            )
            for lead in leads
        ]


def study(seeds, cells=CELLS, leads=LEADS, executor=None):
    """The :class:`Outcome` s of every cell's record of each seed (a process pool's ``map``
    when ``executor`` is given)."""
    mapper = map if executor is None else executor.map
    work = [(seed, cell, tuple(leads)) for cell in cells for seed in seeds]
    return [row for rows in mapper(_one, work, **_chunks(executor, len(work))) for row in rows]


def _chunks(executor, count):
    if executor is None:
        return {}
    return {"chunksize": max(1, min(8, count // 64))}


def coverage(outcomes, key="time_covered"):
    """(fraction [-], binomial standard error [-], count) of the issued ``outcomes`` whose
    ``key`` holds (staircases' ``"pit"``: the randomised PIT in its central 90 %)."""
    chosen = [o for o in outcomes if o.issued]
    if key == "pit":
        values = [0.05 < o.pit < 0.95 for o in chosen if math.isfinite(o.pit)]
    else:
        values = [getattr(o, key) for o in chosen]
    count = len(values)
    if not count:
        return math.nan, math.nan, 0
    share = float(np.mean(values))
    return share, math.sqrt(max(share * (1 - share), 1e-12) / count), count


def reliability(outcomes, bins=10):
    """[(mean predicted probability, observed frequency, count)] of ``probability_within``
    over all outcomes and horizons, its predictions binned in tenths."""
    pairs = np.array([pair for o in outcomes for pair in o.within], dtype=float)
    if not pairs.size:
        return []
    edges = np.linspace(0.0, 1.0, bins + 1)
    index = np.clip(np.searchsorted(edges, pairs[:, 0], side="right") - 1, 0, bins - 1)
    rows = []
    for k in range(bins):
        chosen = pairs[index == k]
        if chosen.size:
            rows.append((float(chosen[:, 0].mean()), float(chosen[:, 1].mean()), len(chosen)))
    return rows
