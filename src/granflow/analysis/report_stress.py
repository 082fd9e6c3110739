"""The views of the report's stress-controlled runs and forecasts, read from the typed
:class:`~granflow.analysis.AnalysisResult`: each stress ramp's failure against the predicted
static yield, each switch's outcome against the simulated one, the static yield per load and
the stability map, the running forecasts (intervals written with digits enough that their two
ends differ). No statistic is computed here: every number is a field of a result, in display
units.
"""

from __future__ import annotations

import math
from typing import Any

from granflow._format import display_text
from granflow.analysis.formatting import (
    DASH,
    display_scale,
    format_interval,
    format_number,
)

__all__ = [
    "forecast_view",
    "prediction_view",
    "ramp_view",
    "switch_view",
]


# --------------------------------------------------------------------------- predictions


def _difference(observed, predicted, scale, unit):
    """observed − predicted in display units and relative to the prediction:
    ``−0.34 mN (−2.5 %)``."""
    if observed is None or predicted is None:
        return DASH
    difference = observed - predicted
    text = format_number(difference, scale, 3)
    text = (text if text.startswith("-") or text == "0" else "+" + text).replace("-", "−")
    text += f" {unit}" if unit else ""
    if predicted:
        text += f" ({100 * difference / abs(predicted):+.2g} %)".replace("-", "−")
    return text


def _row(quantity, observed, predicted, name):
    scale, unit = display_scale(name)
    shown = [DASH if v is None else format_number(v, scale) for v in (observed, predicted)]
    return {
        "quantity": f"{quantity} [{unit}]" if unit else quantity,
        "observed": shown[0],
        "predicted": shown[1],
        "difference": _difference(observed, predicted, scale, unit),
    }


def ramp_view(result: Any) -> list[dict[str, Any]]:
    """Each stress ramp's observed failure against the predicted static yield at its load."""
    entries = []
    for row in result.analyses.stress_ramp:
        observed = row.observed or {}
        width = None
        if row.F_peak_stderr is not None and row.F_peak_spread is not None:
            width = math.hypot(row.F_peak_stderr, row.F_peak_spread)
        entries.append(
            {
                "label": row.run,
                "reason": row.reason,
                "rows": [
                    _row(
                        "failure force F_f",
                        observed.get("failure_force"),
                        row.predicted_force,
                        "force",
                    ),
                    _row(
                        "failure time t_f", observed.get("failure_time"), row.predicted_time, "time"
                    ),
                ],
                "slip": observed.get("failure_slip"),
                "criterion": None if row.criterion is None else display_text(row.criterion),
                "width": width,
                "predicted": row.predicted_force,
                "z": row.z,
                "consistent": row.consistent,
            }
        )
    return entries


def switch_view(result: Any) -> list[dict[str, Any]]:
    """Each switch's observed outcome against the simulated one."""
    return [
        {
            "label": row.run,
            "reason": row.reason,
            "switch_time": row.switch_time,
            "switch_force": row.switch_force,
            "imposed_force": row.observed.get("imposed_force"),
            "factor": row.factor,
            "observed": row.observed.get("outcome"),
            "predicted": row.predicted,
            "agree": row.agree,
            "params_from": row.params_from,
        }
        for row in result.analyses.switch
    ]


def prediction_view(result: Any) -> dict[str, Any]:
    """The static yield per load and the stability map."""
    predictions = result.predictions
    stability = predictions.stability_map
    stability_view = None
    if stability is not None:
        found = stability.map
        counts: dict[str, int] = {}
        for outcome in found.outcome.ravel():
            counts[str(outcome)] = counts.get(str(outcome), 0) + 1
        points, ratios = found.switch_points, found.stress_ratios
        stability_view = {
            "normal_load": stability.normal_load,
            "counts": sorted(counts.items()),
            "points": (len(points), float(min(points)), float(max(points))),
            "ratios": (len(ratios), float(min(ratios)), float(max(ratios))),
            "method": found.method,
            "clock": found.clock,
        }
    return {
        "static_yield": list(predictions.static_yield),
        "static_yield_reason": None if predictions.determined else predictions.static_yield_reason,
        "stability": stability_view,
    }


# --------------------------------------------------------------------------- forecasts


def _interval_text(pair, scale):
    low, high = pair
    if low is None or high is None or (math.isnan(low) and math.isnan(high)):
        return DASH
    text = format_interval(["∞" if math.isinf(v) else v for v in (low, high)], scale)
    return text.replace("—", "∞") if any(math.isinf(v) for v in (low, high)) else text


def forecast_view(result: Any, figures: Any) -> list[dict[str, Any]]:
    """The running forecast of each run: at each cut the failure time and force with their
    intervals (digits enough that the two ends differ), beside the observed failure time
    and the observed failure force (the largest force the layer held)."""
    force_scale, _ = display_scale("force")
    verdict = {True: "yes", False: "no", None: DASH}
    entries = []
    for number, forecast in enumerate(result.forecasts, start=1):
        figure = next((f for f in figures if f["name"] == f"forecast_{number}"), None)
        rows = [
            {
                "cut": format_number(cut.cut),
                "time": format_number(cut.time, significant=5),
                "interval": _interval_text(cut.time_interval, 1.0)
                if cut.time is not None
                else DASH,
                "force": format_number(cut.force, force_scale),
                "force_interval": _interval_text(cut.force_interval, force_scale)
                if cut.time is not None
                else DASH,
                "holds": verdict[forecast.holds(cut)],
                "message": cut.message,
            }
            for cut in forecast.cuts
        ]
        window = forecast.observed_window
        observed = (
            "none in the record"
            if window is None
            else f"between {format_number(window[0])} and {format_number(window[1])} s (the "
            "last point held, the first runaway point)"
        )
        entries.append(
            {
                "label": forecast.run,
                "reason": forecast.reason,
                "level": f"{forecast.level:.0%}",
                "observed": format_number(forecast.observed),
                "observed_between": (
                    f"{format_number(forecast.observed)} s"
                    if window is None
                    else f"between {format_number(window[0])} and {format_number(window[1])} s"
                ),
                "converged": forecast.converged,
                "rows": rows,
                "details": [
                    ("observed failure", observed),
                    (
                        "observed failure force F_f (the largest force held)",
                        f"{format_number(forecast.observed_force, force_scale)} mN",
                    ),
                    ("prior", forecast.prior_from),
                    ("converged", verdict[forecast.converged]),
                ],
                "figure": figure,
            }
        )
    return entries
