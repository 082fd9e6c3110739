"""The failure forecast of a creeping layer: the direct effect (:mod:`granflow.forecast.creep`)
fitted to the slip before the cut (the engine's model
:class:`~granflow.forecast.creep_model.CreepModel`), its strength and failure time profiled
(:func:`forecast_creep`).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from granflow.fitting.multistart import multistart
from granflow.fitting.results import FrozenMap
from granflow.forecast import _inputs
from granflow.forecast.creep_model import EDGE_BOUND, CreepModel, creep_problem
from granflow.forecast.inference import distribution_of, estimate, scan, with_points
from granflow.forecast.quasistatic import (
    NO_TREND,
    loading_error,
    no_date,
    observed_dict,
    quasi_static_fit,
)
from granflow.forecast.results import FailureForecast

__all__ = ["forecast_creep"]

_AMPLITUDE_STARTS = (0.003, 0.01, 0.03)  # A over F_peak
_PEAK_FACTORS = (1.05, 1.3, 2.0)  # F_peak over the largest force held
_RATIOS = (0.5, 0.8)
_INITIAL_STATES = (3e-3, 3e-2)
_NO_FAILURE = 20.0  # a strength this many times the largest force held: no failure in sight
_PROFILE_RATIOS = (0.1, 0.3, 0.5, 0.8)  # the profiles' restarts' shapes (see _profile_starts)
_PROFILE_PEAKS = (0.5, 0.7, 1.0, 1.5, 3.0)  # F_peak over the best fit's, in the time's restarts
_PROFILE_AMPLITUDE = 0.01  # A over F_peak, beside the best fit's, in the restarts
_PROFILE_EDGES = (-5.0, 0.0, 5.0)  # the edges' offset and stretch (e, d): a staircase's grid
_EDGE_GAIN = 0.01  # chi-square a fit made again from other edges must gain to replace it
_PRECISION = 2e-3  # of the profiles' ends' signed roots (not followed live: no need of 1e-4)


def _starts(model, quasi_static, floor):
    """Starting slot values: the quasi-static best fit's shape (F_peak, r, s0) and a grid of
    shapes about the largest force held (a creeping record can send the quasi-static fit far
    off: it reads the creep inside a staircase's steps as no peak in sight), each with A at
    a few fractions of F_peak (unless held) and no lag at the reference rate."""
    shapes = [tuple(quasi_static)]
    shapes += [
        (floor * factor, ratio, s0)
        for factor in _PEAK_FACTORS
        for ratio in _RATIOS
        for s0 in _INITIAL_STATES
    ]
    starts = []
    amplitudes = (None,) if model.fixed is not None else _AMPLITUDE_STARTS
    for peak_force, ratio, s0 in shapes:
        for factor in amplitudes:
            slots = {"peak_force": peak_force, "ratio": ratio, "s0": s0, "lag": 0.0}
            slots.update(e=0.0, d=0.0, z0=0.0, z1=0.0)
            if factor is not None:
                slots["amplitude"] = factor * peak_force
            starts.append([slots[name] for name in model.names])
    return starts


def _profile_starts(model, best, peak_force):
    """``starts(value)`` for the profile of ``model``'s profiled slot (F_peak, or the gap to
    failure in the timed variant) pinned at ``value``: global slot values at the best fit's
    shape and at a grid of shapes, A at the best fit's fraction of F_peak and at 1 % of it,
    and in the timed variant F_peak at a few multiples of the best fit's. The conditional
    fits follow one branch by warm starts; where the creep curve leaves its box (no
    parameters in Eq. 3 give that shape: a flat penalty) the warm start is stranded, while
    the record may well allow the value on another branch (a strength a creeping record
    does not yet bound: the profile flat far above the best fit), so that the profile
    would read a wall where there is none.

    A staircase's profiles also start the best fit from a grid of the edges' offset and
    stretch (e, d) (chi-square over them has many minima), and the timed variant's from
    the offset that keeps the failure where the best fit has it relative to the edge it
    fails after: a creeping layer slips fastest just after each edge, so that a failure
    time pinned across an edge from the best fit's calls for other edges (and shape), which
    a warm start carrying the best fit's does not reach."""
    names = model.names
    fraction = best["amplitude"] / best["peak_force"]
    shapes = [(best["ratio"], best["s0"])]
    shapes += [(ratio, s0) for ratio in _PROFILE_RATIOS for s0 in _INITIAL_STATES]
    fractions = (None,) if model.fixed is not None else (fraction, _PROFILE_AMPLITUDE)
    forces = (None,) if not model.timed else tuple(peak_force * f for f in _PROFILE_PEAKS)
    pinned = names[model.profiled]
    edged = model.staircase
    if edged and model.timed:
        edges = model.edges_at(np.array([best[name] for name in names]))
        failure = model.until + best[pinned]
        after = edges[edges <= failure]
        phase = failure - after[-1] if after.size else 0.0

    def starts(value):
        out = []
        for force in forces:
            for ratio, s0 in shapes:
                for share in fractions:
                    slots = dict(best)
                    slots.update(ratio=ratio, s0=s0)
                    if force is not None:
                        slots["peak_force"] = force
                    slots[pinned] = value
                    if "lag" in slots:
                        slots["lag"] = 0.0
                    if share is not None:
                        slots["amplitude"] = share * slots["peak_force"]
                    out.append([slots[name] for name in names])
        if edged:
            shifts = [(e, d) for e in _PROFILE_EDGES for d in _PROFILE_EDGES]
            if model.timed and edges.size:
                # the smallest move of the edges that puts one ``phase`` before the failure
                lateness = model.until + value - phase - edges
                shift = float(lateness[np.argmin(np.abs(lateness))])
                shifts.append((best["e"] + model.edge_slot(shift), best["d"]))
            for e, d in shifts:
                slots = dict(best)
                slots.update(e=min(max(e, -EDGE_BOUND), EDGE_BOUND), d=d)
                slots[pinned] = value
                out.append([slots[name] for name in names])
        return out

    return starts


def _edges_polished(fit, model):
    """``fit`` solved again (the engine's multistart) from itself and from a grid of a
    staircase's edges' offset and stretch (e, d), the other slots where the fit has them; the
    lowest kept where it gains :data:`_EDGE_GAIN`. Chi-square over (e, d) has many minima
    (each edge moves the burst of creep after it across the record's samples), and the
    fit's descent ends in the one nearest its starts (all at e = d = 0); the profiles search
    the same grid (:func:`_profile_starts`), and a fit that is not the lowest of it would
    have them read the points below it at its own height."""
    problem = fit.problem
    slots = [model.names.index("e"), model.names.index("d")]
    starts = [np.array(fit.values, dtype=float)]
    for shift in [(e, d) for e in _PROFILE_EDGES for d in _PROFILE_EDGES]:
        start = np.array(fit.values, dtype=float)
        start[slots] = shift
        starts.append(start)
    rtol = 1e-3 / max(problem.ndata, 1)
    solution = multistart(problem, starts, 0.0, rtol=rtol, least=len(starts))
    chisqr, _, hessian = problem.state(solution.x, problem.free)
    if not chisqr < fit.chisqr - _EDGE_GAIN:
        return fit
    # the fit it replaces is a minimum a hair above: its valley is profiled too
    return dataclasses.replace(
        fit,
        values=problem.values(solution.x),
        chisqr=float(chisqr),
        hessian=hessian,
        nfev=fit.nfev + solution.nfev,
        others=(np.array(fit.values, dtype=float), *fit.others),
    )


def forecast_creep(time, slip, loading, until, level, amplitude, prior, sigma, observed, message):
    """The forecast with the direct effect of a checked record cut at ``until``: see
    :func:`granflow.forecast_failure`."""
    root, _, _, _ = loading_error(loading, time)
    fit_qs, peak_slip, trend = quasi_static_fit(time, slip, loading, prior, sigma)
    held = float(np.max(loading.force(time)))
    if trend > NO_TREND:
        text = (
            "the layer has not slipped beyond the noise (the slip's trend against none: "
            f"p = {trend:.2g}): no sign of approaching failure"
        )
        return no_date(until, level, loading, time.size, text, prior, observed, bound=held)
    tail = max(time.size // 10, 3)
    last = float(np.polyfit(time[-tail:], slip[-tail:], 1)[0])
    velocity = max(last, float(np.ptp(slip)) / max(float(np.ptp(time)), 1e-300))
    model = CreepModel(time, slip, loading, root, amplitude, until, velocity / peak_slip, peak_slip)
    starts = _starts(model, fit_qs, held)
    if not starts:
        text = "the creep model has no curve for this record: no sign of approaching failure"
        return no_date(until, level, loading, time.size, text, prior, observed)
    fitted = len(model.names) - 2 + 1  # the slots but the nuisance, and x_peak
    fit = estimate(
        lambda noise, values: creep_problem(model, noise, values, prior),
        starts,
        size=time.size - fitted + 4,
        within=0.0,
        sigma=sigma,
        rough=_inputs.rough_noise(slip),
        nuisance=model.first_nuisance,
    )
    if model.staircase:
        fit = _edges_polished(fit, model)
    _, state = model.evaluate(fit.values)
    if state is None:
        text = "the creep model fits no curve to this record: no sign of approaching failure"
        return no_date(until, level, loading, time.size, text, prior, observed, bound=held)
    best = dict(zip(model.names, fit.values, strict=True))
    if model.fixed is not None:
        best["amplitude"] = model.fixed
    force_profile, strength = scan(
        fit,
        0,
        level,
        precision=_PRECISION,
        starts=_profile_starts(model, best, state.peak_force),
        thorough=model.staircase,
    )
    if state.peak_force > _NO_FAILURE * held or not math.isfinite(state.failure_time):
        # no date, but the lower end the record gives of the strength (its one-sided
        # quantile); not of the time: a creeping layer can fail before the force reaches
        # F_peak (static fatigue), so the time's lower end is the cut's
        text = "the fitted creep shows no failure in sight: no sign of approaching failure"
        bound = max(strength.quantile(1.0 - level), held)
        forecast = no_date(until, level, loading, time.size, text, prior, observed, bound=bound)
        return dataclasses.replace(forecast, time_interval=(until, math.inf))
    # the time: the same data with t_f for v_ref
    timed = CreepModel(
        time, slip, loading, root, amplitude, until, model.reference_rate, state.peak_slip, True
    )
    values = dict(best)
    values["gap"] = max(state.failure_time - until, 1e-9)
    timed_values = np.array([values[name] for name in timed.names])
    time_problem = creep_problem(timed, fit.sigma, timed_values, prior)
    # thorough under a staircase: near a step's edge the conditional minima with t_f pinned
    # lie on other branches (the edges' offset and stretch, the shape) than the warm starts
    # follow, at heights short of a jump; each point near the ends is also solved from the
    # restarts (a ramp has no edges: there it would cost half again the CPU for nothing
    # measured)
    time_profile, timing = scan(
        fit,
        timed.profiled,
        level,
        offset=until,
        problem=time_problem,
        values=timed_values,
        precision=_PRECISION,
        starts=_profile_starts(timed, values, state.peak_force),
        thorough=timed.staircase,
    )
    # one likelihood, two profiles: the time's takes the strength's points that undercut it
    # (the same curve with v_ref set by the failure time it gives: the same chi-square)
    lent = []
    for point in force_profile.points:
        _, other = model.evaluate(point.values)
        if other is not None and math.isfinite(other.failure_time):
            slots = dict(zip(model.names, point.values, strict=True))
            slots["gap"] = other.failure_time - until
            lent.append(([slots[name] for name in timed.names], point.delta))
    time_parameter = time_problem.parameters[timed.profiled]
    time_profile = with_points(time_profile, time_parameter, timed.profiled, lent)
    timing = distribution_of(time_profile, time_parameter, until, fit.dof)
    time_interval = timing.interval(level)
    force_interval = strength.interval(level)
    nodes, probabilities = timing.table()
    slips = [state.peak_slip - state.params.x0]
    for point in force_profile.points:
        if force_interval[0] <= point.value <= force_interval[1]:
            _, other = model.evaluate(point.values)
            if other is not None:
                slips.append(other.peak_slip - other.params.x0)
    slip_interval = (min(slips), max(slips))
    if math.isinf(force_interval[1]):
        slip_interval = (slip_interval[0], math.inf)
    if not message and math.isinf(time_interval[1]):
        message = "the record does not yet bound the failure from above"
    p = state.params
    return FailureForecast(
        time=state.failure_time,
        time_interval=time_interval,
        force=state.peak_force,
        force_interval=force_interval,
        slip=state.peak_slip - p.x0,
        slip_interval=slip_interval,
        until=until,
        level=level,
        loading=loading,
        params=FrozenMap(
            {
                "a": p.a,
                "alpha": p.alpha,
                "Fd": p.Fd,
                "x0": p.x0,
                "A": state.amplitude,
                "v_ref": state.velocity,
            }
        ),
        sigma=fit.sigma,
        n_points=time.size,
        approaching=True,
        prior=None if prior is None else prior.to_dict(),
        message=message,
        method="model (creep)",
        cdf={"time": [float(v) for v in nodes], "probability": [float(v) for v in probabilities]},
        observed_failure=None if observed is None else observed.time,
        observed=None if observed is None else observed_dict(observed),
    )
