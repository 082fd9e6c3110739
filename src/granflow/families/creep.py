"""Small closed-form curves: logarithmic creep (:func:`granflow.fit_creep`) and the simple
rivals of Eq. 3 in :func:`granflow.compare_models` (logarithmic aging, one exponential)."""

from granflow.families._seam import Family

FAMILY = Family(
    name="creep",
    description="closed-form curves fitted by least squares: creep, log aging, exponential",
    result_types=("granflow.fitting.creep:CurveFitResult",),
    models=("creep", "log_aging", "exponential", "eq2"),
)
