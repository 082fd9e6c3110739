"""The slide-hold-slide family: friction healing over holds, fitted by rate-and-state laws.

What the family brings (all its own modules; no generic module names it):

- the reader :func:`granflow.io.slide_hold_slide.read_slide_hold_slide` (holds found in the
  load-point displacement; a Protocol of Velocity and Hold segments; one fit window per hold),
- the healing :func:`granflow.fitting.healing.healing` (Δμ_peak per hold, β with its 95 %
  interval, the paper's time-clock prediction) and its result
  :class:`~granflow.fitting.healing.HealingResult`,
- the figure :func:`granflow.plotting.healing.plot_healing`,
- the campaign analysis and report section of :mod:`granflow.analysis.slide_hold_slide`.

The rate-and-state fits over the holds are :func:`granflow.rsf.fit` itself (its result,
:class:`~granflow.fitting.rsf_result.RateStateFitResult`, belongs to the rate-and-state family).
"""

from granflow.families._seam import Family

__all__ = ["FAMILY"]

FAMILY = Family(
    name="slide_hold_slide",
    description="friction healing over slide-hold-slide records, fitted by rate-and-state",
    result_types=("granflow.fitting.healing:HealingResult",),
    test_kind="slide_hold_slide",
    entries="granflow.analysis.slide_hold_slide:slide_hold_slide_entries",
    analyse="granflow.analysis.slide_hold_slide:campaign_slide_hold_slide",
    results="granflow.analysis.slide_hold_slide:SlideHoldSlide",
    section="granflow.analysis.slide_hold_slide:report_section",
)
