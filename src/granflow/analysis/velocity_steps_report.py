"""The report's section of the velocity-step records (``#velocity-steps``), read from the
campaign's :class:`~granflow.analysis.velocity_steps.VelocitySteps`: each record's figure,
its parameters in display units (Dc in µm) with the digits their errors justify, its model
comparison, and the verdict line of the report's summary.

This is the ``section`` of the friction family (:mod:`granflow.families`): the report calls
:func:`velocity_steps_section` for it and renders its template ``velocity_steps.html.j2``.
No statistic is computed here: every number is a field of a result.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from granflow.analysis.formatting import DASH, format_interval, format_number, format_value_error
from granflow.analysis.report_views import comparison_view

__all__ = ["velocity_step_figures", "velocity_steps_line", "velocity_steps_section"]

#: The section's anchor in the report, its title in the contents, its template.
ANCHOR, TITLE, TEMPLATE = "velocity-steps", "Velocity steps", "velocity_steps.html.j2"


def _step_value(value, unit, significant=4):
    scale, shown = (1e6, "µm") if unit == "m" else ((1e-6, "1/µm") if unit == "1/m" else (1, unit))
    return format_number(value, scale, significant), shown


def velocity_steps_view(steps: Any, figures: Any) -> list[dict[str, Any]]:
    """Each velocity-step record of ``steps`` (a
    :class:`~granflow.analysis.velocity_steps.VelocitySteps`): its figure (from ``figures``,
    by name ``velocity-step-<k>``), its parameters in display units (Dc in µm) with the
    digits their errors justify, and its model comparison."""
    records = []
    for index, record in enumerate(steps.records, start=1):
        fit = record.fit
        figure = next((f for f in figures if f["name"] == f"velocity-step-{index}"), None)
        parameters = []
        for p in fit.parameters:
            value, unit = _step_value(p.value, p.unit)
            scale = 1e6 if p.unit == "m" else (1e-6 if p.unit == "1/m" else 1.0)
            parameters.append(
                {
                    "name": p.name,
                    "value": format_value_error(p.value, p.stderr, scale)
                    if p.method != "fixed"
                    else f"{value} (held)",
                    "ci95": format_interval(list(p.ci95), scale) if p.method != "fixed" else DASH,
                    "method": p.method,
                    "unit": unit,
                }
            )
        records.append(
            {
                "name": record.name,
                "law": record.law,
                "figure": figure,
                "parameters": parameters,
                "a_minus_b": format_value_error(fit.a_minus_b, fit.a_minus_b_stderr),
                "a_minus_b_ci": format_number(1.96 * fit.a_minus_b_stderr, significant=2),
                "rms_ratio": format_number(fit.rms_ratio, significant=3),
                "ripple": bool(fit.harmonics),
                "comparison": comparison_view(record.comparison),
            }
        )
    return records


def velocity_step_figures(steps: Any) -> list[dict[str, Any]]:
    """The figure entries of the velocity-step records (``velocity-step-<k>``)."""
    return [
        {
            "name": f"velocity-step-{index}",
            "title": f"{record.name}: rate-and-state fit ({record.law} law)",
            "caption": record.caption,
            "png": record.figure,
        }
        for index, record in enumerate(steps.records, start=1)
    ]


def velocity_steps_line(
    records: list[dict[str, Any]], failed: list[tuple[str, str]]
) -> tuple[str, str, str] | None:
    """The summary's verdict on the velocity steps: (status, text, link), or None."""
    if not records and not failed:
        return None
    parts = []
    for record in records:
        comparison = record["comparison"]
        parts.append(
            f"{record['name']}: a − b = {record['a_minus_b']} ({record['law']} law"
            f"{' with the apparatus ripple' if record['ripple'] else ''}, residual RMS "
            f"{record['rms_ratio']} × the scatter), best by AIC {comparison['best_aic']}"
        )
    parts += [f"{name} failed" for name, _ in failed]
    count = len(records) + len(failed)
    return (
        "warn" if failed else "ok",
        f"Velocity steps ({count} record{'s' if count != 1 else ''}): " + "; ".join(parts) + ".",
        f"#{ANCHOR}",
    )


def velocity_steps_section(
    steps: Any, figures: Callable[[list[dict[str, Any]]], list[dict[str, Any]]]
) -> dict[str, Any]:
    """The report's section of the velocity-step records.

    Parameters
    ----------
    steps : VelocitySteps
        The campaign's velocity-step records.
    figures : callable
        ``figures(entries) -> views``: the report's embedding of figure entries (``name``,
        ``title``, ``caption``, ``png`` relative to the output folder).

    Returns
    -------
    dict
        ``id`` (the anchor), ``title`` (in the contents), ``template``, ``view`` (what the
        template reads: ``records`` and ``failed``, (name, reason) pairs) and ``summary``
        (the verdict line, or None).
    """
    records = velocity_steps_view(steps, figures(velocity_step_figures(steps)))
    failed = [(str(f.get("name")), str(f.get("reason"))) for f in steps.failed]
    return {
        "id": ANCHOR,
        "title": TITLE,
        "template": TEMPLATE,
        "view": {"records": records, "failed": failed},
        "summary": velocity_steps_line(records, failed),
    }
