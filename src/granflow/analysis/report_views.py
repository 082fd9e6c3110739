"""The views of the HTML report: from the content of ``results.json`` to what the template
shows (runs, campaign, material constants and the joint analyses; the rest is in
:mod:`granflow.analysis.report`). Numbers stay in SI units; the template's filters put them
into display units.
"""

from collections.abc import Mapping

from granflow.analysis.formatting import (
    DASH,
    display_unit,
    format_number,
    header_label,
    quantity_text,
    real_number,
)

__all__ = [
    "amontons_view",
    "as_list",
    "as_mapping",
    "campaign_view",
    "collapse_view",
    "comparison_view",
    "forecast_view",
    "labelled",
    "material_view",
    "quality_view",
    "reason_of",
    "runs_view",
    "scalars",
    "spread_view",
]

# --------------------------------------------------------------------------- the view


def as_mapping(value):
    """``value`` when it is a mapping, else an empty one."""
    return value if isinstance(value, Mapping) else {}


def as_list(value):
    """``value`` as a list when it is a list or tuple, else an empty one."""
    return list(value) if isinstance(value, list | tuple) else []


def reason_of(value):
    """The reason an analysis is missing: a mapping holding only reason-like entries."""
    if isinstance(value, Mapping):
        for key in ("reason", "error", "skipped"):
            if isinstance(value.get(key), str):
                return value[key]
    return None


def scalars(mapping, skip=()):
    """(name, display text) of the scalar (or list-of-scalar) entries of a mapping."""
    rows = []
    for key, value in as_mapping(mapping).items():
        if key in skip or isinstance(value, Mapping):
            continue
        if isinstance(value, list | tuple) and any(
            isinstance(item, Mapping | list | tuple) for item in value
        ):
            continue
        rows.append((header_label(key), quantity_text(key, value, unit=False)))
    return rows


def _estimate(params, stderr, name, factor=1.0):
    value, error = real_number(params.get(name)), real_number(stderr.get(name))
    return (
        None if value is None else value * factor,
        None if error is None else abs(error * factor),
    )


def _fit_view(fit, velocity):
    """Eq. 3 fit of one run in slip-domain terms (a time-domain fit is converted with v)."""
    params, stderr = as_mapping(fit.get("params")), as_mapping(fit.get("stderr"))
    at_bound = sorted(str(n) for n, flag in as_mapping(fit.get("at_bound")).items() if flag)
    if "alpha" in params or "x0" in params:
        alpha, x0 = _estimate(params, stderr, "alpha"), _estimate(params, stderr, "x0")
    elif velocity:
        alpha = _estimate(params, stderr, "k", 1.0 / velocity)
        x0 = _estimate(params, stderr, "t0", velocity)
    else:
        alpha = x0 = (None, None)
    return {
        "a": _estimate(params, stderr, "a"),
        "alpha": alpha,
        "Fd": _estimate(params, stderr, "Fd"),
        "x0": x0,
        "redchi": real_number(fit.get("redchi")),
        "sigma_known": bool(fit.get("sigma_known")),
        "success": fit.get("success") is not False,
        "message": str(fit.get("message") or ""),
        "at_bound": at_bound,
    }


def _is_creep_fit(fit):
    params = as_mapping(fit.get("params"))
    return fit.get("model") == "creep" or ("B" in params and "tau_c" in params)


def _creep_view(name, fit, force):
    params, stderr = as_mapping(fit.get("params")), as_mapping(fit.get("stderr"))
    return {
        "name": name,
        "force": real_number(force),
        "B": _estimate(params, stderr, "B"),
        "tau_c": _estimate(params, stderr, "tau_c"),
        "redchi": real_number(fit.get("redchi")),
        "sigma_known": bool(fit.get("sigma_known")),
        "success": fit.get("success") is not False,
        "message": str(fit.get("message") or ""),
    }


def _imposed_force(entry):
    for key in ("force", "imposed_force", "stress", "creep_force"):
        if real_number(entry.get(key)) is not None:
            return entry[key]
    return None


def runs_view(results):
    """The run table's rows (an Eq. 3 fit in slip terms per run, with its plateau noise and
    normalised χ² where the analysis has them) and the creep fits."""
    runs, creep, names = [], [], set()
    goodness = as_mapping(
        as_mapping(as_mapping(results.get("analyses")).get("goodness_of_fit")).get("runs")
    )
    for index, run in enumerate(as_list(results.get("runs"))):
        run = as_mapping(run)
        name = str(run.get("name") or run.get("source") or f"run {index + 1}")
        velocity = real_number(run.get("velocity"))
        fit = as_mapping(run.get("fit"))
        failed = run.get("status") == "failed"
        row = {
            "name": name,
            "source": str(run.get("source") or ""),
            "interval": run.get("interval"),
            "test": str(run.get("test") or DASH),
            "normal_load": real_number(run.get("normal_load")),
            "velocity": velocity,
            "preparation": str(run.get("preparation") or DASH),
            "failed": failed,
            "reason": str(run.get("reason") or run.get("error") or ""),
            "problems": [str(p) for p in as_list(run.get("problems"))],
            "geometry": run.get("geometry"),
            "fit": None,
        }
        if fit and _is_creep_fit(fit):
            creep.append(_creep_view(name, fit, _imposed_force(run)))
            names.add(name)
        elif fit and not failed:
            row["fit"] = _fit_view(fit, velocity)
            judged = as_mapping(goodness.get(name))
            row["fit"]["noise"] = real_number(judged.get("noise"))
            row["fit"]["chi2"] = real_number(judged.get("chi2"))
        runs.append(row)
    analysis = as_mapping(results.get("analyses")).get("creep")
    for index, entry in enumerate(as_list(analysis)):
        entry = as_mapping(entry)
        name = str(entry.get("name") or entry.get("run") or f"creep {index + 1}")
        fit = as_mapping(entry.get("fit"))
        if name not in names and fit:
            creep.append(_creep_view(name, fit, _imposed_force(entry)))
    return runs, creep


def campaign_view(results, runs):
    """The campaign section: counts per test, loads, velocities, preparations, problems."""

    def distinct(key):
        values = sorted({r[key] for r in runs if r[key] is not None})
        return values

    tests = {}
    for run in runs:
        test = run["test"] if run["test"] != DASH else "unspecified"
        tests[test] = tests.get(test, 0) + 1
    campaign = as_mapping(results.get("campaign"))
    return {
        "runs": len(runs),
        "failed": sum(r["failed"] for r in runs),
        "tests": sorted(tests.items()),
        "loads": distinct("normal_load"),
        "velocities": distinct("velocity"),
        "preparations": sorted({r["preparation"] for r in runs if r["preparation"] != DASH}),
        "details": scalars(campaign, skip=("problems", "geometry")),
        "geometry": str(campaign.get("geometry") or "not recorded (runs given as data)"),
        "problems": [str(p) for p in as_list(campaign.get("problems"))],
    }


def quality_view(runs):
    """The data-quality section: each run with problems and its problems, and each run's
    geometry where the runs' geometries differ."""
    flagged = [{"name": r["name"], "problems": r["problems"]} for r in runs if r["problems"]]
    geometries = {r["geometry"] for r in runs if r["geometry"] is not None}
    per_run = (
        [(r["name"], r["geometry"]) for r in runs if r["geometry"] is not None]
        if len(geometries) > 1
        else []
    )
    return {"flagged": flagged, "geometries": per_run}


#: The rows of the material table: (constant, symbol, meaning, (scale, unit) or None for
#: the constant's own display unit). α is shown in 1/µm too (1/m per 1e6: not a display
#: unit of the unit table).
_MATERIAL = (
    ("mu_a", "μ_a", "aging amplitude over normal load a/F_N", None),
    ("mu_d", "μ_d", "dynamic friction coefficient F_d/F_N", None),
    ("alpha", "α", "shear-rejuvenation constant", None),
    ("alpha", "α", "shear-rejuvenation constant", (1e-6, "1/µm")),
)


def material_view(results):
    """The material constants: one row per constant (α twice), or None without any."""
    material = results.get("material")
    if material is None:
        return None
    material = as_mapping(material)
    rows = []
    for key, symbol, meaning, shown in _MATERIAL:
        scale, unit = shown or display_unit(key)
        entry = material.get(key)
        entry = entry if isinstance(entry, Mapping) else {"value": entry}
        value = real_number(entry.get("value"))
        rows.append(
            {
                "symbol": symbol,
                "meaning": meaning,
                "unit": unit,
                "scale": scale,
                "value": value,
                "stderr": real_number(entry.get("stderr")),
                "ci95": entry.get("ci95"),
                "reason": None
                if value is not None
                else str(entry.get("reason") or material.get("reason") or "not determined"),
            }
        )
    return {"rows": rows, "source": str(material.get("source") or "")}


def _joint_status(joint):
    joint = as_mapping(joint)
    return {
        "success": joint.get("success") is not False,
        "message": str(joint.get("message") or ""),
        "redchi": real_number(joint.get("redchi")),
    }


def collapse_view(collapse):
    """The velocity collapse: per-velocity a and α, the shared fit and the test's verdict."""
    if collapse is None:
        return None
    if reason_of(collapse) is not None:
        return {"reason": reason_of(collapse)}
    collapse = as_mapping(collapse)
    per = as_mapping(collapse.get("per_velocity"))
    shared = as_mapping(collapse.get("shared"))
    p, e = as_mapping(per.get("params")), as_mapping(per.get("stderr"))
    rows = [
        {
            "velocity": real_number(v),
            "a": _estimate(p, e, f"a_v{i}"),
            "alpha": _estimate(p, e, f"alpha_v{i}"),
        }
        for i, v in enumerate(as_list(collapse.get("velocities")))
    ]
    sp, se = as_mapping(shared.get("params")), as_mapping(shared.get("stderr"))
    collapses = collapse.get("collapses")
    return {
        "reason": None,
        "rows": rows,
        "shared": {n: _estimate(sp, se, n) for n in ("a", "alpha", "Fd")},
        "statistic": real_number(collapse.get("statistic")),
        "df": collapse.get("df"),
        "p_value": collapse.get("p_value"),
        "verdict": None
        if collapses is None
        else (
            "consistent with one curve in slip: the collapse is not rejected at the 5 % level"
            if collapses
            else "a and α depend on the velocity: the collapse is rejected at the 5 % level"
        ),
        "collapses": collapses,
    }


def amontons_view(amontons):
    """Amontons' law: per-load means, the lines through the origin and the joint fit."""
    if amontons is None:
        return None
    if reason_of(amontons) is not None:
        return {"reason": reason_of(amontons)}
    amontons = as_mapping(amontons)
    joint = as_mapping(amontons.get("joint"))
    jp, je = as_mapping(joint.get("params")), as_mapping(joint.get("stderr"))

    def pair(value):
        value = as_list(value)
        return (real_number(value[0]), real_number(value[1])) if len(value) == 2 else (None, None)

    rows = [
        {
            "normal_load": real_number(row.get("normal_load")),
            "repeats": row.get("repeats"),
            "a": pair(row.get("a")),
            "alpha": pair(row.get("alpha")),
            "alpha_v": pair(row.get("alpha_v")),
            "Fd": pair(row.get("Fd")),
        }
        for row in map(as_mapping, as_list(amontons.get("per_load")))
    ]
    lines = as_mapping(amontons.get("lines"))
    bounds = as_mapping(amontons.get("lines_ci95"))
    return {
        "reason": None,
        "rows": rows,
        "has_alpha_v": any(r["alpha_v"][0] is not None for r in rows),
        "lines": [
            (key, pair(lines.get(key)), pair(bounds.get(key)))
            for key in ("a", "Fd")
            if key in lines
        ],
        "joint": {n: _estimate(jp, je, n) for n in ("mu_a", "mu_d", "alpha")},
        "status": _joint_status(joint),
        "test": _amontons_test(amontons.get("per_load")),
    }


def _amontons_test(per_load):
    from granflow.analysis.report_summary import amontons_test

    return amontons_test(per_load)


def labelled(value, keys=("name", "run", "preparation", "label")):
    """(label, entry) pairs from one result, a list of results or a mapping label -> result."""
    if isinstance(value, list | tuple):
        pairs = []
        for index, entry in enumerate(value):
            entry = as_mapping(entry)
            label = next((str(entry[k]) for k in keys if entry.get(k) is not None), None)
            pairs.append((label or f"#{index + 1}", entry))
        return pairs
    value = as_mapping(value)
    keyed = value and all(isinstance(v, Mapping) for v in value.values())
    if keyed and not any(k in value for k in ("rows", "start", "Fd")):
        return [(str(k), v) for k, v in value.items()]
    return [(None, value)]


def spread_view(spread):
    """The preparation spread of each group of repeats."""
    if spread is None:
        return None
    if reason_of(spread) is not None:
        return {"reason": reason_of(spread), "groups": []}
    groups = []
    for label, entry in labelled(spread):
        label = label if label is None else str(entry.get("preparation") or label)
        domain = entry.get("domain", "slip")
        start_name = "x0" if domain == "slip" else "t0"
        scale, unit = display_unit(start_name)
        start, Fd = as_mapping(entry.get("start")), as_mapping(entry.get("Fd"))
        peaks = [p for p in map(real_number, as_list(entry.get("peak_force"))) if p is not None]
        groups.append(
            {
                "label": label,
                "reason": reason_of(entry),
                "repeats": entry.get("repeats"),
                "start_name": start_name,
                "start_scale": scale,
                "start_unit": unit,
                "start": start,
                "Fd": Fd,
                "peak_range": (min(peaks), max(peaks)) if peaks else None,
                "correlation": real_number(entry.get("correlation")),
                "p_value": entry.get("p_value"),
                "normal_load": real_number(entry.get("normal_load")),
                "velocity": real_number(entry.get("velocity")),
                "held": _held_view(entry.get("held")),
            }
        )
    return {"reason": None, "groups": groups}


def _held_view(held):
    """The joint fit of a group's repeats with a, α and F_d held common, or None."""
    if not isinstance(held, Mapping):
        return None

    def pair(key):
        value = as_list(held.get(key))
        return (real_number(value[0]), real_number(value[1])) if len(value) == 2 else (None, None)

    return {
        "a": pair("a"),
        "alpha": pair("alpha"),
        "Fd": pair("Fd"),
        "x0": [real_number(v) for v in as_list(held.get("x0"))],
        "x0_spread": as_mapping(held.get("x0_spread")),
        "success": held.get("success") is not False,
    }


def comparison_view(comparison):
    """The model comparison of each group: AIC and BIC per model, and the best."""
    if comparison is None:
        return None
    if reason_of(comparison) is not None:
        return {"reason": reason_of(comparison), "groups": []}
    groups = []
    for label, entry in labelled(comparison):
        label = label or (f"run {entry['run']}" if entry.get("run") else None)
        rows = [as_mapping(row) for row in as_list(entry.get("rows"))]
        groups.append(
            {
                "label": label,
                "reason": reason_of(entry),
                "rows": [
                    {
                        "model": str(row.get("model") or DASH),
                        "formula": str(row.get("formula") or ""),
                        "nfree": row.get("nfree"),
                        "aic": real_number(row.get("aic")),
                        "bic": real_number(row.get("bic")),
                        "delta_aic": real_number(row.get("delta_aic")),
                        "delta_bic": real_number(row.get("delta_bic")),
                        "message": str(row.get("message") or ""),
                        "fitted": real_number(row.get("aic")) is not None,
                    }
                    for row in rows
                ],
                "best_aic": str(entry.get("best_aic") or DASH),
                "best_bic": str(entry.get("best_bic") or DASH),
            }
        )
    return {"reason": None, "groups": groups}


def _bounds(pair, scale):
    """An interval for display, an unbounded end as ∞."""
    low, high = ("∞" if value == float("inf") else format_number(value, scale) for value in pair)
    return f"[{low}, {high}]"


def _observed(window):
    if window is None:
        return "none in the record"
    low, high = (format_number(value) for value in window)
    return f"between {low} and {high} s (the last point held, the first runaway point)"


def _forecast_entry(saved, figure):
    from granflow.analysis.forecasts import RunForecast

    try:
        forecast = RunForecast.from_dict(as_mapping(saved))
    except (KeyError, TypeError, ValueError) as exc:
        label = str(as_mapping(saved).get("run") or DASH)
        reason = f"the forecast cannot be read ({type(exc).__name__}: {exc})"
        return {"label": label, "reason": reason, "rows": [], "details": [], "figure": None}
    force, _ = display_unit("force")
    verdict = {True: "yes", False: "no", None: DASH}
    details = [
        ("observed failure", _observed(forecast.observed_window)),
        ("observed F_peak", format_number(forecast.observed_force, force) + " mN"),
        ("prior", forecast.prior_from),
        ("converged", verdict[forecast.converged]),
    ]
    rows = [
        {
            "cut": format_number(cut.cut),
            "time": format_number(cut.time),
            "interval": _bounds(cut.time_interval, 1.0) if cut.time is not None else DASH,
            "force": format_number(cut.force, force),
            "force_interval": _bounds(cut.force_interval, force) if cut.time is not None else DASH,
            "holds": verdict[forecast.holds(cut)],
            "message": cut.message,
        }
        for cut in forecast.cuts
    ]
    return {
        "label": forecast.run,
        "reason": forecast.reason,
        "level": f"{forecast.level:.0%}",
        "observed": format_number(forecast.observed),
        "converged": forecast.converged,
        "rows": rows,
        "details": details,
        "figure": figure,
    }


def forecast_view(forecasts, figures):
    """The running forecast of each run and its figure ("forecast_<k>", k from 1), and the
    other figures; (None, figures) without forecasts."""
    if not forecasts:
        return None, figures
    names = {f"forecast_{k}" for k in range(1, len(forecasts) + 1)}
    own = {figure["name"]: figure for figure in figures if figure["name"] in names}
    entries = [
        _forecast_entry(saved, own.get(f"forecast_{k}"))
        for k, saved in enumerate(as_list(forecasts), start=1)
    ]
    return entries, [figure for figure in figures if figure["name"] not in names]
