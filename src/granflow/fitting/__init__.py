"""Fits with honest uncertainties: one least-squares engine and the fits built on it.

``engine`` (least squares over named parameters, multistart, profile intervals),
``statistics`` (the fit statistics and report lines every result shares), ``single``
(:func:`fit` of one curve, :func:`fit_many`), ``joint`` (tied parameters, velocity collapse,
Amontons' law, preparation spread), ``creep``, ``compare`` (Eq. 3 against simpler laws) and
``mcmc`` (posterior sampling with emcee). Stands on :mod:`granflow.model`.
"""

from granflow._lazy import attach

__getattr__, __dir__, __all__ = attach(
    __name__,
    {
        "single": ["FitResult", "fit", "fit_many"],
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
