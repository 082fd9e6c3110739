"""The report's summary in the paper's words: a headline of what the campaign shows about
aging and rejuvenation, then the verdicts, each with its numbers and a link to its section.

The headline (:func:`headline`) says, as far as the campaign allows: that the layer is
stronger at rest than sliding (static yield F_peak/F_N against the dynamic μ_d), the
rejuvenation length 1/α in grain diameters, that the preparations differ by x0 alone, what
creep below and above F_d does, and that the layer fails at the peak. The verdicts
(:func:`verdicts`) judge each analysis. Both read the typed result and the views of
:mod:`granflow.analysis.report_views`; every number is a field of a result.
"""

from __future__ import annotations

import math
from typing import Any

from granflow.analysis.formatting import (
    display_scale,
    format_interval,
    format_number,
    format_p_value,
    format_value_error,
)
from granflow.analysis.report_views import GRAIN_DIAMETER

__all__ = ["headline", "quality_lines", "verdicts"]

_FORCE = display_scale("force")
_SLIP = display_scale("slip")


def _mN(value, significant=4):
    return f"{format_number(value, _FORCE[0], significant)} {_FORCE[1]}"


def _um(value, significant=3):
    return f"{format_number(value, _SLIP[0], significant)} {_SLIP[1]}"


# --------------------------------------------------------------------------- the headline


def _static_dynamic(result: Any) -> str | None:
    rows = result.predictions.static_yield
    mu_d = result.material.mu_d.value
    if not rows or mu_d is None:
        return None
    peaks = [row.mu_peak for row in rows]
    low, high = min(peaks), max(peaks)
    span = (
        format_number(low, significant=3)
        if math.isclose(low, high, rel_tol=5e-3)
        else f"{format_number(low, significant=3)}–{format_number(high, significant=3)}"
    )
    excess = 100 * (sum(peaks) / len(peaks) / mu_d - 1)
    return (
        f"The layer is stronger at rest than sliding: it yields at F_peak/F_N = {span} "
        f"({len(rows)} load{'s' if len(rows) != 1 else ''}) against the dynamic friction "
        f"μ_d = {format_number(mu_d, significant=4)}, a static overshoot of "
        f"{excess:.0f} % that aging builds and sliding erases."
    )


def _rejuvenation(material: Any) -> str | None:
    length = material.get("length") if material else None
    if not length:
        return None
    return (
        f"Sliding rejuvenates the packing over 1/α = {_um(length['value'])} of slip, "
        f"{format_number(length['grains'], significant=2)} diameters of the paper's "
        f"{_um(GRAIN_DIAMETER, 2)} beads: a few grain contacts renewed, not a flow."
    )


def _preparations(spread: Any) -> str | None:
    if not spread or spread.get("reason"):
        return None
    held = [g for g in spread["groups"] if g["held"] is not None]
    if not held:
        return None
    low = min(g["held"]["x0_spread"]["min"] for g in held)
    high = max(g["held"]["x0_spread"]["max"] for g in held)
    return (
        f"Preparations differ by their initial state alone: x0 from {_um(low)} to {_um(high)} "
        "with a, α and F_d common to the repeats (Fig. 2a)."
    )


def _creep(result: Any, creep: Any) -> str | None:
    below = [c for c in creep if c["over_Fd"] is not None and c["over_Fd"] < 1]
    above = [c for c in creep if c["over_Fd"] is not None and c["over_Fd"] >= 1]
    if not creep:
        return None
    parts = [
        f"{format_number(c['over_Fd'], significant=2)} F_d (B = {_um(c['B'][0], 2)})"
        for c in sorted(creep, key=lambda c: c["over_Fd"] or 0)
        if c["over_Fd"] is not None
    ]
    if below and above:
        bigger = max(above, key=lambda c: c["B"][0] or 0)["B"][0] or 0
        smaller = max(below, key=lambda c: c["B"][0] or 0)["B"][0] or 0
        more = "more" if bigger > smaller else "no more"
        return (
            "Under constant forces that straddle F_d, both below F_peak, the layer creeps "
            f"logarithmically and holds: {', '.join(parts)}; it creeps {more} above F_d "
            "(Fig. 3b)."
        )
    if parts:
        side = "below" if below else "above"
        return (
            f"Under constant forces {side} F_d and below F_peak the layer creeps "
            f"logarithmically and holds: {', '.join(parts)} (Fig. 3b)."
        )
    return None


def _failure(result: Any) -> str | None:
    parts = []
    for row in result.analyses.stress_ramp:
        observed = row.observed or {}
        seen = observed.get("failure_force")
        if seen is None or row.predicted_force is None:
            continue
        parts.append(
            f"the stress ramp fails at {_mN(seen)} against the predicted F_peak "
            f"{_mN(row.predicted_force)}"
            + (" — at the peak" if row.consistent else " — not at the peak")
        )
    for row in result.analyses.switch:
        if row.predicted is None:
            continue
        parts.append(
            f"the switch to {format_number(row.factor, significant=3)} times the force at "
            f"t = {format_number(row.switch_time)} s gives {row.observed.get('outcome')} "
            f"(predicted {row.predicted})"
        )
    if not parts:
        return None
    text = "; ".join(parts)
    return text[0].upper() + text[1:] + " (Fig. 3a, 3c)."


def headline(result: Any, views: dict[str, Any]) -> list[str]:
    """What the campaign shows about aging and rejuvenation, sentence by sentence, in the
    paper's terms (empty when it shows none of it)."""
    sentences = [
        _static_dynamic(result),
        _rejuvenation(views["material"]),
        _preparations(views["spread"]),
        _creep(result, views["creep"]),
        _failure(result),
    ]
    return [s for s in sentences if s]


# --------------------------------------------------------------------------- the verdicts


def _material_line(result, material):
    if material is None or not result.material.determined:
        return None
    parts = []
    for row in material["rows"]:
        value = format_value_error(row["value"], row["stderr"], row["scale"])
        unit = f" {row['unit']}" if row["unit"] else ""
        interval = format_interval(row["ci95"], row["scale"])
        parts.append(f"{row['symbol']} = {value}{unit} (95 %: {interval})")
    text = "Material constants: " + "; ".join(parts)
    if material["source"]:
        text += f" ({material['source']})"
    truth = result.campaign.get("truth")
    if truth:
        outside = [k for k, ok in truth["contained"].items() if not ok]
        text += (
            "; the generator's values lie inside the 95 % intervals"
            if not outside
            else f"; the generator's values of {', '.join(outside)} lie outside the 95 % intervals"
        )
    return "ok", text + ".", "#material"


def _fit_line(result, runs):
    fitted = [r for r in runs if r["fit"]]
    goodness = result.analyses.goodness_of_fit
    if not fitted:
        return None
    if goodness is None:
        return "warn", f"{len(fitted)} Eq. 3 fits; no noise estimate to judge them by.", "#runs"
    noises = [j.noise for j in goodness.runs.values() if math.isfinite(j.noise)]
    noise = ""
    if noises:
        noise = (
            f"; force noise σ from the plateaus {format_number(min(noises), _FORCE[0], 2)}–"
            f"{format_number(max(noises), _FORCE[0], 2)} {_FORCE[1]}"
        )
    switches = sum(r["test"] == "switch" for r in fitted)
    what = f"{len(fitted)} rate-controlled curves" + (
        f" ({switches} before a switch)" if switches else ""
    )
    spread = (
        f"normalised χ² (χ² per degree of freedom over σ²) median "
        f"{format_number(goodness.median, significant=3)}, range "
        f"{format_number(goodness.min, significant=3)}–{format_number(goodness.max, significant=3)}"
        f"{noise}"
    )
    if goodness.poor:
        names = ", ".join(goodness.poor[:6]) + (
            f" and {len(goodness.poor) - 6} more" if len(goodness.poor) > 6 else ""
        )
        return (
            "warn",
            f"Eq. 3 misses {len(goodness.poor)} of {what} (normalised χ² above "
            f"{format_number(goodness.limit, significant=2)}: {names}); {spread}.",
            "#runs",
        )
    return "ok", f"Eq. 3 fits all {what} to the noise: {spread}.", "#runs"


def _collapse_line(collapse):
    if collapse is None or collapse.get("reason"):
        return None
    velocities = [row["velocity"] for row in collapse["rows"]]
    scale, unit = display_scale("velocity")
    span = (
        f"{len(velocities)} velocities ({format_number(min(velocities), scale, 3)}–"
        f"{format_number(max(velocities), scale, 3)} {unit})"
    )
    test = (
        f"likelihood-ratio test of shared a and α: statistic "
        f"{format_number(collapse['statistic'], significant=3)}, {collapse['df']} degrees of "
        f"freedom, p = {format_p_value(collapse['p_value'])}"
    )
    if collapse["collapses"]:
        return "ok", f"The curves collapse in slip: one preparation at {span}; {test}.", "#collapse"
    return (
        "warn",
        f"The curves do not collapse in slip (a or α depends on v): {span}; {test}.",
        "#collapse",
    )


def _amontons_line(amontons):
    if amontons is None or amontons.get("reason"):
        return None
    test = amontons["test"]
    if test is None:
        return "warn", "Amontons' law not tested: fewer than three loads with repeats.", "#amontons"
    parts = [
        f"{r.name}: χ² = {format_number(r.statistic, significant=3)}, {r.df} d.o.f., "
        f"p = {format_p_value(r.p_value)}"
        for r in test.relations
    ]
    verdict = "holds" if test.holds else "fails"
    return (
        "ok" if test.holds else "warn",
        f"Amontons' law {verdict} over {test.loads} loads (p = {format_p_value(test.p_value)}, "
        f"Bonferroni over the three relations): " + "; ".join(parts) + ".",
        "#amontons",
    )


def _spread_line(spread):
    if spread is None or spread.get("reason") or not spread["groups"]:
        return None
    parts = []
    for group in spread["groups"]:
        held = group["held"]
        if held is None:
            continue
        x0 = held["x0_spread"]
        parts.append(
            f"“{group['label']}” at {format_number(group['normal_load'], _FORCE[0], 3)} "
            f"{_FORCE[1]} ({group['repeats']} repeats): x0 {_um(x0['min'])}–{_um(x0['max'])}, "
            f"relative spread {format_number(100 * x0['relative'], significant=2)} %"
        )
    if not parts:
        return None
    shown = parts[:3] + ([f"and {len(parts) - 3} more groups"] if len(parts) > 3 else [])
    return (
        "ok",
        "The preparations differ by x0 alone (a, α and F_d held common to the repeats): "
        + "; ".join(shown)
        + ".",
        "#preparation",
    )


def _yield_line(result):
    rows = result.predictions.static_yield
    if not rows:
        return None
    parts = [
        f"{format_number(row.normal_load, _FORCE[0], 3)} {_FORCE[1]}: "
        f"{format_value_error(row.F_peak, row.stderr, _FORCE[0])} {_FORCE[1]}"
        for row in rows
    ]
    return "ok", "Static yield F_peak per load F_N — " + "; ".join(parts) + ".", "#static-yield"


def _stress_lines(result, views):
    lines = []
    for entry in views["ramp"]:
        if entry["reason"] or entry["predicted"] is None:
            continue
        failure = entry["rows"][0]
        timing = entry["rows"][1]
        text = (
            f"Stress ramp {entry['label']}: failed at {failure['observed']} mN, "
            f"{failure['difference']} from the predicted F_peak "
            f"{format_value_error(entry['predicted'], entry['width'], _FORCE[0])} mN"
        )
        if timing["observed"] != "—" and timing["predicted"] != "—":
            text += f", at t = {timing['observed']} s (predicted {timing['predicted']} s)"
        good = entry["consistent"]
        ending = " — consistent." if good else " — not consistent."
        lines.append(("ok" if good else "warn", text + ending, "#ramp"))
    for row in views["creep"]:
        if row["over_peak"] is None:
            continue
        text = (
            f"Creep {row['name']}: held at {_mN(row['force'])} "
            f"({format_number(row['over_Fd'], significant=3)} F_d, "
            f"{format_number(row['over_peak'], significant=2)} F_peak), logarithmic creep "
            f"B = {_um(row['B'][0])}, no failure, as predicted below F_peak."
        )
        lines.append(("ok", text, "#creep"))
    for entry in views["switch"]:
        if entry["reason"]:
            continue
        agree = entry["agree"]
        text = (
            f"Switch {entry['label']} at t = {format_number(entry['switch_time'])} s to "
            f"{format_number(entry['factor'], significant=3)} times the force: observed "
            f"{entry['observed']}, predicted {entry['predicted']}"
        )
        lines.append(
            (
                "ok" if agree else "warn",
                text + (" — agree." if agree else " — disagree."),
                "#switch",
            )
        )
    for forecast in views["forecasts"]:
        if forecast["reason"] or not forecast["rows"]:
            continue
        last = forecast["rows"][-1]
        lines.append(
            (
                "ok" if forecast["converged"] else "warn",
                f"Failure forecast {forecast['label']}: at {last['cut']} s, t_f = "
                f"{last['time']} s {last['interval']} ({forecast['level']}) against the "
                f"failure observed {forecast['observed_between']}.",
                "#forecasting",
            )
        )
    return lines


def verdicts(result: Any, views: dict[str, Any]) -> list[dict[str, str]]:
    """The verdicts at the top of the report, in the order of the sections: (status, text,
    link) per line."""
    lines = [
        _material_line(result, views["material"]),
        _fit_line(result, views["runs"]),
        _collapse_line(views["collapse"]),
        _amontons_line(views["amontons"]),
        _spread_line(views["spread"]),
        _yield_line(result),
        *_stress_lines(result, views),
        *(section["summary"] for section in views["record_sections"]),
    ]
    return [{"status": s, "text": t, "link": link} for s, t, link in filter(None, lines)]


def quality_lines(views: dict[str, Any]) -> list[dict[str, str]]:
    """The data-quality verdicts: each flagged run, failed run, fit at a bound, poor
    convergence and warning; one line saying so when there is none."""
    warnings = views["warnings"]
    lines = [
        ("warn", f"{item['name']}: " + "; ".join(item["problems"]), "#data-quality")
        for item in views["quality"]["flagged"]
    ]
    lines += [
        ("bad", f"{f['name']} failed: {f['reason']}", "#failed-runs") for f in warnings["failed"]
    ]
    lines += [
        ("warn", f"{name}: {params} at a bound of its range", "#at-bound")
        for name, params in warnings["at_bound"]
    ]
    lines += [
        ("warn", f"{name}: {message}", "#convergence") for name, message in warnings["convergence"]
    ]
    lines += [("warn", message, "#analysis-warnings") for message in warnings["messages"]]
    lines += [("warn", message, "#report-warnings") for message in warnings["report"]]
    if not lines:
        lines.append(
            (
                "ok",
                f"No data-quality problem: all {len(views['runs'])} runs read whole and "
                "analysed, no point left out, no fit at a bound, every fit converged.",
                "#data-quality",
            )
        )
    return [{"status": s, "text": t, "link": link} for s, t, link in lines]
