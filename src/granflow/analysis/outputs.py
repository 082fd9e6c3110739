"""The files :func:`granflow.analyze` writes (each atomically): tables, figures, report.

Tables are built from ``results.json``'s content (the ``to_dict()`` of the campaign's
:class:`~granflow.analysis.result.AnalysisResult`); figures from the result's objects.
"""

from pathlib import Path

from granflow._files import write_atomic
from granflow.analysis.files import FIGURES_DIR, TABLES_DIR
from granflow.model.units import si_unit

__all__ = [
    "FORECAST_FIGURE",
    "draw_forecast",
    "figure_jobs",
    "make_figures",
    "table_files",
    "write_report",
    "write_tables",
]

#: Name of the running forecast's figure (the report shows it in its forecast section).
FORECAST_FIGURE = "forecast"


# --------------------------------------------------------------------------- tables


_TABLE_PARAMS = ("a", "alpha", "Fd", "x0", "B", "tau_c")


def _runs_table(entries):
    rows = []
    for entry in entries:
        row = {
            key: entry.get(key)
            for key in (
                "index",
                "name",
                "source",
                "interval",
                "test",
                "status",
                "reason",
                "normal_load",
                "velocity",
                "preparation",
                "points",
            )
        }
        fit = entry.get("fit") or {}
        for name in _TABLE_PARAMS:
            value = (fit.get("params") or {}).get(name)
            row[name] = value
            row[f"{name}_stderr"] = (
                (fit.get("stderr") or {}).get(name) if value is not None else None
            )
            low, high = (fit.get("ci95") or {}).get(name) or (None, None)
            row[f"{name}_ci95_low"], row[f"{name}_ci95_high"] = low, high
        row["redchi"] = fit.get("redchi")
        row["problems"] = "; ".join(entry.get("problems") or ())
        row["geometry"] = entry.get("geometry")
        row["peak_force"] = (entry.get("peak") or {}).get("force")
        row["failure_force"] = (entry.get("failure") or {}).get("force")
        row["switch_outcome"] = (entry.get("switch") or {}).get("outcome")
        rows.append(row)
    return rows


def _loads_table(results):
    amontons = results["analyses"].get("amontons") or {}
    per_load = {row["normal_load"]: row for row in amontons.get("per_load", [])}
    yields = {row["normal_load"]: row for row in results["predictions"].get("static_yield", [])}
    rows = []
    for load in sorted(set(per_load) | set(yields)):
        row = {"normal_load": load}
        measured = per_load.get(load, {})
        row["repeats"] = measured.get("repeats")
        for key in ("a", "alpha", "alpha_v", "Fd"):
            mean, error = measured.get(key) or (None, None)
            row[f"{key}_mean"], row[f"{key}_stderr"] = mean, error
        predicted = yields.get(load, {})
        row["x0"] = predicted.get("x0")
        row["x0_stderr"] = (predicted.get("x0_estimate") or {}).get("stderr")
        row["F_peak"] = predicted.get("F_peak")
        row["F_peak_stderr"] = predicted.get("stderr")
        row["F_peak_spread"] = predicted.get("F_peak_spread")
        rows.append(row)
    return rows


def _material_table(material):
    return [
        {
            "constant": name,
            "value": material[name]["value"],
            "stderr": material[name]["stderr"],
            "ci95_low": material[name]["ci95"][0],
            "ci95_high": material[name]["ci95"][1],
            "unit": si_unit(name),
            "source": material.get("source"),
        }
        for name in ("mu_a", "mu_d", "alpha")
    ]


def _predictions_table(predictions):
    rows = []
    for row in predictions.get("static_yield", []):
        flat = {k: v for k, v in row.items() if k not in ("ci95", "x0_estimate")}
        flat["F_peak_stderr"] = flat.pop("stderr", None)
        flat["ci95_low"], flat["ci95_high"] = row["ci95"]
        flat["x0_stderr"] = row["x0_estimate"]["stderr"]
        flat["x0_from"] = row["x0_estimate"]["from"]
        rows.append(flat)
    return rows


#: Names of table columns that are not quantities themselves, and the quantity each is.
_COLUMN_QUANTITY = {"peak_force": "force", "switch_point": "time", "F_peak_spread": "force"}
#: Suffixes of a column named after a quantity (its error, its interval, a mean).
_SUFFIXES = ("_stderr", "_ci95_low", "_ci95_high", "_mean")
_ASCII_UNITS = str.maketrans({"µ": "u", "/": "_per_", " ": "_"})


def column_unit(column):
    """(display scale, column name with its display unit) of a table column:
    ``normal_load`` -> (1000.0, "normal_load_mN"); (1.0, column) without a unit."""
    from granflow.analysis.formatting import display_scale

    base = column
    for suffix in _SUFFIXES:
        if column.endswith(suffix):
            base = column[: -len(suffix)]
            break
    scale, unit = display_scale(_COLUMN_QUANTITY.get(base, base))
    if not unit:
        return 1.0, column
    return scale, f"{column}_{unit.replace('1/', 'per_').translate(_ASCII_UNITS)}"


def with_units(rows):
    """Rows in display units, each column named with its unit (``x0_um``, ``alpha_per_m``,
    ``velocity_um_per_s``); text and unitless columns as they are."""
    converted = []
    for row in rows:
        out = {}
        for key, value in row.items():
            scale, name = column_unit(key)
            number = isinstance(value, int | float) and not isinstance(value, bool)
            out[name] = value * scale if number and value is not None else value
        converted.append(out)
    return converted


def write_tables(output, results, warnings_list, executor=None):
    """CSV and Parquet of runs, loads, material and predictions; returns results["tables"].

    Quantities are in display units with the unit in the column name (``normal_load_mN``,
    ``x0_um``, ``alpha_per_m``); the material table keeps SI values with a ``unit`` column.
    The tables are built by :func:`table_files` as one task of ``executor`` (default in this
    process), so that pandas is loaded there, not here, and written here, each atomically.
    """
    files, notes = table_files(results) if executor is None else executor.call(table_files, results)
    warnings_list += notes
    folder = output / TABLES_DIR
    folder.mkdir(exist_ok=True)
    written = {}
    for name, contents in files.items():
        paths = {}
        for suffix, content in contents.items():
            paths[suffix] = f"{TABLES_DIR}/{name}.{suffix}"
            write_atomic(
                output / paths[suffix],
                lambda temporary, c=content: Path(temporary).write_bytes(c),
            )
        written[name] = paths
    return written


def table_files(results):
    """The tables of :func:`write_tables` as file contents.

    Parameters
    ----------
    results : dict
        ``results.json``'s content.

    Returns
    -------
    (dict, list of str)
        ``{table: {"csv": bytes, "parquet": bytes}}`` (CSV only without pyarrow) and the
        notes for the warnings (why there is no Parquet).
    """
    import io

    import pandas as pd

    tables = {
        "runs": _runs_table(results["runs"]),
        "loads": _loads_table(results),
        "material": _material_table(results["material"]),
        "predictions": _predictions_table(results["predictions"]),
    }
    stability = results["predictions"].get("stability_map")
    if stability:
        tables["stability_map"] = [
            {
                "switch_point": point,
                "stress_ratio": ratio,
                "outcome": stability["outcome"][i][j],
                "stop_slip": stability["stop_slip"][i][j],
                "failure_time": stability["failure_time"][i][j],
            }
            for i, point in enumerate(stability["switch_points"])
            for j, ratio in enumerate(stability["stress_ratios"])
        ]
    notes = []
    try:
        import pyarrow  # noqa: F401

        parquet = True
    except ImportError:
        parquet = False
        notes.append(
            "tables written as CSV only: Parquet needs pyarrow (pip install granflow[parquet])"
        )
    files = {}
    for name, rows in tables.items():
        frame = pd.DataFrame(rows if name == "material" else with_units(rows))
        text = frame.to_csv(index=False, float_format="%.17g")
        files[name] = {"csv": text.encode("utf-8")}
        if parquet:
            strings = {c: "string" for c in frame.columns if frame[c].dtype == object}
            buffer = io.BytesIO()
            frame.astype(strings).to_parquet(buffer, index=False)
            files[name]["parquet"] = buffer.getvalue()
    return files, notes


# --------------------------------------------------------------------------- figures and report


def draw_forecast(forecast):
    """The running forecast of one run (a :class:`~granflow.analysis.forecasts.RunForecast`),
    with the stretch of the record where the failure lies (between the last point held and
    the first runaway point) shaded."""
    from granflow.plotting import plot_forecast

    ax = plot_forecast(forecast.running())
    window = forecast.observed_window
    if window is not None:
        low, high = ax.get_ylim()
        ax.axhspan(*window, color="0.85", zorder=0, label="the failure lies here (sampling)")
        ax.set_ylim(
            min(low, window[0] - 0.05 * (high - low)), max(high, window[1] + 0.05 * (high - low))
        )
        ax.legend(fontsize="small", loc="upper right")
    return ax


def _forecast_jobs(forecasts):
    """The running forecast of each run with a dated forecast, named "forecast_<k>" after its
    place k (from 1) in ``results["forecasts"]``."""
    from granflow.analysis.figures import FigureJob

    jobs = []
    for number, forecast in enumerate(forecasts, start=1):
        if not forecast.dated:
            continue
        observed = "" if forecast.observed is None else " and the observed failure (dashed)"
        caption = (
            f"{forecast.run}: the failure time forecast from the slip before each cut time, "
            f"with its {forecast.level:.0%} band{observed}; prior: {forecast.prior_from}."
        )
        jobs.append(
            FigureJob(
                f"{FORECAST_FIGURE}_{number}",
                "Forecasting the failure",
                caption,
                draw_forecast,
                {"forecast": forecast},
            )
        )
    return jobs


def figure_jobs(result, joint):
    """Every figure of the campaign as an independent job (see
    :mod:`granflow.analysis.figures`), the forecasts' after Fig. 3a."""
    from granflow.analysis import figures

    jobs = figures.figure_jobs(result, joint)
    at = next((i + 1 for i, job in enumerate(jobs) if job.name == "stress_ramp"), len(jobs))
    return jobs[:at] + _forecast_jobs(result.forecasts) + jobs[at:]


def _figure_specs(result, joint):
    """``(name, title, draw)`` for every figure, ``draw() -> (figure, caption)``: what
    :func:`granflow.analysis.render.render_figures` draws, here or in a worker (which
    rebuilds the list from the pickled result and joint stage)."""
    from granflow.analysis import figures

    return [
        (job.name, job.title, lambda job=job: figures.draw_figure(job))
        for job in figure_jobs(result, joint)
    ]


def make_figures(output, result, joint, warnings_list, formats=("png",), executor=None):
    """Draw every figure the campaign allows into OUTPUT/figures, each once, in ``formats``
    (each file written atomically); returns the entries of results["figures"].

    Parameters
    ----------
    output : pathlib.Path
    result : granflow.analysis.result.AnalysisResult
        The campaign's result (its runs with their data).
    joint : granflow.analysis.stage.JointStage
        What the joint stage found (the start-ups and the representative one).
    warnings_list : list of str
        Figures that could not be drawn are added to it.
    formats : sequence of {"png", "svg", "pdf"}
        The files of each figure (the report embeds the PNG and links the SVG).
    executor : granflow._parallel.Executor, optional
        Draws the figures in parallel (:mod:`granflow.analysis.render`); default in this
        process.
    """
    from granflow.analysis.render import render_figures
    from granflow.plotting.files import check_formats

    formats = check_formats(formats, "figure_formats")
    specs = _figure_specs(result, joint)
    outcomes = render_figures(
        _figure_specs, (result, joint), output / FIGURES_DIR, executor, formats=formats
    )
    figures = []
    for (name, title, _), outcome in zip(specs, outcomes, strict=True):
        if isinstance(outcome, str):  # a figure that fails must not cost the results
            warnings_list.append(f"figure {name!r} could not be drawn: {outcome}")
            continue
        caption, files = outcome
        entry = {"name": name, "title": title, "caption": caption}
        entry.update({suffix: f"{FIGURES_DIR}/{file}" for suffix, file in files.items()})
        figures.append(entry)
    return figures


def write_report(output, result):
    """report.html (written atomically by :func:`granflow.analysis.report.render_report`)."""
    from granflow.analysis.report import render_report

    return render_report(result, output)
