"""The report's verdicts and its predictions in a physicist's words.

:func:`summary_view` states, with numbers, what the campaign shows (one line per verdict,
each linking to its section); :func:`amontons_test` tests Amontons' law on the per-load means;
:func:`experiment_view` puts a stress-controlled run's observation beside its prediction
(names a physicist reads, display units, signed differences observed − predicted).
Numbers arrive in SI units (the content of ``results.json``).
"""

import math
import re
from collections.abc import Mapping

from granflow.analysis.formatting import (
    DASH,
    display_unit,
    format_number,
    format_p_value,
    format_value_error,
    real_number,
)
from granflow.analysis.report_views import as_list, as_mapping, labelled, reason_of

__all__ = ["LABELS", "amontons_test", "experiment_view", "physical_text", "summary_view"]

#: The names a physicist reads for the keys of ``results.json`` (symbol and words).
LABELS = {
    "failure_force": "failure force F_f",
    "failure_time": "failure time t_f",
    "failure_slip": "slip at failure δ_f",
    "F_peak": "static yield F_peak",
    "F_peak_stderr": "standard error of the predicted F_peak",
    "F_peak_spread": "spread of F_peak over the preparations",
    "ratio": "observed / predicted",
    "z": "(observed − predicted) / combined error",
    "consistent": "consistent (within two combined errors)",
    "criterion": "failure criterion",
    "outcome": "outcome",
    "imposed_force": "imposed force",
    "switch_force": "force at the switch",
    "switch_time": "switch time",
    "factor": "imposed force / force at the switch",
    "agree": "observation and prediction agree",
    "params_from": "model parameters from",
    "simulation": "simulation of the prediction",
    "mu_peak": "F_peak / F_N",
    "x_peak": "slip at the peak x_peak",
    "t_peak": "time of the peak t_peak",
    "x0": "mean initial state x0",
    "repeats": "repeats",
    "velocity": "velocity v",
    "normal_load": "normal load F_N",
    "stress": "imposed force",
    "stress_over_peak": "imposed force / F_peak",
    "stress_over_Fd": "imposed force / F_d",
}

#: Display digits of the quantities a comparison shows.
_SIGNIFICANT = 4


def label_of(key):
    """The physicist's name of a key, with its display unit: ``failure force F_f [mN]``."""
    unit = display_unit(key)[1]
    name = LABELS.get(key, str(key).replace("_", " "))
    return f"{name} [{unit}]" if unit else name


def _number(key, value, significant=_SIGNIFICANT):
    scale = display_unit(key)[0]
    return format_number(value, scale, significant)


def _text(key, value):
    if isinstance(value, bool):
        return "yes" if value else "no"
    if key in ("z", "ratio") and real_number(value) is not None:
        return f"{value:.2f}".replace("-", "−")
    if real_number(value) is not None:
        return _number(key, value)
    if value is None:
        return DASH
    return physical_text(str(value))


_SI_QUANTITY = re.compile(r"(?P<value>[-+]?\d+(?:\.\d+)?(?:[eE][-+]?\d+)?) (?P<unit>m/s|m|N|s)\b")


def physical_text(text):
    """A message with SI quantities (``slip = 6.88e-05 m, force = 0.01267863 N``) put into
    display units with four significant digits (``slip = 68.8 µm, force = 12.68 mN``)."""
    names = {"m": "slip", "N": "force", "s": "time", "m/s": "velocity"}

    def replace(match):
        name = names[match["unit"]]
        scale, unit = display_unit(name)
        return f"{format_number(float(match['value']), scale, _SIGNIFICANT)} {unit}"

    return _SI_QUANTITY.sub(replace, text)


def _difference(key, observed, predicted):
    """observed − predicted in display units, and relative to the prediction:
    ``−0.34 mN (−2.5 %)``."""
    seen, model = real_number(observed), real_number(predicted)
    if seen is None or model is None:
        return DASH
    scale, unit = display_unit(key)
    difference = seen - model
    text = format_number(difference, scale, 3)
    text = (text if text.startswith("-") or text == "0" else "+" + text).replace("-", "−")
    if unit:
        text += f" {unit}"
    if model != 0:
        text += f" ({100 * difference / abs(model):+.2g} %)".replace("-", "−")
    return text


def _rows(observed, predicted):
    rows = []
    for key in dict.fromkeys([*observed, *predicted]):
        rows.append(
            {
                "quantity": label_of(key),
                "observed": _text(key, observed.get(key)),
                "predicted": _text(key, predicted.get(key)),
                "difference": _difference(key, observed.get(key), predicted.get(key)),
            }
        )
    return rows


def experiment_view(experiment):
    """Stress ramp or switch: observed against predicted per run, with signed differences
    (observed − predicted) and the other entries under their physicist's names."""
    if experiment is None:
        return None
    if reason_of(experiment) is not None:
        return {"reason": reason_of(experiment), "entries": []}
    entries = []
    for label, entry in labelled(experiment, keys=("run", "name")):
        observed, predicted = as_mapping(entry.get("observed")), as_mapping(entry.get("predicted"))
        skip = ("run", "name", "reason", "error", "observed", "predicted", "params")
        details = [
            (label_of(key), _text(key, value))
            for key, value in entry.items()
            if key not in skip and not isinstance(value, Mapping | list | tuple)
        ]
        entries.append(
            {
                "label": label,
                "reason": reason_of(entry),
                "rows": _rows(observed, predicted),
                "details": details,
            }
        )
    return {"reason": None, "entries": entries}


# --------------------------------------------------------------------------- Amontons


def _normal_deviate(t_value, df):
    """A Student's t deviate with ``df`` degrees of freedom as the normal deviate of the same
    tail probability (a small number of repeats makes the standard errors uncertain)."""
    from scipy.stats import norm, t

    if df is None or df < 1:
        return float(t_value)
    return float(norm.isf(t.sf(t_value, df)))


def amontons_test(per_load):
    """Amontons' law tested on the per-load means: a/F_N, F_d/F_N and α each constant.

    For each relation, the per-load values r_i (standard errors s_i from n_i repeats) are
    compared with their weighted mean r̄: t_i = (r_i − r̄)/s_i, turned into the normal
    deviate z_i of the same Student's-t tail probability (n_i − 1 degrees of freedom), and
    χ² = Σ z_i² with (loads − 1) degrees of freedom.

    Returns
    -------
    dict or None
        ``tests``: (name, weighted mean, statistic, df, p) per relation; ``holds``: every
        p at least 0.05; None with fewer than three loads with errors.
    """
    from scipy.stats import chi2

    rows = [as_mapping(row) for row in as_list(per_load)]
    tests = []
    for name, key, per_load_of in (
        ("a ∝ F_N", "a", True),
        ("F_d ∝ F_N", "Fd", True),
        ("α independent of F_N", "alpha", False),
    ):
        values, errors, repeats = [], [], []
        for row in rows:
            pair = as_list(row.get(key))
            load = real_number(row.get("normal_load"))
            if len(pair) != 2 or load is None or load <= 0:
                continue
            value, error = real_number(pair[0]), real_number(pair[1])
            if value is None or error is None or error <= 0:
                continue
            divisor = load if per_load_of else 1.0
            values.append(value / divisor)
            errors.append(error / divisor)
            count = row.get("repeats")
            repeats.append(int(count) if isinstance(count, int) and count > 1 else None)
        if len(values) < 3:
            return None
        weights = [1.0 / e**2 for e in errors]
        mean = sum(w * v for w, v in zip(weights, values, strict=True)) / sum(weights)
        statistic = sum(
            _normal_deviate((v - mean) / e, None if n is None else n - 1) ** 2
            for v, e, n in zip(values, errors, repeats, strict=True)
        )
        df = len(values) - 1
        tests.append((name, mean, statistic, df, float(chi2.sf(statistic, df))))
    return {"tests": tests, "holds": all(p >= 0.05 for *_, p in tests)}


# --------------------------------------------------------------------------- the summary


def _material_line(material):
    if material is None:
        return None
    rows = {row["symbol"] + (row["unit"] or ""): row for row in material["rows"]}
    parts = []
    for key in ("μ_a", "μ_d", "α1/m"):
        row = rows.get(key)
        if row is None:
            continue
        if row["reason"]:
            parts.append(f"{row['symbol']} not determined ({row['reason']})")
            continue
        value = format_value_error(row["value"], row["stderr"], row["scale"])
        bounds = as_list(row["ci95"])
        interval = ""
        if len(bounds) == 2:
            low, high = (format_number(b, row["scale"], 5) for b in bounds)
            interval = f" (95 %: [{low}, {high}])"
        unit = f" {row['unit']}" if row["unit"] else ""
        parts.append(f"{row['symbol']} = {value}{unit}{interval}")
    source = f" ({material['source']})" if material.get("source") else ""
    return "; ".join(parts) + source


def _fit_line(goodness, runs):
    fitted = [r for r in runs if r["fit"]]
    if not fitted:
        return None, None
    if goodness.get("runs"):
        fitted = list(as_mapping(goodness["runs"]))
    if not goodness:
        return "warn", f"{len(fitted)} start-ups fitted; no noise estimate to judge them by."
    noises = [
        real_number(as_mapping(v).get("noise")) for v in as_mapping(goodness.get("runs")).values()
    ]
    noises = [n for n in noises if n is not None]
    noise = ""
    if noises:
        low, high = min(noises), max(noises)
        scale, unit = display_unit("force")
        noise = (
            f"; force noise σ from the plateaus {format_number(low, scale, 2)}–"
            f"{format_number(high, scale, 2)} {unit}"
        )
    median, limit = real_number(goodness.get("median")), real_number(goodness.get("limit"))
    poor = [str(p) for p in as_list(goodness.get("poor"))]
    spread = (
        f"normalised χ² (χ² per degree of freedom over σ²) median {format_number(median, 1, 3)}, "
        f"range {format_number(goodness.get('min'), 1, 3)}–"
        f"{format_number(goodness.get('max'), 1, 3)}{noise}"
    )
    if poor:
        names = ", ".join(poor[:6]) + (f" and {len(poor) - 6} more" if len(poor) > 6 else "")
        return "warn", (
            f"Eq. 3 misses {len(poor)} of {len(fitted)} start-ups (normalised χ² above "
            f"{format_number(limit, 1, 2)}: {names}); {spread}."
        )
    return "ok", f"Eq. 3 fits all {len(fitted)} start-ups to the noise: {spread}."


def _collapse_line(collapse, results):
    if collapse is None or collapse.get("reason"):
        return None
    entry = as_mapping(as_mapping(results.get("analyses")).get("velocity_collapse"))
    velocities = [v for v in map(real_number, as_list(entry.get("velocities"))) if v is not None]
    scale, unit = display_unit("velocity")
    span = (
        f"{len(velocities)} velocities ({format_number(min(velocities), scale, 3)}–"
        f"{format_number(max(velocities), scale, 3)} {unit})"
        if velocities
        else "several velocities"
    )
    test = (
        "likelihood-ratio test of shared a and α: statistic "
        f"{format_number(collapse['statistic'], 1, 3)}, {collapse['df']} degrees of "
        f"freedom, p = {format_p_value(collapse['p_value'])}"
    )
    if collapse["collapses"]:
        return "ok", f"The curves collapse in slip: one preparation at {span}; {test}."
    return "warn", f"The curves do not collapse in slip (a or α depends on v): {span}; {test}."


def _amontons_line(amontons):
    if amontons is None or amontons.get("reason"):
        return None
    test = amontons.get("test")
    if test is None:
        return "warn", "Amontons' law not tested: fewer than three loads with repeats."
    parts = [
        f"{name}: χ² = {format_number(statistic, 1, 3)}, {df} d.o.f., p = {format_p_value(p)}"
        for name, _, statistic, df, p in test["tests"]
    ]
    verdict = "holds" if test["holds"] else "fails"
    how = (
        f"χ² test of the per-load means about one constant, {len(amontons['rows'])} loads, "
        "Student's t for the repeats' standard errors"
    )
    return ("ok" if test["holds"] else "warn"), f"Amontons' law {verdict} ({how}): " + (
        "; ".join(parts) + "."
    )


def _spread_line(spread):
    if spread is None or spread.get("reason") or not spread["groups"]:
        return None
    by_state = {}
    for group in spread["groups"]:
        held = group.get("held")
        if held is not None and not group.get("reason"):
            by_state.setdefault(group["label"] or "repeats", []).append(group)
    if not by_state:
        return None
    scale, unit = display_unit("x0")
    parts = []
    for state, groups in by_state.items():
        spreads = [as_mapping(g["held"].get("x0_spread")) for g in groups]
        low = min(real_number(x.get("min")) or math.inf for x in spreads)
        high = max(real_number(x.get("max")) or -math.inf for x in spreads)
        relative = [100 * (real_number(x.get("relative")) or math.nan) for x in spreads]
        repeats = sum(int(g["repeats"] or 0) for g in groups)
        where = f"at {len(groups)} loads, " if len(groups) > 1 else ""
        spread_text = (
            f"{format_number(relative[0], 1, 2)} %"
            if len(relative) == 1
            else f"{format_number(min(relative), 1, 2)}–{format_number(max(relative), 1, 2)} %"
        )
        parts.append(
            f"“{state}” ({where}{repeats} repeats): x0 from {format_number(low, scale, 3)} to "
            f"{format_number(high, scale, 3)} {unit}, relative spread {spread_text}"
        )
    return "ok", (
        "The preparations differ by their initial state x0 alone (a, α and F_d held common "
        "to the repeats): " + "; ".join(parts) + "."
    )


def _yield_line(static_yield):
    if static_yield is None or static_yield.get("reason") or not static_yield["rows"]:
        return None
    force = display_unit("force")
    parts = [
        f"{format_number(row['normal_load'], force[0], 3)} {force[1]}: "
        f"{format_value_error(*row['F_peak'], scale=force[0])} {force[1]}"
        for row in static_yield["rows"]
    ]
    return "ok", "Static yield F_peak per load F_N — " + "; ".join(parts) + "."


def _stress_lines(analyses, forecasts):
    lines = []
    force, time = display_unit("force"), display_unit("time")
    for _, entry in labelled(analyses.get("stress_ramp"), keys=("run",)):
        if not entry or reason_of(entry):
            continue
        observed, predicted = as_mapping(entry.get("observed")), as_mapping(entry.get("predicted"))
        seen, model = observed.get("failure_force"), predicted.get("failure_force")
        if real_number(seen) is None or real_number(model) is None:
            continue
        width = math.hypot(
            real_number(entry.get("F_peak_stderr")) or 0.0,
            real_number(entry.get("F_peak_spread")) or 0.0,
        )
        text = (
            f"Stress ramp {entry.get('run')}: failed at {format_number(seen, force[0])} "
            f"{force[1]}, {_difference('failure_force', seen, model)} from the predicted "
            f"F_peak {format_value_error(model, width, force[0])} {force[1]}"
        )
        t_seen, t_model = observed.get("failure_time"), predicted.get("failure_time")
        if real_number(t_seen) is not None and real_number(t_model) is not None:
            text += (
                f", at t = {format_number(t_seen)} {time[1]} (predicted "
                f"{format_number(t_model)} {time[1]})"
            )
        good = entry.get("consistent")
        lines.append(
            (
                "ok" if good else "warn",
                text + (" — consistent." if good else " — not consistent."),
                "#ramp",
            )
        )
    for _, entry in labelled(analyses.get("creep"), keys=("run",)):
        ratio = real_number(entry.get("stress_over_peak"))
        fit = as_mapping(entry.get("fit"))
        b = real_number(as_mapping(fit.get("params")).get("B"))
        if ratio is None:
            continue
        slip = display_unit("slip")
        text = (
            f"Creep {entry.get('run')}: held at {format_number(entry.get('stress'), force[0])} "
            f"{force[1]} ({format_number(ratio, 1, 2)} F_peak), logarithmic creep"
            + (f" B = {format_number(b, slip[0], 3)} {slip[1]}" if b is not None else "")
            + ", no failure, as predicted below F_peak."
        )
        lines.append(("ok", text, "#creep"))
    for _, entry in labelled(analyses.get("switch"), keys=("run",)):
        if not entry or reason_of(entry):
            continue
        seen = as_mapping(entry.get("observed")).get("outcome")
        model = as_mapping(entry.get("predicted")).get("outcome")
        agree = entry.get("agree")
        text = (
            f"Switch {entry.get('run')} at t = {format_number(entry.get('switch_time'))} "
            f"{time[1]} to {format_number(entry.get('factor'), 1, 3)} times the force: "
            f"observed {seen or DASH}, predicted {model or DASH}"
        )
        lines.append(
            (
                "ok" if agree else "warn",
                text + (" — agree." if agree else " — disagree."),
                "#switch",
            )
        )
    for forecast in forecasts or ():
        if forecast.get("reason") or not forecast.get("rows"):
            continue
        last = forecast["rows"][-1]
        lines.append(
            (
                "ok" if forecast.get("converged") else "warn",
                f"Failure forecast {forecast['label']}: at {last['cut']} s, "
                f"t_f = {last['time']} s {last['interval']} against the observed "
                f"{forecast['observed']} s.",
                "#forecasting",
            )
        )
    return lines


def _quality_lines(quality, warnings, runs):
    lines = []
    for item in quality["flagged"]:
        lines.append(("warn", f"{item['name']}: " + "; ".join(item["problems"]), "#data-quality"))
    for item in warnings["failed"]:
        lines.append(("bad", f"{item['name']} failed: {item['reason']}", "#failed-runs"))
    for name, params in warnings["at_bound"]:
        lines.append(("warn", f"{name}: {params} at a bound of its range", "#at-bound"))
    for name, message in warnings["convergence"]:
        lines.append(("warn", f"{name}: {message}", "#convergence"))
    for message in warnings["messages"]:
        lines.append(("warn", str(message), "#analysis-warnings"))
    for message in warnings["report"]:
        lines.append(("warn", str(message), "#report-warnings"))
    if not lines:
        lines.append(
            (
                "ok",
                f"No data-quality problem: all {len(runs)} runs read whole and analysed, no "
                "point left out, no fit at a bound, every fit converged.",
                "#data-quality",
            )
        )
    return lines


def summary_view(results, context):
    """The verdicts at the top of the report: (class, text, link) per line, in the order
    material, fits, collapse, Amontons, preparations, static yield, stress-controlled runs,
    data quality."""
    joint, prediction = context["joint"], context["prediction"]
    analyses = as_mapping(results.get("analyses"))
    lines = []
    material = _material_line(context["material"])
    if material:
        truth = as_mapping(as_mapping(results.get("campaign")).get("truth")).get("contained")
        if isinstance(truth, Mapping) and truth:
            inside = [k for k, v in truth.items() if v]
            material += (
                "; the generator's values lie inside the 95 % intervals"
                if len(inside) == len(truth)
                else f"; the generator's values of {', '.join(k for k in truth if not truth[k])} "
                "lie outside the 95 % intervals"
            )
        lines.append(("ok", "Material constants: " + material + ".", "#material"))
    for line, link in (
        (_fit_line(as_mapping(analyses.get("goodness_of_fit")), context["runs"]), "#runs"),
        (_collapse_line(joint["collapse"], results), "#collapse"),
        (_amontons_line(joint["amontons"]), "#amontons"),
        (_spread_line(joint["spread"]), "#preparation"),
        (_yield_line(prediction["static_yield"]), "#static-yield"),
    ):
        if line and line[0]:
            lines.append((line[0], line[1], link))
    lines += _stress_lines(analyses, context["forecasts"])
    quality = _quality_lines(context["quality"], context["warnings"], context["runs"])
    return [{"status": s, "text": t, "link": link} for s, t, link in lines], [
        {"status": s, "text": t, "link": link} for s, t, link in quality
    ]
