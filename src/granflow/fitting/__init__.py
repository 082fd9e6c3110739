"""Fits with honest uncertainties: one least-squares engine and the fits built on it.

``engine`` (least squares of a :class:`Model` over named parameters, profile intervals),
``statistics`` (the one builder of fit statistics and the report lines every result shares),
``results`` (equality by value and the JSON codec of every result), ``curves`` (data at the
door, starting values), ``single`` (:func:`fit` of one curve), ``batch`` (:func:`fit_many`),
``joint`` (tied parameters, velocity collapse,
Amontons' law, preparation spread), ``creep``, ``compare`` (Eq. 3 against simpler laws) and
``mcmc`` (posterior sampling with emcee). Stands on :mod:`granflow.model`.
"""

from granflow._lazy import attach

__getattr__, __dir__, __all__ = attach(
    __name__,
    {
        "single": ["FitResult", "fit"],
        "batch": ["fit_many"],
        "engine": ["Model"],
        "joint": [
            "AmontonsResult",
            "CollapseResult",
            "JointFitResult",
            "PreparationSpread",
            "fit_amontons",
            "fit_joint",
            "preparation_spread",
            "velocity_collapse",
        ],
        "creep": ["CurveFitResult", "fit_creep"],
        "compare": ["ModelComparison", "compare_models"],
        "mcmc": ["PosteriorResult", "sample_posterior"],
    },
)
