"""Fits with honest uncertainties: one least-squares engine and the fits built on it.

``parameters`` (:class:`Parameter` and :class:`Parameters`, lmfit-style named parameters
that :func:`fit`, :func:`fit_joint` and :func:`fit_creep` take as ``params=``), ``engine``
(least squares of a :class:`Model` over named parameters, multistart), ``profile``
(covariance and profile-likelihood intervals), ``statistics`` (the one builder of fit
statistics, the fields every result shares and the one report, :func:`fit_report`),
``results`` (equality by value and the JSON codec of every result), ``curves`` (data at the
door, starting values), ``single`` (:func:`fit` of one curve), ``batch`` (:func:`fit_many`),
``joint`` (tied parameters, velocity collapse, Amontons' law, preparation spread),
``amontons_test`` (the test of Amontons' law over loads),
``creep``, ``compare`` (Eq. 3 against simpler laws and, through :mod:`granflow.families`,
the other families' rows), ``likelihoods`` (the log-likelihood a result rebuilds from what it
stores) and ``mcmc`` (posterior sampling with emcee, of any family's fit). Stands on
:mod:`granflow.model`.
"""

from granflow._lazy import attach

__getattr__, __dir__, __all__ = attach(
    __name__,
    {
        "single": ["FitResult", "fit"],
        "batch": ["fit_many"],
        "engine": ["Model"],
        "parameters": ["Parameter", "Parameters"],
        "statistics": ["fit_report"],
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
        "amontons_test": ["AmontonsTest", "RelationTest", "amontons_test"],
        "creep": ["CurveFitResult", "fit_creep"],
        "compare": ["ModelComparison", "compare_models"],
        "mcmc": ["PosteriorResult", "sample_posterior"],
    },
)
