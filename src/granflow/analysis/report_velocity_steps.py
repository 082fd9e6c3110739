"""The report's velocity-step section and its verdict line, from ``results["velocity_steps"]``.

One block per record: the figure of the rate-and-state fit over the data with its residuals,
the parameter table (value, standard error, 95 % interval) and the model comparison (the
rate-and-state aging and slip laws, the paper's Eq. 2 with and without the direct effect).
"""

from collections.abc import Callable, Mapping
from typing import Any

from granflow._format import real_number
from granflow.analysis.report_views import as_list, as_mapping, comparison_view

__all__ = ["velocity_steps_line", "velocity_steps_view"]


def _number(value: Any, significant: int = 3) -> str:
    value = real_number(value)
    return "—" if value is None else f"{value:.{significant}g}"


def velocity_steps_view(
    results: Mapping[str, Any], figures: Callable[[Mapping[str, Any]], list[dict[str, Any]]]
) -> dict[str, Any] | None:
    """The section's records, or None without velocity-step records.

    Parameters
    ----------
    results : mapping
        The content of ``results.json``.
    figures : callable
        Turns ``{"figures": [...]}`` into the report's figure entries (embedded PNGs).
    """
    steps = as_mapping(results.get("velocity_steps"))
    if not steps:
        return None
    records = []
    for index, record in enumerate(as_list(steps.get("records"))):
        record = as_mapping(record)
        fit = as_mapping(record.get("fit"))
        name = str(record.get("name") or f"record {index + 1}")
        (figure,) = figures(
            {
                "figures": [
                    {
                        "name": f"velocity-step-{index + 1}",
                        "title": f"{name}: rate-and-state fit ({record.get('law')} law)",
                        "caption": str(record.get("caption") or ""),
                        "png": record.get("figure"),
                    }
                ]
            }
        )
        comparison = comparison_view([{**as_mapping(record.get("comparison")), "label": None}])
        rows = []
        for row in as_list(fit.get("parameters")):
            row = as_mapping(row)
            low, high = [*as_list(row.get("ci95")), None, None][:2]
            rows.append(
                {
                    "name": str(row.get("name")),
                    "value": _number(row.get("value"), 4),
                    "stderr": _number(row.get("stderr"), 2),
                    "ci95": f"[{_number(low, 4)}, {_number(high, 4)}]",
                    "method": str(row.get("method") or ""),
                    "unit": str(row.get("unit") or ""),
                }
            )
        records.append(
            {
                "name": name,
                "law": str(record.get("law") or ""),
                "figure": figure,
                "parameters": rows,
                "a_minus_b": _number(fit.get("a_minus_b"), 3),
                "a_minus_b_ci": _number(1.96 * (real_number(fit.get("a_minus_b_stderr")) or 0), 2),
                "rms_ratio": _ratio(fit),
                "ripple": bool(fit.get("harmonics")),
                "comparison": comparison["groups"][0] if comparison else None,
            }
        )
    failed = [as_mapping(f) for f in as_list(steps.get("failed"))]
    return {
        "records": records,
        "failed": [(str(f.get("name")), str(f.get("reason"))) for f in failed],
    }


def _ratio(fit: Mapping[str, Any]) -> str:
    rms, scatter = real_number(fit.get("residual_rms")), real_number(fit.get("scatter"))
    return "—" if rms is None or not scatter else f"{rms / scatter:.2f}"


def velocity_steps_line(view: Mapping[str, Any] | None) -> tuple[str, str, str] | None:
    """One verdict with numbers: (class, text, link), or None without velocity-step records."""
    if view is None:
        return None
    parts = []
    for record in view["records"]:
        comparison = record["comparison"] or {}
        parts.append(
            f"{record['name']}: a − b = {record['a_minus_b']} ± {record['a_minus_b_ci']} "
            f"({record['law']} law{' with the apparatus ripple' if record.get('ripple') else ''}"
            f", residual RMS {record['rms_ratio']} × the scatter), "
            f"best by AIC {comparison.get('best_aic', '—')}"
        )
    parts += [f"{name} failed" for name, _ in view["failed"]]
    status = "warn" if view["failed"] else "ok"
    count = len(view["records"]) + len(view["failed"])
    text = f"Velocity steps ({count} record{'s' if count != 1 else ''}): " + "; ".join(parts) + "."
    return status, text, "#velocity-steps"
