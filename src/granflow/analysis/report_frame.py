"""The frame of the HTML report, read from the typed :class:`~granflow.analysis.AnalysisResult`:
its figures by section (PNG embedded as data URIs, SVG linked), the warnings, the analysis
options by name with their units, and the timing.
"""

from __future__ import annotations

import base64
import os
import re
from pathlib import Path
from typing import Any

from granflow.analysis.formatting import DASH, display_scale, format_number, real_number

__all__ = ["FIGURE_SECTIONS", "figures_view", "options_view", "timing_view", "warnings_view"]

#: The section each figure belongs to, by the figure's name (``forecast_<k>`` go to the
#: forecasts; any other figure to the publication figures).
FIGURE_SECTIONS = {
    "startup": "runs",
    "fits": "runs",
    "collapse": "collapse",
    "amontons": "amontons",
    "stress_ramp": "ramp",
    "creep": "creep",
    "switch": "switch",
    "stability_map": "stability-map",
}

_PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"


def _figure_section(name: str) -> str:
    if name.startswith("forecast_"):
        return "forecasting"
    if name.startswith("fits"):
        return "runs"
    return FIGURE_SECTIONS.get(name, "publication")


def _png_size(data: bytes) -> tuple[int, int]:
    return int.from_bytes(data[16:20], "big"), int.from_bytes(data[20:24], "big")


def figures_view(
    figures: Any, output_dir: Path | None, report_dir: Path, problems: list[str]
) -> dict[str, list[dict[str, Any]]]:
    """The figures by section: each with its PNG embedded as a data URI and a link to its
    SVG; a figure whose file cannot be read is named in ``problems``."""
    by_section: dict[str, list[dict[str, Any]]] = {}
    for index, figure in enumerate(figures):
        name = str(figure.get("name") or f"figure {index + 1}")
        entry: dict[str, Any] = {
            "name": name,
            "anchor": "fig-" + re.sub(r"[^A-Za-z0-9_-]", "-", name),
            "title": str(figure.get("title") or name),
            "caption": str(figure.get("caption") or ""),
            "src": None,
            "width": None,
            "height": None,
            "svg": None,
        }
        png = figure.get("png")
        if png and output_dir is not None:
            try:
                data = Path(output_dir, png).read_bytes()
            except OSError as exc:
                problems.append(f"figure {name!r}: cannot read {png}: {exc.strerror or exc}")
            else:
                if data.startswith(_PNG_SIGNATURE) and len(data) > 24:
                    encoded = base64.b64encode(data).decode("ascii")
                    entry["src"] = f"data:image/png;base64,{encoded}"
                    entry["width"], entry["height"] = _png_size(data)
                else:
                    problems.append(f"figure {name!r}: {png} is not a PNG file")
        else:
            problems.append(f"figure {name!r}: no PNG file given")
        svg = figure.get("svg")
        if svg and output_dir is not None and Path(output_dir, svg).is_file():
            entry["svg"] = Path(os.path.relpath(Path(output_dir, svg), report_dir)).as_posix()
        by_section.setdefault(_figure_section(name), []).append(entry)
    return by_section


# --------------------------------------------------------------------------- the rest


def warnings_view(result: Any, runs: Any, problems: Any) -> dict[str, Any]:
    """Failed runs, fits at a bound or not converged, the analysis' warnings and the
    report's own problems."""
    failed = [
        {
            "name": str(f.get("name") or f.get("source") or DASH),
            "source": str(f.get("source") or ""),
            "reason": str(f.get("reason") or "no reason given"),
        }
        for f in result.failed_runs
    ]
    at_bound = [
        (run["name"], ", ".join(run["fit"]["at_bound"]))
        for run in runs
        if run["fit"] and run["fit"]["at_bound"]
    ]
    convergence = [
        (run["name"], run["fit"]["message"] or "the fit did not converge")
        for run in runs
        if run["fit"] and not run["fit"]["success"]
    ]
    analyses = result.analyses
    joint = []
    if analyses.velocity_collapse is not None:
        collapse = analyses.velocity_collapse.result
        joint += [
            ("velocity collapse (shared fit)", collapse.shared),
            ("velocity collapse (per-velocity fit)", collapse.per_velocity),
        ]
    if analyses.amontons is not None:
        joint.append(("Amontons joint fit", analyses.amontons.result.joint))
    convergence += [
        (name, str(fit.message or "did not converge")) for name, fit in joint if not fit.success
    ]
    return {
        "failed": failed,
        "at_bound": at_bound,
        "convergence": convergence,
        "messages": [str(w) for w in result.warnings],
        "report": problems,
    }


#: How each analysis option is shown: (label, quantity for its unit, or a formatter).
_OPTIONS = {
    "mcmc": ("posterior sampling (MCMC)", None),
    "seed": ("random seed", None),
    "strict": ("data-quality problems are errors", None),
    "analysis_version": ("analysis version", None),
    "runaway_factor": ("runaway: velocity above this many times the reference", None),
    "reference_velocity": ("reference velocity", "velocity"),
    "elastic_ramp_tolerance": ("elastic ramp: tolerance in noise levels", None),
    "forecast.cut_fractions": ("forecast cuts, as fractions of the failure time", None),
    "forecast.level": ("forecast intervals", "fraction"),
    "stability_map.switch_points": ("stability map: switch times", None),
    "stability_map.stress_ratios": ("stability map: force ratios", None),
    "stability_map.hold": ("stability map: hold after the switch", "time"),
}


def _option_text(value, quantity):
    if isinstance(value, bool):
        return "yes" if value else "no"
    if quantity == "fraction" and real_number(value) is not None:
        return f"{100 * value:.3g} %"
    if quantity is not None and real_number(value) is not None:
        scale, unit = display_scale(quantity)
        return f"{format_number(value, scale)} {unit}"
    if isinstance(value, list | tuple):
        return ", ".join(format_number(v) if real_number(v) is not None else str(v) for v in value)
    return str(value)


def options_view(provenance: Any) -> list[tuple[str, str]]:
    """The analysis options by name and with their units (a fraction as a percentage: the
    forecast level 0.9 is "90 %"); an option this table does not know is shown as given."""
    rows = []

    def visit(prefix, options):
        for key, value in options.items():
            path = f"{prefix}{key}"
            if hasattr(value, "items"):
                visit(f"{path}.", value)
                continue
            label, quantity = _OPTIONS.get(path, (path, None))
            rows.append((label, _option_text(value, quantity)))

    visit("", provenance.get("options", {}))
    return rows


def timing_view(timing: Any) -> list[tuple[str, str]]:
    """When the analysis ran, how long each stage took and how it ran."""
    rows = []
    for key in ("started", "finished"):
        if timing.get(key):
            rows.append((key, str(timing[key])))
    if timing.get("elapsed_s") is not None:
        rows.append(("elapsed", f"{format_number(timing['elapsed_s'], significant=3)} s"))
    stages = timing.get("stages_s") or {}
    if stages:
        rows.append(
            (
                "stages",
                ", ".join(
                    f"{key.removesuffix('_s').replace('_', ' ')} "
                    f"{format_number(value, significant=2)} s"
                    for key, value in stages.items()
                ),
            )
        )
    if timing.get("jobs") is not None:
        rows.append(("worker processes", str(timing["jobs"])))
    if timing.get("scheduler"):
        rows.append(("scheduler", str(timing["scheduler"])))
    for key, label in (("fitted_now", "runs analysed now"), ("reused", "saved results reused")):
        if timing.get(key) is not None:
            rows.append((label, str(timing[key])))
    return rows
