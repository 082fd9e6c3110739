"""The joint stage of :func:`granflow.analyze`: the joint analyses, the predictions and the
retrospective failure forecasts, one
pure function of the campaign's runs (:func:`joint_stage`) returning one value
(:class:`JointStage`).
"""

from dataclasses import dataclass, field

from granflow.analysis.forecasts import retrospective_forecasts
from granflow.analysis.joint import (
    Startup,
    goodness_of_fit,
    material_constants,
    mcmc_analysis,
    model_comparison,
    preparation_spreads,
    representative,
    startups_of,
    switch_startups,
    velocity_collapse,
)
from granflow.analysis.joint_results import Analyses, Material
from granflow.analysis.predictions import predict
from granflow.fitting.results import FrozenMap

__all__ = ["JointStage", "joint_stage"]


@dataclass(frozen=True, eq=False)
class JointStage:
    """Everything the joint stage found.

    Attributes
    ----------
    material : Material
    analyses : Analyses
    predictions : granflow.analysis.joint_results.Predictions
    warnings : tuple of str
    startups : tuple of Startup
        The successful start-ups (for the figures).
    representative : Startup or None
    forecasts : tuple of granflow.analysis.forecasts.RunForecast
        The running forecast of each stress ramp (or staircase).
    """

    material: Material
    analyses: Analyses
    predictions: object
    warnings: tuple = ()
    startups: tuple = field(default=(), repr=False)
    representative: Startup | None = None
    forecasts: tuple = ()


def joint_stage(entries, executor, *, mcmc, seed):
    """The joint analyses and the predictions of a campaign.

    Parameters
    ----------
    entries : sequence of granflow.analysis.result.RunEntry
        The campaign's runs in manifest order, with their data and results.
    executor : granflow._parallel.Executor
        Runs the stability map's cells.
    mcmc : bool
        Sample the posterior of the representative start-up fit.
    seed : int
        Seed of the sampler.

    Returns
    -------
    JointStage
    """
    startups = startups_of(entries)
    chosen = representative(startups)
    collapse, notes = velocity_collapse(startups)
    basis, fitted, fitted_as, more = material_constants(startups)
    notes += more
    spreads, more = preparation_spreads(startups)
    notes += more
    comparison, more = model_comparison(chosen)
    notes += more
    posterior = None
    if mcmc:
        posterior, more = mcmc_analysis(chosen, seed)
        notes += more
    forecast, comparisons, more = predict(entries, startups, chosen, basis, executor)
    notes += more
    forecasts = retrospective_forecasts(entries, basis.material, executor)
    analyses = Analyses(
        velocity_collapse=collapse,
        **({fitted_as: fitted} if fitted is not None else {}),
        preparation_spread=spreads,
        model_comparison=comparison,
        mcmc=posterior,
        **comparisons,
        goodness_of_fit=goodness_of_fit(startups + switch_startups(entries)),
        errors=FrozenMap(dict(notes.errors)),
    )
    return JointStage(
        material=basis.material,
        analyses=analyses,
        predictions=forecast,
        warnings=notes.warnings,
        startups=startups,
        representative=chosen,
        forecasts=forecasts,
    )
