"""The figures of a campaign analysis, each an independent job.

:func:`figure_jobs` lists the figures a campaign allows as :class:`FigureJob` values: a name,
a title, a caption and a drawing function of plain, picklable inputs (runs, fits, results,
parameters), so that each figure can be drawn on its own, in this process or another.
:func:`draw_figure` draws one job; :mod:`granflow.analysis.render` draws them all through
the executor and writes each once, in the formats asked for.

The figures tell the paper's story: Fig. 2a the preparations (three repeats of one
preparation state, with their a, αv and t0), Fig. 2b the velocity collapse of one
preparation, Fig. 2c Amontons' law, a small-multiples page with every start-up fit, Fig. 3a
the stress ramp (the creep before failure, the predicted failure, the quasi-static slip in
grey), Fig. 3b creep on a logarithmic time axis with the rate-controlled overshoot inset,
Fig. 3c the switch, the stability map with its analytic boundary, and two publication
multi-panel figures (Fig. 2 and Fig. 3 at a journal's double-column width, panel letters).
"""

import math
from dataclasses import dataclass, field

from granflow.model.units import display_unit, to_display

__all__ = [
    "DOUBLE_COLUMN",
    "FigureJob",
    "draw_fig2",
    "draw_fig3",
    "draw_figure",
    "figure_jobs",
]

#: A journal's double-column width [inch] (178 mm).
DOUBLE_COLUMN = 7.0


@dataclass(frozen=True)
class FigureJob:
    """One figure to draw: ``draw(**inputs)`` returns a matplotlib Figure.

    Attributes
    ----------
    name : str
        The file stem (``figures/<name>.png``).
    title, caption : str
    draw : callable
        A module-level function (picklable by reference).
    inputs : dict
        Its keyword arguments (picklable values).
    """

    name: str
    title: str
    caption: str
    draw: object
    inputs: dict = field(default_factory=dict)


def _figure(drawn):
    from granflow.plotting.files import figure_of

    return figure_of(drawn)


def draw_figure(job):
    """Draw ``job``: ``(figure, caption)``. Closing the figure is the caller's (see
    :func:`granflow.analysis.render.render_figures`)."""
    return _figure(job.draw(**job.inputs)), job.caption


# --------------------------------------------------------------------------- drawing


def draw_startup(runs, fits):
    """Fig. 2a: the start-ups of the preparations, with their fits and residuals."""
    from granflow.plotting import plot_startup

    return plot_startup(runs, fits)


def draw_collapse(result):
    """Fig. 2b."""
    from granflow.plotting import plot_collapse

    return plot_collapse(result)


def draw_amontons(result):
    """Fig. 2c."""
    from granflow.plotting import plot_amontons

    return plot_amontons(result)


def draw_fit_grid(fits, names):
    """Every start-up fit, small multiples."""
    from granflow.plotting import plot_fit_grid

    return plot_fit_grid(fits, names)


def draw_stress_ramp(run, params, velocity=None):
    """Fig. 3a, with the rate-controlled F(t) at ``velocity`` [m/s] in grey."""
    from granflow.plotting import plot_stress_ramp

    return plot_stress_ramp(run, params, velocity=velocity)


def draw_creep(runs, fits, params):
    """Fig. 3b, on a logarithmic time axis."""
    from granflow.plotting import plot_creep

    return plot_creep(runs, fits, params=params, log_time=True)


def draw_switch(run, params, switch_time):
    """Fig. 3c."""
    from granflow.plotting import plot_switch

    return plot_switch(run, params, switch_time=switch_time)


def _stability_map(saved):
    """A :class:`granflow.StabilityMap` from its ``to_dict()`` (which pickles; the map's
    options do not)."""
    from granflow.simulation.stability import StabilityMap

    return StabilityMap.from_dict(saved)


def draw_stability(stability):
    """The stability map (given as its ``to_dict()``) with its analytic boundary."""
    from granflow.plotting import plot_stability_map

    return plot_stability_map(_stability_map(stability))


def draw_corner(posterior):
    """The posterior of the representative fit."""
    from granflow.plotting import plot_corner

    return plot_corner(posterior)


def _legends_inside(figure, places=None, fontsize=6, letters=None):
    """Move each legend drawn above its axes inside them (upper-most twin; at ``places[ax]``,
    else the best place), so that the panels of a multi-panel figure keep their width;
    ``places[ax] == "key"`` moves its entries into one key below the figure instead, each
    prefixed by the panel's letter from ``letters`` (a busy panel, whose inset or labels a
    legend inside would hide)."""
    key = []
    places, letters = places or {}, letters or {}
    found = [(ax, ax.get_legend()) for ax in figure.axes if ax.get_legend() is not None]
    for ax, legend in found:
        handles, texts = legend.legend_handles, [t.get_text() for t in legend.get_texts()]
        title = legend.get_title().get_text()
        legend.remove()
        twins = [a for a in figure.axes if a.bbox.bounds == ax.bbox.bounds]
        target = twins[-1] if twins else ax
        place = places.get(ax, "best")
        if place == "key":
            prefix = letters.get(ax, "")
            key += [(f"{prefix}{text}", h) for h, text in zip(handles, texts, strict=True)]
            continue
        target.legend(
            handles,
            texts,
            loc=place,
            fontsize=fontsize,
            title=title or None,
            title_fontsize=fontsize,
            framealpha=0.85,
            borderaxespad=0.3,
            handlelength=1.5,
        )
    if key:
        labels, handles = zip(*key, strict=True)
        figure.legend(
            handles,
            labels,
            loc="outside lower center",
            ncols=3,
            fontsize=fontsize,
            frameon=False,
            handlelength=1.5,
            columnspacing=1.2,
        )


def draw_fig2(startup=None, collapse=None, amontons=None):
    """Fig. 2 at double-column width: (a) the preparations, (b) the collapse, (c) Amontons'
    law in three panels, one row each; a panel without its input is left out."""
    import matplotlib.pyplot as plt

    from granflow.plotting import plot_amontons, plot_collapse, plot_startup
    from granflow.plotting._axes import panel_letter

    rows = [key for key, value in (("a", startup), ("b", collapse), ("c", amontons)) if value]
    figure = plt.figure(figsize=(DOUBLE_COLUMN, 2.9 * max(len(rows), 1)), layout="constrained")
    parts = figure.subfigures(len(rows), 1, squeeze=False)[:, 0] if len(rows) > 1 else [figure]
    for part, key in zip(parts, rows, strict=True):
        letter = "abc"[rows.index(key)]
        if key == "a":
            ax = part.subplots()
            plot_startup(startup[0], startup[1], ax=ax)
            panel_letter(ax, letter)
        elif key == "b":
            ax = part.subplots()
            plot_collapse(collapse, ax=ax)
            panel_letter(ax, letter)
        else:
            axes = part.subplots(1, 3)
            plot_amontons(amontons, axes=axes)
            panel_letter(axes[0], letter)
    return figure


def draw_fig3(ramp=None, creep=None, switch=None, stability=None):
    """Fig. 3 at double-column width, 2 x 2: (a) stress ramp, (b) creep (log time), (c)
    switch, (d) stability map; the legends of (a)-(c) in one key below the panels (inside
    they would hide the creep inset and the runaway), the map's inside; a panel without its
    input is left out."""
    import matplotlib.pyplot as plt

    from granflow.plotting import plot_creep, plot_stability_map, plot_stress_ramp, plot_switch
    from granflow.plotting._axes import panel_letter

    panels = [
        (name, value)
        for name, value in (
            ("ramp", ramp),
            ("creep", creep),
            ("switch", switch),
            ("map", stability),
        )
        if value is not None
    ]
    columns = 2 if len(panels) > 1 else 1
    rows = max(1, -(-len(panels) // columns))
    figure, axes = plt.subplots(
        rows,
        columns,
        figsize=(DOUBLE_COLUMN, 3.4 * rows + 0.6),
        layout="constrained",
        squeeze=False,
    )
    places, letters = {}, {}
    for index, ax in enumerate(axes.flat):
        if index >= len(panels):
            ax.set_axis_off()
            continue
        name, value = panels[index]
        if name == "ramp":  # the slip axis is scaled to the creep: no inset needed
            plot_stress_ramp(value[0], value[1], ax=ax, inset=False, velocity=value[2])
            places[ax] = "key"
        elif name == "creep":
            plot_creep(value[0], value[1], ax=ax, params=value[2], log_time=True)
            places[ax] = "key"  # the inset fills the upper left
        elif name == "switch":
            plot_switch(value[0], value[1], ax=ax, switch_time=value[2])
            places[ax] = "key"
        else:
            plot_stability_map(_stability_map(value), ax=ax)
            places[ax] = "upper right"
        panel_letter(ax, "abcd"[index])
        letters[ax] = f"({'abcd'[index]}) "
    _legends_inside(figure, places, letters=letters)
    return figure


# --------------------------------------------------------------------------- the jobs


def _load_text(load):
    if load is None:
        return "an unknown load"
    return f"F_N = {to_display('normal_load', load):.4g} {display_unit('normal_load')}"


#: What the switch's observed outcome means, for the caption of Fig. 3c.
_SWITCH_OUTCOMES = {
    "failure": "The layer runs away: switched after the peak, the friction falls as it slips. ",
    "stop": "The layer slides a little and stops: before the peak the friction rises as it slips. ",
    "creep": "The layer creeps under the constant force. ",
}


def _velocity_text(velocity):
    if velocity is None:
        return "the campaign's velocity"
    return f"{to_display('velocity', velocity):.3g} {display_unit('velocity')}"


def _ok_entries(result, kind):
    return [entry for entry in result.runs if entry.test == kind and entry.ok]


def params_at_load(result, load):
    """The model parameters at a normal load [N]: the material constants and the mean x0 of
    the static-yield prediction there, or None."""
    from granflow.model.params import Params

    material = result.material
    if load is None or material is None or getattr(material, "reason", None):
        return None
    row = next(
        (
            r
            for r in result.predictions.static_yield
            if math.isclose(r.normal_load, load, rel_tol=1e-6)
        ),
        None,
    )
    values = [getattr(material, n).value for n in ("mu_a", "mu_d", "alpha")]
    if row is None or any(v is None for v in values):
        return None
    mu_a, mu_d, alpha = values
    try:
        return Params(a=mu_a * load, alpha=alpha, Fd=mu_d * load, x0=row.x0)
    except (ValueError, TypeError):
        return None


def _named(run):
    """The run named by its preparation label in legends (when it has one)."""
    from dataclasses import replace

    label = run.meta.get("preparation")
    if not label or "name" in run.meta:
        return run
    return replace(run, meta={**run.meta, "name": f"preparation {label}"})


def _startup_job(result, joint):
    from granflow.analysis.joint import figure_preparations, preparation_of

    chosen = figure_preparations(joint.startups, result.analyses.preparation_spread)
    if not chosen:
        return None
    state = preparation_of(chosen[0])
    same = all(preparation_of(s) == state for s in chosen) and state is not None
    what = f"repeats of the preparation state “{state}”" if same else "the most different x0"
    caption = (
        f"Friction force during start-up at {_load_text(chosen[0].load)} and "
        f"{to_display('velocity', chosen[0].velocity):.4g} µm/s: {len(chosen)} preparations "
        f"({what}), data (points), fits of Eq. 3 (lines, their a, αv and t0 in the legend) and "
        "residuals (Fig. 2a). The preparations differ by t0 alone."
    )
    inputs = {"runs": [_named(s.run) for s in chosen], "fits": [s.fit for s in chosen]}
    return FigureJob(
        "startup", "Preparations (start-up curves and fits)", caption, draw_startup, inputs
    )


#: Start-up fits on one page of small multiples (6 rows of 8): a campaign of hundreds of runs
#: gets several pages, which the executor draws side by side.
FITS_PER_PAGE = 48


def _fit_pages(startups):
    """The small-multiples pages of every start-up fit: ``fits``, ``fits_2``, ..."""
    pages = [startups[i : i + FITS_PER_PAGE] for i in range(0, len(startups), FITS_PER_PAGE)]
    jobs = []
    for number, page in enumerate(pages, start=1):
        first = (number - 1) * FITS_PER_PAGE + 1
        which = (
            f" (runs {first}–{first + len(page) - 1} of {len(startups)})" if len(pages) > 1 else ""
        )
        caption = (
            f"Every start-up fit{which or f' ({len(page)} runs)'}: data (grey) and Eq. 3 (red), "
            "force against slip; a fit that did not converge is titled in red."
        )
        jobs.append(
            FigureJob(
                "fits" if number == 1 else f"fits_{number}",
                "Every start-up fit"
                + (f", page {number} of {len(pages)}" if len(pages) > 1 else ""),
                caption,
                draw_fit_grid,
                {"fits": [s.fit for s in page], "names": [s.name for s in page]},
            )
        )
    return jobs


def figure_jobs(result, joint):
    """The figures the campaign allows, as :class:`FigureJob` values in report order.

    Parameters
    ----------
    result : granflow.analysis.result.AnalysisResult
        The campaign's result (its runs with their data).
    joint : granflow.analysis.stage.JointStage
        The start-ups (for Fig. 2a and the small multiples).

    Returns
    -------
    list of FigureJob
    """
    analyses = result.analyses
    jobs = []
    fig2, fig3 = {}, {}
    startup = _startup_job(result, joint)
    if startup is not None:
        jobs.append(startup)
        fig2["startup"] = (startup.inputs["runs"], startup.inputs["fits"])
    if analyses.velocity_collapse is not None:
        collapse = analyses.velocity_collapse
        caption = (
            f"One preparation sheared at {len(collapse.result.velocities)} velocities "
            f"({_load_text(collapse.conditions.get('normal_load'))}), against slip, with the "
            "joint fit of Eq. 3 (a, α and F_d shared, x0 per run); inset: the short slips, "
            "the box in the main panel marking its range (Fig. 2b)."
        )
        jobs.append(
            FigureJob(
                "collapse", "Velocity collapse", caption, draw_collapse, {"result": collapse.result}
            )
        )
        fig2["collapse"] = collapse.result
    if analyses.amontons is not None:
        caption = (
            "a, αv and F_d against the normal load: means over the repeats with standard "
            "errors; a and F_d with their lines through the origin (slopes μ_a, μ_d), αv with "
            "the joint fit's load-independent value (Fig. 2c)."
        )
        jobs.append(
            FigureJob(
                "amontons",
                "Amontons' law",
                caption,
                draw_amontons,
                {"result": analyses.amontons.result},
            )
        )
        fig2["amontons"] = analyses.amontons.result
    jobs += _fit_pages(joint.startups)
    jobs += _stress_jobs(result, fig3)
    if fig2:
        jobs.append(
            FigureJob(
                "fig2",
                "Fig. 2 (publication, double column)",
                "Fig. 2 at a journal's double-column width (178 mm): (a) preparations, "
                "(b) velocity collapse, (c) Amontons' law.",
                draw_fig2,
                fig2,
            )
        )
    if fig3:
        jobs.append(
            FigureJob(
                "fig3",
                "Fig. 3 (publication, double column)",
                "Fig. 3 at a journal's double-column width (178 mm): (a) stress ramp, "
                "(b) creep, (c) switch to stress control, (d) stability map.",
                draw_fig3,
                fig3,
            )
        )
    if analyses.mcmc is not None and joint.representative is not None:
        jobs.append(
            FigureJob(
                "corner",
                "Posterior (MCMC)",
                f"Posterior of the Eq. 3 fit of {joint.representative.name} (emcee), the "
                "least-squares values marked.",
                draw_corner,
                {"posterior": analyses.mcmc.result},
            )
        )
    return jobs


def _stress_jobs(result, fig3):
    """Fig. 3a, 3b, 3c and the stability map (their inputs also go into ``fig3``)."""
    from granflow.analysis.joint import rounded

    analyses = result.analyses
    jobs = []
    ramps = _ok_entries(result, "ramp")
    if ramps:
        entry = ramps[0]
        params = params_at_load(result, rounded(entry.run.normal_load))
        velocity = result.material.velocity
        caption = (
            f"{entry.name}: slip (left, blue) and imposed force (right, black) against time "
            "under a stress ramp, with the model at its load: the rate-controlled F(t) at "
            f"{_velocity_text(velocity)} (grey), its peak, the static yield F_peak (red "
            "dashed), and the predicted failure where the imposed force reaches it (red "
            "dotted). The layer creeps up the rising branch and fails at the peak. The "
            "quasi-static slip of the model (grey dashed) uses the load's mean x0 and has no "
            "creep: this run's preparation and its creep put the measured slip above it. "
            "Inset: the sub-µm creep long before the failure. The slip axis is scaled to the "
            "creep; the runaway leaves through the top (Fig. 3a)."
        )
        jobs.append(
            FigureJob(
                "stress_ramp",
                "Stress ramp",
                caption,
                draw_stress_ramp,
                {"run": entry.run, "params": params, "velocity": velocity},
            )
        )
        fig3["ramp"] = (entry.run, params, velocity)
    creeps = _ok_entries(result, "creep")
    if creeps:
        load = rounded(creeps[0].run.normal_load)
        params = params_at_load(result, load)
        inputs = {
            "runs": [e.run for e in creeps],
            "fits": [e.result.fit for e in creeps],
            "params": params,
        }
        caption = (
            "Slip against time (logarithmic) under constant forces, with fits of "
            "δ = B ln(1 + t/τ_c) (lines); inset: the rate-controlled overshoot F(x) at the "
            "load, the creep forces and F_d (Fig. 3b)."
        )
        jobs.append(FigureJob("creep", "Creep", caption, draw_creep, inputs))
        fig3["creep"] = (inputs["runs"], inputs["fits"], params)
    switches = _ok_entries(result, "switch")
    if switches:
        entry = switches[0]
        params = {row.run: row.params for row in analyses.switch}.get(entry.name)
        if params is None:
            params = params_at_load(result, rounded(entry.run.normal_load))
        switch_time = entry.result.switch.switch_time
        caption = (
            f"{entry.name}: slip (left, blue) and force (right, black) against time: rate "
            f"control up to the switch at {switch_time:.4g} s (orange dotted), then a constant "
            "force slightly above the friction there, with the rate-controlled curve of the "
            f"model (grey). {_SWITCH_OUTCOMES.get(entry.result.switch.outcome, '')}(Fig. 3c)."
        )
        inputs = {"run": entry.run, "params": params, "switch_time": switch_time}
        jobs.append(
            FigureJob("switch", "Switch from rate to stress control", caption, draw_switch, inputs)
        )
        fig3["switch"] = (entry.run, params, switch_time)
    if result.predictions.stability_map is not None:
        stability = result.predictions.stability_map.map.to_dict()
        caption = (
            "Predicted outcome of a switch to force control, over the switch time and the "
            "ratio of imposed to current force (quasi-static, slip clock): failure (grey) or "
            "the slip to the stop (colour); dashed: the analytic boundary F_peak/F(x) before "
            "the peak and 1 after it; dotted red: the switch time of the peak."
        )
        jobs.append(
            FigureJob(
                "stability_map",
                "Stability map",
                caption,
                draw_stability,
                {"stability": stability},
            )
        )
        fig3["stability"] = stability
    return jobs
