"""HTML representations of results, for Jupyter (``_repr_html_``), in the manner of lmfit.

Every result shows as one ``<div class="granflow-result">``: a title, then tables. Fits show
their statistics, a table of variables (value ± standard error with the digits the error
justifies, relative error, 95 % interval, unit) and their correlations (:func:`fit_html`);
other results turn their lmfit-style text report into tables (:func:`report_html`). Every
piece of text is escaped here, once: callers pass plain strings, and :class:`Html` marks what
is already markup. Pure Python: importing it loads nothing heavy.
"""

from __future__ import annotations

import html
import math
import re
from collections.abc import Iterable, Sequence
from typing import Any

from granflow._format import DASH, format_interval, format_number, format_value_error

__all__ = [
    "Html",
    "HtmlReport",
    "fit_html",
    "heading",
    "report_html",
    "report_parts",
    "result_html",
    "table",
    "text",
]

_STYLE = (
    "<style>.granflow-result table{border-collapse:collapse;margin:0.2em 0 0.6em}"
    ".granflow-result th,.granflow-result td{padding:0.15em 0.6em;text-align:left;"
    "vertical-align:top}.granflow-result td.num{text-align:right;font-variant-numeric:"
    "tabular-nums}.granflow-result h4,.granflow-result h5{margin:0.4em 0 0.2em}</style>"
)
_CORRELATION_SHOWN = 0.1  # as the text report: correlations at least this large
_SECTION = re.compile(r"^\[\[(?P<title>[^\]]*)\]\]\s*(?P<rest>.*)$")
_ROW = re.compile(r"^\s+(?P<key>[^=]*?\S)\s+=\s(?P<value>.*)$")


class Html(str):
    """Text that is already HTML (not escaped again by :func:`text`)."""

    __slots__ = ()


def text(value: object) -> Html:
    """``value`` as HTML: escaped, unless it is :class:`Html` already."""
    if isinstance(value, Html):
        return value
    return Html(html.escape(str(value), quote=True))


def table(
    rows: Iterable[Sequence[object]],
    *,
    header: Sequence[object] | None = None,
    numeric: Sequence[int] = (),
) -> Html:
    """A ``<table>`` of ``rows`` (cells escaped), with an optional header row; the columns
    whose positions are in ``numeric`` are right-aligned."""
    parts = ["<table>"]
    if header is not None:
        parts.append("<tr>" + "".join(f"<th>{text(cell)}</th>" for cell in header) + "</tr>")
    for row in rows:
        cells = [
            f'<td class="num">{text(cell)}</td>' if i in numeric else f"<td>{text(cell)}</td>"
            for i, cell in enumerate(row)
        ]
        parts.append("<tr>" + "".join(cells) + "</tr>")
    parts.append("</table>")
    return Html("".join(parts))


def heading(title: object) -> Html:
    """A section heading inside a result."""
    return Html(f"<h5>{text(title)}</h5>")


def result_html(title: object, parts: Iterable[object]) -> Html:
    """One result: its title and its parts (HTML, or text that is escaped)."""
    body = "".join(text(part) for part in parts)
    return Html(f'<div class="granflow-result">{_STYLE}<h4>{text(title)}</h4>{body}</div>')


def report_html(title: object, report: str) -> Html:
    """An lmfit-style text report (``[[Section]]`` headings, ``    key = value`` lines, other
    lines as they are) as HTML: one heading and one two-column table per section."""
    return result_html(title, report_parts(report))


def report_parts(report: str) -> list[Html]:
    """The headings and tables of :func:`report_html`, to put in a result of one's own."""
    parts: list[Html] = []
    rows: list[tuple[str, str]] = []

    def flush() -> None:
        if rows:
            parts.append(table(rows))
            rows.clear()

    for line in report.splitlines():
        section = _SECTION.match(line)
        if section:
            flush()
            parts.append(heading(section["title"]))
            if section["rest"]:
                parts.append(Html(f"<p>{text(section['rest'])}</p>"))
            continue
        row = _ROW.match(line)
        if row:
            rows.append((row["key"], row["value"]))
        elif line.strip():
            rows.append((line.strip(), ""))
    flush()
    return parts


def _relative(value: float, error: float) -> str:
    if not (math.isfinite(value) and math.isfinite(error)) or value == 0:
        return DASH
    return f"{100 * error / abs(value):.2g} %"


def _variables(result: Any) -> Html:
    """The table of variables of a fit: value ± stderr, relative error, 95 % interval, unit
    (the display unit of the parameter's SI unit: mN, µm) and how the interval was found
    (or that the parameter was held, or ended on a bound)."""
    method = getattr(result, "ci_method", None)
    at_bound = getattr(result, "at_bound", None)
    fixed = getattr(result, "fixed", ())
    from granflow.model.units import display_of_si

    rows = []
    for name in result.names:
        value, error = result.params[name], result.stderr[name]
        scale, unit = display_of_si(result.units[name])
        if name in fixed:
            rows.append((name, format_number(value, scale, 6), DASH, DASH, unit, "fixed"))
            continue
        note = [] if method is None else [str(method[name])]
        if at_bound is not None and at_bound[name]:
            note.append("at bound")
        rows.append(
            (
                name,
                format_value_error(value, error, scale),
                _relative(value, error),
                format_interval(result.ci95[name], scale),
                unit,
                ", ".join(note),
            )
        )
    header = ("name", "value ± standard error", "relative", "95 % interval", "unit", "")
    return table(rows, header=header, numeric=(1, 2))


def _correlations(correl: Any, names: Sequence[str]) -> list[tuple[str, str]]:
    free = [name for name in names if name in correl]
    pairs = [(correl[p][q], p, q) for i, p in enumerate(free) for q in free[i + 1 :]]
    return [
        (f"C({p}, {q})", f"{value:+.4f}")
        for value, p, q in sorted(pairs, key=lambda item: -abs(item[0]))
        if abs(value) >= _CORRELATION_SHOWN
    ]


def fit_html(
    result: Any,
    *,
    title: str,
    extra: Sequence[tuple[str, object]] = (),
    after: Sequence[tuple[str, object]] = (),
) -> Html:
    """A fit result as HTML, the counterpart of
    :func:`granflow.fitting.statistics.fit_report` (same arguments): fit statistics,
    variables, correlations."""
    rows: list[tuple[str, object]] = [
        ("success", result.success),
        ("message", result.message),
        *extra,
        ("data points", result.ndata),
        ("variables", result.nfree),
        ("chi-square", format_number(result.chisqr)),
        ("reduced chi-square", format_number(result.redchi)),
        ("Akaike info crit", format_number(result.aic, significant=6)),
        ("Bayesian info crit", format_number(result.bic, significant=6)),
    ]
    if hasattr(result, "rsquared"):
        rows.append(("R-squared", format_number(result.rsquared, significant=6)))
    rows += list(after)
    parts: list[object] = [heading("Fit statistics"), table(rows), heading("Variables")]
    parts.append(_variables(result))
    correl = getattr(result, "correl", None)
    if correl is not None:
        pairs = _correlations(correl, result.names)
        parts.append(heading(f"Correlations (|C| ≥ {_CORRELATION_SHOWN:g})"))
        parts.append(table(pairs) if pairs else Html("<p>none</p>"))
    return result_html(title, parts)


class HtmlReport:
    """Mixin: ``_repr_html_`` shows the result's text ``report()`` as tables, titled with
    the class name (for results whose report is a list of ``key = value`` lines)."""

    __slots__ = ()

    def _repr_html_(self) -> str:
        return report_html(type(self).__name__, self.report())  # type: ignore[attr-defined]
