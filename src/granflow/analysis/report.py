"""The HTML report of a campaign analysis: one self-contained file that opens offline.

:func:`render_report` turns the content of ``results.json`` (see :mod:`granflow.analysis`)
into ``report.html``: a summary of verdicts first (the material constants with intervals;
the fits against the noise of their plateaus; the velocity collapse; Amontons' law and its
test; the preparation spread; the static yield per load; the stress-controlled runs against
their predictions; every data-quality problem; each line linking to its section, see
:mod:`granflow.analysis.report_summary`), then the campaign, material constants, per-run fits,
joint analyses, predictions, the failure forecasts, figures (PNG embedded as base64 data
URIs), warnings and provenance. The page has no external resources (no fonts, style sheets
or scripts) and no JavaScript; a print style sheet keeps every column (the run table on
landscape pages) and puts figures two to a page.

Every quantity in ``results`` is in SI units; the report shows display units (mN, µm, µm/s,
s, 1/m and 1/µm). Sections whose entry is missing or None are left out; an analysis given as
``{"reason": "..."}`` (or whose material value is None) shows that reason instead.

Accepted shapes beyond the plain ``to_dict()`` of granflow's results:

* ``analyses["preparation_spread"]`` and ``analyses["model_comparison"]``: one result, a list
  of results (each with an optional ``"name"``, ``"run"`` or ``"preparation"``), or a mapping
  from a label to a result; a spread's ``"held"`` (the joint fit with a, α and F_d common to
  the repeats) is shown where given;
* ``analyses["goodness_of_fit"]``: ``"runs"`` (name -> ``noise`` [N], ``chi2``) for the run
  table's σ and χ²ₙ columns and the summary;
* ``analyses["stress_ramp"]`` and ``analyses["switch"]``: a mapping or a list of mappings with
  an optional ``"run"`` (or ``"name"``) and ``"observed"`` / ``"predicted"`` mappings of
  quantities, shown side by side with the signed difference observed − predicted (in display
  units and relative to the prediction); other scalar entries are listed under the table by
  a physicist's name (:data:`granflow.analysis.report_summary.LABELS`);
* ``analyses["creep"]``: a list of mappings with ``"name"`` (or ``"run"``), an optional
  imposed ``"force"`` (or ``"stress"``, ``"imposed_force"``) [N] and a ``"fit"`` (the
  ``to_dict()`` of :class:`granflow.CurveFitResult`); runs whose own fit is a creep fit are
  listed too;
* ``forecasts``: a list of :meth:`granflow.analysis.forecasts.RunForecast.to_dict`, shown
  with the figures named ``forecast_<k>`` (k from 1, its place in the list);
* ``predictions["stability_map"]``: the ``to_dict()`` of :class:`granflow.StabilityMap` (or a
  summary with ``"counts"``), or a list of them.

:func:`render_report` also takes the :class:`granflow.analysis.AnalysisResult` itself (it
renders its ``results``). Quantities are put into display units by their names, looked up in
the unit table (:func:`granflow.analysis.formatting.display_unit`).
"""

import base64
import os
import re
from collections.abc import Mapping
from pathlib import Path

from granflow._files import write_text_atomic
from granflow.analysis.formatting import (
    DASH,
    display_unit,
    format_interval,
    format_number,
    format_p_value,
    format_percent,
    format_value_error,
    header_label,
    quantity_text,
    real_number,
)
from granflow.analysis.report_summary import experiment_view, label_of, summary_view
from granflow.analysis.report_velocity_steps import velocity_steps_line, velocity_steps_view
from granflow.analysis.report_views import (
    amontons_view,
    as_list,
    as_mapping,
    campaign_view,
    collapse_view,
    comparison_view,
    forecast_view,
    labelled,
    material_view,
    quality_view,
    reason_of,
    runs_view,
    scalars,
    spread_view,
)
from granflow.errors import InvalidParameterError

__all__ = [
    "display_unit",
    "format_interval",
    "format_number",
    "format_p_value",
    "format_value_error",
    "render_html",
    "render_report",
]

TEMPLATE = "report.html.j2"
#: The symbols of the model's parameters in the report's text.
_SYMBOLS = {"alpha": "α", "Fd": "F_d", "x0": "x₀", "t0": "t₀", "k": "αv"}
_PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"


def _stability_view(stability):
    if stability is None:
        return None
    if reason_of(stability) is not None:
        return {"reason": reason_of(stability), "maps": []}
    maps = []
    for label, entry in labelled(stability, keys=("name", "label")):
        if real_number(entry.get("normal_load")) is not None:
            label = f"at F_N = {quantity_text('normal_load', entry['normal_load'])}"
        counts = dict(as_mapping(entry.get("counts")))
        if not counts:
            for row in as_list(entry.get("outcome")):
                for cell in as_list(row) if isinstance(row, list | tuple) else [row]:
                    counts[str(cell)] = counts.get(str(cell), 0) + 1
        points = [p for p in map(real_number, as_list(entry.get("switch_points"))) if p is not None]
        ratios = [r for r in map(real_number, as_list(entry.get("stress_ratios"))) if r is not None]
        params = as_mapping(entry.get("params"))
        maps.append(
            {
                "label": label,
                "reason": reason_of(entry),
                "counts": sorted(counts.items()),
                "points": (len(points), min(points), max(points)) if points else None,
                "ratios": (len(ratios), min(ratios), max(ratios)) if ratios else None,
                "details": scalars(
                    {k: entry.get(k) for k in ("velocity", "method", "clock") if k in entry}
                ),
                "params": [
                    (_SYMBOLS.get(str(k), str(k)), quantity_text(k, v)) for k, v in params.items()
                ],
            }
        )
    return {"reason": None, "maps": maps}


def _static_yield_view(rows):
    if rows is None:
        return None
    if reason_of(rows) is not None:
        return {"reason": reason_of(rows), "rows": [], "extra": [], "has_ci95": False}
    rows = [as_mapping(row) for row in as_list(rows)]
    known = {"normal_load", "F_peak", "stderr", "ci95", "velocity"}
    extra = list(
        dict.fromkeys(
            key
            for row in rows
            for key, value in row.items()
            if key not in known and real_number(value) is not None
        )
    )
    return {
        "reason": None,
        "has_ci95": any(isinstance(row.get("ci95"), list | tuple) for row in rows),
        "extra": [label_of(key) for key in extra],
        "rows": [
            {
                "normal_load": real_number(row.get("normal_load")),
                "F_peak": (real_number(row.get("F_peak")), real_number(row.get("stderr"))),
                "ci95": row.get("ci95"),
                "extra": [quantity_text(key, row.get(key), unit=False) for key in extra],
            }
            for row in rows
        ],
    }


def _png_size(data):
    """(width, height) from a PNG header."""
    return int.from_bytes(data[16:20], "big"), int.from_bytes(data[20:24], "big")


def _figures_view(results, output_dir, report_dir, problems):
    figures = []
    for index, figure in enumerate(as_list(results.get("figures"))):
        figure = as_mapping(figure)
        name = str(figure.get("name") or f"figure {index + 1}")
        entry = {
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
        if png:
            file = Path(output_dir, png)
            try:
                data = file.read_bytes()
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
        if svg and Path(output_dir, svg).is_file():
            entry["svg"] = Path(os.path.relpath(Path(output_dir, svg), report_dir)).as_posix()
        figures.append(entry)
    return figures


def _warnings_view(results, runs, analyses, problems):
    failed = []
    for entry in as_list(results.get("failed_runs")):
        entry = as_mapping(entry)
        failed.append(
            {
                "name": str(entry.get("name") or entry.get("source") or DASH),
                "source": str(entry.get("source") or ""),
                "reason": str(entry.get("reason") or "no reason given"),
            }
        )
    listed = {f["name"] for f in failed}
    for run in runs:
        if run["failed"] and run["name"] not in listed:
            failed.append(
                {
                    "name": run["name"],
                    "source": run["source"],
                    "reason": run["reason"] or "no reason given",
                }
            )
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
    for name, joint in (
        (
            "velocity collapse (shared fit)",
            as_mapping(analyses.get("velocity_collapse")).get("shared"),
        ),
        (
            "velocity collapse (per-velocity fit)",
            as_mapping(analyses.get("velocity_collapse")).get("per_velocity"),
        ),
        ("Amontons joint fit", as_mapping(analyses.get("amontons")).get("joint")),
    ):
        if isinstance(joint, Mapping) and joint.get("success") is False:
            convergence.append((name, str(joint.get("message") or "did not converge")))
    return {
        "failed": failed,
        "at_bound": at_bound,
        "convergence": convergence,
        "messages": [str(w) for w in as_list(results.get("warnings"))],
        "report": problems,
    }


def _provenance_view(results):
    provenance = as_mapping(results.get("provenance"))
    inputs = [
        {
            "file": str(as_mapping(i).get("file") or DASH),
            "sha256": str(as_mapping(i).get("sha256") or ""),
        }
        for i in as_list(provenance.get("inputs"))
    ]
    options = []
    for key, value in as_mapping(provenance.get("options")).items():
        options.append((str(key), quantity_text("", value)))
    timing = [
        (header_label(k), quantity_text(k, v, unit=False))
        for k, v in as_mapping(results.get("timing")).items()
    ]
    tables = []
    for name, files in as_mapping(results.get("tables")).items():
        files = as_mapping(files)
        tables.append((str(name), ", ".join(str(v) for v in files.values() if v)))
    from granflow import __version__

    return {
        "version": str(results.get("granflow_version") or DASH),
        "renderer": __version__,
        "inputs": inputs,
        "options": options,
        "timing": timing,
        "tables": tables,
        "extra": scalars(provenance, skip=("inputs", "options")),
    }


def _context(results, output_dir, report_dir):
    if hasattr(results, "results"):  # an AnalysisResult: its results.json content
        results = results.results
    if not isinstance(results, Mapping):
        raise InvalidParameterError(
            f"results must be a mapping (the content of results.json), got {type(results).__name__}"
        )
    problems = []
    runs, creep = runs_view(results)
    analyses = as_mapping(results.get("analyses"))
    predictions = as_mapping(results.get("predictions"))
    campaign = as_mapping(results.get("campaign"))
    timing = as_mapping(results.get("timing"))
    joint = {
        "collapse": collapse_view(analyses.get("velocity_collapse")),
        "amontons": amontons_view(analyses.get("amontons")),
        "spread": spread_view(analyses.get("preparation_spread")),
        "comparison": comparison_view(analyses.get("model_comparison")),
    }
    known = {
        "velocity_collapse",
        "amontons",
        "preparation_spread",
        "model_comparison",
        "creep",
        "stress_ramp",
        "switch",
        "goodness_of_fit",
    }
    other = [
        (str(k), reason_of(v) or "", scalars(v))
        for k, v in analyses.items()
        if k not in known and v is not None
    ]
    prediction = {
        "static_yield": _static_yield_view(predictions.get("static_yield")),
        "stability": _stability_view(predictions.get("stability_map")),
        "ramp": experiment_view(analyses.get("stress_ramp")),
        "switch": experiment_view(analyses.get("switch")),
    }
    figures = _figures_view(results, output_dir, report_dir, problems)
    forecasts, figures = forecast_view(as_list(results.get("forecasts")), figures)
    context = {
        "synthetic": bool(results.get("synthetic")),
        "title": str(campaign.get("name") or campaign.get("title") or "campaign"),
        "date": str(timing.get("finished") or timing.get("started") or ""),
        "campaign": campaign_view(results, runs),
        "material": material_view(results),
        "runs": runs,
        "quality": quality_view(runs),
        "any_fit": any(r["fit"] for r in runs),
        "chi_scaled": any(r["fit"] and not r["fit"]["sigma_known"] for r in runs),
        "creep": creep,
        "joint": joint,
        "any_joint": any(v is not None for v in joint.values()) or bool(other),
        "other": other,
        "prediction": prediction,
        "any_prediction": any(v is not None for v in prediction.values()),
        "forecasts": forecasts,
        "figures": figures,
        "warnings": _warnings_view(results, runs, analyses, problems),
        "provenance": _provenance_view(results),
    }
    context["velocity_steps"] = velocity_steps_view(
        results, lambda found: _figures_view(found, output_dir, report_dir, problems)
    )
    context["summary"], context["quality_summary"] = summary_view(results, context)
    line = velocity_steps_line(context["velocity_steps"])
    if line is not None:
        status, text, link = line
        context["summary"].append({"status": status, "text": text, "link": link})
    return context


# --------------------------------------------------------------------------- rendering


def _environment():
    import jinja2

    environment = jinja2.Environment(
        loader=jinja2.PackageLoader("granflow.analysis", "templates"),
        autoescape=True,
        undefined=jinja2.StrictUndefined,
        trim_blocks=True,
        lstrip_blocks=True,
        keep_trailing_newline=True,
    )

    def scale(name):
        return display_unit(name)[0]

    environment.globals.update(unit=lambda name: display_unit(name)[1], scale=scale)
    environment.filters.update(
        si=lambda value, name, significant=4: format_number(value, scale(name), significant),
        pm_si=lambda estimate, name: format_value_error(*estimate, scale=scale(name)),
        interval_si=lambda bounds, name: format_interval(bounds, scale(name)),
        num=format_number,
        pm=lambda estimate, scale=1.0: format_value_error(*estimate, scale=scale),
        value_error=format_value_error,
        interval=format_interval,
        pvalue=format_p_value,
        percent=format_percent,
    )
    return environment


def render_html(results, output_dir=".", *, report_dir=None):
    """The report as an HTML string (see :func:`render_report`).

    Parameters
    ----------
    results : mapping
        The content of ``results.json``.
    output_dir : str or path-like
        Folder the figure paths in ``results["figures"]`` are relative to.
    report_dir : str or path-like, optional
        Folder the report will be written to, for the relative links to SVG files
        (default ``output_dir``).

    Returns
    -------
    str
    """
    output_dir = Path(output_dir)
    context = _context(results, output_dir, Path(report_dir or output_dir))
    return _environment().get_template(TEMPLATE).render(**context)


def render_report(results, output_dir, *, path=None):
    """Write the HTML report of an analysis: one self-contained file that opens offline.

    Parameters
    ----------
    results : mapping
        The content of ``results.json`` (SI units), as written by :func:`granflow.analysis.analyze`.
    output_dir : str or path-like
        The analysis' output folder; the PNG files of ``results["figures"]`` are read from it
        and embedded in the page as base64 data URIs.
    path : str or path-like, optional
        Where to write the report (default ``output_dir/report.html``). Written atomically:
        a reader never sees a half-written file.

    Returns
    -------
    pathlib.Path
        The report's path.

    Raises
    ------
    InvalidParameterError
        When ``results`` is not a mapping.

    Examples
    --------
    >>> import json, tempfile
    >>> from granflow.analysis.report import render_report
    >>> folder = tempfile.mkdtemp()
    >>> path = render_report({"synthetic": True, "runs": []}, folder)
    >>> "SYNTHETIC DATA" in path.read_text(encoding="utf-8")
    True
    """
    output_dir = Path(output_dir)
    path = Path(path) if path is not None else output_dir / "report.html"
    html = render_html(results, output_dir, report_dir=path.parent)
    path.parent.mkdir(parents=True, exist_ok=True)
    write_text_atomic(path, html)
    return path
