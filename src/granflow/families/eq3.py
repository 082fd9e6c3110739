"""The paper's Eq. 3: fits of one start-up curve (:func:`granflow.fit`)."""

from granflow.families._seam import Family

FAMILY = Family(
    name="eq3",
    description="Eq. 3 of the aging-rejuvenation model fitted to a start-up curve",
    result_types=("granflow.fitting.single:FitResult",),
    models=("eq3",),
)
