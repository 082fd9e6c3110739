"""The joint stage of :func:`granflow.analyze`: analyses over runs and the predictions.

Runs in the calling process after the per-run work, from the saved per-run results (never
from objects that only a fresh fit would have), so that its output does not depend on which
runs were fitted now and which were reused. Rules in :mod:`granflow.analysis`.
"""

import math
import warnings
from collections import Counter
from dataclasses import dataclass, field

import numpy as np

from granflow.analysis.runs import StartupData, _fit_from_record, startup_data
from granflow.errors import ConvergenceWarning, GranflowError

_MAP_POINTS, _MAP_RATIOS = 8, 7  # the stability map's grid
_MAP_HOLD = 60.0  # s under force control in each cell of the map


def _rounded(value):
    """A load or velocity rounded to 6 significant digits (for grouping), or None."""
    if value is None:
        return None
    value = float(value)
    return float(f"{value:.6g}") if math.isfinite(value) and value != 0 else value


def _estimate(value, stderr, ci95):
    return {"value": value, "stderr": stderr, "ci95": [ci95[0], ci95[1]]}


def _no_material(reason):
    empty = {"value": None, "stderr": None, "ci95": [None, None]}
    return {
        "mu_a": dict(empty),
        "mu_d": dict(empty),
        "alpha": dict(empty),
        "source": None,
        "reason": reason,
    }


def _most_common(values):
    """The most frequent value (ties: the first seen)."""
    counts = Counter(values)
    best = max(counts.values())
    return next(value for value in values if counts[value] == best)


# --------------------------------------------------------------------------- joint analyses


@dataclass(eq=False)
class _Startup:
    """A successful start-up run with its window and its fit (rebuilt from the record)."""

    item: object  # analysis._Item
    data: StartupData
    fit: object

    @property
    def load(self):
        return _rounded(self.item.run.normal_load)

    @property
    def velocity(self):
        return _rounded(self.item.run.nominal_velocity)

    @property
    def pair(self):
        return (self.data.slip, self.data.force)


@dataclass(eq=False)
class _Context:
    """What the joint stage found: the JSON parts and the objects figures are drawn from."""

    items: list
    startups: list
    analyses: dict = field(default_factory=dict)
    material: dict = field(default_factory=dict)
    predictions: dict = field(default_factory=dict)
    warnings: list = field(default_factory=list)
    constants: object = None  # MaterialConstants
    covariance: object = None  # 3 x 3 array over (mu_a, mu_d, alpha)
    material_velocity: float | None = None
    collapse: object = None
    amontons: object = None
    stability: object = None
    posterior: object = None
    representative: _Startup | None = None
    ramp_params: dict = field(default_factory=dict)  # item name -> Params
    switch_params: dict = field(default_factory=dict)


def _attempt(context, key, function):
    """``function()``, or None with a warning naming the analysis and the reason."""
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", ConvergenceWarning)
            return function()
    except GranflowError as exc:
        context.analyses[key] = {"error": str(exc)}
        context.warnings.append(f"{key.replace('_', ' ')}: {exc}")
        return None


def _velocity_collapse(context):
    from granflow.fitting.joint import velocity_collapse

    groups = {}
    for startup in context.startups:
        groups.setdefault(startup.load, []).append(startup)
    best = None
    for load, members in groups.items():
        distinct = len({m.velocity for m in members})
        if distinct >= 2 and (best is None or (distinct, len(members)) > best[0]):
            best = ((distinct, len(members)), load, members)
    if best is None:
        return
    _, load, members = best
    result = _attempt(
        context,
        "velocity_collapse",
        lambda: velocity_collapse(
            [m.pair for m in members], velocities=[m.item.run.nominal_velocity for m in members]
        ),
    )
    if result is None:
        return
    context.collapse = result
    context.analyses["velocity_collapse"] = {
        "normal_load": load,
        "runs": [m.item.name for m in members],
        **result.to_dict(),
    }


def _set_material(context, names, params, stderr, ci95, covariance, source, **extra):
    from granflow.model.params import MaterialConstants

    context.material = {
        name: _estimate(params[key], stderr[key], ci95[key]) for name, key in names.items()
    }
    context.material.update(source=source, reason=None, **extra)
    context.covariance = covariance
    try:
        context.constants = MaterialConstants(
            mu_a=context.material["mu_a"]["value"],
            mu_d=context.material["mu_d"]["value"],
            alpha=context.material["alpha"]["value"],
        )
    except GranflowError as exc:
        context.warnings.append(f"material constants out of their domain: {exc}")


def _material(context):
    """Amontons over loads at the most common velocity; one load: a joint fit over the load."""
    from granflow.fitting.joint import fit_amontons, fit_joint

    if not context.startups:
        context.material = _no_material("no start-up run could be fitted")
        return
    loaded = [s for s in context.startups if s.load is not None and s.load > 0]
    if not loaded:
        context.material = _no_material("no normal load is given for the start-up runs")
        return
    velocity = _most_common([s.velocity for s in loaded])
    chosen = [s for s in loaded if s.velocity == velocity]
    context.material_velocity = velocity
    loads = sorted({s.load for s in chosen})
    names = ("mu_a", "mu_d", "alpha")
    if len(loads) >= 2:
        result = _attempt(
            context,
            "amontons",
            lambda: fit_amontons(
                [s.pair for s in chosen],
                normal_loads=[s.item.run.normal_load for s in chosen],
                velocities=[s.item.run.nominal_velocity for s in chosen],
            ),
        )
        if result is None:
            context.material = _no_material("the Amontons joint fit failed")
            return
        context.amontons = result
        joint = result.joint
        context.analyses["amontons"] = {
            "velocity": velocity,
            "runs": [s.item.name for s in chosen],
            **result.to_dict(),
        }
        if not joint.success:
            context.warnings.append(f"Amontons joint fit: {joint.message}")
        covariance = np.array([[joint.covar[p][q] for q in names] for p in names])
        _set_material(
            context,
            {n: n for n in names},
            joint.params,
            joint.stderr,
            joint.ci95,
            covariance,
            "amontons joint fit",
            runs=len(chosen),
            normal_loads=loads,
            velocity=velocity,
        )
        return
    load = float(np.mean([s.item.run.normal_load for s in chosen]))
    result = _attempt(
        context,
        "joint_fit",
        lambda: fit_joint([s.pair for s in chosen], shared=("a", "alpha", "Fd"), per_run=("x0",)),
    )
    if result is None:
        context.material = _no_material("the joint fit at the single load failed")
        return
    context.analyses["joint_fit"] = {
        "normal_load": load,
        "velocity": velocity,
        "runs": [s.item.name for s in chosen],
        **result.to_dict(),
    }
    keys = {"mu_a": "a", "mu_d": "Fd", "alpha": "alpha"}
    scale = {"mu_a": 1.0 / load, "mu_d": 1.0 / load, "alpha": 1.0}
    params = {n: result.params[keys[n]] * scale[n] for n in names}
    stderr = {n: result.stderr[keys[n]] * scale[n] for n in names}
    ci95 = {n: tuple(b * scale[n] for b in result.ci95[keys[n]]) for n in names}
    covariance = np.array(
        [[result.covar[keys[p]][keys[q]] * scale[p] * scale[q] for q in names] for p in names]
    )
    _set_material(
        context,
        {n: n for n in names},
        params,
        stderr,
        ci95,
        covariance,
        f"joint fit at the single load {load * 1e3:.6g} mN, divided by the load",
        runs=len(chosen),
        normal_loads=[_rounded(load)],
        velocity=velocity,
    )
    if not result.success:
        context.warnings.append(f"joint fit at one load: {result.message}")


def _preparation_spread(context):
    from granflow.fitting.joint import preparation_spread

    groups = {}
    for startup in context.startups:
        key = (startup.load, startup.velocity, startup.item.run.meta.get("preparation"))
        groups.setdefault(key, []).append(startup)
    rows = []
    for (load, velocity, preparation), members in groups.items():
        if len(members) < 2:
            continue
        spread = _attempt(
            context, "preparation_spread", lambda m=members: preparation_spread([s.fit for s in m])
        )
        if spread is not None:
            rows.append(
                {
                    "normal_load": load,
                    "velocity": velocity,
                    "preparation": preparation,
                    "runs": [s.item.name for s in members],
                    **spread.to_dict(),
                }
            )
    if rows:
        context.analyses["preparation_spread"] = rows


def _representative(context):
    if not context.startups:
        return None
    largest = _most_common([(s.load, s.velocity) for s in context.startups])
    return next(s for s in context.startups if (s.load, s.velocity) == largest)


def _model_comparison(context):
    from granflow.fitting.compare import compare_models

    chosen = context.representative
    if chosen is None:
        return
    result = _attempt(context, "model_comparison", lambda: compare_models(chosen.pair))
    if result is not None:
        context.analyses["model_comparison"] = {"run": chosen.item.name, **result.to_dict()}


def _mcmc(context, seed):
    from granflow.fitting.mcmc import sample_posterior

    chosen = context.representative
    if chosen is None:
        context.warnings.append("mcmc: no start-up fit to sample")
        return
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", ConvergenceWarning)
        posterior = _attempt(context, "mcmc", lambda: sample_posterior(chosen.fit, seed=seed))
    context.warnings += [f"mcmc: {w.message}" for w in caught if w.category is ConvergenceWarning]
    if posterior is not None:
        context.posterior = posterior
        context.analyses["mcmc"] = {"run": chosen.item.name, **posterior.to_dict()}


# --------------------------------------------------------------------------- predictions


def _peak_force(mu_a, mu_d, alpha, x0, load):
    from granflow.model.friction import peak
    from granflow.model.params import Params

    return peak(Params(a=mu_a * load, alpha=alpha, Fd=mu_d * load, x0=x0)).force


def _x0_at(context, load):
    """Per-run x0 [m] of the start-ups at ``load`` (at the material's velocity when there
    are some), or of every start-up when none has that load; and where they came from."""
    at_load = [s for s in context.startups if s.load == load]
    same_velocity = [s for s in at_load if s.velocity == context.material_velocity]
    chosen, origin = (same_velocity or at_load), "start-up runs at this load"
    if not chosen:
        chosen = [s for s in context.startups if s.velocity == context.material_velocity]
        chosen, origin = chosen or context.startups, "all start-up runs (none at this load)"
    return [s.fit.params["x0"] for s in chosen], origin


def _yield_at(context, load):
    """Predicted static yield at one load, with its standard error and preparation spread."""
    from granflow.model.friction import peak

    constants = context.constants
    x0_values, origin = _x0_at(context, load)
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
    variance = gradient[:3] @ context.covariance @ gradient[:3] + (gradient[3] * x0_error) ** 2
    stderr = math.sqrt(max(float(variance), 0.0))
    per_run = [_peak_force(*point[:3], value, load) for value in x0_values]
    params = constants.params_at(load, x0)
    top = peak(params, velocity=context.material_velocity)
    return {
        "normal_load": load,
        "repeats": len(x0_values),
        "x0": x0,
        "x0_estimate": {"stderr": x0_error, "from": origin},
        "F_peak": force,
        "stderr": stderr,
        "ci95": [force - 1.959963984540054 * stderr, force + 1.959963984540054 * stderr],
        "F_peak_spread": float(np.std(per_run, ddof=1)) if len(per_run) > 1 else 0.0,
        "mu_peak": force / load,
        "x_peak": top.slip,
        "t_peak": top.time,
        "velocity": context.material_velocity,
    }


def _params_at(context, load):
    """Model parameters at a load from the material constants and the mean x0 there."""
    x0_values, _ = _x0_at(context, load)
    if context.constants is None or not x0_values or load is None:
        return None
    return context.constants.params_at(load, float(np.mean(x0_values)))


def _static_yield(context):
    loads = {s.load for s in context.startups if s.load is not None}
    loads |= {
        _rounded(item.run.normal_load)
        for item in context.items
        if item.run is not None and item.kind != "startup" and item.run.normal_load
    }
    if context.constants is None:
        context.predictions["static_yield"] = []
        context.predictions["static_yield_reason"] = context.material.get("reason")
        return
    rows = [_yield_at(context, load) for load in sorted(loads)]
    context.predictions["static_yield"] = [row for row in rows if row is not None]


def _yield_row(context, load):
    return next(
        (row for row in context.predictions.get("static_yield", []) if row["normal_load"] == load),
        None,
    )


def _ok(item, kind):
    return item.kind == kind and item.record is not None and item.record["status"] == "ok"


def _compare_ramps(context):
    """Each stress ramp's observed failure force against the predicted static yield."""
    rows = []
    for item in context.items:
        if not _ok(item, "ramp"):
            continue
        load = _rounded(item.run.normal_load)
        failure = item.record["failure"]
        row = {"run": item.name, "normal_load": load}
        if failure is not None:
            row["observed"] = {
                "failure_force": failure["force"],
                "failure_time": failure["time"],
                "failure_slip": failure["slip"],
            }
            row["criterion"] = failure["criterion"]
        predicted = _yield_row(context, load)
        params = _params_at(context, load)
        if params is not None:
            context.ramp_params[item.name] = params
        if predicted is None:
            row["reason"] = "no predicted static yield at this load"
            rows.append(row)
            continue
        row["predicted"] = {"failure_force": predicted["F_peak"]}
        row["F_peak_stderr"] = predicted["stderr"]
        row["F_peak_spread"] = predicted["F_peak_spread"]
        if failure is None:
            row["reason"] = "no failure observed in this run"
        else:
            width = math.hypot(predicted["stderr"], predicted["F_peak_spread"])
            difference = failure["force"] - predicted["F_peak"]
            row["ratio"] = failure["force"] / predicted["F_peak"]
            row["z"] = difference / width if width > 0 else None
            row["consistent"] = bool(width > 0 and abs(difference) <= 2.0 * width)
        rows.append(row)
    if rows:
        context.analyses["stress_ramp"] = rows


def _compare_creep(context):
    """Each creep test's stress against the predicted peak and the steady friction."""
    rows = []
    for item in context.items:
        if not _ok(item, "creep"):
            continue
        load = _rounded(item.run.normal_load)
        record = item.record
        row = {"run": item.name, "normal_load": load, "stress": record["stress"]}
        predicted = _yield_row(context, load)
        if predicted is not None:
            row["stress_over_peak"] = record["stress"] / predicted["F_peak"]
        if context.constants is not None and load:
            row["stress_over_Fd"] = record["stress"] / (context.constants.mu_d * load)
        row["fit"] = record["fit"]
        rows.append(row)
    if rows:
        context.analyses["creep"] = rows


def _predict_switch(params, switch):
    """Outcome of the switch under the model (quasi-static, slip clock): the start-up at the
    nominal velocity up to the switch time (the simulator's clock starts at t0 = x0 / v, the
    export's at 0), then the observed force ratio held for the observed time (at least 1 s)."""
    from granflow.simulation.driver import simulate
    from granflow.simulation.protocol import Protocol, SwitchToForce, Velocity

    velocity = switch["velocity"]
    duration = switch["switch_time"] - params.x0 / velocity
    if duration <= 0:
        return None
    protocol = Protocol(
        [
            Velocity(velocity, duration),
            SwitchToForce(max(switch["hold_time"], 1.0), factor=switch["factor"]),
        ]
    )
    return simulate(params, protocol)


def _compare_switches(context):
    """Each switch's observed outcome against the model's, from the run's own start-up fit
    (or the material constants at its load)."""
    from granflow.model.params import Params

    rows = []
    for item in context.items:
        if not _ok(item, "switch"):
            continue
        record, switch = item.record, item.record["switch"]
        row = {"run": item.name, "normal_load": _rounded(item.run.normal_load)}
        row["observed"] = {"outcome": switch["outcome"], "imposed_force": switch["imposed_force"]}
        row.update({k: switch[k] for k in ("switch_time", "factor", "switch_force")})
        fit = record.get("fit")
        if fit is not None and fit.get("success"):
            params, origin = Params(**fit["params"]), "the run's own start-up fit"
        else:
            params = _params_at(context, _rounded(item.run.normal_load))
            origin = "the material constants at the run's load"
        result = None
        if params is not None and switch.get("factor"):
            context.switch_params[item.name] = params
            result = _predict_switch(params, switch)
        if result is None:
            row["reason"] = "no parameters (or no switch time after t0) to predict the switch"
            rows.append(row)
            continue
        if result.failed:
            predicted = "failure"
        elif result.success and result.velocity[-1] == 0:
            predicted = "stop"
        else:
            predicted = "creep" if result.success else "error"
        row["predicted"] = {"outcome": predicted}
        row.update(
            agree=predicted == switch["outcome"],
            params_from=origin,
            params=params.to_dict(),
            simulation=result.message,
        )
        rows.append(row)
    if rows:
        context.analyses["switch"] = rows


class _Mapper:
    """Adapts the executor to ``stability_map(executor=...)``."""

    def __init__(self, executor):
        self.executor = executor

    def map(self, function, items):
        return self.executor.map(function, items)


def _stability(context, executor):
    from granflow.model.friction import peak
    from granflow.simulation.stability import stability_map

    switches = [i for i in context.items if i.kind == "switch" and i.run is not None]
    if switches and switches[0].run.normal_load:
        load = _rounded(switches[0].run.normal_load)
    elif any(s.load for s in context.startups):
        load = _most_common([s.load for s in context.startups if s.load])
    else:
        load = None
    params = _params_at(context, load) if load is not None else None
    velocity = context.material_velocity
    if params is None and context.representative is not None:
        params = context.representative.fit.to_params()
        load = context.representative.load
        velocity = context.representative.velocity
    if params is None or not velocity:
        return
    t_peak = peak(params, velocity=velocity).time
    points = np.linspace(0.25 * t_peak, 4.0 * t_peak, _MAP_POINTS)
    ratios = np.linspace(0.97, 1.09, _MAP_RATIOS)
    result = _attempt(
        context,
        "stability_map",
        lambda: stability_map(
            params, points, ratios, velocity=velocity, hold=_MAP_HOLD, executor=_Mapper(executor)
        ),
    )
    if result is not None:
        context.stability = result
        context.predictions["stability_map"] = {"normal_load": load, **result.to_dict()}


def _joint_stage(items, executor, *, mcmc, seed):
    startups = []
    for item in items:
        if item.kind == "startup" and item.record is not None and item.record["status"] == "ok":
            data = startup_data(item.run)
            startups.append(_Startup(item=item, data=data, fit=_fit_from_record(item.record, data)))
    context = _Context(items=items, startups=startups)
    context.representative = _representative(context)
    _velocity_collapse(context)
    _material(context)
    _preparation_spread(context)
    _model_comparison(context)
    if mcmc:
        _mcmc(context, seed)
    _static_yield(context)
    _compare_ramps(context)
    _compare_creep(context)
    _compare_switches(context)
    _stability(context, executor)
    return context
