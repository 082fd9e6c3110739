"""The files :func:`granflow.analyze` writes (each atomically): tables, figures, report.

Tables are built from ``results.json``'s content (the ``to_dict()`` of the campaign's
:class:`~granflow.analysis.result.AnalysisResult`); figures from the result's objects.
"""

from granflow._files import write_atomic
from granflow.analysis.files import FIGURES_DIR, TABLES_DIR
from granflow.model.units import display_unit, si_unit, to_display

__all__ = ["FORECAST_FIGURE", "make_figures", "write_report", "write_tables"]

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
        flat["ci95_low"], flat["ci95_high"] = row["ci95"]
        flat["x0_stderr"] = row["x0_estimate"]["stderr"]
        flat["x0_from"] = row["x0_estimate"]["from"]
        rows.append(flat)
    return rows


def write_tables(output, results, warnings_list):
    """CSV and Parquet of runs, loads, material and predictions; returns results["tables"]."""
    import pandas as pd

    folder = output / TABLES_DIR
    folder.mkdir(exist_ok=True)
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
    try:
        import pyarrow  # noqa: F401

        parquet = True
    except ImportError:
        parquet = False
        warnings_list.append(
            "tables written as CSV only: Parquet needs pyarrow (pip install granflow[parquet])"
        )
    written = {}
    for name, rows in tables.items():
        frame = pd.DataFrame(rows)
        paths = {"csv": f"{TABLES_DIR}/{name}.csv"}
        write_atomic(
            output / paths["csv"],
            lambda temporary, f=frame: f.to_csv(temporary, index=False, float_format="%.17g"),
        )
        if parquet:
            paths["parquet"] = f"{TABLES_DIR}/{name}.parquet"
            write_atomic(
                output / paths["parquet"],
                lambda temporary, f=frame: f.astype(
                    {c: "string" for c in f.columns if f[c].dtype == object}
                ).to_parquet(temporary, index=False),
            )
        written[name] = paths
    return written


# --------------------------------------------------------------------------- figures and report


def _startup_figure(joint):
    """Fig. 2a: the start-ups of the representative load and velocity (at most six)."""
    from granflow.plotting import plot_startup

    chosen = joint.representative
    group = [s for s in joint.startups if (s.load, s.velocity) == (chosen.load, chosen.velocity)]
    group = group[:6]
    axes = plot_startup([s.run for s in group], [s.fit for s in group])
    caption = (
        f"Friction force during start-up at {_display_load(chosen.load)} and "
        f"{to_display('velocity', chosen.velocity):.4g} µm/s: data (points), fits of Eq. 3 "
        "(lines) and residuals (Fig. 2a)."
    )
    return axes, caption


def _ok_entries(result, kind):
    return [entry for entry in result.runs if entry.test == kind and entry.ok]


def _figure_specs(result, joint):
    """(name, title, draw) for each figure the campaign allows; draw() -> (figure, caption)."""
    from granflow import plotting

    analyses = result.analyses
    specs = []
    if joint.startups:
        specs.append(("startup", "Start-up curves and fits", lambda: _startup_figure(joint)))
    if analyses.velocity_collapse is not None:
        specs.append(
            (
                "collapse",
                "Velocity collapse",
                lambda: (
                    plotting.plot_collapse(analyses.velocity_collapse.result),
                    "Start-ups at several velocities against slip, with the shared fit of "
                    "Eq. 3; inset: the short slips (Fig. 2b).",
                ),
            )
        )
    if analyses.amontons is not None:
        specs.append(
            (
                "amontons",
                "Amontons' law",
                lambda: (
                    plotting.plot_amontons(analyses.amontons.result),
                    "a, αv and F_d against the normal load: means over the repeats with "
                    "standard errors, F_d with its line through the origin (Fig. 2c).",
                ),
            )
        )
    ramps = _ok_entries(result, "ramp")
    if ramps:
        params = {row.run: row.params for row in analyses.stress_ramp}
        specs.append(
            (
                "stress_ramp",
                "Stress ramp",
                lambda: (
                    plotting.plot_stress_ramp(ramps[0].run, params.get(ramps[0].name)),
                    f"{ramps[0].name}: slip and imposed force against time under a stress "
                    "ramp, with the predicted static yield F_peak at its load (Fig. 3a).",
                ),
            )
        )
    specs += _forecast_specs(result.forecasts)
    creeps = _ok_entries(result, "creep")
    if creeps:
        specs.append(
            (
                "creep",
                "Creep",
                lambda: (
                    plotting.plot_creep([e.run for e in creeps], [e.result.fit for e in creeps]),
                    "Slip against time under constant forces, with fits of "
                    "δ = B ln(1 + t/τ_c) (Fig. 3b).",
                ),
            )
        )
    switches = _ok_entries(result, "switch")
    if switches:
        entry = switches[0]
        params = {row.run: row.params for row in analyses.switch}
        specs.append(
            (
                "switch",
                "Switch from rate to stress control",
                lambda: (
                    plotting.plot_switch(
                        entry.run,
                        params.get(entry.name),
                        switch_time=entry.result.switch.switch_time,
                    ),
                    f"{entry.name}: slip and force against time, the switch marked, with the "
                    "rate-controlled curve of the fitted parameters (Fig. 3c).",
                ),
            )
        )
    if result.predictions.stability_map is not None:
        specs.append(
            (
                "stability_map",
                "Stability map",
                lambda: (
                    plotting.plot_stability_map(result.predictions.stability_map.map),
                    "Predicted outcome of a switch to force control, over the switch time and "
                    "the ratio of imposed to current force (quasi-static, slip clock): failure "
                    "(grey) or the slip to the stop.",
                ),
            )
        )
    if analyses.mcmc is not None:
        specs.append(
            (
                "corner",
                "Posterior (MCMC)",
                lambda: (
                    plotting.plot_corner(analyses.mcmc.result),
                    f"Posterior of the Eq. 3 fit of {joint.representative.name} "
                    "(emcee), the least-squares values marked.",
                ),
            )
        )
    return specs


def _forecast_specs(forecasts):
    """The running forecast of each run with a dated forecast, named "forecast_<k>" after its
    place k (from 1) in ``results["forecasts"]``."""
    from granflow.plotting import plot_forecast

    specs = []
    for number, forecast in enumerate(forecasts, start=1):
        if not forecast.dated:
            continue
        name = f"{FORECAST_FIGURE}_{number}"
        observed = "" if forecast.observed is None else " and the observed failure (dashed)"
        caption = (
            f"{forecast.run}: the failure time forecast from the slip before each cut time, "
            f"with its {forecast.level:.0%} band{observed}; prior: {forecast.prior_from}."
        )
        specs.append(
            (
                name,
                "Forecasting the failure",
                lambda forecast=forecast, caption=caption: (
                    plot_forecast(forecast.running()),
                    caption,
                ),
            )
        )
    return specs


def _display_load(load):
    if load is None:
        return "an unknown load"
    return f"F_N = {to_display('normal_load', load):.4g} {display_unit('normal_load')}"


def make_figures(output, result, joint, warnings_list, executor=None):
    """Draw every figure the campaign allows into OUTPUT/figures (PNG and SVG, each written
    atomically); returns the entries of results["figures"].

    Parameters
    ----------
    output : pathlib.Path
    result : granflow.analysis.result.AnalysisResult
        The campaign's result (its runs with their data).
    joint : granflow.analysis.stage.JointStage
        What the joint stage found (the start-ups and the representative one).
    warnings_list : list of str
        Figures that could not be drawn are added to it.
    executor : granflow._parallel.Executor, optional
        Draws the figures in parallel (:mod:`granflow.analysis.render`); default in this
        process.
    """
    from granflow.analysis.render import render_figures

    specs = _figure_specs(result, joint)
    outcomes = render_figures(_figure_specs, (result, joint), output / FIGURES_DIR, executor)
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
