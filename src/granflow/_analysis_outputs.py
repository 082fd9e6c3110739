"""The files :func:`granflow.analyze` writes (each atomically): tables, figures, report."""

import contextlib
import json
import os
import tempfile
import warnings
from pathlib import Path

import numpy as np

from granflow._analysis_runs import _creep_from_record

RESULTS_FILE = "results.json"
REPORT_FILE = "report.html"
RUNS_DIR = "runs"
TABLES_DIR = "tables"
FIGURES_DIR = "figures"


# ---------------------------------------------------------------- files written atomically


def _write_atomic(path, write):
    """Call ``write(temporary_path)``, then move the file into place (same folder)."""
    path = Path(path)
    handle, temporary = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    os.close(handle)
    try:
        write(Path(temporary))
        os.replace(temporary, path)
    except BaseException:
        with contextlib.suppress(OSError):
            os.unlink(temporary)
        raise
    return path


def _dump(value):
    return json.dumps(value, indent=2, ensure_ascii=False, allow_nan=False) + "\n"


def _write_json(path, value):
    text = _dump(value)
    return _write_atomic(path, lambda temporary: temporary.write_text(text, encoding="utf-8"))


def _read_json(path):
    try:
        return json.loads(Path(path).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None


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
        for key in ("x0", "x0_stderr", "F_peak", "stderr", "spread"):
            row[f"predicted_{key}" if key in ("stderr", "spread") else key] = predicted.get(key)
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
            "unit": "1/m" if name == "alpha" else "",
            "source": material.get("source"),
        }
        for name in ("mu_a", "mu_d", "alpha")
    ]


def _predictions_table(predictions):
    rows = []
    for row in predictions.get("static_yield", []):
        rows.append(
            {k: v for k, v in row.items() if k != "ci95"}
            | {
                "ci95_low": row["ci95"][0],
                "ci95_high": row["ci95"][1],
            }
        )
    return rows


def _write_tables(output, results, warnings_list):
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
        _write_atomic(
            output / paths["csv"],
            lambda temporary, f=frame: f.to_csv(temporary, index=False, float_format="%.17g"),
        )
        if parquet:
            paths["parquet"] = f"{TABLES_DIR}/{name}.parquet"
            _write_atomic(
                output / paths["parquet"],
                lambda temporary, f=frame: f.astype(
                    {c: "string" for c in f.columns if f[c].dtype == object}
                ).to_parquet(temporary, index=False),
            )
        written[name] = paths
    return written


# --------------------------------------------------------------------------- figures and report


def _figure_specs(context):
    """(name, title, caption, draw) for each figure the campaign allows; draw() -> Figure."""
    import matplotlib.pyplot as plt

    from granflow import plotting

    specs = []
    paper = getattr(plotting, "plot_startup", None)
    startups = context.startups
    if startups:
        chosen = [
            s
            for s in startups
            if (s.load, s.velocity)
            == (context.representative.load, context.representative.velocity)
        ][:6]

        def startup():
            figure, (ax, residual) = plt.subplots(
                2, 1, sharex=True, figsize=(6.0, 5.0), height_ratios=(3, 1), layout="constrained"
            )
            if paper is not None:
                paper(
                    [s.item.run for s in chosen], [s.fit for s in chosen], ax, residual_ax=residual
                )
            else:
                context.representative.fit.plot(ax, residual_ax=residual)
            return figure

        specs.append(
            (
                "startup",
                "Start-up curves and fits",
                f"Friction force during start-up at {_display_load(context.representative.load)} "
                "with the fits of Eq. 3 and their residuals (Fig. 2a).",
                startup,
            )
        )
    if context.collapse is not None:
        specs.append(
            (
                "collapse",
                "Velocity collapse",
                "Start-up curves at several velocities against slip, with the shared fit "
                "(Fig. 2b).",
                lambda: plotting.plot_collapse(context.collapse).figure,
            )
        )
    if context.amontons is not None:
        specs.append(
            (
                "amontons",
                "Amontons' law",
                "a, αv and F_d against the normal load, means with standard errors over the "
                "repeats and lines through the origin (Fig. 2c).",
                lambda: plotting.plot_amontons(context.amontons)[0].figure,
            )
        )
    ramp = getattr(plotting, "plot_stress_ramp", None)
    for item in context.items:
        if (
            ramp is not None
            and item.kind == "ramp"
            and item.record
            and item.record["status"] == "ok"
        ):
            params = context.ramp_params.get(item.name)
            specs.append(
                (
                    "stress_ramp",
                    "Stress ramp",
                    "Slip and stress against time under a stress ramp, with the predicted static "
                    "yield (Fig. 3a).",
                    lambda i=item, p=params: _figure_of(ramp(i.run, p)),
                )
            )
            break
    creep = getattr(plotting, "plot_creep", None)
    creeps = [
        i for i in context.items if i.kind == "creep" and i.record and i.record["status"] == "ok"
    ]
    if creep is not None and creeps:
        specs.append(
            (
                "creep",
                "Creep",
                "Slip against time under constant stresses below the peak, with logarithmic "
                "fits (Fig. 3b).",
                lambda: _figure_of(
                    creep(
                        [i.run for i in creeps],
                        [_creep_from_record(i.record, i.run) for i in creeps],
                    )
                ),
            )
        )
    switch = getattr(plotting, "plot_switch", None)
    for item in context.items:
        if (
            switch is not None
            and item.kind == "switch"
            and item.record
            and item.record["status"] == "ok"
        ):
            params = context.switch_params.get(item.name)
            specs.append(
                (
                    "switch",
                    "Switch from rate to stress control",
                    "Force and slip against time, the switch marked, with the rate-controlled "
                    "curve of the fitted parameters (Fig. 3c).",
                    lambda i=item, p=params: _figure_of(switch(i.run, p)),
                )
            )
            break
    if context.stability is not None:
        specs.append(
            (
                "stability_map",
                "Stability map",
                "Predicted outcome of switching to stress control, over the switch time and the "
                "ratio of imposed to current force (quasi-static, slip clock).",
                lambda: plotting.plot_stability_map(context.stability).figure,
            )
        )
    if context.posterior is not None:
        specs.append(
            (
                "corner",
                "Posterior (MCMC)",
                f"Posterior of the Eq. 3 fit of {context.representative.item.name} (emcee), "
                "with the least-squares values marked.",
                lambda: plotting.plot_corner(context.posterior),
            )
        )
    return specs


def _display_load(load):
    return "an unknown load" if load is None else f"F_N = {load * 1e3:.4g} mN"


def _figure_of(axes):
    """The Figure of whatever a plot function returned (Axes, array of Axes, Figure)."""
    if hasattr(axes, "savefig"):
        return axes
    if hasattr(axes, "figure"):
        return axes.figure
    return np.ravel(axes)[0].figure


def _save_figure(figure, folder, stem):
    try:
        from granflow.plotting import save_figure
    except ImportError:
        paths = {}
        for suffix, options in (("png", {"dpi": 150}), ("svg", {})):
            paths[suffix] = folder / f"{stem}.{suffix}"
            figure.savefig(paths[suffix], **options)
        return paths
    return save_figure(figure, folder, stem)


def _make_figures(output, context, warnings_list):
    """Draw every figure the campaign allows into OUTPUT/figures; returns results["figures"]."""
    import matplotlib.pyplot as plt

    folder = output / FIGURES_DIR
    folder.mkdir(exist_ok=True)
    figures = []
    with tempfile.TemporaryDirectory(prefix=".figures-", dir=output) as scratch:
        for name, title, caption, draw in _figure_specs(context):
            try:
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore")
                    figure = draw()
                    paths = _save_figure(figure, Path(scratch), name)
                plt.close(figure)
            except Exception as exc:  # a figure that fails must not cost the results
                warnings_list.append(
                    f"figure {name!r} could not be drawn: {type(exc).__name__}: {exc}"
                )
                plt.close("all")
                continue
            entry = {"name": name, "title": title, "caption": caption}
            for suffix, path in sorted(paths.items()):
                os.replace(path, folder / f"{name}.{suffix}")
                entry[suffix] = f"{FIGURES_DIR}/{name}.{suffix}"
            figures.append(entry)
    return figures


def _report_renderer():
    try:
        from granflow.report import render_report
    except ImportError:
        return None
    return render_report


def _write_report(output, results, render):
    """Render report.html atomically (into a temporary file, then moved into place)."""
    return _write_atomic(
        output / REPORT_FILE, lambda temporary: render(results, output, path=temporary)
    )
