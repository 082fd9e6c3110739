"""The HTML report of a campaign analysis: one self-contained file that opens offline.

:func:`render_report` turns the typed :class:`~granflow.analysis.AnalysisResult` into
``report.html``. It opens with what the campaign shows about aging and rejuvenation, in the
paper's terms (:mod:`granflow.analysis.report_summary`), then the verdicts, each linking to
its section; every section holds its table and its figure (PNG embedded as a base64 data
URI): material constants, the start-ups (Fig. 2a and every fit), the velocity collapse
(Fig. 2b), Amontons' law (Fig. 2c), the preparations, the model comparison, the static yield,
the stress ramp (Fig. 3a), creep (Fig. 3b), the switch (Fig. 3c), the stability map, the
forecasts, the sections of the record families (:mod:`granflow.families`: each family's
``section`` and its template), the publication figures, then the campaign, data quality,
warnings and provenance. The page has no external resources and no JavaScript; a print style
sheet keeps every column (the run table on landscape pages).

The report reads the result's fields and computes no statistic: every estimate, test and
interval shown is a field of a result (:mod:`granflow.analysis.report_views` picks them and
puts them into display units: mN, µm, µm/s, s, 1/m). A ``results.json`` read back is
accepted as its content, through :meth:`AnalysisResult.from_dict`.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

from granflow._files import write_text_atomic
from granflow.analysis.formatting import (
    display_scale,
    format_interval,
    format_number,
    format_p_value,
    format_percent,
    format_value_error,
)
from granflow.analysis.report_frame import (
    figures_view,
    options_view,
    timing_view,
    warnings_view,
)
from granflow.analysis.report_stress import (
    forecast_view,
    prediction_view,
    ramp_view,
    switch_view,
)
from granflow.analysis.report_summary import headline, quality_lines, verdicts
from granflow.analysis.report_views import (
    SECTIONS,
    amontons_view,
    campaign_view,
    collapse_view,
    creep_view,
    material_view,
    model_comparison_view,
    quality_view,
    runs_view,
    spread_view,
)
from granflow.analysis.result import AnalysisResult
from granflow.errors import InvalidParameterError
from granflow.families import record_families, resolve

if TYPE_CHECKING:
    from granflow._typing import PathLike

__all__ = ["render_html", "render_report"]

TEMPLATE = "report.html.j2"


def _typed(result: Any) -> AnalysisResult:
    """The :class:`AnalysisResult` to render (a ``results.json`` content read back)."""
    if isinstance(result, AnalysisResult):
        return result
    if not isinstance(result, Mapping):
        raise InvalidParameterError(
            "result must be an AnalysisResult (or the content of results.json), got "
            f"{type(result).__name__}"
        )
    try:
        return AnalysisResult.from_dict(result)
    except (KeyError, TypeError, ValueError) as exc:
        raise InvalidParameterError(
            f"result is not the content of a results.json ({type(exc).__name__}: {exc})"
        ) from exc


def _record_sections(result, output_dir, report_dir, problems):
    """The sections of the record families (:mod:`granflow.families`) that hold anything:
    each family's ``section`` of its part of the result, its figures embedded."""

    def embedded(entries):
        return figures_view(entries, output_dir, report_dir, problems).get("publication", [])

    sections = []
    for family in record_families():
        part = result.record_analyses.get(family.test_kind)
        if part and family.section is not None:
            sections.append(resolve(family.section)(part, embedded))
    return sections


def _contents(shown, sections):
    """The contents: the fixed sections shown, the record families' before the publication
    figures."""
    contents = []
    for anchor, title in SECTIONS:
        if anchor == "publication":
            contents += [(section["id"], section["title"]) for section in sections]
        if shown.get(anchor, True):
            contents.append((anchor, title))
    return contents


def _context(result: AnalysisResult, output_dir: Path | None, report_dir: Path) -> dict[str, Any]:
    problems: list[str] = []
    views: dict[str, Any]
    figures = figures_view(result.figures, output_dir, report_dir, problems)
    runs = runs_view(result)
    views = {
        "runs": runs,
        "creep": creep_view(result),
        "material": material_view(result),
        "collapse": collapse_view(result),
        "amontons": amontons_view(result),
        "spread": spread_view(result),
        "comparison": model_comparison_view(result),
        "prediction": prediction_view(result),
        "ramp": ramp_view(result),
        "switch": switch_view(result),
        "forecasts": forecast_view(result, figures.pop("forecasting", [])),
        "record_sections": _record_sections(result, output_dir, report_dir, problems),
        "quality": quality_view(runs),
        "campaign": campaign_view(result, runs),
    }
    views["warnings"] = warnings_view(result, runs, problems)
    shown = {
        "material": views["material"] is not None,
        "runs": True,
        "collapse": views["collapse"] is not None,
        "amontons": views["amontons"] is not None,
        "preparation": views["spread"] is not None,
        "model-comparison": views["comparison"] is not None,
        "static-yield": bool(views["prediction"]["static_yield"])
        or views["prediction"]["static_yield_reason"] is not None,
        "ramp": bool(views["ramp"]) or "ramp" in figures,
        "creep": bool(views["creep"]),
        "switch": bool(views["switch"]) or "switch" in figures,
        "stability-map": views["prediction"]["stability"] is not None,
        "forecasting": bool(views["forecasts"]),
        "publication": bool(figures.get("publication")),
    }
    contents = _contents(shown, views["record_sections"])
    timing = timing_view(result.timing)
    return {
        **views,
        "synthetic": result.synthetic,
        "title": str(result.campaign.get("name") or "campaign"),
        "date": str(result.timing.get("finished") or result.timing.get("started") or ""),
        "version": result.granflow_version,
        "renderer": __import__("granflow").__version__,
        "figures": figures,
        "contents": contents,
        "headline": headline(result, views),
        "summary": verdicts(result, views),
        "quality_summary": quality_lines(views),
        "options": options_view(result.provenance),
        "timing": timing,
        "inputs": [
            {"file": str(i.get("file") or ""), "sha256": str(i.get("sha256") or "")}
            for i in result.provenance.get("inputs", ())
        ],
        "tables": [
            (str(name), ", ".join(str(v) for v in files.values() if v))
            for name, files in result.tables.items()
        ],
        "errors": dict(result.analyses.errors),
    }


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
        return display_scale(name)[0]

    environment.globals.update(unit=lambda name: display_scale(name)[1], scale=scale)
    environment.filters.update(
        si=lambda value, name, significant=4: format_number(value, scale(name), significant),
        pm_si=lambda estimate, name: format_value_error(*estimate, scale=scale(name)),
        interval_si=lambda bounds, name: format_interval(list(bounds), scale(name)),
        num=format_number,
        pm=lambda estimate, scale=1.0: format_value_error(*estimate, scale=scale),
        interval=lambda bounds, scale=1.0: format_interval(list(bounds), scale),
        pvalue=format_p_value,
        percent=format_percent,
        tokens=_tokens,
    )
    return environment


def _tokens(name: object) -> Any:
    """A run or file name with a break opportunity after each "_", ".", "#" and "/" (the
    name is escaped first): at 800 px it wraps between its tokens, never inside one."""
    from markupsafe import Markup, escape

    text = str(escape(str(name)))
    for mark in ("_", "#", "/", "."):
        text = text.replace(mark, mark + "<wbr>")
    return Markup(text)


def render_html(
    result: AnalysisResult | Mapping[str, Any],
    output_dir: PathLike | None = None,
    *,
    report_dir: PathLike | None = None,
) -> str:
    """The report as an HTML string (see :func:`render_report`).

    Parameters
    ----------
    result : AnalysisResult
        The campaign's result (or the content of its ``results.json``).
    output_dir : str or path-like, optional
        Folder the figure paths of ``result.figures`` are relative to (default
        ``result.output``).
    report_dir : str or path-like, optional
        Folder the report will be written to, for the relative links to SVG files
        (default ``output_dir``).

    Returns
    -------
    str
    """
    result = _typed(result)
    if output_dir is None:
        output_dir = result.output
    output = None if output_dir is None else Path(output_dir)
    context = _context(result, output, Path(report_dir or output or "."))
    return _environment().get_template(TEMPLATE).render(**context)


def render_report(
    result: AnalysisResult | Mapping[str, Any],
    output_dir: PathLike | None = None,
    *,
    path: PathLike | None = None,
) -> Path:
    """Write the HTML report of an analysis: one self-contained file that opens offline.

    Parameters
    ----------
    result : AnalysisResult
        What :func:`granflow.analyze` returned (or the content of its ``results.json``).
    output_dir : str or path-like, optional
        The analysis' output folder, where its figures are read from and embedded in the
        page as base64 data URIs (default ``result.output``).
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
        When ``result`` is neither an AnalysisResult nor the content of a results.json,
        or when there is no folder to write to.

    Examples
    --------
    >>> import json, tempfile
    >>> import granflow as gf
    >>> from granflow.analysis.report import render_report
    >>> folder = tempfile.mkdtemp()
    >>> run = gf.simulate(gf.Params(3.3e-3, 5e4, 11e-3, 3e-7),
    ...                   [gf.Velocity("0.86 um/s", "200 s")]).to_run()
    >>> result = gf.analyze(gf.Campaign([run]), folder, quiet=True)
    >>> "Start-ups: per-run fits" in render_report(result).read_text(encoding="utf-8")
    True
    """
    result = _typed(result)
    if output_dir is None:
        output_dir = result.output
    if output_dir is None and path is None:
        raise InvalidParameterError("give output_dir or path: the result has no output folder")
    path = Path(path) if path is not None else Path(output_dir or ".") / "report.html"
    html = render_html(result, output_dir, report_dir=path.parent)
    path.parent.mkdir(parents=True, exist_ok=True)
    write_text_atomic(path, html)
    return path
