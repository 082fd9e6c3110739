"""What the material constants predict, against what the stress-controlled runs showed.

Pure functions of the joint stage of :func:`granflow.analyze` (rules in
:mod:`granflow.analysis`): the static yield per load with its propagated uncertainty, each
stress ramp's failure force, each creep test's stress and each switch's outcome against the
model, and a stability map at a representative load.
"""

import math

import numpy as np

from granflow.analysis.joint import Notes, attempt, most_common, rounded
from granflow.analysis.prediction_results import (
    CreepComparison,
    Predictions,
    RampComparison,
    StabilityPrediction,
    SwitchComparison,
    YieldPrediction,
)
from granflow.fitting.results import FrozenMap
from granflow.fitting.statistics import WALD_Z

__all__ = [
    "MAP_HOLD",
    "MAP_POINTS",
    "MAP_RATIOS",
    "compare_creep",
    "compare_ramps",
    "compare_switches",
    "params_at",
    "predict",
    "stability",
    "static_yield",
]

#: Switch points and force ratios of the stability map's grid.
MAP_POINTS, MAP_RATIOS = 48, 31
#: Time under force control in each cell of the map [s].
MAP_HOLD = 60.0


def _peak_force(mu_a, mu_d, alpha, x0, load):
    from granflow.model.friction import peak
    from granflow.model.params import Params

    return peak(Params(a=mu_a * load, alpha=alpha, Fd=mu_d * load, x0=x0)).force


def _x0_at(startups, velocity, load):
    """Per-run x0 [m] of the start-ups at ``load`` (at the material's ``velocity`` when there
    are some), or of every start-up when none has that load; and where they came from."""
    at_load = [s for s in startups if s.load == load]
    same_velocity = [s for s in at_load if s.velocity == velocity]
    chosen, origin = (same_velocity or at_load), "start-up runs at this load"
    if not chosen:
        chosen = [s for s in startups if s.velocity == velocity]
        chosen, origin = chosen or startups, "all start-up runs (none at this load)"
    return [s.fit.params["x0"] for s in chosen], origin


def _yield_at(startups, basis, load):
    """Predicted static yield at one load, with its standard error and preparation spread."""
    from granflow.model.friction import peak

    constants = basis.constants
    x0_values, origin = _x0_at(startups, basis.velocity, load)
    if constants is None or not x0_values:
        return None
    x0 = float(np.mean(x0_values))
    x0_error = (
        float(np.std(x0_values, ddof=1) / math.sqrt(len(x0_values))) if len(x0_values) > 1 else 0.0
    )
    point = np.array([constants.mu_a, constants.mu_d, constants.alpha, x0])
    force = _peak_force(*point, load)
    gradient = np.empty(4)
    for k in range(4):
        step = 1e-6 * point[k]
        up, down = point.copy(), point.copy()
        up[k] += step
        down[k] -= step
        gradient[k] = (_peak_force(*up, load) - _peak_force(*down, load)) / (2 * step)
    variance = gradient[:3] @ basis.covariance @ gradient[:3] + (gradient[3] * x0_error) ** 2
    stderr = math.sqrt(max(float(variance), 0.0))
    per_run = [_peak_force(*point[:3], value, load) for value in x0_values]
    top = peak(constants.params_at(load, x0), velocity=basis.velocity)
    return YieldPrediction(
        normal_load=load,
        repeats=len(x0_values),
        x0=x0,
        x0_stderr=x0_error,
        x0_from=origin,
        F_peak=force,
        stderr=stderr,
        ci95=(force - WALD_Z * stderr, force + WALD_Z * stderr),
        F_peak_spread=float(np.std(per_run, ddof=1)) if len(per_run) > 1 else 0.0,
        mu_peak=force / load,
        x_peak=top.slip,
        t_peak=top.time,
        velocity=basis.velocity,
    )


def params_at(startups, basis, load):
    """Model parameters at a load from the material constants and the mean x0 there, or
    None."""
    x0_values, _ = _x0_at(startups, basis.velocity, load)
    if basis.constants is None or not x0_values or load is None:
        return None
    return basis.constants.params_at(load, float(np.mean(x0_values)))


def static_yield(entries, startups, basis):
    """The predicted static yield at every load of the campaign, by increasing load."""
    loads = {s.load for s in startups if s.load is not None}
    loads |= {
        rounded(entry.run.normal_load)
        for entry in entries
        if entry.run is not None and entry.test != "startup" and entry.run.normal_load
    }
    if basis.constants is None:
        return Predictions(determined=False, static_yield_reason=basis.material.reason)
    rows = [_yield_at(startups, basis, load) for load in sorted(loads)]
    return Predictions(static_yield=tuple(row for row in rows if row is not None))


def _yield_row(forecast, load):
    return next((row for row in forecast.static_yield if row.normal_load == load), None)


def _ok(entries, kind):
    return [entry for entry in entries if entry.test == kind and entry.ok]


def _reaches(run, force):
    """The first time [s] the imposed force of a ramp reaches ``force`` [N] (linear
    interpolation between samples, on the record's clock), or None."""
    t, imposed = np.asarray(run.t, dtype=float), np.asarray(run.force, dtype=float)
    keep = np.isfinite(t) & np.isfinite(imposed)
    t, imposed = t[keep], imposed[keep]
    above = np.flatnonzero(imposed >= force)
    if above.size == 0:
        return None
    i = int(above[0])
    if i == 0:
        return float(t[0])
    f0, f1 = imposed[i - 1], imposed[i]
    return float(t[i - 1] + (force - f0) / (f1 - f0) * (t[i] - t[i - 1]))


def compare_ramps(entries, startups, basis, forecast):
    """Each stress ramp's observed failure force against the predicted static yield."""
    rows = []
    for entry in _ok(entries, "ramp"):
        load = rounded(entry.run.normal_load)
        failure = entry.result.failure
        observed = {}
        if failure is not None:
            observed = {
                "observed": FrozenMap(
                    {
                        "failure_force": failure.force,
                        "failure_time": failure.time,
                        "failure_slip": failure.slip,
                    }
                ),
                "criterion": failure.criterion,
            }
        common = {
            "run": entry.name,
            "normal_load": load,
            "params": params_at(startups, basis, load),
            **observed,
        }
        predicted = _yield_row(forecast, load)
        if predicted is None:
            rows.append(RampComparison(**common, reason="no predicted static yield at this load"))
            continue
        common.update(
            predicted_force=predicted.F_peak,
            predicted_time=_reaches(entry.run, predicted.F_peak),
            F_peak_stderr=predicted.stderr,
            F_peak_spread=predicted.F_peak_spread,
        )
        if failure is None:
            rows.append(RampComparison(**common, reason="no failure observed in this run"))
            continue
        width = math.hypot(predicted.stderr, predicted.F_peak_spread)
        difference = failure.force - predicted.F_peak
        rows.append(
            RampComparison(
                **common,
                ratio=failure.force / predicted.F_peak,
                z=difference / width if width > 0 else None,
                consistent=bool(width > 0 and abs(difference) <= 2.0 * width),
            )
        )
    return tuple(rows)


def compare_creep(entries, basis, forecast):
    """Each creep test's stress against the predicted peak and the steady friction."""
    rows = []
    for entry in _ok(entries, "creep"):
        load = rounded(entry.run.normal_load)
        stress = entry.result.stress
        predicted = _yield_row(forecast, load)
        over_Fd = None
        if basis.constants is not None and load:
            over_Fd = stress / (basis.constants.mu_d * load)
        rows.append(
            CreepComparison(
                run=entry.name,
                normal_load=load,
                stress=stress,
                stress_over_peak=None if predicted is None else stress / predicted.F_peak,
                stress_over_Fd=over_Fd,
                fit=entry.result.fit,
            )
        )
    return tuple(rows)


def _predict_switch(params, switch):
    """Outcome of the switch under the model (quasi-static, slip clock): the start-up at the
    nominal velocity up to the switch time (on the record's clock, as the simulator reads
    it), then the observed force ratio held for the observed time (at least 1 s); None when
    the switch comes before the model takes over at t0 = x0 / v."""
    from granflow.simulation.driver import simulate
    from granflow.simulation.protocol import Protocol, SwitchToForce, Velocity

    if switch.switch_time <= params.x0 / switch.velocity:
        return None
    protocol = Protocol(
        [
            Velocity(switch.velocity, switch.switch_time),
            SwitchToForce(max(switch.hold_time, 1.0), factor=switch.factor),
        ]
    )
    return simulate(params, protocol)


def compare_switches(entries, startups, basis):
    """Each switch's observed outcome against the model's, from the run's own start-up fit
    (or the material constants at its load)."""
    rows = []
    for entry in _ok(entries, "switch"):
        switch = entry.result.switch
        load = rounded(entry.run.normal_load)
        fit = entry.result.fit
        if fit is not None and fit.success:
            params, origin = fit.to_params(), "the run's own start-up fit"
        else:
            params = params_at(startups, basis, load)
            origin = "the material constants at the run's load"
        result = None
        if params is not None and switch.factor:
            result = _predict_switch(params, switch)
        else:
            params = None
        common = {
            "run": entry.name,
            "normal_load": load,
            "observed": FrozenMap(
                {"outcome": switch.outcome, "imposed_force": switch.imposed_force}
            ),
            "switch_time": switch.switch_time,
            "factor": switch.factor,
            "switch_force": switch.switch_force,
            "params": params,
        }
        if result is None:
            reason = "no parameters (or no switch time after t0) to predict the switch"
            rows.append(SwitchComparison(**common, reason=reason))
            continue
        if result.failed:
            predicted = "failure"
        elif result.success and result.velocity[-1] == 0:
            predicted = "stop"
        else:
            predicted = "creep" if result.success else "error"
        rows.append(
            SwitchComparison(
                **common,
                predicted=predicted,
                agree=predicted == switch.outcome,
                params_from=origin,
                simulation=result.message,
            )
        )
    return tuple(rows)


def stability(entries, startups, chosen, basis, executor):
    """The stability map at the first switch's load (else the most common start-up load),
    from the material constants there (else the representative start-up's fit)."""
    from granflow.model.friction import peak
    from granflow.simulation.stability import stability_map

    switches = [e for e in entries if e.test == "switch" and e.run is not None]
    if switches and switches[0].run.normal_load:
        load = rounded(switches[0].run.normal_load)
    elif any(s.load for s in startups):
        load = most_common([s.load for s in startups if s.load])
    else:
        load = None
    params = params_at(startups, basis, load) if load is not None else None
    velocity = basis.velocity
    if params is None and chosen is not None:
        params, load, velocity = chosen.fit.to_params(), chosen.load, chosen.velocity
    if params is None or not velocity:
        return None, Notes()
    t_peak = peak(params, velocity=velocity).time
    points = np.linspace(0.25 * t_peak, 4.0 * t_peak, MAP_POINTS)
    ratios = np.linspace(0.97, 1.09, MAP_RATIOS)
    result, notes = attempt(
        "stability_map",
        lambda: stability_map(
            params,
            points,
            ratios,
            velocity=velocity,
            hold=MAP_HOLD,
            executor=executor,
        ),
    )
    return (None if result is None else StabilityPrediction(load, result)), notes


def predict(entries, startups, chosen, basis, executor):
    """Every prediction of the joint stage.

    Returns
    -------
    (Predictions, dict, Notes)
        The predictions, the comparisons by entry of
        :class:`~granflow.analysis.joint_results.Analyses` (``stress_ramp``, ``creep``,
        ``switch``) and the notes.
    """
    forecast = static_yield(entries, startups, basis)
    comparisons = {
        "stress_ramp": compare_ramps(entries, startups, basis, forecast),
        "creep": compare_creep(entries, basis, forecast),
        "switch": compare_switches(entries, startups, basis),
    }
    stability_map, notes = stability(entries, startups, chosen, basis, executor)
    forecast = Predictions(
        static_yield=forecast.static_yield,
        determined=forecast.determined,
        static_yield_reason=forecast.static_yield_reason,
        stability_map=stability_map,
    )
    return forecast, comparisons, notes
