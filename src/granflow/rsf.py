"""Rate-and-state friction models beside granflow's own: ``from granflow import rsf``.

The models live in :mod:`granflow.simulation.rsf`, the fits of velocity steps in
:mod:`granflow.fitting.rsf_fit`; this module gives them their public name.

Examples
--------
>>> from granflow import rsf
>>> model = rsf.RateState(0.6, 0.005, 1.0, 1e-3, [rsf.State(0.01, 10.0, "aging")])
>>> round(model.steady_state_friction(10.0), 6)
0.588487
"""

from typing import TYPE_CHECKING

from granflow._lazy import attach

if TYPE_CHECKING:  # the public names as type checkers and editors see them
    from granflow.fitting.healing import HealingResult as HealingResult
    from granflow.fitting.healing import healing as healing
    from granflow.fitting.healing import paper_healing as paper_healing
    from granflow.fitting.rsf_fit import fit as fit
    from granflow.fitting.rsf_result import RateStateFitResult as RateStateFitResult
    from granflow.io.slide_hold_slide import SlideHoldSlideRecord as SlideHoldSlideRecord
    from granflow.io.slide_hold_slide import parse_slide_hold_slide as parse_slide_hold_slide
    from granflow.io.slide_hold_slide import read_slide_hold_slide as read_slide_hold_slide
    from granflow.io.velocity_steps import VelocityStepRecord as VelocityStepRecord
    from granflow.io.velocity_steps import parse_velocity_steps as parse_velocity_steps
    from granflow.io.velocity_steps import read_velocity_steps as read_velocity_steps
    from granflow.simulation.rsf.model import LAWS as LAWS
    from granflow.simulation.rsf.model import RateState as RateState
    from granflow.simulation.rsf.model import State as State
    from granflow.simulation.rsf.result import RateStateResult as RateStateResult
    from granflow.simulation.rsf.simulate import simulate as simulate

__getattr__, __dir__, __all__ = attach(
    __name__,
    {
        "granflow.simulation.rsf.model": ["LAWS", "RateState", "State"],
        "granflow.simulation.rsf.simulate": ["simulate"],
        "granflow.simulation.rsf.result": ["RateStateResult"],
        "granflow.fitting.rsf_fit": ["fit"],
        "granflow.fitting.rsf_result": ["RateStateFitResult"],
        "granflow.fitting.healing": ["HealingResult", "healing", "paper_healing"],
        "granflow.io.slide_hold_slide": [
            "SlideHoldSlideRecord",
            "parse_slide_hold_slide",
            "read_slide_hold_slide",
        ],
        "granflow.io.velocity_steps": [
            "VelocityStepRecord",
            "parse_velocity_steps",
            "read_velocity_steps",
        ],
    },
)
